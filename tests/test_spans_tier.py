"""The spans tier (issue 30) against closed forms and the statics: the installed state is its equilibrium, a
loaded two-pulley drive settles on creep theory's speed loss and the loaded statics' tensions, gross slip holds
the capstan limit exactly, the free rotational mode is the discrete model's, and gradients agree forward,
reverse and by central differences."""

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import quick_compile

import jaxbelt as jb
from jaxbelt.analysis.parameters import get_parameter, set_parameter
from jaxbelt.analysis.statics import statics
from jaxbelt.outputs.summary import creep_theory_for
from jaxbelt.spans import initial_spans_state, simulate_spans, spans_signals

jax.config.update("jax_enable_x64", True)


def _benchmark(load=None, viscous=2.0, speed=None):
    spec = jb.benchmark_a(n_elements=40, t_end=2.45)
    if load is not None:
        spec.pulleys[1].load = load
    spec.pulleys[1].viscous = viscous
    if speed is not None:
        spec.pulleys[0].speed = speed
    return jb.build_drive(spec)


@pytest.fixture(scope="module")
def at_rest():
    """Benchmark A without loads, its driver held, and its installed state: one drive for the two tests that
    start from rest (its programs traced and compiled once)."""
    drive = _benchmark(load=0.0, viscous=0.0, speed=0.0)
    return drive, initial_spans_state(drive)


def test_the_installed_state_is_its_equilibrium(at_rest):
    """Held at rest for 2 s (saved every step: the run program of the free-rotation test), every state is the
    installed one (measured 2.4e-15)."""
    drive, st0 = at_rest
    tr = simulate_spans(drive, t_end=2.0, save_dt=1e-4)
    np.testing.assert_allclose(
        np.asarray(tr.states.tension), np.broadcast_to(st0.tension, tr.states.tension.shape), rtol=1e-12
    )
    assert np.all(np.asarray(tr.states.omega) == 0.0)


@pytest.fixture(scope="module")
def loaded():
    drive = _benchmark()
    tr = simulate_spans(drive, t_end=3.7, save_dt=1e-3)
    return drive, spans_signals(drive, tr)


def test_a_loaded_two_pulley_drive_settles_on_creep_theory_and_the_statics(loaded):
    """Benchmark A at 12 rad/s with its 25 N m load and 2 N m s viscous brake: the driven speed within 0.1 % of
    creep theory's speed loss (measured -0.05 % at 3.4-3.7 s: the adhesion arcs' tension follows the
    arriving spans' over the wraps' transit time, 0.26 s at 1.2 m/s, so the run settles slowly after the load
    step at 1-1.5 s), the tension difference the torque over the radius, and both tensions the loaded statics'
    (creep theory on each wrap, belt-length compatibility)."""
    drive, s = loaded
    w = s["t"] > 3.4
    th = creep_theory_for(drive, compliant=False)  # this tier's wraps are rigid
    w1, w2 = s["omega:driver"][w].mean(), s["omega:driven"][w].mean()
    assert w1 - w2 == pytest.approx(th.speed_loss, rel=1e-3)
    Tt, Ts = s["tension:driven-driver"][w].mean(), s["tension:driver-driven"][w].mean()
    torque = 25.0 + 2.0 * w2
    assert (Tt - Ts) * 0.1 == pytest.approx(torque, rel=1e-4)  # measured 1.5e-5 (the last transient)
    ref = {sp["name"]: sp["tension"] for sp in statics(drive, {"driven": torque}).spans}
    assert Tt == pytest.approx(ref["driven-driver"], rel=2e-4)
    assert Ts == pytest.approx(ref["driver-driven"], rel=2e-4)
    assert np.all(s["slip:driven"][w] == 0.0) and np.all(s["friction_use:driven"][w] < 1.0)


def test_gross_slip_holds_the_capstan_limit():
    """A 90 N m load on Benchmark A's driven pulley (the wraps carry about 55 N m): one wrap slides (the
    driver's, whose faster belt has the larger centrifugal tension), its (T_tight - m'v^2) / (T_slack - m'v^2)
    = e^{mu phi} (Euler-Eytelwein) within 1e-8 and its friction use (1 / slip safety factor) 1; the driven pulley
    slows down."""
    drive = _benchmark(load={"smooth_step": [0.6, 0.8, 0.0, 90.0]}, viscous=0.0)
    tr = simulate_spans(drive, t_end=1.2, save_dt=1e-3)
    s = spans_signals(drive, tr)
    st = jax.tree.map(np.asarray, tr.states)
    late = s["t"] > 1.0
    slipping = late & (np.abs(s["slip:driver"]) > 0)
    assert slipping.sum() > 0.9 * late.sum()
    mu, m = float(drive.params.mu), float(drive.params.belt.mass_per_length)
    u = 0.1 * st.omega[slipping, 0]
    c = m / (1 + 0.5 * (st.strain[slipping, 0] + st.strain[slipping, 1])) * u**2
    Tt, Ts = st.tension[slipping, 1], st.tension[slipping, 0]  # the span arriving at the driver is tight
    # measured 2.4e-9 (one round of the projection and the wraps' balance: 3.9e-5)
    np.testing.assert_allclose((Tt - c) / (Ts - c), math.exp(mu * math.pi), rtol=1e-8)
    np.testing.assert_allclose(s["friction_use:driver"][slipping], 1.0, rtol=1e-8)
    assert np.all(s["friction_use:driven"][slipping] <= 1.0)
    assert s["omega:driven"][-1] < 0.5 * s["omega:driver"][-1]  # the load wins: the driven pulley slows down
    from jaxbelt.spans import run_spans

    status = run_spans(drive, t_end=1.2).summary["status"]  # the run says so (the CLI exits 1)
    assert status.startswith("gross slip") and "driver" in status, status


def test_the_free_rotational_mode_is_the_discrete_models(at_rest):
    """Driver held, the driven pulley (no load) set swinging: its frequency is sqrt(k / J_eff) of the discrete
    model (k = 2 EA / l R^2, l the spans' stress-free length: a stuck wrap turned by d theta takes R d theta /
    (1 + eps) of stress-free belt from one span to the other, k = EA (1 + eps) / L; J_eff = J + the belt on
    its wrap and a third of each span at R) with the Kelvin-Voigt damping's factor sqrt(1 - zeta^2), within
    1e-4 (measured 8e-5 at 0.005 rad/s; the wraps' microslip softens larger swings: -0.85 % at 0.5 rad/s,
    whose +-27 N open slip arcs of 0.27 rad at the exits)."""
    drive, installed = at_rest
    st0 = dataclasses.replace(installed, omega=jnp.asarray([0.0, 0.005]))
    tr = simulate_spans(drive, t_end=2.0, save_dt=1e-4, state0=st0)
    w = np.asarray(tr.states.omega)[:, 1]
    t = np.asarray(tr.ts)
    up = np.flatnonzero((w[:-1] < 0) & (w[1:] >= 0))
    tc = t[up] - w[up] * (t[up + 1] - t[up]) / (w[up + 1] - w[up])
    f = (len(tc) - 1) / (tc[-1] - tc[0])
    b, R, L = drive.params.belt, 0.1, 0.1 * math.pi
    m, EA, J = float(b.mass_per_length), float(b.EA), float(drive.params.pulleys.inertia[1])
    J_eff = J + m * R**2 * (R * math.pi + 2 * L / 3)
    k = 2 * EA / float(st0.free[0]) * R**2
    c = 2 * float(b.axial_damping) / L * R**2
    zeta = c / (2 * math.sqrt(k * J_eff))
    f_ref = math.sqrt(k / J_eff) * math.sqrt(1 - zeta**2) / (2 * math.pi)
    assert len(tc) > 10
    assert f == pytest.approx(f_ref, rel=1e-4)


@pytest.mark.long
def test_gradients_forward_equals_reverse_and_central_differences():
    """d(mean slack tension over the last 0.1 s) / d(EA, driven inertia, mu) of a 0.4 s loaded run.

    Cost (compiling is what this test spends): the installed state once, outside the differentiated figure
    (it was traced again, op by op, under each transformation); the forward Jacobian and the six central
    differences' runs from one compiled, batched jvp program (``forward_jacobian_and_differences``); the
    reverse mode as one compiled pullback (``reverse_jacobian``), not an eager ``jax.grad``. The run saves
    every step and the figure reads every 0.01 s of it: the same states (the same step count and times
    ``k dt``) as saves every 0.01 s, but one loop over the steps instead of a loop of saves of a loop of
    steps, whose reverse-mode program compiled in 20 instead of 32 s (CPU). Measured: forward - reverse 2e-12
    relative, forward - central differences 5e-8."""
    from helpers import forward_jacobian_and_differences, reverse_jacobian

    from jaxbelt.spans import spans_time_step

    drive = _benchmark(load={"smooth_step": [0.05, 0.15, 0.0, 20.0]}, speed={"ramp": [0.0, 0.1, 0.0, 12.0]})
    keys = ["belt.EA", "pulleys.driven.inertia", "contact.mu"]
    x0 = np.asarray([float(get_parameter(drive, drive.params, k)) for k in keys])
    st0 = initial_spans_state(drive)  # the built drive's: no derivative through the installed state
    dt = spans_time_step(drive)
    every = round(0.01 / dt)  # saves of the figure: every 0.01 s

    def figure(x):
        p = drive.params
        for k, v in zip(keys, x):
            p = set_parameter(drive, p, k, v)
        tr = simulate_spans(drive, p, t_end=0.4, dt=dt, save_dt=dt, state0=st0)
        return jnp.mean(tr.states.tension[::every][-10:, 0])[None]  # t = 0.31, 0.32, ..., 0.40 s

    with quick_compile():  # programs compiled once and run once: XLA's backend optimisations cost more than they save
        fwd, fd = (J[0] for J in forward_jacobian_and_differences(figure, x0, 1e-5))
        rev = reverse_jacobian(figure, x0, 1)[0]
    np.testing.assert_allclose(fwd, rev, rtol=1e-9, atol=1e-12 * np.abs(fwd).max())
    for i in range(len(keys)):
        assert fwd[i] == pytest.approx(fd[i], rel=1e-4, abs=1e-9 * abs(fwd).max()), (keys[i], fwd[i], fd[i])


def test_run_model_spans_writes_its_figures(tmp_path, capsys):
    """``jaxbelt run --model spans``: signals.csv and summary.json whose window figures are the signals'; a window
    still inside the start-up says so (exit 1, as the ANCF tier's run); bad combinations refused with exit 2."""
    from jaxbelt.cli import main
    from jaxbelt.io import read_signals_csv, read_summary

    out = tmp_path / "spans"
    cfg = "examples/two_pulley_benchmark.toml"
    assert main(["run", cfg, "--model", "spans", "--t-end", "0.3", "--out", str(tmp_path / "short"), "-q"]) == 1
    assert "not steady: prescribed laws still change" in capsys.readouterr().out
    assert main(["run", cfg, "--model", "spans", "--out", str(out), "-q"]) == 0
    summary, sig = read_summary(out / "summary.json"), read_signals_csv(out / "signals.csv")
    assert summary["model"] == "spans" and summary["status"] == "ok"
    w = sig["t"] >= summary["window"][0] - 1e-12
    for name in ("tension:driver-driven", "hub_load:driven", "omega:driven"):
        f = summary["figures"][name]
        assert f["mean"] == pytest.approx(sig[name][w].mean(), rel=1e-9)
        assert f["pp"] == pytest.approx(np.ptp(sig[name][w]), rel=1e-9, abs=1e-9)
    capsys.readouterr()
    assert main(["run", cfg, "--model", "spans", "--animate", "--out", str(out)]) == 2
    assert "--model spans" in capsys.readouterr().err


def test_spans_modes_are_the_discrete_models_with_the_kelvin_voigt_damping():
    """``spans_modes`` (the one-step map's eigenvalues about the installed state) of Benchmark A: its rotational
    mode is the discrete model's sqrt(k / J_eff) with k = 2 EA / l R^2, and its damping ratio the Kelvin-Voigt
    spans' c / (2 sqrt(k J_eff)), c = 2 eta A / l R^2 (loads, viscous brake and the driver's law left out),
    within 1e-4 and 1e-3."""
    from jaxbelt.spans import spans_modes

    drive = _benchmark()
    with quick_compile():  # test_spans_analyses' program (test_spans_mode_sensitivities_are_exact)
        mode = spans_modes(drive, count=1)[0]
    st0 = initial_spans_state(drive)
    b, R, L = drive.params.belt, 0.1, 0.1 * math.pi
    m, EA, J = float(b.mass_per_length), float(b.EA), float(drive.params.pulleys.inertia[1])
    J_eff = J + m * R**2 * (R * math.pi + 2 * L / 3)
    k = 2 * EA / float(st0.free[0]) * R**2
    zeta = 2 * float(b.axial_damping) / float(st0.free[0]) * R**2 / (2 * math.sqrt(k * J_eff))
    assert mode["frequency_hz"] == pytest.approx(
        math.sqrt(k / J_eff) * math.sqrt(1 - zeta**2) / (2 * math.pi), rel=1e-4
    )
    assert mode["damping_ratio"] == pytest.approx(zeta, rel=1e-3)


@pytest.mark.long
def test_spans_modes_of_a_drive_with_an_arm_tensioner_are_the_ancf_tiers():
    """A three-pulley drive with an arm tensioner (helpers._tensioner_spec, 60 elements): the spans tier's
    undamped rotational modes against the ANCF tier's (`jaxbelt modes`, contacts stuck): the first within 1 %
    (measured +0.1 %; -3.5 % while a carrier's motion moved the belt at a wrap's entry into its leaving span
    instead of its arriving one), the next two within 4 % (measured +3.0 / -1.8 %: the spans' own mass is
    lumped). The spans' first transverse modes (``spans_span_modes``: the span model of ``jaxbelt span-tension``
    at the installed tensions) against the ANCF tier's, span by span, within 4 % (measured -0.7 / -3.3 / +1.4 %:
    the ANCF mesh at 60 elements, the span model's compliant ends)."""
    from helpers import _tensioner_spec

    from jaxbelt.analysis.modes import linear_modes, settled_state
    from jaxbelt.spans import spans_modes, spans_span_modes

    drive = jb.build_drive(_tensioner_spec())
    settled = settled_state(drive)  # by the run's own program (test_drive_cases runs this drive: shared)
    with quick_compile():  # the two tiers' modes: programs this test alone compiles, each run once
        ancf = linear_modes(drive, count=6, state=settled)
        spans = np.array([m["frequency_hz"] for m in spans_modes(drive, count=3, damped=False)])
    rotational = ancf.frequencies[[i for i, k in enumerate(ancf.kinds) if k == "rotational"]][:3]
    assert spans[0] == pytest.approx(rotational[0], rel=0.01)
    np.testing.assert_allclose(spans[1:], rotational[1:], rtol=0.04)
    ancf_span = {s: f for f, k, s in zip(ancf.frequencies, ancf.kinds, ancf.span) if k == "transverse"}
    span_modes = spans_span_modes(drive)
    assert sorted(m["span"] for m in span_modes) == sorted(ancf_span)  # each span's first mode, one each
    for m in span_modes:
        assert m["kind"] == "transverse" and m["frequency_hz"] == pytest.approx(ancf_span[m["span"]], rel=0.04)


@pytest.mark.long
def test_runup_model_spans_tracks_the_orders(tmp_path):
    """``jaxbelt runup --model spans`` runs the ramp on the spans tier: the windows' crank speeds rise through
    the range, each window's 2nd-order amplitude of the tensioner arm is positive and within its half
    peak-to-peak (a sinusoid's amplitude is at most the signal's half range)."""
    import csv

    from jaxbelt.cli import main

    out = tmp_path / "ru"
    args = ["runup", "examples/accessory_drive.toml", "--rpm", "800:1400", "--duration", "0.5", "--model", "spans"]
    assert main([*args, "--orders", "2", "--no-modes", "--no-plots", "--out", str(out), "-q"]) == 0
    with open(out / "runup.csv") as fh:
        rows = list(csv.DictReader(fh))
    rpm = np.array([float(r["rpm"]) for r in rows])
    assert 800 < rpm[0] < rpm[-1] < 1400 and np.all(np.diff(rpm) > 0)
    amp = np.array([float(r["order2_deg:arm_angle:tensioner"]) for r in rows])
    half = np.array([float(r["amplitude_deg:arm_angle:tensioner"]) for r in rows])
    assert np.all(amp > 0) and np.all(amp <= 1.0001 * half)
