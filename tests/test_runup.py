"""Run-up: order tracking against closed forms (synthetic orders on a speed ramp; the crank's own 2nd-order
excitation through a real run-up) and resonance crossings: at 60 f / k rpm for a mode of fixed frequency, on the
moving string's falling line for a span's transverse mode."""

import csv
import json
import math
import types

import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt.analysis.runup import RunUp, resonance_crossings, run_up, track_orders
from jaxbelt.cli import main
from jaxbelt.viz import plot_run_up

pytestmark = pytest.mark.filterwarnings("ignore:pulley .* is wrapped by belt elements")


def test_track_orders_reads_synthetic_orders_on_a_ramp():
    """phi(t) = 2 pi (f0 t + a t^2 / 2) from 10 to 30 rev/s; x = 2 cos(2 phi) + 0.5 cos(4 phi + 1): every
    window of 4 revolutions reads 2 and 0.5 at orders 2 and 4 (on-bin, Hann: within 1e-3), and the mean
    speed of the window."""
    t = np.linspace(0.0, 2.0, 40001)
    f0, a = 10.0, 10.0
    phi = 2 * math.pi * (f0 * t + 0.5 * a * t**2)
    sig = {"t": t, "x": 2 * np.cos(2 * phi) + 0.5 * np.cos(4 * phi + 1.0)}
    rpm, amp, orders = track_orders(phi, sig, (1, 2, 4), revolutions=4)
    assert len(rpm) > 5 and np.all(np.diff(rpm) > 0) and 600 < rpm[0] < rpm[-1] < 1800
    np.testing.assert_allclose(orders["x"][2], 2.0, rtol=1e-3)
    np.testing.assert_allclose(orders["x"][4], 0.5, rtol=1e-3)
    np.testing.assert_allclose(orders["x"][1], 0.0, atol=2e-3)
    assert np.all(amp["x"] > 2.0) and np.all(amp["x"] <= 2.5 + 1e-9)


def test_crossings_are_at_60_f_over_k():
    modes = types.SimpleNamespace(frequencies=np.array([20.0, 55.0]), kinds=["rotational", "transverse"])
    c = resonance_crossings(modes, (1, 2, 4), 500.0, 3000.0)
    assert [x["rpm"] for x in c] == sorted(x["rpm"] for x in c)
    assert all(abs(x["rpm"] - 60 * x["frequency_hz"] / x["order"]) < 1e-9 for x in c)
    assert {(x["mode"], x["order"]) for x in c} == {(1, 1), (1, 2), (2, 2), (2, 4)}  # 1200, 600, 1650, 825 rpm


def test_real_run_up_keeps_the_crank_order_through_the_ramp(tmp_path, capsys):
    """Benchmark A (20 elements) with +-0.5 deg of 2nd order on the crank, 600 -> 900 rpm in 0.6 s, through
    ``jaxbelt runup``: the tracked order-2 amplitude of the crank speed in runup.csv is 2 omega X pi / 180 at
    each window's speed (2 %)."""
    spec = jb.benchmark_a(n_elements=20, t_end=0.5, save_dt=5e-4)
    spec.pulleys[0].excitation = {2: {"amplitude_deg": 0.5}}
    # within the belt's capacity (about 58 N m): Benchmark A's viscous load of 2 N m s/rad would need 190 N m at
    # 900 rpm, and its 0.25 kg m^2 78 N m in a 0.2 s lead-in to 600 rpm; with them the driven pulley hung at
    # 29 rad/s, the belt sliding over the driver's whole arc (now status "gross slip", exit 1). A 0.5 s lead-in
    # needs 31 N m.
    spec.pulleys[1].viscous = 0.1
    cfg = tmp_path / "runup.toml"
    cfg.write_text(jb.dump_toml(spec))
    # a misspelt signal is refused before anything runs, with a suggestion
    with pytest.raises(jb.ConfigError, match="did you mean"):
        run_up(spec, 300.0, 900.0, 0.01, signals=["omega:drivr"], modes=False)
    for bad, words in ((["--rpm", "900:900"], "two different speeds"), (["--orders", "0"], "orders > 0")):
        argv = ["runup", str(cfg), "--rpm", "600:900", "--duration", "0.6", "--out", str(tmp_path / "bad")]
        assert main(argv + bad) == 2
        assert words in capsys.readouterr().err
    out = tmp_path / "out"
    argv = ["runup", str(cfg), "--rpm", "600:900", "--duration", "0.6", "--revolutions", "1", "--no-modes"]
    argv += ["--lead-time", "0.5"]
    argv += ["--signal", "omega:driver", "--signal", "omega:driven", "--out", str(out), "--quiet"]
    assert main(argv) == 0
    with open(out / "runup.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    rpm = np.array([float(r["rpm"]) for r in rows])
    crank2 = np.array([float(r["order2:omega:driver"]) for r in rows])
    driven2 = np.array([float(r["order2:omega:driven"]) for r in rows])
    assert json.loads((out / "runup.json").read_text())["status"] == "ok"
    assert 600 < rpm[0] < rpm[-1] < 900 and len(rpm) >= 4
    omega = rpm * 2 * math.pi / 60
    np.testing.assert_allclose(crank2, 2 * omega * 0.5 * math.pi / 180, rtol=0.02)
    # 2nd order at 20-30 Hz, far above the driven pulley's torsional mode (7 Hz): it is isolated, its order-2
    # speed amplitude well below the crank's (single-DOF transmissibility ~ (7 / 25)^2 = 0.08 without damping)
    assert np.all(driven2 < 0.2 * crank2)
    # the order plot: per signal the half peak-to-peak and one line per tracked order against rpm
    assert (out / "orders.png").stat().st_size > 0
    tracked = {"omega:x": {1: rpm, 2: crank2}}
    r = RunUp(rpm=rpm, amplitude={"omega:x": rpm * 0}, orders=tracked, crossings=[], result=None)
    lines = plot_run_up(r).axes[0].get_lines()
    assert len(lines) == 3
    np.testing.assert_allclose(lines[2].get_ydata(), crank2)


def test_span_mode_crossings_follow_the_moving_string():
    """A span's transverse mode computed at rest, f0, runs at f0 (1 - v^2 m / T) at belt speed v (the
    axially moving string; m per current length): order k meets it where k n / 60 = f0 (1 - a n^2),
    a = (2 pi R / 60)^2 m / T, the quadratic's root (0.05 % with the lines on a 2,001-point grid; at rest the
    crossing would be 60 f0 / k, 12 % higher here); a rotational mode keeps 60 f / k. Under a tension
    1.21 T0 the span's line at rest is 1.1 f0 (the string's sqrt(T), within 0.5 %: bending and the contact's
    end compliance)."""
    from jaxbelt.analysis.campbell import campbell_lines, order_crossings
    from jaxbelt.analysis.statics import statics

    drive = jb.build_drive(jb.benchmark_a(n_elements=20))
    span = statics(drive).spans[0]
    T0, name = span["tension"], span["name"]
    R = float(drive.params.pulleys.radius[0])
    m = float(drive.params.belt.mass_per_length) / (1 + T0 / float(drive.params.belt.EA))
    rows = [dict(mode=1, frequency_hz=40.0, kind="rotational", span=None),
            dict(mode=2, frequency_hz=60.0, kind="transverse", span=name)]  # fmt: skip
    rpm = np.linspace(0.0, 8000.0, 2001)
    lines = campbell_lines(drive, rows, rpm)
    v = 2 * math.pi / 60 * rpm * R
    np.testing.assert_allclose(lines.frequency[1], 60.0 * np.maximum(1 - v**2 * m / T0, 0.0), rtol=1e-12)  # 0 past c
    a = (2 * math.pi * R / 60) ** 2 * m / T0
    for k in (1, 2):
        hand = (-k / 60 + math.sqrt((k / 60) ** 2 + 4 * a * 60.0**2)) / (2 * a * 60.0)
        (c,) = [c for c in order_crossings(lines, (k,), 0.0, 8000.0) if c["mode"] == 2]
        assert c["rpm"] == pytest.approx(hand, rel=5e-4) and c["span"] == name
        assert c["frequency_hz"] == pytest.approx(k * hand / 60, rel=5e-4) and hand < 0.95 * 3600 / k
    (c,) = order_crossings(lines, (2,), 0.0, 8000.0)[:1]
    assert (c["mode"], c["rpm"]) == (1, pytest.approx(1200.0))
    tight = campbell_lines(drive, rows, np.zeros(1), {name: 1.21 * T0})
    assert tight.frequency[1, 0] == pytest.approx(66.0, rel=5e-3)
