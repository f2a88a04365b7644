"""Loads (``load``, ``power_kw``) are brakes: dissipative torques that stop a pulley but never turn it
backwards. An overloaded drive therefore slips with its accessories standing still instead of running
in reverse (a constant torque opposing the running sense would drive them backwards)."""

import math

import jax.numpy as jnp
import numpy as np
import pytest
from helpers import capstan_belt

import jaxbelt as jb
from jaxbelt.pulleys.carrier import loaded_velocity


class _Model:
    brake_sense = (1.0, -1.0, 0.0)


def test_brake_update_is_the_backward_euler_projection_of_a_coulomb_torque():
    """Closed form: omega+ = sign(u) max(|u| - h Q, 0) / (I + h c) for a brake, linear otherwise."""
    inertia, viscous, h = jnp.array([2.0, 2.0, 2.0]), jnp.array([0.5, 0.0, 0.5]), 0.1
    q = 3.0  # brake magnitude [N m]
    applied = jnp.array([-q, +q, -q])  # brakes oppose their running sense (+1, -1); the third is a torque
    for omega in (jnp.array([5.0, -5.0, 5.0]), jnp.array([0.1, -0.1, 0.1]), jnp.array([-5.0, 5.0, -5.0])):
        out, torque = loaded_velocity(_Model(), inertia, omega, applied, viscous, h)
        u = inertia * omega
        expect_brake = np.sign(u) * np.maximum(np.abs(u) - h * q, 0.0) / (inertia + h * viscous)
        expect_torque = (u + h * applied) / (inertia + h * viscous)
        np.testing.assert_allclose(out[:2], expect_brake[:2], rtol=1e-15)
        np.testing.assert_allclose(out[2], expect_torque[2], rtol=1e-15)
        # the torque that acted reproduces the update and never exceeds the brake's magnitude
        np.testing.assert_allclose((inertia + h * viscous) * out - u, h * torque, atol=1e-14)
        assert np.all(np.abs(np.asarray(torque[:2])) <= q + 1e-12)
    # a pulley slower than h Q / I is held: zero speed, not reversed
    out, _ = loaded_velocity(_Model(), inertia, jnp.array([0.1, -0.1, 0.0]), applied, viscous, h)
    assert float(out[0]) == 0.0 and float(out[1]) == 0.0


def _overload_spec(load):
    return jb.DriveSpec(
        belt=capstan_belt(),
        pulleys=[
            jb.PulleySpec("A", (0, 0), 0.1, role="driver", inertia=0.1, speed={"smooth_step": [0.0, 0.1, 0.0, 20.0]}),
            jb.PulleySpec("B", (0.3, 0), 0.1, role="driven", inertia=0.01, load=load),
        ],
        contact=jb.ContactSpec(mu=0.3, stiffness=1e8, damping=2e3),
        solver=jb.SolverSpec(t_end=0.45, save_dt=2e-3),
    )


def test_overloaded_pulley_stops_and_never_runs_backwards():
    """Equal pulleys, flat belt, mu = 0.3: the drive transmits at most Q_max = r (T1 - T2) with
    T1 / T2 = exp(mu pi) and T1 + T2 = 2 T0 (400 N): 17.6 N m. Below it (8 N m) the driven pulley runs at
    the driver's speed less the creep (T1 - T2) / EA; after a step to 30 N m (1.7 Q_max) it stops within
    a few steps' creep of zero and stays there while the driver slips at the Euler-Eytelwein ratio."""
    r = jb.run(_overload_spec({"table": [[0.0, 8.0], [0.25, 8.0], [0.27, 30.0]]}))
    s, t = r.signals, r.signals["t"]
    limit = math.exp(0.3 * math.pi)
    # running below the limit: speed ratio by creep theory, omega_B / omega_A = (1 + eps_slack) / (1 + eps_tight)
    run = (t > 0.18) & (t < 0.25)
    T_tight = np.maximum(s["tension:A-B"], s["tension:B-A"])[run].mean()
    T_slack = np.minimum(s["tension:A-B"], s["tension:B-A"])[run].mean()
    assert (T_tight - T_slack) * 0.1 == pytest.approx(8.0, rel=0.02)  # the load, through the spans
    creep = (1 + T_slack / 5000.0) / (1 + T_tight / 5000.0)
    ratio = s["omega:B"][run].mean() / s["omega:A"][run].mean()
    # 1 % on the ratio: this coarse mesh (32 elements, 38 mm on r = 0.1 m) measured 0.979 against 0.985; creep
    # theory itself is asserted at 60 elements in test_benchmark_a. Here it shows B driven at the belt's speed.
    assert ratio == pytest.approx(creep, abs=0.01)
    # overloaded: B stops and is never reversed. The brake acts in the free step, before the contact
    # impulses of the same step: a held pulley creeps at up to h Q_max / I (the belt's torque at the
    # limit, one step's impulse), 0.07 rad/s here against the driver's 20 rad/s, an O(h) error.
    held = t > 0.33
    q_max = 0.1 * 400.0 * (limit - 1.0) / (limit + 1.0)
    creep_bound = r.drive.dt * q_max / 0.01
    assert np.all(np.abs(s["omega:B"][held]) < 1.1 * creep_bound), (s["omega:B"][held].max(), creep_bound)
    assert s["omega:B"].min() > -1.1 * creep_bound
    assert s["omega:A"][held].mean() == pytest.approx(20.0, rel=1e-3)
    hi = np.maximum(s["tension:A-B"], s["tension:B-A"])[held]
    lo = np.minimum(s["tension:A-B"], s["tension:B-A"])[held]
    assert (hi / lo).mean() == pytest.approx(limit, rel=0.02)
    # the energy balance closes with the brake in it (1 %)
    assert abs(r.summary["energy"]["residual_relative"]) < 0.01, r.summary["energy"]
