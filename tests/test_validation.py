"""Bad input gets a clear error before anything is compiled; a diverging run says so."""

import dataclasses

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbelt as jb


def _spec(**changes):
    spec = jb.benchmark_a(n_elements=24, t_end=0.02)
    for path, value in changes.items():
        obj = spec
        parts = path.split(".")
        for p in parts[:-1]:
            obj = obj[int(p)] if p.isdigit() else getattr(obj, p)
        setattr(obj, parts[-1], value)
    return spec


@pytest.mark.parametrize(
    "change, field",
    [
        ({"belt.EA": -1.0}, "belt.EA"),
        ({"belt.EA": 0.0}, "belt.EA"),
        ({"belt.EI": float("nan")}, "belt.EI"),
        ({"belt.mass_per_length": 0.0}, "belt.mass_per_length"),
        ({"belt.axial_damping": -0.1}, "belt.axial_damping"),
        ({"belt.n_elements": 3}, "belt.n_elements"),
        ({"contact.mu": -0.2}, "contact.mu"),
        ({"contact.mu": 0.0}, "contact.mu"),
        ({"contact.stiffness": 0.0}, "contact.stiffness"),
        ({"pulleys.0.radius": 0.0}, "radius"),
        ({"pulleys.1.inertia": -1.0}, "inertia"),
        ({"solver.dt": 1e-3}, "solver.dt"),
        ({"belt.stress_free_length": 2.0}, "belt.stress_free_length"),
        ({"belt.stress_free_length": 0.5}, "belt.stress_free_length"),
        ({"pulleys.1.center": (0.15, 0.0)}, "overlap"),
        ({"contact.friction_law": "viscous"}, "contact.friction_law"),
    ],
)
def test_bad_input_raises_config_error_naming_the_field(change, field):
    with pytest.raises(jb.ConfigError) as err:
        jb.build_drive(_spec(**change))
    assert field in str(err.value)


def test_time_step_error_states_the_limit():
    with pytest.raises(jb.ConfigError, match=r"stability limit [0-9.e-]+ s"):
        jb.build_drive(_spec(**{"solver.dt": 1e-3}))


def test_coarse_mesh_on_a_small_pulley_warns():
    spec = _spec()
    spec.pulleys[1].radius = 0.02  # 24 elements of ~40 mm on a 20 mm pulley
    spec.pulleys[1].center = (0.25, 0.0)
    spec.belt.stress_free_length, spec.belt.pretension = None, 400.0
    with pytest.warns(UserWarning, match="elements"):
        jb.build_drive(spec)


def test_divergence_stops_with_time_and_advice_and_keeps_history():
    drive = jb.build_drive(_spec(**{"solver.t_end": 0.3, "solver.settle_time": 0.0, "belt.n_elements": 40}))
    # Bypass validation on purpose: 4x the stability limit.
    limit = jb.dynamics.stable_time_step(drive.model, drive.params)
    drive = dataclasses.replace(drive, dt=4.0 * limit)  # Drive is frozen
    r = jb.run(drive, t_end=0.3)
    status = r.summary["status"]
    assert status.startswith("diverged at t =") and "dt" in status
    t_fault = float(r.trajectory.final.fault_time)
    assert 0.0 <= t_fault < 0.3
    ts = np.asarray(r.trajectory.ts)
    before = ts < t_fault - 1e-9
    assert before.any() and np.all(np.isfinite(np.asarray(r.trajectory.states.q)[before]))


def test_unconverged_contact_solver_is_flagged_in_the_summary():
    spec = _spec(**{"solver.t_end": 0.2, "belt.n_elements": 30})
    spec.solver.lcp_iterations = 1  # one sweep: not converged
    spec.solver.expect_steady = False  # a 0.2 s start-up: only the contact solve decides the status
    r = jb.run(spec)
    assert r.summary["lcp_residual_median"] > 1e-3
    assert any("not converged" in w for w in r.summary["warnings"])
    assert r.summary["status"].startswith("contact solver not converged")  # not "ok": exit 1 on the CLI
    from jaxbelt.cli.common import status_kind

    assert status_kind(r.summary["status"]).startswith("the contact solve did not converge")
    ok = jb.run(_spec(**{"solver.t_end": 0.2, "belt.n_elements": 30}))
    assert ok.summary["warnings"] == []
    # converged in the median but one save interval of the window above the bound: a warning, the status stands
    from jaxbelt.outputs.summary import summary

    traj = ok.trajectory
    ts = np.asarray(traj.ts)
    k = len(ts) - 3
    res = np.asarray(traj.states.lcp_residual).copy()
    res[k] = 5e-3
    states = eqx.tree_at(lambda s: s.lcp_residual, traj.states, jnp.asarray(res))
    s = summary(ok.drive, ts, states, traj.final, steady=True)
    assert s["status"] == ok.summary["status"] and s["lcp_residual_max"] == 5e-3
    (w,) = s["warnings"]
    assert w.startswith("contact solver not converged at some steps: 1 of ") and f"t = {ts[k]:.4g} s" in w, w
