"""Transverse vibration of a tensioned span between two fixed-axis pulleys (issue 12).

Benchmark A's belt on its two pulleys, no gravity, no load, the driven pulley free: the driver is run up
to a constant speed, then the upper span gets a transverse velocity bump at 0.3 L and the drive runs on.
The spectrum of the transverse displacement at five fixed points of the span must peak within 1 % of the
axially moving string's frequencies ``f_n = n (c^2 - v^2) / (2 c L)``, ``c = sqrt(T / m')`` (T the mean
axial force in the span, m' the mass per current length), times the bending factor ``sqrt(1 + B n^2)``,
``B = pi^2 EI / (T L^2)``; at rest and at v/c ~ 0.3. Two compiled programs (run-up, then the record)
are shared by both speeds."""

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import build_quietly

import jaxbelt as jb
from jaxbelt.analysis.modes import linear_modes, mode_sensitivities
from jaxbelt.analysis.parameters import get_parameter, set_parameter
from jaxbelt.belt.tension import axial_force_profile
from jaxbelt.dynamics.simulate import simulate
from jaxbelt.pulleys.timelaw import table

N = 40  # 10.5 elements per span: mode 3 has 7 elements per wavelength
R, SPAN = 0.1, 0.1 * math.pi  # equal pulleys: the span is the centre distance
RAMP, T_RUNUP, T_REC, SAVE = 0.08, 0.12, 0.25, 1e-4
PROBES = (0.15, 0.3, 0.45, 0.6, 0.85)  # fractions of the span


STIFF_DT = 2e-4  # solver.implicit_stiffness: 3.4 x the explicit limit of this mesh (6 x at 60 elements)
STIFF_T_REC = 1.0  # 4 x longer record (cheap at this step): mode 1 at speed is measured to +-2 % in 0.25 s


def _programs(implicit_stiffness=False, t_rec=T_REC):
    spec = jb.benchmark_a(n_elements=N, t_end=t_rec, save_dt=SAVE)
    spec.gravity = (0.0, 0.0)
    spec.pulleys[1].inertia, spec.pulleys[1].load, spec.pulleys[1].viscous = 0.005, None, 0.0
    save = SAVE
    if implicit_stiffness:
        spec.solver.implicit_stiffness, spec.solver.dt, spec.solver.save_dt = True, STIFF_DT, STIFF_DT
        save = STIFF_DT
    d = build_quietly(spec)
    runup = simulate(d.model, d.params, d.state0, t_end=T_RUNUP, dt=d.dt, save_dt=T_RUNUP, _ahead_of_time=True)
    record = simulate(
        d.model, d.params, d.state0, t_end=t_rec, dt=d.dt, save_dt=save, settle_time=0.0, _ahead_of_time=True
    )
    return d, runup, record


@pytest.fixture(scope="module")
def programs():
    return _programs()


@pytest.fixture(scope="module")
def stiff_programs():
    return _programs(implicit_stiffness=True, t_rec=STIFF_T_REC)


def _with_driver_speed(d, w0, w1):
    law = lambda a, b: table([0.0, RAMP], [a, b])  # noqa: E731  (same shape for every run: one compile)
    speed = jax.tree.map(lambda *x: jnp.stack(x), law(w0, w1), law(0.0, 0.0))
    return dataclasses.replace(d.params, pulleys=dataclasses.replace(d.params.pulleys, speed=speed))


def _hermite(t, L):
    h = np.array([1 - 3 * t**2 + 2 * t**3, L * (t - 2 * t**2 + t**3), 3 * t**2 - 2 * t**3, L * (t**3 - t**2)])
    dh = np.array([6 * t**2 - 6 * t, L * (1 - 4 * t + 3 * t**2), 6 * t - 6 * t**2, L * (3 * t**2 - 2 * t)])
    return h, dh


def _y_at(q, x0, L):
    """Height of the upper span at the spatial abscissa x0 (the belt moves through the probe)."""
    x, y = q[:, 0, 0], q[:, 0, 1]
    j = np.arange(q.shape[0])
    k = (j + 1) % q.shape[0]
    jj = np.flatnonzero((y > 0.5 * R) & (np.minimum(x, x[k]) <= x0) & (np.maximum(x, x[k]) > x0))[0]
    e = np.concatenate([q[jj], q[k[jj]]])  # (4, 2): r_j, r'_j, r_k, r'_k
    t = (x0 - x[jj]) / (x[k[jj]] - x[jj])
    for _ in range(4):  # Newton on the cubic x(t)
        h, dh = _hermite(t, L)
        t -= (h @ e[:, 0] - x0) / (dh @ e[:, 0])
    return _hermite(t, L)[0] @ e[:, 1]


def _peak(f, p, f0):
    """Spectral peak near f0 (parabolic interpolation of the log power)."""
    band = np.flatnonzero((f > 0.85 * f0) & (f < 1.15 * f0))
    i = band[np.argmax(p[band])]
    a, b, c = np.log(p[i - 1 : i + 2])
    return f[i] + 0.5 * (a - c) / (a - 2 * b + c) * (f[1] - f[0])


_RUN_UP: dict = {}


def _run_up(programs, w):
    """The drive's state after the run-up to driver speed ``w`` (one run per speed, shared by the tests)."""
    d, runup, _ = programs
    key = (d.model.implicit_stiffness, w)
    if key not in _RUN_UP:
        _RUN_UP[key] = runup(_with_driver_speed(d, 0.0, w), d.state0).final
    return _RUN_UP[key]


def _installed_wave_speed(d):
    belt = d.params.belt
    EA, rho_a = float(belt.EA), float(belt.mass_per_length)
    T0 = EA * (2 * SPAN + 2 * math.pi * R) / float(belt.stress_free_length) - EA  # installed tension
    return math.sqrt(T0 * (1 + T0 / EA) / rho_a)


def _frequencies(programs, v_over_c):
    d, runup, record = programs
    belt = d.params.belt
    EA, EI, rho_a = float(belt.EA), float(belt.EI), float(belt.mass_per_length)
    T0 = EA * (2 * SPAN + 2 * math.pi * R) / float(belt.stress_free_length) - EA  # installed tension
    c0 = math.sqrt(T0 * (1 + T0 / EA) / rho_a)
    w = v_over_c * c0 / R
    st = _run_up(programs, w)
    q, v = np.asarray(st.q), np.array(st.v)
    x, y = q[:, 0, 0], q[:, 0, 1]
    v[:, 0, 1] += 0.05 * np.exp(-0.5 * ((x - 0.3 * SPAN) / (0.04 * SPAN)) ** 2) * (y > 0.5 * R)
    tr = record(_with_driver_speed(d, w, w), dataclasses.replace(st, v=jnp.asarray(v)))
    assert int(tr.final.fault) == 0
    ts, Q = np.asarray(tr.ts), np.asarray(tr.states.q)
    Tax, mid = jax.vmap(lambda q, v: axial_force_profile(N, belt, q, v))(tr.states.q, tr.states.v)
    Tax, mid = np.asarray(Tax).ravel(), np.asarray(mid).reshape(-1, 2)
    T = Tax[(mid[:, 1] > 0.5 * R) & (mid[:, 0] > 0.2 * SPAN) & (mid[:, 0] < 0.8 * SPAN)].mean()
    c = math.sqrt(T * (1 + T / EA) / rho_a)  # m' = rhoA / stretch
    vb = float(tr.final.omega[0]) * R
    B = math.pi**2 * EI / (T * SPAN**2)
    theory = np.array([n * (c * c - vb * vb) / (2 * c * SPAN) * math.sqrt(1 + B * n * n) for n in (1, 2, 3)])
    L = float(belt.stress_free_length) / N
    sig = np.array([[_y_at(qi, a * SPAN, L) for a in PROBES] for qi in Q])
    sig = (sig - sig.mean(0)) * np.hanning(len(ts))[:, None]
    nfft = 1 << 18
    p = (np.abs(np.fft.rfft(sig, n=nfft, axis=0)) ** 2).sum(1)
    f = np.fft.rfftfreq(nfft, ts[1] - ts[0])
    return np.array([_peak(f, p, f0) for f0 in theory]), theory, vb / c


# Measured (2026-11-23, 0.25 s record), modes 1/2/3: at rest -3.1/-3.0/-3.0 % with 40 elements, -1.4 % (all
# three) with 80, -0.8 % with 120: the same for every mode and shrinking like the element length, i.e. the
# span acts ~0.3 element longer (the belt leaves the pulley at its last contact point, 2 per element). At
# v/c = 0.3: within 1 % with 40 elements; +2.3/+0.1/-0.2 % with 80, +1.1/-0.3/-0.1 % with 120 (mode 1 has
# 8 periods in the record: its peak is the least certain).
# The 1 % target stays; the case at rest is an expected failure until the lift-off point converges faster.
AT_REST = pytest.mark.xfail(strict=True, reason="span at rest measured 3 % low with 40 elements (see comment)")


@pytest.mark.parametrize("v_over_c", [pytest.param(0.0, marks=AT_REST), 0.3])
def test_span_frequencies_match_axially_moving_string(programs, v_over_c):
    measured, theory, ratio = _frequencies(programs, v_over_c)
    assert ratio == pytest.approx(v_over_c, abs=0.03)
    np.testing.assert_allclose(measured, theory, rtol=0.01)


@pytest.mark.long
@pytest.mark.parametrize("v_over_c", [0.0, 0.3])
def test_implicit_stiffness_keeps_the_span_frequencies(programs, stiff_programs, v_over_c):
    """``solver.implicit_stiffness`` at h = 2e-4 s. At rest against the explicit scheme on the same mesh:
    measured +0.000 / -0.012 / -0.022 % (the string part is not scaled at this mesh and step, see
    ``mass_scaling_blocks``; with it fully scaled -0.04 / -0.16 / -0.35 %). At v/c = 0.3 against the moving
    string within 1 % as the explicit scheme, over a 1 s record: measured -0.83 / -0.22 / -0.04 % (mode 1
    over 0.25 / 0.5 / 1 s records: +1.4 / -1.9 / -0.8 %: the short record, not the scheme)."""
    measured, theory, ratio = _frequencies(stiff_programs, v_over_c)
    if v_over_c == 0:
        explicit, _, _ = _frequencies(programs, v_over_c)
        np.testing.assert_allclose(measured, explicit, rtol=0.01)
    else:
        assert ratio == pytest.approx(v_over_c, abs=0.03)
        np.testing.assert_allclose(measured, theory, rtol=0.01)


def _running(programs):
    """(drive at v/c = 0.3, its state after the run-up, driver speed): one drive object, so that the tests
    share its compiled running-modes program."""
    if "running" not in _RUN_UP:
        d = programs[0]
        w = 0.3 * _installed_wave_speed(d) / R
        _RUN_UP["running"] = dataclasses.replace(d, params=_with_driver_speed(d, w, w)), _run_up(programs, w), w
    return _RUN_UP["running"]


def _span_tensions(d, state):
    """Mean axial force in the middle of the upper and lower spans [N]."""
    Tax, mid = axial_force_profile(N, d.params.belt, state.q, state.v)
    Tax, mid = np.asarray(Tax).ravel(), np.asarray(mid).reshape(-1, 2)
    inner = (mid[:, 0] > 0.2 * SPAN) & (mid[:, 0] < 0.8 * SPAN)
    return {
        side: float(Tax[inner & (sign * mid[:, 1] > 0.5 * R)].mean()) for side, sign in (("upper", 1), ("lower", -1))
    }


def test_running_modes_match_axially_moving_string(programs):
    """Linearised modes about steady running (``linear_modes(about="running")``) at v/c ~ 0.3, the first three
    transverse modes of each span, against f_n = n (c^2 - v^2) / (2 c L) sqrt(1 + B n^2) with each span's
    running tension (from the running shape the modes are linearised about):
    - the belt's transport alone: each frequency over that of the same running shape without the transport
      terms (``transport=False``) is (c^2 - v^2) / c^2 within 0.3 % (measured 0.02-0.18 %, growing with n);
    - the frequencies themselves within 2 %: measured +0.9 to +1.4 % at 40 elements; without the transport
      terms the same offsets appear against the string at rest (+0.5 to +1.0 % at 80 elements in a loaded
      case), so they come from the span ends (the belt leaves the pulley at a contact point, two per element)
      and the bending correction, not from the transport."""
    d = programs[0]
    belt = d.params.belt
    EA, EI, rho_a = float(belt.EA), float(belt.EI), float(belt.mass_per_length)
    drive, state, w = _running(programs)
    running = linear_modes(drive, state=state, about="running", count=8)
    still = linear_modes(drive, state=state, about="running", count=8, transport=False)
    assert running.about == "running" and max(abs(running.growth_rate)) < 1e-6
    tensions = _span_tensions(d, running.equilibrium)
    side = {"driver-driven": "lower", "driven-driver": "upper"}  # the path's first span runs below
    v = running.belt_speed
    assert v == pytest.approx(w * R, rel=0.02)
    f_run, f_still = _by_span(running), _by_span(still)
    for (span, n), f in f_run.items():
        if n > 3:  # mode 4 has 2.6 elements per half wave
            continue
        T = tensions[side[span]]
        c = math.sqrt(T * (1 + T / EA) / rho_a)  # m' per current length
        B = math.pi**2 * EI / (T * SPAN**2)
        assert f / f_still[span, n] == pytest.approx((c * c - v * v) / (c * c), rel=0.003), (span, n)
        assert f == pytest.approx(n * (c * c - v * v) / (2 * c * SPAN) * math.sqrt(1 + B * n * n), rel=0.02)
    assert {(s, n) for s in side for n in (1, 2, 3)} <= set(f_run), running.table()


def _by_span(modes):
    """{(span, n): frequency} of the transverse modes, n counted per span from the lowest."""
    out: dict = {}
    for f, kind, span in zip(modes.frequencies, modes.kinds, modes.span):
        if kind == "transverse":
            out[span, 1 + sum(s == span for s, _ in out)] = f
    return out


@pytest.mark.long
def test_running_mode_sensitivities_match_central_differences_and_the_moving_string(programs):
    """d f / d p of the running modes (``mode_sensitivities(about="running")``: same belt speed and loads, the
    running shape's shift included) against central differences of the running frequencies (step 1e-4
    relative; measured agreement to 5 digits), and for the spans against the moving string at constant
    speed: d ln f / d ln m' = -(c^2 + v^2) / (2 (c^2 - v^2)) (-0.599 at v/c = 0.3; measured -0.601), 2 %."""
    d = programs[0]
    drive, state, _ = _running(programs)
    keys = ["belt.mass_per_length", "belt.pretension"]
    sens = mode_sensitivities(drive, keys, count=4, state=state, about="running")
    base = linear_modes(drive, state=state, about="running", count=4)
    for key in keys:
        p0 = float(get_parameter(drive, drive.params, key))
        f = [
            linear_modes(
                drive, state=state, about="running", count=4, params=set_parameter(drive, drive.params, key, x)
            ).frequencies
            for x in (p0 * (1 + 1e-4), p0 * (1 - 1e-4))
        ]
        np.testing.assert_allclose(
            sens[key], (f[0] - f[1]) / (2e-4 * p0), rtol=1e-3, atol=1e-6 * np.max(base.frequencies) / p0
        )
    tensions = _span_tensions(d, base.equilibrium)
    side = {"driver-driven": "lower", "driven-driver": "upper"}
    rho_a, EA, v = float(d.params.belt.mass_per_length), float(d.params.belt.EA), base.belt_speed
    for j, (kind, span) in enumerate(zip(base.kinds, base.span)):
        if kind == "transverse":
            T = tensions[side[span]]
            c2 = T * (1 + T / EA) / rho_a
            relative = sens["belt.mass_per_length"][j] * rho_a / base.frequencies[j]
            assert relative == pytest.approx(-(c2 + v * v) / (2 * (c2 - v * v)), rel=0.02), (span, relative)
