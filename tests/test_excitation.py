"""Crankshaft excitation: engine orders over crank angle, angular oscillations, tables over the crank
angle, their checks and their gradients (closed forms; see jaxbelt/pulleys/excitation.py).

One small two-pulley drive shape (12 elements) runs 1 s for two laws in one batched run (a run-up with
an absolute order-2 amplitude, and a constant speed with an order-2 angular oscillation): both specs
build parameters of the same shapes, so one compiled program serves both."""

import math
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import build_quietly, excited_two_pulley_spec

import jaxbelt as jb
from jaxbelt import ConfigError, get_parameter, set_parameter, simulate_signals
from jaxbelt.config import get_key, read_toml, validate_spec
from jaxbelt.dynamics import simulate
from jaxbelt.pulleys.excitation import pulley_laws

A = 5.0  # rad/s, order 2 of the run-up
X = 0.2  # deg, order 2 angular oscillation at constant speed
OMEGA = 100.0  # rad/s


def _spec(speed, excitation, t_end=1.0, **driver):
    return excited_two_pulley_spec(speed, excitation, t_end, **driver)


RUN_UP = _spec(
    {"speed": {"ramp": [0.0, 1.0, 60.0, 140.0]}}, {2: {"amplitude": A, "phase_deg": 30.0}, 4: {"amplitude": 0.0}}
)
STEADY = _spec({"speed": {"ramp": [0.0, 1.0, OMEGA, OMEGA]}}, {2: {"amplitude_deg": X}, 4: {"amplitude": 0.0}})


@pytest.fixture(scope="module")
def runs():
    """Crank angle and speed (saved states) of both laws, one batched 1 s run."""
    a, b = build_quietly(RUN_UP), build_quietly(STEADY)
    params = jax.tree.map(lambda x, y: jnp.stack([x, y]), a.params, b.params)

    def crank(p):
        tr = simulate(a.model, p, a.state0, t_end=1.0, dt=a.dt, save_dt=1e-3, settle_time=a.options.settle_time)
        return tr.ts, tr.states.theta[:, 0], tr.states.omega[:, 0]

    ts, theta, omega = jax.jit(jax.vmap(crank))(params)
    return np.asarray(ts[0]), np.asarray(theta), np.asarray(omega)


def _order_amplitude(phi, y, k):
    """Amplitude of order ``k`` of ``y`` sampled at crank angles ``phi``: resampled on a uniform angle
    grid over whole revolutions, FFT over angle (bin = k x revolutions)."""
    revs = int((phi[-1] - phi[0]) // (2 * math.pi))
    grid = phi[0] + np.arange(revs * 256) * (2 * math.pi * revs / (revs * 256))
    spec = np.fft.rfft(np.interp(grid, phi, y)) / grid.size
    return 2 * abs(spec[round(k * revs)]), 2 * np.abs(spec[1:]), revs


def test_run_up_keeps_order_2_at_its_amplitude_over_crank_angle(runs):
    ts, theta, omega = runs
    keep = ts > 0.01
    phi, w = theta[0][keep], omega[0][keep]
    mean = 60.0 + 80.0 * ts[keep]  # the ramp
    amp, spectrum, revs = _order_amplitude(phi, w - mean, 2)
    assert amp == pytest.approx(A, rel=0.01)
    # the line sits at order 2 of the crank angle through the run-up (no smearing over neighbouring orders)
    others = np.delete(spectrum, 2 * revs - 1)
    assert others.max() < 0.01 * A
    # and at twice the crank frequency at each instant: the residual is A cos(2 phi + 30 deg) sample by sample
    np.testing.assert_allclose(w - mean, A * np.cos(2 * phi + math.radians(30.0)), atol=0.01 * A)


def test_angular_oscillation_in_degrees_is_a_speed_amplitude_k_omega_x(runs):
    ts, theta, omega = runs
    keep = ts > 0.01
    phi, w = theta[1][keep], omega[1][keep]
    amp, _, _ = _order_amplitude(phi, w, 2)
    assert amp == pytest.approx(2 * OMEGA * math.radians(X), rel=0.01)
    # the crank angle itself oscillates by X: phi = Omega' t + X sin(...) with Omega' = Omega sqrt(1 - a^2),
    # a = k X (exact solution of dphi/dt = Omega (1 + a cos k phi); its fundamental is a/k to O(a^2))
    a = 2 * math.radians(X)
    wt = 2 * OMEGA * math.sqrt(1 - a * a) * ts[keep]
    basis = np.stack([np.ones_like(wt), ts[keep], np.cos(wt), np.sin(wt), np.cos(2 * wt), np.sin(2 * wt)], 1)
    coef, *_ = np.linalg.lstsq(basis, phi, rcond=None)
    assert math.degrees(math.hypot(coef[2], coef[3])) == pytest.approx(X, rel=0.01)


def test_measured_speed_table_over_crank_angle_is_reproduced():
    """A table over crank angle (rpm, 720 deg cycle) read at the crank angle wrapped into its period."""
    table = [[0.0, 800.0], [180.0, 860.0], [360.0, 780.0], [540.0, 840.0], [720.0, 800.0]]
    drive = build_quietly(_spec({"speed_rpm": {"angle_table": table}}, None))
    pp = drive.params.pulleys
    kin = jnp.asarray(drive.model.kinematic)
    angles = np.linspace(-400.0, 2000.0, 97)
    for deg in angles:
        theta = jnp.asarray([math.radians(deg), 0.0])
        speed, _ = pulley_laws(pp.speed, pp.torque, pp.excitation, kin, theta, jnp.zeros(2), 0.3, 1e-5)
        expect = np.interp(deg % 720.0, *np.asarray(table).T) * 2 * math.pi / 60
        assert float(speed[0]) == pytest.approx(expect, rel=1e-12)


def test_driver_torque_orders_over_crank_angle():
    """Driver by torque: mean torque plus orders in N m at the crank angle (a period-less law of time)."""
    spec = _spec({"torque": 10.0}, {2: {"amplitude": 4.0, "phase_deg": 90.0}, 0.5: {"amplitude": 1.0}})
    drive = build_quietly(spec)
    pp, kin = drive.params.pulleys, jnp.asarray(drive.model.kinematic)
    for phi in (0.0, 0.3, 2.0, 7.5):
        _, torque = pulley_laws(
            pp.speed, pp.torque, pp.excitation, kin, jnp.asarray([phi, 0.0]), jnp.zeros(2), 0.5, 0.0
        )
        expect = 10.0 + 4.0 * math.cos(2 * phi + math.pi / 2) + math.cos(0.5 * phi)
        assert float(torque[0]) == pytest.approx(expect, rel=1e-12)


@pytest.mark.long
def test_amplitude_gradient_matches_central_differences():
    """d(driven speed + tension at the end)/d(amplitude), forward mode, against central differences. The
    regularised law keeps the output smooth (under Coulomb every stick/slip switch is a kink: 2 % apart)."""
    spec = _spec({"speed": 60.0}, {2: {"amplitude": 8.0}}, t_end=0.05)
    spec.contact.friction_law, spec.solver.settle_time = "regularized", 0.02
    # the load (a brake: it holds a standing pulley, a set-valued law) comes on once the pulley turns, so
    # that no breakaway from rest, a kink in the amplitude, lies in the window
    spec.pulleys[1].load = {"smooth_step": [0.01, 0.02, 0.0, 2.0]}
    drive = build_quietly(spec)
    key = "pulleys.crank.excitation.2.amplitude"
    assert key in jb.parameter_keys(drive)
    assert float(get_parameter(drive, drive.params, key)) == 8.0

    def out(a):
        _, s = simulate_signals(drive, set_parameter(drive, drive.params, key, a), adjoint="forward")
        return s["omega:driven"][-1] + 0.05 * s["tension:crank-driven"][-1]

    value_and_slope = jax.jit(lambda a: jax.jvp(out, (a,), (jnp.ones_like(a),)))  # one program for all three
    # step 1e-3 relative: measured AD/FD - 1 = -1.4e-3, 8.9e-5, -1.4e-5 at steps 1e-5, 1e-4, 1e-3 (the smallest
    # straddles a contact event of this coarse 12-element mesh; brakes off gives the same numbers)
    a0, h = jnp.asarray(8.0), 8.0 * 1e-3
    _, slope = value_and_slope(a0)
    fd = (float(value_and_slope(a0 + h)[0]) - float(value_and_slope(a0 - h)[0])) / (2 * h)
    assert abs(float(slope)) > 1e-3
    assert float(slope) == pytest.approx(fd, rel=1e-4)


# --------------------------------------------------------------------------- bad input
BAD = [
    ({"speed": 50.0}, {0: {"amplitude": 1.0}}, "pulleys.crank.excitation.0", "order must be a number > 0"),
    ({"speed": 50.0}, {-2: {"amplitude": 1.0}}, "pulleys.crank.excitation.-2", "> 0"),
    ({"speed": 50.0}, {2: {"amplitude": 60.0}}, "pulleys.crank.excitation.2.amplitude = 60", "backwards"),
    ({"speed": {"ramp": [0, 1, 0, 100]}}, {2: {"amplitude": 1.0}}, "excitation.2.amplitude = 1", "backwards"),
    ({"speed": 50.0}, {2: {"amplitude_deg": 30.0}}, "pulleys.crank.excitation.2.amplitude_deg = 30", "backwards"),
    ({"torque": 5.0}, {2: {"amplitude_deg": 1.0}}, "excitation.2.amplitude_deg = 1", "needs a prescribed speed"),
    ({"speed": 50.0}, {2: {"amplitude": 1.0, "amplitude_deg": 1.0}}, "pulleys.crank.excitation.2", "exactly one"),
    ({"speed": 50.0}, {2: {"amplitud": 1.0}}, "pulleys.crank.excitation.2.amplitud", "did you mean 'amplitude'"),
]


@pytest.mark.parametrize("speed, exc, where, why", BAD)
def test_bad_excitation_refused_before_compiling(speed, exc, where, why):
    with pytest.raises(ConfigError) as err:
        validate_spec(_spec(speed, exc))
    msg = str(err.value)
    assert where in msg and why in msg and "\n" not in msg, msg


def test_angular_oscillation_through_a_start_from_standstill_is_accepted():
    """amplitude_deg scales with the mean speed (k omega X pi/180 < omega while k X pi/180 < 1): a run-up from
    0 rpm with +-1.5 deg at order 2 never turns the crank backwards, so it is valid (absolute amplitudes are not)."""
    validate_spec(_spec({"speed": {"ramp": [0, 1, 0, 100]}}, {2: {"amplitude_deg": 1.5}}))


def test_excitation_on_an_idler_refused():
    spec = _spec({"speed": 50.0}, None)
    spec.pulleys[1].role, spec.pulleys[1].load = "idler", None
    spec.pulleys[1].excitation = {2: {"amplitude": 1.0}}
    with pytest.raises(ConfigError, match=r"pulleys.driven.excitation = .*not a pulley of role 'idler'"):
        validate_spec(spec)


def test_toml_keys_and_round_trip(tmp_path):
    text = jb.dump_toml(RUN_UP)
    path = tmp_path / "d.toml"
    path.write_text(text)
    back = jb.load_config(path)
    assert back.pulleys[0].excitation == {"2": {"amplitude": A, "phase_deg": 30.0}, "4": {"amplitude": 0.0}}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        d1, d2 = jb.build_drive(RUN_UP), jb.build_drive(back)
    np.testing.assert_array_equal(d1.params.pulleys.excitation.amplitude, d2.params.pulleys.excitation.amplitude)
    assert get_key(read_toml(path), "pulleys.crank.excitation.2.phase_deg") == 30.0


@pytest.mark.parametrize(
    "key, entry, value",
    [("excitation.2.amplitude", "amplitude", 7.0), ("excitation.2.phase_deg", "phase_deg", 45.0)],
)
def test_set_parameter_equals_building_the_edited_spec(key, entry, value):
    drive = build_quietly(RUN_UP)
    spec = _spec(
        {"speed": {"ramp": [0.0, 1.0, 60.0, 140.0]}}, {2: {"amplitude": A, "phase_deg": 30.0}, 4: {"amplitude": 0.0}}
    )
    spec.pulleys[0].excitation[2][entry] = value
    edited = build_quietly(spec)
    p = set_parameter(drive, drive.params, "pulleys.crank." + key, value)
    assert float(get_parameter(drive, p, "pulleys.crank." + key)) == pytest.approx(value, rel=1e-14)
    for name in ("amplitude", "phase"):
        np.testing.assert_allclose(
            getattr(p.pulleys.excitation, name), getattr(edited.params.pulleys.excitation, name), rtol=1e-14
        )
