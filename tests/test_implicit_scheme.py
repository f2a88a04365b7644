"""The implicit scheme (``solver.scheme = "implicit"``): its Newton contact solve and its automatic time step.

The Newton solve (``dynamics.contact_newton``): its bordered linear solve is the step's Delassus operator applied
to the impulses it returns (to round-off, on a drive with an arm tensioner and a clutch); it converges where the
Jacobi sweeps did not (Benchmark A: the largest residual of any step <= 1e-6), and the figures engineers read
agree with the explicit scheme at its own fine step. The step rule (``dynamics.time_step``): each bound by hand.
"""

import math
import warnings
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import (
    build_quietly,
    forward_jacobian_and_differences,
    normalised_error,
    quick_compile,
    reverse_jacobian,
    stiff_serpentine_spec,
)

import jaxbelt as jb
from jaxbelt.dynamics import contact_newton as cn
from jaxbelt.dynamics import step as st
from jaxbelt.dynamics.time_step import TRAVEL_FRACTION

EXAMPLES = Path(__file__).parents[1] / "examples"


def _bordered_solve(coupling: bool, sweeps: int):
    """One linear solve of the Newton contact solve on the accessory example (arm tensioner, clutch rotor, a
    prescribed crank) after the settle phase, random laws at every point (``coupling``: every closed point that
    does not stick slides, its friction ``0.35 lam_n``), and the velocities the returned impulses give when
    applied the plain way (the belt's W^-1 through its factor, the pulleys' and arm's inverse inertias)."""
    spec = jb.load_config(EXAMPLES / "accessory_drive.toml")
    spec.solver.scheme = "implicit"
    d = build_quietly(spec)
    model, params = d.model, d.params
    spins = tuple(k for k in range(model.n_pulleys) if not model.kinematic[k])
    carriers = tuple(k for k, c in enumerate(model.carriers) if c.movable or c.constrained)

    def check(params, state, t, h, laws, u_free):
        ops = st.drive_operators(model, params)
        phase = st.step_phase(params, t, h)
        forces = st.smooth_forces(params, ops, state, model.implicit_damping)
        free = st.free_velocities(model, params, ops, state, forces, phase, t, h)
        frames = st.contact_frames(model, params, ops, state)
        fr = frames.frame
        system = cn.newton_system(frames, free, cn.PulleyUnknowns(spins, carriers))
        (un, ut, _, g_t), _ = cn.linear_solve(system, frames, free, laws, u_free)
        kn, gn, kt = laws[:3]
        lam_n, lam_t = gn - kn * un, g_t - kt * ut
        Px, Py = lam_n * fr.nx + lam_t * fr.tx, lam_n * fr.ny + lam_t * fr.ty
        d_omega, d_psi_dot, _ = frames.pulley_response(free, Px, Py)
        wx, wy = frames.pulley_velocity(d_omega, d_psi_dot)
        bx, by = free.implicit.at_points(free.implicit.response(Px, Py))
        dux, duy = bx - wx, by - wy
        plain = (u_free[0] + dux * fr.nx + duy * fr.ny, u_free[1] + dux * fr.tx + duy * fr.ty)
        return system.free, (un, ut), plain, g_t

    state, t, h = d.state0, 0.01, d.dt  # after the settle phase: the pulleys move under impulses
    nc = st.contact_frames(model, params, st.drive_operators(model, params), state).frame.gap.shape[0]
    r = lambda k: np.asarray(jax.random.normal(jax.random.PRNGKey(k), (nc,)))
    kn, kt = np.where(r(1) > 0, 3e-3, 0.0), np.where(r(2) > 0, 5e-2, 0.0)
    c = np.where((kn > 0) & (kt == 0), 0.35, 0.0) if coupling else np.zeros(nc)
    laws = (kn, 1e-3 * r(3), kt, 1e-3 * r(4), c, 1e-3 * np.abs(r(7)))
    sweeps_before, cn.COUPLING_SWEEPS = cn.COUPLING_SWEEPS, sweeps
    try:  # read while tracing: one program per sweep count
        out = jax.jit(check)(params, state, t, h, laws, (r(5), r(6)))
    finally:
        cn.COUPLING_SWEEPS = sweeps_before
    return laws, out


def test_the_bordered_linear_solve_is_the_delassus_operator():
    """(A + J^T kappa J) dz = J^T (g - kappa u_free) means u = u_free + G (g - kappa u), G = J A^-1 J^T: checked
    with G applied the plain way, random laws at every point, on the accessory example."""
    laws, (free_dofs, (un, ut), (un_plain, ut_plain), g_t) = _bordered_solve(coupling=False, sweeps=1)
    assert np.count_nonzero(np.asarray(free_dofs)) >= 7  # six spins, the arm, the rotor (crank prescribed)
    scale = float(jnp.max(jnp.abs(un)))
    np.testing.assert_allclose(un, un_plain, atol=1e-11 * scale)
    np.testing.assert_allclose(ut, ut_plain, atol=1e-11 * scale)
    np.testing.assert_array_equal(g_t, laws[3])  # no coupling: the tangential law as given


@pytest.mark.long
def test_the_sliding_friction_follows_the_normal_impulse_within_the_linear_solve():
    """A sliding point's friction follows its normal impulse, ``g_t + c (lam_n - lam_ref)``: the linear solve
    re-solves with the updated friction (``COUPLING_SWEEPS``, the factor reused). The ``g_t`` it returns is
    consistent with its velocities (the Delassus check, to round-off), and the coupled law's defect shrinks:
    with these random laws 0.28 of the largest normal impulse lagged (no re-solve), 0.035 after one, 0.0052 after
    two (a Richardson iteration with the symmetric factor: 8 x and 6.7 x per re-solve; in the Newton solve, whose
    iterates are close, one re-solve did what two, four and eight did: ``COUPLING_SWEEPS``)."""
    defects = []
    for sweeps in (0, 1, 2):
        laws, (_, (un, ut), (un_plain, ut_plain), g_t) = _bordered_solve(coupling=True, sweeps=sweeps)
        kn, gn, kt, gt, c, lam_ref = laws
        scale = float(jnp.max(jnp.abs(un)))
        np.testing.assert_allclose(un, un_plain, atol=1e-11 * scale)
        np.testing.assert_allclose(ut, ut_plain, atol=1e-11 * scale)
        lam_n = gn - kn * un
        defects.append(float(jnp.max(jnp.abs(g_t - (gt + c * (lam_n - lam_ref))))) / float(jnp.max(lam_n)))
    assert defects[1] <= 0.25 * defects[0] and defects[2] <= 0.25 * defects[1], defects


def _figures(s):
    spans = {x["name"]: (x["tension_mean"], x["tension_amplitude"]) for x in s["spans"]}
    return spans, s["pulleys"]


@pytest.fixture(scope="module")
def benchmark_a_both():
    """Benchmark A, 40 elements, 0.5 s (the driver still speeding up, the load on): explicit (its 0.9 x limit,
    5.9e-5 s) and implicit at 1e-4 s."""
    out = {}
    for scheme in ("explicit", "implicit"):
        spec = jb.benchmark_a(n_elements=40, t_end=0.5)
        spec.solver.scheme, spec.solver.expect_steady = scheme, False  # compared during the driver's ramp
        if scheme == "implicit":
            spec.solver.dt = 1e-4
        out[scheme] = jb.run(spec).summary
    return out


def test_the_newton_solve_converges_at_every_step(benchmark_a_both):
    """Every step reaches the solve's convergence criterion (``CONVERGED`` = 1e-6 of the largest normal impulse)
    within its 8 iterations: measured median 2.0e-7, largest 9.4e-7 (with the criterion at 1e-11, until 2026-11-28:
    1.4e-12 / 5.0e-11; before the sliding friction followed the normal impulse within the solve,
    ``COUPLING_SWEEPS``: 1.1e-8; earlier 4.9e-6); the Jacobi sweeps at this step: median 5e-4. The issue's bounds are
    1e-4 median, 1e-3 at most."""
    s = benchmark_a_both["implicit"]
    assert s["status"] == "ok" and s["num_steps"] > 5000
    assert s["lcp_residual_max"] <= cn.CONVERGED
    assert s["lcp_residual_median"] <= cn.CONVERGED


@pytest.mark.parametrize("n_elements", [20, pytest.param(120, marks=pytest.mark.long)])
def test_the_newton_solve_converges_through_the_driver_ramp(n_elements):
    """Benchmark A, the automatic step (5e-5 s), the first 0.3 s (the driver speeding up): every contact step's
    residual (each save carries the largest since the one before) within the issue's bound 1e-3 of the largest
    normal impulse. Measured: largest 1.0e-6 at both meshes (the convergence criterion). With the penalties fixed
    (until 2026-11-29: sticking 1e4 x a point's mass, trial 30 x) the iteration cycled at the end of a stick arc
    at 120 elements from t = 0.22 s (largest 0.27 over 0.5 s; 327 of 7,001 steps above 1e-3 over 0.35 s) and on a
    sliding point whose direction flipped at 20 elements (largest 0.066 at 0.2385 s; 6-8 of 10,001 steps above
    1e-3 over 0.5 s, largest 0.17); with the sticking penalty at 1e3 x (the first fix, trial still 30 x) the 20
    elements still did."""
    spec = jb.benchmark_a(n_elements=n_elements, t_end=0.3)
    spec.solver.scheme, spec.solver.expect_steady = "implicit", False
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # 20 elements: the polygon-effect warning
        r = jb.run(spec)
    assert r.summary["dt"] == pytest.approx(5e-5) and r.summary["status"] == "ok"
    residual = np.asarray(r.trajectory.states.lcp_residual)
    assert residual.size > 100 and residual.max() <= 1e-3, residual.max()


def test_benchmark_a_reads_as_the_explicit_scheme(benchmark_a_both):
    """Measured: tensions within 0.01 %, amplitudes +1.2 / -0.3 %, slip arcs within 0.3 deg, speeds 0.1 %."""
    a, b = benchmark_a_both["explicit"], benchmark_a_both["implicit"]
    (sa, pa), (sb, pb) = _figures(a), _figures(b)
    for name, (T, amp) in sa.items():
        assert sb[name][0] == pytest.approx(T, rel=0.01), name
        assert sb[name][1] == pytest.approx(amp, rel=0.10), name
    for name, p in pa.items():
        q = pb[name]
        for arc in ("stick_arc_deg", "slip_arc_deg"):
            assert abs(q[arc] - p[arc]) <= max(3.0, 0.1 * p[arc]), (name, arc)
        assert q["hub_load_mean"] == pytest.approx(p["hub_load_mean"], rel=0.01), name
        assert q["slip_safety_factor"] == pytest.approx(p["slip_safety_factor"], rel=0.05), name
        assert q["slip_safety_factor_min"] == pytest.approx(p["slip_safety_factor_min"], rel=0.05), name
        assert q["omega_mean"] == pytest.approx(p["omega_mean"], rel=2e-3), name
    assert abs(b["energy"]["residual_relative"]) <= 1e-3
    assert (a["scheme"], b["scheme"]) == ("explicit", "implicit")
    assert b["dt_reason"] == "solver.dt as given" and "stability limit" in a["dt_reason"]


def _accessory(**solver):
    spec = jb.load_config(EXAMPLES / "accessory_drive.toml")
    spec.solver.scheme = "implicit"
    for k, v in solver.items():
        setattr(spec.solver, k, v)
    return spec


@pytest.mark.long
def test_a_light_carried_pulley_between_short_spans_runs_at_three_times_the_default_step():
    """The issue's supplier drive (``stiff_serpentine_spec``) through its start-up and load ramp at 1.5e-4 s (the
    automatic step is 5e-5 s, 1e-4 s until 2026-11-28). Before the scaled modes were damped
    (``MASS_SCALING_DISSIPATION``) it diverged at t = 0.174 s, the tensioner-alternator span's tension ringing at
    1.8 kHz (the scaled band's top) from -3.7 to +4.2 kN step to step. Measured now: ok, contact residual median
    2.1e-7 / max 7.3e-6 (3.9e-10 / 7.3e-6 with the solve's convergence criterion at 1e-11 of the largest normal
    impulse, now 1e-6: ``CONVERGED``; 5.5e-6 / 4.3e-3 before the sliding friction followed the normal impulse within
    the solve), energy-audit residual -2.3e-4, span tensions 243-476 N; over 0.4 s it runs at 2e-4 s too (3e-4 s:
    runs, contact not converged; 5e-4 s: diverges; measured before that change).

    The contact residual over every step of the run (each save carries the largest since the one before; the
    figures above counted the saved steps only), against the issue's bounds (median 1e-4, largest 1e-3): median
    8.3e-7, largest 8.0e-4 (8 Newton iterations too few at that step; with ``lcp_iterations = 12``: 1.8e-6).
    With the sticking penalty fixed at 1e4 x a point's mass (until 2026-11-29) 4 steps were above 1e-3 (4.3e-3), the
    window's largest 4.9e-5; at 1e3 (``STICK_PENALTY`` not following the step) the median was 1.9e-5."""
    spec = stiff_serpentine_spec(t_end=0.2)
    spec.solver.scheme, spec.solver.dt = "implicit", 1.5e-4
    r = jb.run(spec)
    s = r.summary
    assert s["status"] == "ok", s["status"]
    assert s["lcp_residual_median"] <= cn.CONVERGED
    assert np.asarray(r.trajectory.states.lcp_residual).max() <= 1e-3
    assert abs(s["energy"]["residual_relative"]) <= 1e-3
    tensions = [x["tension_mean"] for x in s["spans"]]
    assert min(tensions) > 0 and max(tensions) < 2e3  # no ringing span: installed 300 N, loads on


def test_the_step_resolves_max_frequency_orders_and_travel():
    """Each bound by hand on the accessory example: crank 800 rpm (r 80 mm: 6.70 m/s), order 2 (26.7 Hz),
    114 elements x 2 contact points over the stress-free length. 80 steps per period (40 until 2026-11-28: the
    accessory example's alternator slip arc +6.8 deg from the explicit reference at 1e-4 s, +2.8 at 5e-5 s)."""
    d = build_quietly(_accessory())
    assert d.dt == pytest.approx(1.0 / (80 * 250.0)) and "80 steps per period" in d.dt_reason
    assert "max_frequency = 250 Hz" in d.dt_reason

    L0 = float(d.params.belt.stress_free_length)
    v = 800 * 2 * math.pi / 60 * 0.080
    travel = TRAVEL_FRACTION * (L0 / (114 * 2)) / v
    orders = 1.0 / (80 * 2 * 800 / 60)
    d = build_quietly(_accessory(max_frequency=10.0, save_dt=1e-2))  # 2.5e-3 s: the other two bind
    assert d.dt == pytest.approx(min(travel, orders), rel=1e-9)
    assert ("travels at most 0.17" in d.dt_reason) == (travel < orders)
    assert ("engine order 2 at 800 rpm" in d.dt_reason) == (orders < travel)

    d = build_quietly(_accessory(max_frequency=10.0, save_dt=1.5e-4))
    assert d.dt == 1.5e-4 and "save_dt" in d.dt_reason
    d = build_quietly(_accessory(dt=5e-5))
    assert d.dt == 5e-5 and d.dt_reason == "solver.dt as given"
    d = build_quietly(_accessory(scheme="explicit"))
    assert d.dt < 1e-5 and "stability limit" in d.dt_reason and d.scheme == "explicit"


@pytest.mark.parametrize(
    "key, value, match",
    [
        ("scheme", "fast", r"solver\.scheme = 'fast': must be \"auto\""),
        ("max_frequency", 0.0, r"solver\.max_frequency"),
        ("max_frequency", "high", r"solver\.max_frequency"),
    ],
)
def test_bad_scheme_keys_are_refused(key, value, match):
    with pytest.raises(jb.ConfigError, match=match):
        jb.build_drive(_accessory(**{key: value}))


def test_a_duty_over_crank_speeds_runs_every_point_at_the_fastest_points_step():
    """A sweep of the driver's constant speed (what ``jaxbelt duty`` runs) takes the smallest accuracy step over
    its points: at 5,500 rpm a belt point travels 46.1 m/s x h, bounded by 0.17 of the contact-point spacing
    (7.2 mm): 2.65e-5 s. Until then every point ran at the base drive's step (1e-4 s at 800 rpm then, 5e-5 s
    now), which diverged from 3,600 rpm on in a 10-point duty of this drive.
    Validation only: nothing is compiled."""
    import importlib

    sweep = importlib.import_module("jaxbelt.analysis.sweep")  # the module (jaxbelt.analysis.sweep is the function)
    spec = _accessory()
    spec.pulleys[0].speed_rpm = 800.0  # a duty point's base: the driver at a constant speed
    drive = build_quietly(spec)
    rpm = np.array([800.0, 2400.0, 5500.0])
    points = {"pulleys.crank.speed": rpm * 2 * math.pi / 60}
    keys, pts = sweep._sweep_points(drive, points, None)
    steps = sweep._check_points(drive, keys, pts, None, None)
    dt, note = sweep._shared_time_step(drive, keys, pts, None, steps)
    L0 = float(drive.params.belt.stress_free_length)
    travel = TRAVEL_FRACTION * (L0 / (114 * 2)) / (5500 * 2 * math.pi / 60 * 0.080)
    assert drive.dt == pytest.approx(5e-5) and dt == pytest.approx(travel, rel=1e-9) and travel < 0.3e-4
    assert "point 3" in note and "travels at most 0.17 of the contact-point spacing" in note


@pytest.mark.long
def test_a_sweep_without_dt_runs_every_point_at_the_implicit_step():
    """The explicit sweep takes 0.9 x the smallest stability limit over the grid; the implicit scheme has none
    (it used to be inf x 0.9): every point runs at the base drive's accuracy step."""
    spec = jb.benchmark_a(n_elements=24, t_end=0.05, save_dt=0.01)
    spec.solver.scheme = "implicit"
    drive = build_quietly(spec)
    res = jb.sweep(drive, {"contact.mu": [0.4, 0.6]})
    assert res.timing["dt"] == drive.dt == pytest.approx(5e-5)
    assert np.all(np.isfinite(res.figures["tension:driven-driver:mean"]))


@pytest.mark.long
def test_a_sweep_large_enough_to_take_its_branches_batch_wide_equals_separate_runs():
    """From ``BATCHED_BRANCHES_FROM`` points per device a sweep's runs take the Newton solve's branches (its stop at
    convergence, its reuse of an unchanged factor) batch-wide (``_branch.batch_cond``): the same impulses as each
    point run alone, to round-off amplified by stick/slip over the run (no other test reaches that program)."""
    import importlib

    sweep = importlib.import_module("jaxbelt.analysis.sweep")
    spec = jb.benchmark_a(n_elements=16, t_end=0.04, save_dt=0.01)
    spec.solver.scheme = "implicit"
    drive = build_quietly(spec)
    mu = np.linspace(0.3, 0.65, sweep.BATCHED_BRANCHES_FROM * jax.device_count())
    res = jb.sweep(drive, {"contact.mu": mu})
    assert res.timing["points_per_chunk"] // res.timing["devices"] >= sweep.BATCHED_BRANCHES_FROM  # batch-wide
    swept = res.figures["tension:driven-driver:mean"]
    for i in (0, len(mu) - 1):
        ts, s = jb.simulate_signals(drive, jb.set_parameter(drive, drive.params, "contact.mu", mu[i]))
        sel = np.asarray(ts) >= float(ts[-1]) - 0.2 * float(ts[-1] - ts[0])
        assert swept[i] == pytest.approx(float(np.asarray(s["tension:driven-driver"])[sel].mean()), rel=1e-6)


def test_the_scheme_flag_runs_the_implicit_scheme_and_says_why(tmp_path, capsys):
    """``jaxbelt run --scheme implicit``: the configuration's scheme overridden, the step the accuracy rule's
    (5e-5 s for Benchmark A: 80 steps per period of solver.max_frequency, 250 Hz), stated on the run's line and
    in summary.json."""
    import json

    from jaxbelt.cli import main

    cfg = tmp_path / "bench.toml"
    text = (EXAMPLES / "two_pulley_benchmark.toml").read_text()
    cfg.write_text(text.replace("n_elements = 60", "n_elements = 24"))
    out = tmp_path / "out"
    code = main(["run", str(cfg), "--t-end", "0.05", "--scheme", "implicit", "--out", str(out), "--no-plots"])
    assert code in (0, 1)  # 0.05 s is no steady state: the status says so
    printed = capsys.readouterr().out
    assert (
        "implicit scheme (solver.scheme = implicit; dt 5e-05 s: 80 steps per period of solver.max_frequency" in printed
    )
    summary = json.loads((out / "summary.json").read_text())
    assert summary["scheme"] == "implicit" and summary["dt"] == 5e-5
    assert summary["scheme_reason"] == "solver.scheme = implicit"
    assert summary["dt_reason"] == "80 steps per period of solver.max_frequency = 250 Hz"
    out = tmp_path / "out_auto"
    code = main(["run", str(cfg), "--t-end", "0.05", "--out", str(out), "--no-plots"])
    assert code in (0, 1)  # the default, "auto": at 24 elements the explicit step is over 1/4 of the implicit one
    summary = json.loads((out / "summary.json").read_text())
    assert summary["scheme"] == "explicit" and summary["scheme_reason"].startswith("auto: the implicit step would")
    with pytest.raises(SystemExit) as refused:  # argparse's own refusal: exit 2 with the choices
        main(["run", str(cfg), "--scheme", "fast", "--out", str(out)])
    assert refused.value.code == 2


@pytest.mark.long
def test_derivatives_of_the_newton_solve_on_a_drive_with_carriers_are_those_of_its_root():
    """d(the pulleys' spins and carrier angles, the mean friction impulse)/d(EA, mu, the tensioner's spring) over 20
    implicit steps of the accessory example at idle (arm tensioner with pivot friction and stops, overrunning
    alternator clutch), regularised law: the Newton solve's derivatives come from its root
    (``contact_newton._root_of``), so forward mode equals reverse mode to round-off and both match central
    differences (of the root: the iteration run to 1e-13). Through the iterations (as before 2026-11-28) these
    derivatives were NaN on this drive (measured, 100 steps, either friction law). From the installed state
    instead of a running one the differences cross the carriers' own kinks (pivot friction, clutch: 2e-2 ... 1.9
    apart, forward = reverse still)."""
    spec = jb.load_config(EXAMPLES / "accessory_drive.toml")
    spec.solver.scheme, spec.solver.t_end = "implicit", 0.3
    spec.belt.n_elements = 60
    spec.contact.friction_law, spec.contact.nu_s = "regularized", 50.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = jb.run(spec)
    d, state = run.drive, run.trajectory.final
    keys = ["belt.EA", "contact.mu", "pulleys.tensioner.tensioner.stiffness"]
    x0 = np.array([float(jb.get_parameter(d, d.params, k)) for k in keys])

    def outputs(x):
        p = d.params
        for k, v in zip(keys, x):
            p = jb.set_parameter(d, p, k, v)
        ops = st.drive_operators(d.model, p)
        s = jax.lax.fori_loop(0, 20, lambda i, s: st.drive_step(d.model, p, ops, s, 0.3 + i * d.dt, d.dt), state)
        return jnp.concatenate([s.omega, s.psi, jnp.mean(s.lam_t)[None]])

    # central differences of the root itself: the iteration to 1e-13 (its stop at CONVERGED = 1e-6 moves the
    # differences of EA by up to 1.5e-4 of the largest sensitivity, measured; the root's tangent does not move).
    # Relative step 3e-5: measured 3.4e-6 / 3.5e-6 with two versions of the solve's loop (round-off apart); at 1e-5
    # the same two gave 3.5e-6 ... 1.4e-5 from one compilation to another (the solve's 1e-13 over the step), at
    # 3e-6 2.4e-5 ... 6.2e-5
    converged, cn.CONVERGED = cn.CONVERGED, 1e-13
    try:
        with quick_compile():
            J_fwd, J_fd = forward_jacobian_and_differences(outputs, x0, 3e-5, batched=False)
            J_rev = reverse_jacobian(outputs, x0, J_fwd.shape[0])
    finally:
        cn.CONVERGED = converged
    moving = np.abs(J_fwd * x0).max(axis=1) > 0  # outputs the parameters move (not a prescribed spin, a fixed carrier)
    assert np.all(np.isfinite(J_fwd)) and moving.sum() >= 5
    assert normalised_error(x0, J_rev[moving], J_fwd[moving]).max() < 1e-9
    assert normalised_error(x0, J_fwd[moving], J_fd[moving]).max() < 1e-5  # measured 3.5e-6
