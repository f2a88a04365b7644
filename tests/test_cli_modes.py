"""``jaxbelt modes``: the table and modes.json against closed forms of the sensitivities (string frequencies
go as m'^(-1/2); the rotational mode of Benchmark A as the square root of its belt stiffness, softened by
the contact in series), and its bad inputs refused in one line before anything is compiled."""

import json
import math

import pytest

import jaxbelt as jb
from jaxbelt.analysis.modes import linear_modes
from jaxbelt.cli import main

SPEC = jb.benchmark_a(n_elements=40, t_end=0.1)  # the drive of test_modes (same programs: compile cache)


@pytest.fixture(scope="module")
def modes_json(tmp_path_factory):
    d = tmp_path_factory.mktemp("modes")
    cfg = d / "bA.toml"
    cfg.write_text(jb.dump_toml(SPEC))
    argv = ["modes", str(cfg), "--out", str(d / "out"), "--count", "4", "--quiet"]
    rc = main(argv + ["--sensitivity", "belt.EA", "--sensitivity", "belt.mass_per_length"])
    assert rc == 0
    return json.loads((d / "out" / "modes.json").read_text())


def test_modes_json_sensitivities_follow_the_closed_forms(modes_json):
    rows = modes_json["modes"]
    f = [r["frequency_hz"] for r in rows]
    assert len(rows) == 4 and f == sorted(f)
    assert rows[0]["kind"] == "rotational" and all(r["kind"] == "transverse" for r in rows[1:]), rows
    # spans: f = n c / (2 L) sqrt(1 + B n^2), c = sqrt(T / m'): d ln f / d ln m' = -1/2 (measured -0.499..-0.501)
    for r in rows[1:]:
        assert r["relative_sensitivity"]["belt.mass_per_length"] == pytest.approx(-0.5, abs=0.005), r
    # rotational: f^2 = k_eff / J with k_eff = (1 / k_belt + 1 / k_contact)^-1 and k_belt ~ EA, so
    # d ln f / d ln EA = k_eff / (2 k_belt) = (f / f_belt)^2 / 2, f_belt the stiff-contact discrete model
    # (test_modes); 1 % (measured 0.4951 against 0.4987: the discrete model lumps the belt's inertia)
    drive = jb.build_drive(SPEC)
    p, b = drive.params.pulleys, drive.params.belt
    R, J, L, m = float(p.radius[1]), float(p.inertia[1]), float(drive.path.span_length[0]), float(b.mass_per_length)
    J_eff = J + m * R * math.pi * R**2 + 2 * (m * L / 3) * R**2
    f_belt = math.sqrt(2 * float(b.EA) / L * R**2 / J_eff) / (2 * math.pi)
    expected = 0.5 * (f[0] / f_belt) ** 2
    assert rows[0]["relative_sensitivity"]["belt.EA"] == pytest.approx(expected, rel=0.01)
    # the absolute sensitivity is the relative one times f / p
    EA = float(b.EA)
    assert rows[0]["sensitivity"]["belt.EA"] * EA / f[0] == pytest.approx(rows[0]["relative_sensitivity"]["belt.EA"])


@pytest.mark.parametrize(
    "extra, words",
    [(["--count", "0"], ["--count 0", ">= 1"]), (["--sensitivity", "belt.EAX"], ["belt.EAX"])],
)
def test_bad_modes_options_exit_2_with_one_line(tmp_path, capsys, extra, words):
    cfg = tmp_path / "bA.toml"
    cfg.write_text(jb.dump_toml(SPEC))
    assert main(["modes", str(cfg), "--out", str(tmp_path / "out")] + extra) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and all(w in err for w in words), err
    assert not (tmp_path / "out" / "modes.json").exists()


@pytest.mark.long
def test_running_modes_from_the_cli_are_those_of_the_python_api(tmp_path):
    """``--running`` linearises at the end of the configured run (``--t-end``), exactly as
    ``linear_modes(drive, about="running")`` does (the physics of running modes: test_span_vibration); the belt
    speed it reports lies between the pulleys' surface speeds (Benchmark A at 0.1 s, the driver ramping up),
    and the spans' sensitivity to m' is the moving string's, -(c^2 + v^2) / (2 (c^2 - v^2)) = -0.5 at this
    low speed (v/c < 0.002), within 1 %."""
    cfg = tmp_path / "bA.toml"
    cfg.write_text(jb.dump_toml(SPEC))
    argv = ["modes", str(cfg), "--out", str(tmp_path / "out"), "--count", "4", "--quiet", "--running"]
    # 0.1 s is inside the driver's ramp: not steady running. The modes are written, said to be about a state that
    # is not steady running (modes.json's status, stderr) and the exit code is 1 (was 0: an audit's find)
    assert main(argv + ["--t-end", "0.1", "--sensitivity", "belt.mass_per_length"]) == 1
    out = json.loads((tmp_path / "out" / "modes.json").read_text())
    assert out["status"].startswith("not steady: prescribed laws still change"), out["status"]
    py = linear_modes(jb.build_drive(SPEC), count=4, about="running")
    assert out["about"] == py.about == "running"
    assert out["belt_speed"] == pytest.approx(py.belt_speed, rel=1e-9)
    surface = [float(w) * 0.1 for w in py.equilibrium.omega]  # both radii 0.1 m
    assert min(surface) * 0.99 < out["belt_speed"] < max(surface) * 1.01, (surface, out["belt_speed"])
    assert out["belt_speed"] > 0.05
    for row, f, kind in zip(out["modes"], py.frequencies, py.kinds):
        assert row["kind"] == kind and row["frequency_hz"] == pytest.approx(f, rel=1e-9)
        assert abs(row["growth_rate_per_s"]) < 1e-6 * 2 * math.pi * f  # undamped and stable
        if kind == "transverse":
            assert row["relative_sensitivity"]["belt.mass_per_length"] == pytest.approx(-0.5, rel=0.01), row
    # without --sensitivity, --running computes none (each costs a derivative through the run)
    assert main(argv + ["--t-end", "0.1"]) == 1
    out = json.loads((tmp_path / "out" / "modes.json").read_text())
    assert all(not row.get("sensitivity") for row in out["modes"]), out["modes"][0]
