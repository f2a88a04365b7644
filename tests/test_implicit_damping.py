"""Implicit Kelvin-Voigt belt damping (``solver.implicit_damping``): the operator is the damping force's
exact Jacobian, the cyclic solve is exact, the step bound loses its damping term, and a drive run with it
keeps the energy audit."""

import dataclasses
import functools

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt._linalg import xy_components
from jaxbelt.belt import implicit as dm
from jaxbelt.belt.ring import belt_operators, internal_forces, ring_mass_matrix
from jaxbelt.dynamics.stability import BeltNumbers, rate_bounds, stable_time_step, step_limit
from jaxbelt.dynamics.stages import belt_implicit_free_velocity, belt_smooth_forces


@functools.cache
def _belt(n):
    spec = jb.benchmark_a(n_elements=n, t_end=0.01)
    spec.solver.scheme = "explicit"  # the explicit scheme's step bounds ("auto" runs 120 elements implicit)
    d = jb.build_drive(spec)
    return d, d.params.belt, belt_operators(n, d.params.belt)


def _dense(vec_op, n):
    """Dense matrix of a linear map on per-node 4-vectors (n, 4)."""
    eye = np.eye(4 * n)
    return np.stack([np.asarray(vec_op(jnp.asarray(e.reshape(n, 4)))).ravel() for e in eye], axis=1)


def test_damping_operator_is_the_kelvin_voigt_force():
    d, p, ops = _belt(30)
    q = d.state0.q
    v = jax.random.normal(jax.random.PRNGKey(0), q.shape)
    no_kv = eqx.tree_at(lambda b: b.axial_damping, p, jnp.zeros(()))
    f_kv = internal_forces(q, v, p, ops)[0] - internal_forces(q, v, no_kv, ops)[0]
    cv = dm.apply_blocks(dm.damping_blocks(q, p, ops), dm.node_vectors(*xy_components(v)))
    np.testing.assert_allclose(-cv, dm.node_vectors(*xy_components(f_kv)), rtol=0, atol=1e-12 * np.abs(cv).max())


@pytest.mark.parametrize("n", [3, 4, 5, 7, 12, 30])
def test_cyclic_solve_matches_a_dense_solve(n):
    d, p, _ = _belt(30)
    ops = belt_operators(n, p)
    q = d.state0.q[:: 30 // n][:n] if n <= 30 else d.state0.q
    q = q + 0.01 * jax.random.normal(jax.random.PRNGKey(n), q.shape)  # arbitrary stretch and bending
    h, a = 3e-5, 1.2
    D, U, Cb = dm.implicit_blocks(q, p, ops, a, h)
    M = np.asarray(ring_mass_matrix(n, ops.element_length, p.mass_per_length))

    def W(u):
        mx, my = (jnp.asarray(M) @ c for c in dm.from_node_vectors(u))
        return a * dm.node_vectors(mx, my) + h * dm.apply_blocks(Cb, u)

    Wd = _dense(W, n)
    np.testing.assert_allclose(Wd, Wd.T, atol=1e-12 * np.abs(Wd).max())
    b = np.asarray(jax.random.normal(jax.random.PRNGKey(1), (n, 4, 2)))
    x = np.asarray(dm.solve_cyclic(D, U, jnp.asarray(b)))
    ref = np.linalg.solve(Wd, b.reshape(4 * n, 2)).reshape(n, 4, 2)
    np.testing.assert_allclose(x, ref, rtol=0, atol=1e-10 * np.abs(ref).max())


def test_free_stage_is_implicit_euler_on_the_damping_and_differentiates_alike_both_ways():
    d, p, ops = _belt(30)
    q, h, alpha = d.state0.q, 5e-5, 3.0
    v = 0.1 * jax.random.normal(jax.random.PRNGKey(2), q.shape)
    g = jnp.zeros_like(q)

    def stage(eta):
        pp = eqx.tree_at(lambda b: b.axial_damping, p, eta)
        f = belt_smooth_forces(pp, ops, g, q, v, implicit_damping=True)
        vx, vy = xy_components(v)
        return belt_implicit_free_velocity(pp, ops, q, f, vx, vy, h, alpha), f

    r, f = stage(p.axial_damping)
    vx, vy = xy_components(v)
    # (1 + h alpha) M v+ + h C v+ = M v + h f
    for vn, c, v0, fc in ((r.vx, r.damping_x, vx, f.fx), (r.vy, r.damping_y, vy, f.fy)):
        lhs = (1 + h * alpha) * ops.mass.apply(vn) + h * c
        np.testing.assert_allclose(lhs, ops.mass.apply(v0) + h * fc, atol=1e-12 * float(jnp.abs(lhs).max()))
    out = lambda eta: stage(eta)[0].vx  # noqa: E731
    eta0 = p.axial_damping
    fwd = jax.jvp(out, (eta0,), (jnp.ones_like(eta0),))[1]  # forward mode: d vx / d eta
    y, pullback = jax.vjp(out, eta0)
    # reverse mode, one cotangent per output (jacrev's rows), the pullback compiled: run eagerly, the cyclic
    # reduction's many small operations made this test take 52 s alone, cold (now 23 s)
    rev = jax.jit(jax.vmap(pullback))(jnp.eye(y.shape[0], dtype=y.dtype))[0]
    np.testing.assert_allclose(fwd, rev, rtol=1e-12, atol=1e-14 * float(jnp.abs(fwd).max()))
    e = 1e-4 * float(p.axial_damping)
    fd = (out(p.axial_damping + e) - out(p.axial_damping - e)) / (2 * e)
    np.testing.assert_allclose(fwd, fd, rtol=1e-5, atol=1e-7 * float(jnp.abs(fwd).max()))


def test_step_bound_drops_only_the_axial_damping_term():
    d, p, _ = _belt(120)
    belt = BeltNumbers.of(p)
    w2, c = rate_bounds(120, belt)
    w2i, ci = rate_bounds(120, belt, implicit_damping=True)
    assert w2i == w2
    assert (
        ci
        == float(p.bending_damping) * 2500.0 * float(p.EI) / belt.mass_per_length / (belt.stress_free_length / 120) ** 4
    )
    implicit = dataclasses.replace(d.model, implicit_damping=True)
    assert stable_time_step(implicit, d.params) == pytest.approx(step_limit(w2i, ci), rel=1e-12)
    assert stable_time_step(implicit, d.params) > 2.5 * stable_time_step(d.model, d.params)  # 3.1e-5 vs 1.15e-5


def test_bad_option_is_refused_naming_the_key():
    spec = jb.benchmark_a(n_elements=20, t_end=0.01)
    spec.solver.implicit_damping = "yes"  # type: ignore[assignment]
    with pytest.raises(jb.ConfigError, match="solver.implicit_damping"):
        jb.build_drive(spec)


@pytest.fixture(scope="module")
def implicit_run():
    spec = jb.benchmark_a(n_elements=40, t_end=1.2, save_dt=1e-2)
    spec.solver.implicit_damping = True
    spec.solver.expect_steady = False  # ends inside the load step: the scheme, not a duty point, is tested
    return jb.run(spec)


def test_drive_runs_at_the_wave_bound_and_the_energy_audit_closes(implicit_run):
    r = implicit_run
    d = r.drive
    assert d.model.implicit_damping
    explicit = stable_time_step(dataclasses.replace(d.model, implicit_damping=False), d.params)
    assert d.dt > 1.2 * explicit  # beyond the explicit damping bound: stable only because it is implicit
    assert r.summary["status"] == "ok"
    a = r.summary["energy"]
    assert abs(a["residual_relative"]) < 0.01, a
    assert a["belt_damping_J"] > 0
