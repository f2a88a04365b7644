"""Parameter keys and output signals of the accessory-drive elements: one-way clutch pulleys (rotor
inertia, decoupler spring and damper) and lossy tensioners (pivot friction, unloading damping, stops).

Keys: each new key gives the parameters that editing the configuration builds, round-trips through
``get_parameter``, is listed only for pulleys that have the element, passes the sweep's per-point
checks, and differentiates (d arm angle / d friction_torque, reverse mode vs central differences).
Signals: on the serpentine example (coarse) with its alternator on a clutch and pivot friction and
stops on its arm: the steady clutch torque carries the rotor's load, an overrun has zero clutch
torque with the rotor faster than its sheave, the pivot friction stays inside its band (at the band
while sliding) and a stop pushes only when the arm is on it; the split of a step's impulse into
friction and stop reaction matches the closed form of an arm held on its stop (belt-free rig).
"""

import copy

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import (
    arm_rig_params,
    CLUTCH_DROP,
    CLUTCH_J,
    CLUTCH_LOAD,
    assert_trees_close,
    build_quietly,
    clutch_serpentine_spec,
    lossy_serpentine_spec,
)

import jaxbelt as jb
from jaxbelt import ConfigError, get_parameter, parameter_keys, set_parameter, simulate_signals
from jaxbelt.analysis.sweep import _check_points
from jaxbelt.outputs import signal_units
from jaxbelt.pulleys import ArmCarrier, LossyCarrier
from jaxbelt.pulleys.rig import simulate_carrier

T, A = "pulleys.tensioner.", "pulleys.alternator."
ALT = 2
# key -> (a new value, how to write it into the spec)
EDITS = {
    A + "rotor_inertia": (2.5e-3, lambda s, v: setattr(s.pulleys[ALT], "rotor_inertia", v)),
    A + "clutch_stiffness": (55.0, lambda s, v: setattr(s.pulleys[ALT], "clutch_stiffness", v)),
    A + "clutch_damping": (0.05, lambda s, v: setattr(s.pulleys[ALT], "clutch_damping", v)),
    T + "tensioner.friction_torque": (0.7, lambda s, v: setattr(s.pulleys[1].tensioner, "friction_torque", v)),
    T + "tensioner.damping_unload": (0.9, lambda s, v: setattr(s.pulleys[1].tensioner, "damping_unload", v)),
    T + "tensioner.stops.min": (-0.2, lambda s, v: setattr(s.pulleys[1].tensioner, "stops", (v, 0.3))),
    T + "tensioner.stops.max": (0.25, lambda s, v: setattr(s.pulleys[1].tensioner, "stops", (-0.3, v))),
    # no damping_unload in the spec: the arm damps unloading with `damping` too, and the key moves both
    T + "tensioner.damping": (0.45, lambda s, v: setattr(s.pulleys[1].tensioner, "damping", v)),
    # the arm's inertia about its pivot (a design variable of the first rotational mode)
    T + "tensioner.inertia": (3.0e-3, lambda s, v: setattr(s.pulleys[1].tensioner, "inertia", v)),
}


def _both(clutch="decoupler", friction=0.3, stops=(-0.3, 0.3)):
    """The clutch serpentine with pivot friction and stops on its arm too (built, never run here)."""
    spec = clutch_serpentine_spec(clutch)
    spec.pulleys[1].tensioner.friction_torque, spec.pulleys[1].tensioner.stops = friction, stops
    return spec


@pytest.fixture(scope="module")
def decoupler():
    return build_quietly(_both())


def test_keys_are_listed_for_the_pulleys_with_the_element(decoupler):
    keys = parameter_keys(decoupler)
    assert set(EDITS) <= set(keys)
    new = {"rotor_inertia", "clutch_stiffness", "clutch_damping", "friction_torque", "damping_unload", "stops"}
    for k in keys:  # nowhere else: not on the crank, the idler, or the arm's own spin
        if any(n in k.split(".") for n in new):
            assert k in EDITS, k
    # an OAP has a rotor but no spring; an arm without friction, stops or unloading damping no constraint keys
    spec = _both("oap", friction=None, stops=None)
    oap = build_quietly(spec)
    keys = parameter_keys(oap)
    assert A + "rotor_inertia" in keys and A + "clutch_stiffness" not in keys and A + "clutch_damping" not in keys
    assert not [k for k in keys if ".friction_torque" in k or ".damping_unload" in k or ".stops." in k]
    with pytest.raises(ConfigError, match=r"clutch_stiffness' is not a parameter of this drive"):
        get_parameter(oap, oap.params, A + "clutch_stiffness")


@pytest.mark.parametrize("key", list(EDITS))
def test_set_parameter_equals_building_the_edited_spec(decoupler, key):
    value, edit = EDITS[key]
    spec = copy.deepcopy(decoupler.spec)
    edit(spec, value)
    edited = build_quietly(spec)
    p = set_parameter(decoupler, decoupler.params, key, value)
    assert float(get_parameter(decoupler, p, key)) == pytest.approx(value, rel=1e-15)
    assert float(get_parameter(decoupler, decoupler.params, key)) != pytest.approx(value)  # it did change
    assert_trees_close(p, edited.params, rtol=1e-14, what=key)


def test_damping_and_unloading_damping_together_in_either_order(decoupler):
    """``damping`` also sets the unloading damping of an arm whose file gives none, unless
    ``damping_unload`` is given too: the file with both edited, whatever order the keys come in."""
    spec = copy.deepcopy(decoupler.spec)
    spec.pulleys[1].tensioner.damping, spec.pulleys[1].tensioner.damping_unload = 0.45, 0.9
    edited = build_quietly(spec).params
    pairs = [(T + "tensioner.damping", 0.45), (T + "tensioner.damping_unload", 0.9)]
    for order in (pairs, pairs[::-1]):
        assert_trees_close(jb.set_parameters(decoupler, decoupler.params, order), edited, rtol=1e-14)


def test_sweep_checks_each_point_under_the_key(decoupler):
    keys = [T + "tensioner.friction_torque", A + "clutch_stiffness", T + "tensioner.stops.min"]
    _check_points(decoupler, keys, np.array([[0.5, 30.0, -0.1], [1.0, 60.0, -0.2]]), None, None)
    with pytest.raises(ConfigError, match=r"sweep point 2 of 2 .*tensioner\.friction_torque = -0\.5"):
        _check_points(decoupler, keys, np.array([[0.5, 30.0, -0.1], [-0.5, 60.0, -0.2]]), None, None)
    with pytest.raises(ConfigError, match=r"sweep point 1 of 1 .*tensioner\.stops = \(0\.1, 0\.3\): must contain"):
        _check_points(decoupler, keys, np.array([[0.5, 30.0, 0.1]]), None, None)


@pytest.mark.long
def test_clutch_spring_gradient_through_its_key_matches_central_differences():
    """d(alternator speed after 0.12 s)/d(decoupler spring) through ``set_parameter``: forward mode vs
    central differences (the drive and output of tests/test_clutch.py, which sets the leaf directly:
    the same compiled programs)."""
    drive = build_quietly(clutch_serpentine_spec("decoupler", t_end=0.12, n_elements=24))
    key = A + "clutch_stiffness"

    def out(k):
        _, s = simulate_signals(drive, set_parameter(drive, drive.params, key, k), adjoint="forward")
        return s["omega:alternator"][-1]

    k0 = jnp.asarray(40.0)
    _, g = jax.jvp(out, (k0,), (jnp.ones_like(k0),))
    fd = (float(out(k0 * (1 + 1e-5))) - float(out(k0 * (1 - 1e-5)))) / (2e-5 * 40.0)
    assert np.isfinite(float(g)) and float(g) != 0.0
    assert float(g) == pytest.approx(fd, rel=1e-4, abs=1e-6 * abs(fd) + 1e-12)


# ----------------------------------------------------------------------------- signals
@pytest.fixture(scope="module")
def oap():
    return jb.run(build_quietly(clutch_serpentine_spec("oap")))


@pytest.fixture(scope="module")
def lossy():
    """Friction 0.3 N m and the lower stop 0.01 rad below the drawn arm, where the belt pushes it."""
    return jb.run(build_quietly(lossy_serpentine_spec(friction=0.3, stops=(-0.01, 0.3))))


def test_signals_have_units(oap, lossy):
    units = {**signal_units(oap.drive), **signal_units(lossy.drive)}
    assert units["rotor_omega:alternator"] == "rad/s" and units["clutch_torque:alternator"] == "N m"
    assert units["pivot_friction:tensioner"] == "N m" and units["stop_torque:tensioner"] == "N m"
    extra = {"rotor_omega", "clutch_torque", "pivot_friction", "stop_torque"}
    assert {n for n in signal_units(oap.drive) if n.split(":")[0] in extra} == {
        "rotor_omega:alternator",
        "clutch_torque:alternator",
    }
    assert {n for n in signal_units(lossy.drive) if n.split(":")[0] in extra} == {
        "pivot_friction:tensioner",
        "stop_torque:tensioner",
    }


def test_locked_clutch_torque_carries_the_rotor_load(oap):
    """Locked, sheave (J_s) and rotor (J_r) share one acceleration (tau_b - L) / (J_s + J_r) under the belt
    torque tau_b and the load L on the rotor, so the clutch torque is L + J_r (tau_b - L) / (J_s + J_r):
    the load in a steady state, plus the rotor's share of the polygon effect's torque ripple."""
    s, ts = oap.signals, oap.signals["t"]
    steady = (ts > 0.22) & (ts < CLUTCH_DROP)
    np.testing.assert_allclose(s["rotor_omega:alternator"][steady], s["omega:alternator"][steady], rtol=1e-9)
    Js, Jr = CLUTCH_J
    tau_b, clutch = s["torque:alternator"][steady], s["clutch_torque:alternator"][steady]
    np.testing.assert_allclose(clutch, CLUTCH_LOAD + Jr * (tau_b - CLUTCH_LOAD) / (Js + Jr), rtol=1e-6)
    # the ripple (0.7 to 2.2 N m here) averages out: the mean over 40 saves is the load (measured 0.7 % off)
    assert np.mean(clutch) == pytest.approx(CLUTCH_LOAD, rel=0.01)


def test_overrun_has_zero_clutch_torque_and_a_faster_rotor(oap):
    s, ts = oap.signals, oap.signals["t"]
    rotor, sheave, torque = s["rotor_omega:alternator"], s["omega:alternator"], s["clutch_torque:alternator"]
    over = (ts > CLUTCH_DROP) & (rotor > sheave + 1e-6)
    assert over.sum() >= 5 and np.max(rotor[over] - sheave[over]) > 10.0  # measured: 20 ms, up to 25 rad/s
    assert np.max(np.abs(torque[over])) < 1e-12 * np.max(torque)  # round-off of the last engaged sweep
    # it drives the rotor, never brakes it (measured -5e-18 N m once: the saved state's round-off)
    assert np.all(torque >= -1e-12 * np.max(torque)) and np.max(torque) > CLUTCH_LOAD


def test_pivot_friction_in_its_band_and_stop_reaction_on_the_stop_only(lossy):
    s, F, low = lossy.signals, 0.3, -0.01
    psi, friction, stop = s["arm_angle:tensioner"], s["pivot_friction:tensioner"], s["stop_torque:tensioner"]
    w = np.asarray(lossy.trajectory.states.psi_dot)[:, 1]
    assert np.all(np.abs(friction) <= F * (1 + 1e-12))
    sliding = (np.abs(w) > 1e-6) & (psi > low + 1e-9)
    assert sliding.sum() > 5
    np.testing.assert_allclose(friction[sliding], -F * np.sign(w[sliding]), rtol=1e-12)  # against the motion
    on = np.isclose(psi, low, rtol=0, atol=1e-12)
    assert on.sum() > 5 and np.max(stop[on]) > 0.1
    scale = np.max(np.abs(stop))
    assert np.all(np.abs(stop[~on]) <= 1e-12 * scale)  # off the stop: no reaction
    assert np.all(stop[on] >= -1e-12 * scale)  # the lower stop pushes up only
    # at rest (on the stop or stuck: no velocity, the angle of the save before), friction and stop hold the
    # spring and the belt: their torques about the pivot, the belt's from the hub load. That sums the step's
    # contact impulses along the normals of the end-of-step geometry, not the step's own start geometry:
    # measured 0.94 % of the belt torque (12 N m) apart at most, 0.06 % typically; within 2 % of it here
    pp = lossy.drive.params.pulleys
    rest = (np.abs(w) < 1e-12) & np.concatenate([[False], np.abs(np.diff(psi)) < 1e-14])
    n = pp.carrier[1]
    spring = float(n["preload"]) - float(n["stiffness"]) * (psi - float(n["rest"]))
    H, ang = s["hub_load:tensioner"], np.radians(s["hub_direction:tensioner"])
    L = float(n["length"])
    belt = H * L * (np.sin(ang) * np.cos(psi) - np.cos(ang) * np.sin(psi))  # r x F, r = L (cos psi, sin psi)
    assert rest.sum() > 5 and on[rest].sum() > 5  # measured 23 saves at rest, 19 of them on the stop
    scale = np.max(np.abs(belt[rest]))
    np.testing.assert_allclose((friction + stop)[rest], -(spring + belt)[rest], rtol=0, atol=0.02 * scale)


@pytest.mark.parametrize("F", [0.2, 0.4])
def test_stop_reaction_is_the_torque_beyond_the_friction_band(F):
    """The arm of tests/test_tensioner_friction.py (inertia 2e-3, spring 20 N m/rad, preload -1 N m, load
    0.3 N m) driven onto its lower stop at -0.02 rad: there the net torque pushing into the stop is
    -1 + 20 x 0.02 + 0.3 = -0.3 N m. Friction F = 0.2 takes F and the stop the rest, 0.1 N m; with
    F = 0.4 (the arm still swings past -0.02 rad: to -0.03 without the stop) it rests on the stop held
    by friction alone (0.3 N m), the stop pushing nothing."""
    K, low, h = 20.0, -0.02, 1e-4
    pp = arm_rig_params(
        damping=0.05, preload=-1.0, inertia=2e-3, spring=K, friction=F, damping_unload=0.05, stops=(low, np.inf)
    )
    arm = LossyCarrier(inner=ArmCarrier())
    r = simulate_carrier(arm, pp, 0, 0.0, 0.0, h, 3000, 0.3)
    assert float(r.psi[-1]) == pytest.approx(low, abs=1e-15) and float(r.psi_dot[-1]) == pytest.approx(0, abs=1e-15)
    friction, stop = (np.asarray(x) for x in arm.constraint_parts(pp, 0, r.impulse, r.psi_dot, h))
    excess = -1.0 - K * low + 0.3
    held = min(F, -excess)
    assert friction[-1] == pytest.approx(held, rel=1e-9)
    assert stop[-1] == pytest.approx(-excess - held, abs=1e-9 * abs(excess))
    # with symmetric damping the impulse is friction and stop reaction only, at every step
    np.testing.assert_allclose(friction + stop, np.asarray(r.impulse) / h, rtol=0, atol=1e-12)
