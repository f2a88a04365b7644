"""Tension from a span's transverse frequency (issue 30): the span solver against closed forms in each of its
limits, its inverse and uncertainty, the ANCF tier's own span spectrum, and the ``span-tension`` command."""

import dataclasses
import json
import math

import jax
import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt._errors import ConfigError
from jaxbelt.analysis.modes import linear_modes, settled_state
from jaxbelt.analysis.span_tension import Span, span_frequency, span_of, span_tension
from jaxbelt.belt.tension import axial_force_profile
from jaxbelt.cli import main

jax.config.update("jax_enable_x64", True)

# an 8PK-like span: 0.144 kg/m, EA 88 kN, EI 2e-3 N m^2 (a typical poly-V), contact 4e9 N/m^3 x 28.5 mm
BELT = dict(length=0.15, mass_per_length=0.144, EA=88e3, EI=2e-3, foundation=4e9 * 0.0285)
T0 = 600.0


def _string(**kw):
    return Span(**{**BELT, "EI": 0.0, "foundation": math.inf, **kw})


@pytest.mark.parametrize("mode", [1, 2, 3])
def test_a_string_between_fixed_points_gives_the_sonic_meter_formula_with_the_current_mass(mode):
    """EI = 0, rigid pulleys: f_n = n / (2L) sqrt(T / m'), m' = m0 / (1 + T / EA) per current length."""
    span = _string()
    m = span.mass_per_length / (1 + T0 / span.EA)
    f = mode / (2 * span.length) * math.sqrt(T0 / m)
    assert span_frequency(span, T0, mode) == pytest.approx(f, rel=1e-12)
    r = span_tension(span, f, mode)
    assert r.tension == pytest.approx(T0, rel=1e-12)
    assert r.current_mass_tension == pytest.approx(T0, rel=1e-12)
    assert r.string_tension == pytest.approx(4 * span.mass_per_length * span.length**2 * f**2 / mode**2, rel=1e-14)


@pytest.mark.parametrize("v_over_c", [0.2, 0.6])
def test_a_running_string_follows_the_axially_moving_string(v_over_c):
    """f_n = n (c^2 - v^2) / (2 c L), c = sqrt(T / m') (Wickert & Mote), and its inverse."""
    c = math.sqrt(T0 / _string().mass_at(T0))
    span = _string(speed=v_over_c * c)
    for n in (1, 2):
        f = n * (c * c - span.speed**2) / (2 * c * span.length)
        assert span_frequency(span, T0, n) == pytest.approx(f, rel=1e-12)
        assert span_tension(span, f, n).tension == pytest.approx(T0, rel=1e-11)


def test_a_string_on_compliant_contact_ends_inside_the_wraps():
    """EI = 0 on a foundation k: the deflection decays over l = sqrt(T / (k - m' w^2)) into each wrap, so the
    span's slope at its ends is -w / l. Mode 1: cot(a L / 2) = a l, a = w / c, solved here by Newton
    independently; for l << L the span acts 2 l longer (first order)."""
    span = _string(foundation=BELT["foundation"])
    h, m = span.length / 2, span.mass_at(T0)
    c = math.sqrt(T0 / m)

    def g(x):  # x = a h
        ell = math.sqrt(T0 / (span.foundation - m * (x * c / h) ** 2))
        return math.cos(x) - x * ell / h * math.sin(x)

    x = math.pi / 2
    for _ in range(50):
        x -= g(x) * 1e-7 / (g(x + 1e-7) - g(x))
    ell = math.sqrt(T0 / span.foundation)
    f_exact = x / h * c / (2 * math.pi)
    assert span_frequency(span, T0, 1) == pytest.approx(f_exact, rel=1e-12)
    f_longer = c / (2 * (span.length + 2 * ell))
    assert span_frequency(span, T0, 1) == pytest.approx(f_longer, rel=(ell / span.length) ** 2 * 10)
    assert span_frequency(span, T0, 1) < c / (2 * span.length) * (1 - ell / span.length)


@pytest.mark.parametrize("mode", [1, 2, 3])
def test_a_tensioned_beam_on_rigid_pulleys_is_clamped_at_the_tangent_points(mode):
    """k -> inf: a tensioned Euler-Bernoulli beam clamped at both ends, f_n = f_string (1 + 2 / lam +
    (4 + n^2 pi^2 / 2) / lam^2 + O(lam^-3)), lam = L sqrt(T / EI) (boundary-layer asymptotics): the error of
    the two-term formula falls like lam^-3 (its lam^3 multiple changes < 3 % from lam = 400 to 800)."""
    scaled = []
    for lam in (400.0, 800.0):
        span = Span(**{**BELT, "EI": T0 * (BELT["length"] / lam) ** 2, "foundation": math.inf, "EA": 1e12})
        f_string = mode / (2 * span.length) * math.sqrt(T0 / span.mass_per_length)  # EA -> inf: m' = m0
        f_asym = f_string * (1 + 2 / lam + (4 + mode**2 * math.pi**2 / 2) / lam**2)
        scaled.append((span_frequency(span, T0, mode) / f_asym - 1) * lam**3)
    assert 0 < scaled[1] == pytest.approx(scaled[0], rel=0.03), scaled
    span = Span(**{**BELT, "foundation": math.inf})
    # the contact foundation tends to the clamped end like (EI / k)^(1/4) / L (the beam-on-foundation length)
    assert span_frequency(dataclasses.replace(span, foundation=1e24), T0, mode) == pytest.approx(
        span_frequency(span, T0, mode), rel=1e-5
    )
    beam = Span(**{**BELT, "EI": 1e-12})
    assert span_frequency(beam, T0, mode) == pytest.approx(
        span_frequency(_string(**{"foundation": BELT["foundation"]}), T0, mode), rel=1e-5
    )


def test_inverse_and_uncertainty_agree_with_the_forward_frequency():
    span = Span(**BELT, speed=10.0)
    for T in (80.0, 600.0, 3000.0):
        for n in (1, 2, 4):
            f = span_frequency(span, T, n)
            r = span_tension(span, f, n, frequency_uncertainty=0.01 * f, length_uncertainty=1e-3)
            assert r.tension == pytest.approx(T, rel=1e-11)
            dT = 1e-5 * T  # dT/df from the inverse against df/dT of the forward frequency
            df_dT = (span_frequency(span, T + dT, n) - span_frequency(span, T - dT, n)) / (2 * dT)
            assert r.dT_df * df_dT == pytest.approx(1.0, rel=1e-6)
            assert r.uncertainty == pytest.approx(math.hypot(r.dT_df * 0.01 * f, r.dT_dL * 1e-3), rel=1e-12)
    # a string at rest (T = 4 m L^2 f^2): dT/T = 2 df/f, dT/T = 2 dL/L
    r = span_tension(_string(EA=1e15), 100.0, 2)
    assert r.dT_df * r.frequency / r.tension == pytest.approx(2.0, rel=1e-6)
    assert r.dT_dL * r.length / r.tension == pytest.approx(2.0, rel=1e-6)


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda s: span_tension(s, -3.0), "frequency"),
        (lambda s: span_tension(s, float("nan")), "frequency"),
        (lambda s: span_tension(s, 50.0, 0), "mode"),
        (lambda s: span_tension(s, 50.0, frequency_uncertainty=-1.0), "frequency_uncertainty"),
        (lambda s: span_frequency(s, -10.0), "tension"),
        (lambda s: span_frequency(dataclasses.replace(s, speed=500.0), 100.0), "critical speed"),
        (lambda s: Span(**{**BELT, "length": 0.0}), "length"),
        (lambda s: Span(**{**BELT, "EI": -1.0}), "EI"),
    ],
)
def test_bad_input_is_refused_with_a_clear_message(call, message):
    with pytest.raises(ConfigError, match=message):
        call(Span(**BELT))


N_FINE = 160  # 2 contact points per 4.9 mm element: the spacing nears the contact's decay length (1.1 mm)


@pytest.mark.long
def test_the_tension_from_the_ancf_spans_first_frequency_is_its_axial_force():
    """Benchmark A (no gravity) linearised about its installed state at 160 elements: the first transverse
    mode of a span, inverted, gives the span's mean axial force within 1 % (measured -0.48 % at 160
    elements, -0.004 % at 320; -5.2 / -2.1 % at 40 / 80, where the contact points are too far apart to
    resolve the 1.1 mm the belt sinks into the wrap's compliant contact). The plain string formula is +4 %
    off (mass per current length, bending and the ends together)."""
    spec = jb.benchmark_a(n_elements=N_FINE, t_end=0.1)
    spec.gravity = (0.0, 0.0)
    drive = jb.build_drive(spec)
    state = settled_state(drive)
    modes = linear_modes(drive, state=state, count=4)
    f1 = next(f for f, kind in zip(modes.frequencies, modes.kinds) if kind == "transverse")
    R, L = 0.1, 0.1 * math.pi
    force, mid = axial_force_profile(N_FINE, drive.params.belt, state.q, state.v)
    force, mid = np.asarray(force).ravel(), np.asarray(mid).reshape(-1, 2)
    T = force[(mid[:, 1] > 0.5 * R) & (mid[:, 0] > 0.2 * L) & (mid[:, 0] < 0.8 * L)].mean()
    r = span_tension(span_of(drive, "driver-driven"), f1)
    assert r.tension == pytest.approx(T, rel=0.01)
    assert r.string_tension / T - 1 > 0.03


def test_the_command_inverts_its_own_frequency(tmp_path, capsys):
    cfg = "examples/accessory_drive.toml"
    out = tmp_path / "st"
    assert main(["span-tension", cfg, "--span", "crank-ac", "--tension", "500", "--out", str(out), "-q"]) == 0
    first = json.loads((out / "span_tension.json").read_text())
    assert first["span"] == "ac-crank" and first["frequencies"]["1"] == pytest.approx(first["frequency"])
    f1 = first["frequency"]
    args = ["span-tension", cfg, "--span", "ac-crank", "--frequency", str(f1), "--frequency-uncertainty", "1"]
    assert main([*args, "--out", str(out), "-q"]) == 0
    second = json.loads((out / "span_tension.json").read_text())
    assert second["tension"] == pytest.approx(500.0, rel=1e-9)
    assert second["uncertainty"] == pytest.approx(second["dT_df"], rel=1e-12)
    assert second["length"] == pytest.approx(first["length"]) and second["length_from"] == "installation statics"
    capsys.readouterr()
    assert main(["span-tension", cfg, "--span", "ac-crank", "--out", str(out)]) == 2
    assert "either --frequency" in capsys.readouterr().err
    assert main(["span-tension", cfg, "--span", "crank-nowhere", "--tension", "5", "--out", str(out)]) == 2
    assert "the drive's spans are" in capsys.readouterr().err
    # 1e6 Hz (kHz read as Hz, say): some 1e9 N, a strain no belt takes: written, said implausible, exit 1 (was 0)
    assert main(["span-tension", cfg, "--span", "ac-crank", "--frequency", "1e6", "--out", str(out), "-q"]) == 1
    assert "implausible: a tension of" in capsys.readouterr().err
    assert json.loads((out / "span_tension.json").read_text())["status"].startswith("implausible")
