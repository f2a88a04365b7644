"""One-way clutch pulleys: the overrunning alternator pulley (OAP) and the decoupler (OAD).

The serpentine example (coarse, 32 elements) with its alternator on a clutch: the crank runs up,
holds 40 rad/s, then drops to 25 rad/s in 10 ms. Steady: the clutch is locked and the drive equals
one with a solid alternator pulley of the summed inertia (0.5 %). After the drop the rotor overruns
with exactly zero clutch torque. The energy audit closes with the clutch's engagement loss (and
the decoupler's spring and damper) counted. A clutch on a driver is refused before any compile.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import CLUTCH_DROP, CLUTCH_J, build_quietly
from helpers import clutch_serpentine_spec as _spec  # the drive described above (shared with other tests)

import jaxbelt as jb
from jaxbelt import simulate_signals

ALT = 2  # the alternator's index
J_SHEAVE, J_ROTOR = CLUTCH_J
DROP = CLUTCH_DROP  # crank deceleration starts [s]


@pytest.fixture(scope="module")
def oap():
    return jb.run(build_quietly(_spec()))


@pytest.fixture(scope="module")
def solid():
    return jb.run(build_quietly(_spec(clutch=None)))


def test_steady_drive_locks_the_clutch_and_equals_a_solid_pulley(oap, solid):
    ts = oap.ts
    steady = (ts > 0.22) & (ts < DROP)
    s = oap.trajectory.states
    rotor, sheave = np.asarray(s.psi_dot[:, ALT]), np.asarray(s.omega[:, ALT])
    np.testing.assert_allclose(rotor[steady], sheave[steady], rtol=1e-9)  # locked
    assert np.all(np.asarray(s.constraints.impulse[:, ALT])[steady] > 0)  # and transmitting the load
    for name in ("omega:alternator", "tension:crank-tensioner", "tension:alternator-idler", "arm_angle:tensioner"):
        a, b = oap.signals[name][steady], solid.signals[name][steady]
        scale = np.max(np.abs(b))
        assert np.max(np.abs(a - b)) < 0.005 * scale, name


def test_crank_deceleration_overruns_the_rotor_with_zero_clutch_torque(oap, solid):
    ts = oap.ts
    s = oap.trajectory.states
    rotor, sheave = np.asarray(s.psi_dot[:, ALT]), np.asarray(s.omega[:, ALT])
    impulse = np.asarray(s.constraints.impulse[:, ALT])
    over = (ts > DROP) & (rotor > sheave + 1e-6)
    # measured: the rotor overruns for ~20 ms (10 saves), up to 25 rad/s above the sheave, then re-engages
    assert over.sum() >= 5 and np.max(rotor[over] - sheave[over]) > 10.0
    assert np.max(np.abs(impulse[over])) < 1e-12 * np.max(impulse)  # no clutch torque while overrunning
    # the rotor coasts down under its load alone: d omega / dt = -load / J_rotor
    after = np.nonzero(over)[0]
    after = after[: np.argmax(np.diff(after) > 1) + 1] if np.any(np.diff(after) > 1) else after
    rate = np.diff(rotor[after]) / np.diff(ts[after])
    np.testing.assert_allclose(rate, -1.5 / J_ROTOR, rtol=5e-3)
    # a solid pulley is dragged down with the belt instead
    assert np.all(solid.signals["omega:alternator"][after[2:]] < rotor[after[2:]] - 1.0)


def test_energy_audit_closes_with_the_clutch(oap):
    a = oap.summary["energy"]
    assert abs(a["residual_relative"]) < 0.005, a
    assert a["clutch_J"] >= -1e-6 * a["work_supplied_J"]  # re-engagement dissipates (measured -3e-7 J: round-off)


@pytest.mark.long
def test_decoupler_energy_audit_and_spring_gradient():
    drive = build_quietly(_spec("decoupler", t_end=0.12, n_elements=24))
    r = jb.run(drive)
    a = r.summary["energy"]
    assert abs(a["residual_relative"]) < 0.005, a
    assert a["clutch_J"] >= -1e-9 * a["work_supplied_J"]

    def out(params, k):
        p = eqx.tree_at(lambda p: p.pulleys.carrier[ALT]["clutch_stiffness"], params, k)
        _, s = simulate_signals(drive, p, adjoint="forward")
        return s["omega:alternator"][-1]

    # one compiled forward-mode program (parameters an argument) for the slope and all three values
    value_and_slope = jax.jit(lambda params, k: jax.jvp(lambda k: out(params, k), (k,), (jnp.ones_like(k),)))
    k0 = jnp.asarray(40.0)
    _, g = value_and_slope(drive.params, k0)
    fd = (
        float(value_and_slope(drive.params, k0 * (1 + 1e-5))[0])
        - float(value_and_slope(drive.params, k0 * (1 - 1e-5))[0])
    ) / (2e-5 * 40.0)
    assert np.isfinite(float(g)) and float(g) != 0.0
    assert float(g) == pytest.approx(fd, rel=1e-4, abs=1e-6 * abs(fd) + 1e-12)


def test_clutch_on_a_driver_is_refused():
    spec = _spec()
    spec.pulleys[0].clutch, spec.pulleys[0].rotor_inertia = "oap", 1e-3
    with pytest.raises(jb.ConfigError, match=r"crank.*\.clutch = 'oap': a one-way clutch belongs on a driven pulley"):
        jb.build_drive(spec)
    spec = _spec()
    spec.pulleys[ALT].rotor_inertia = 0.0
    with pytest.raises(jb.ConfigError, match=r"rotor_inertia = 0\.0"):
        jb.build_drive(spec)
    spec = _spec("decoupler")
    spec.pulleys[ALT].clutch_stiffness = 0.0
    with pytest.raises(jb.ConfigError, match=r"clutch_stiffness = 0\.0"):
        jb.build_drive(spec)
