"""Tensioner pivot friction (true sticking), unloading damping and hard stops.

Closed forms on the belt-free carrier rig (``jaxbelt.pulleys.rig``: the same implicit step and the
same constraint solve as a drive step): a free arm with dry friction F on a spring k loses 4 F / k
of amplitude per cycle and comes to rest inside the band |psi - rest| <= F / k; an arm whose net
torque lies inside the band does not move at all; a stop holds the arm at its limit with the
reaction equal to the excess torque; the unloading damping decays the unloading half-cycles only.
In a drive (the serpentine example, coarse): the energy audit closes with the friction work
counted, a stop keeps the arm inside its range, and a wide band freezes the arm.
"""

import math
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import arm_rig_params, build_quietly, lossy_serpentine_spec

import jaxbelt as jb
from jaxbelt.pulleys import ArmCarrier, LossyCarrier
from jaxbelt.pulleys.rig import simulate_carrier

I, K = 2e-3, 20.0  # arm inertia [kg m^2], spring [N m/rad]
OMEGA = math.sqrt(K / I)
PERIOD = 2 * math.pi / OMEGA


def _arm(damping=0.0, preload=0.0, **losses):
    return arm_rig_params(damping, preload, inertia=I, spring=K, **losses)


def _extrema(psi):
    d = np.diff(psi)
    i = np.nonzero((d[:-1] > 0) != (d[1:] > 0))[0] + 1
    return psi[i]


def test_free_arm_with_dry_friction_loses_4F_over_k_per_cycle():
    F, A0 = 0.1, 0.05
    h = PERIOD / 4000
    r = simulate_carrier(LossyCarrier(inner=ArmCarrier()), _arm(friction=F), 0, A0, 0.0, h, 4000 * 5)
    ext = _extrema(np.asarray(r.psi))
    amps = np.abs(np.concatenate([[A0], ext]))
    per_cycle = amps[:-2] - amps[2:]
    # the implicit spring's own numerical damping adds ~ (omega h)^2 / 2 per step: 0.4 % of 4F/k here
    np.testing.assert_allclose(per_cycle, 4 * F / K, rtol=0.01)
    # at rest inside the friction band, still to round-off (the impulse cancels the free velocity)
    assert abs(float(r.psi[-1])) <= F / K
    assert abs(float(r.psi_dot[-1])) < 1e-18 and abs(float(r.psi[-1] - r.psi[-2])) < 1e-18


def test_arm_inside_its_friction_band_does_not_move():
    F = 0.5
    # spring torque K * 0.01 = 0.2 and a load of 0.25 N m: net 0.45 N m, inside the 0.5 N m band
    r = simulate_carrier(LossyCarrier(inner=ArmCarrier()), _arm(friction=F), 0, -0.01, 0.0, 1e-4, 500, 0.25)
    np.testing.assert_allclose(np.asarray(r.psi), -0.01, rtol=0, atol=1e-16)
    np.testing.assert_allclose(np.asarray(r.psi_dot), 0.0, rtol=0, atol=1e-16)
    # the friction torque holds exactly the net torque
    np.testing.assert_allclose(np.asarray(r.impulse) / 1e-4, -(0.2 + 0.25), rtol=1e-12)
    # just outside the band it moves
    r = simulate_carrier(LossyCarrier(inner=ArmCarrier()), _arm(friction=F), 0, -0.01, 0.0, 1e-4, 50, 0.31)
    assert float(r.psi[-1]) > -0.01


def test_stop_holds_the_arm_with_the_excess_torque():
    low, h = -0.02, 1e-4
    pp = _arm(damping=0.05, preload=-1.0, stops=(low, np.inf))  # preload drives the arm into the stop
    r = simulate_carrier(LossyCarrier(inner=ArmCarrier()), pp, 0, 0.0, 0.0, h, 3000, 0.3)
    psi = np.asarray(r.psi)
    assert psi.min() >= low - 1e-15  # never beyond the stop
    assert psi[-1] == pytest.approx(low, abs=1e-15) and float(r.psi_dot[-1]) == pytest.approx(0.0, abs=1e-15)
    excess = -1.0 - K * low + 0.3  # spring + preload + load at the stop, pushing into it
    np.testing.assert_allclose(float(r.impulse[-1]) / h, -excess, rtol=1e-9)


def test_symmetric_lossy_arm_equals_the_plain_arm():
    pp, h = _arm(damping=0.02, damping_unload=0.02), PERIOD / 500
    plain = simulate_carrier(ArmCarrier(), pp, 0, 0.03, 0.0, h, 800)
    lossy = simulate_carrier(LossyCarrier(inner=ArmCarrier()), pp, 0, 0.03, 0.0, h, 800)
    np.testing.assert_allclose(np.asarray(lossy.psi), np.asarray(plain.psi), rtol=1e-12, atol=1e-15)


def test_unloading_damping_acts_on_unloading_half_cycles_only():
    # load_sense -1: moving to negative angles winds the spring up (loading, no damping here);
    # moving to positive angles unloads, with damping c: amplitude x exp(-c T / (4 I)) per half cycle
    c, h = 0.01, PERIOD / 8000
    r = simulate_carrier(
        LossyCarrier(inner=ArmCarrier(), load_sense=-1),
        _arm(damping_unload=c),
        0,
        -0.05,
        0.0,
        h,
        8000 * 2,
    )
    amps = np.abs(np.concatenate([[-0.05], _extrema(np.asarray(r.psi))]))
    ratios = amps[1:] / amps[:-1]  # half-cycles: unloading (up), loading (down), ...
    numerical = math.exp(-((OMEGA * h) ** 2) / 2 * 4000)  # the implicit spring's own decay per half cycle
    np.testing.assert_allclose(ratios[0::2], math.exp(-c * PERIOD / (4 * I)) * numerical, rtol=2e-3)
    np.testing.assert_allclose(ratios[1::2], numerical, rtol=2e-3)


def test_friction_gradient_matches_central_differences_and_the_closed_form():
    h, n = PERIOD / 4000, 4000 * 2  # two full cycles: amplitude A0 - 8 F / k

    def final(F):
        return simulate_carrier(LossyCarrier(inner=ArmCarrier()), _arm(friction=F), 0, 0.05, 0.0, h, n).psi[-1]

    F = jnp.asarray(0.1)
    g = float(jax.grad(final)(F))
    fd = (float(final(F + 1e-6)) - float(final(F - 1e-6))) / 2e-6
    assert g == pytest.approx(fd, rel=1e-6)
    assert g == pytest.approx(-8 / K, rel=0.02)  # psi(2T) = A0 - 8 F / k (phase near a maximum)


# ----------------------------------------------------------------------------- in a drive
@pytest.fixture(scope="module")
def serpentine():
    return jb.run(build_quietly(lossy_serpentine_spec()))


def test_drive_energy_audit_closes_with_pivot_friction(serpentine):
    a = serpentine.summary["energy"]
    assert abs(a["residual_relative"]) < 0.005, a  # measured 1.4e-4 (0.5 s)
    assert a["carrier_friction_J"] > 0  # pivot friction and unloading damping dissipate


def test_drive_stop_keeps_the_arm_in_range(serpentine):
    spec = lossy_serpentine_spec(friction=0.0, stops=(-0.01, 0.01))
    r = jb.run(build_quietly(spec))
    psi = r.signals["arm_angle:tensioner"]
    assert psi.min() >= -0.01 - 1e-12 and psi.max() <= 0.01 + 1e-12
    wide = serpentine.signals["arm_angle:tensioner"]
    assert wide.min() < -0.015  # with the stops at +-0.3 rad it swings further
    assert np.sum(np.isclose(psi, -0.01, atol=1e-12)) > 5  # and it rests on the stop


def test_drive_arm_inside_a_wide_band_does_not_move():
    spec = lossy_serpentine_spec(friction=50.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = jb.run(jb.build_drive(spec))
    np.testing.assert_allclose(r.signals["arm_angle:tensioner"], float(r.drive.state0.psi[1]), rtol=0, atol=1e-14)


def test_friction_at_least_the_spring_load_warns_and_bad_stops_are_refused():
    spec = lossy_serpentine_spec(friction=12.5)  # installed spring torque: preload -12 N m
    with pytest.warns(UserWarning, match=r"tensioner\.friction_torque = 12\.5: .*12 N m \(allowed: below it\)"):
        jb.build_drive(spec)
    spec = lossy_serpentine_spec(stops=(0.1, 0.3))
    with pytest.raises(
        jb.ConfigError, match=r"tensioner\.stops = \(0\.1, 0\.3\): must contain the installed arm angle"
    ):
        jb.build_drive(spec)
    spec = lossy_serpentine_spec(friction=-1.0)
    with pytest.raises(jb.ConfigError, match=r"tensioner\.friction_torque = -1\.0"):
        jb.build_drive(spec)
