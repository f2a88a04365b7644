"""The frictional contact solver on small problems with known solutions."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxbelt.contact.friction import Coulomb, Regularised
from jaxbelt.contact import Delassus, PointProblem, SolveSettings, solve_contact


def _solve(G, u_free_n, u_free_t, mu, bias=None, compliance=None, iterations=200, law=None, nu_s=0.0):
    G = jnp.asarray(G)
    nc = len(u_free_n)

    def apply_G(ln, lt):
        out = G @ jnp.concatenate([ln, lt])
        return out[:nc], out[nc:]

    diag = jnp.diagonal(G)
    z = jnp.zeros(nc)
    problem = PointProblem(
        u_free_n=jnp.asarray(u_free_n),
        u_free_t=jnp.asarray(u_free_t),
        bias_n=z if bias is None else jnp.asarray(bias),
        compliance_n=z if compliance is None else jnp.asarray(compliance),
        mu=jnp.full(nc, mu),
    )
    settings = SolveSettings(
        iterations=iterations, relaxation=1.0, friction_law=law or Coulomb(), friction_params={"nu_s": nu_s}
    )
    return solve_contact(Delassus(apply_G, diag[:nc], diag[nc:]), problem, (z, z), settings)


def test_single_block_sticks_below_and_slides_above_the_friction_limit():
    # Unit mass block pressed on a rigid plane: approach speed 1 -> normal impulse 1 (rigid contact).
    # A tangential velocity 0.3 needs impulse 0.3 < mu*1 = 0.5: sticks exactly.
    G = np.eye(2)
    ln, lt, res = _solve(G, [-1.0], [0.3], mu=0.5)
    assert float(ln[0]) == pytest.approx(1.0, rel=1e-12)
    assert float(lt[0]) == pytest.approx(-0.3, rel=1e-12)
    # Tangential 0.8 needs 0.8 > 0.5: slides with impulse -mu*lambda_n and keeps 0.3 of its speed.
    ln, lt, _ = _solve(G, [-1.0], [0.8], mu=0.5)
    assert float(lt[0]) == pytest.approx(-0.5, rel=1e-12)
    assert float(res) < 1e-12


def test_separating_contact_carries_no_impulse():
    ln, lt, _ = _solve(np.eye(2), [+0.2], [0.5], mu=0.5)
    assert float(ln[0]) == 0.0 and float(lt[0]) == 0.0


def test_compliant_normal_law_is_an_implicit_spring_damper():
    # Compliance eps and bias b: lambda = max(0, -(u + b)/(G + eps)) for a single point.
    G, eps, b, u = 2.0, 3.0, -0.4, -0.1
    ln, _, _ = _solve(np.diag([G, G]), [u], [0.0], mu=0.5, bias=[b], compliance=[eps])
    assert float(ln[0]) == pytest.approx(-(u + b) / (G + eps), rel=1e-12)


def test_coupled_points_match_a_direct_solve_when_all_stick():
    # Random SPD Delassus with moderate coupling; all contacts stick if mu is large -> G lam = -u.
    rng = np.random.default_rng(0)
    A = rng.normal(size=(8, 8)) * 0.15
    G = np.eye(8) + A @ A.T
    u_n = -np.abs(rng.normal(size=4)) - 0.5
    u_t = rng.normal(size=4) * 0.1
    ln, lt, res = _solve(G, u_n, u_t, mu=5.0, iterations=400)
    lam = np.concatenate([ln, lt])
    np.testing.assert_allclose(G @ lam, -np.concatenate([u_n, u_t]), atol=1e-10)
    assert float(res) < 1e-10


def test_regularised_law_matches_its_closed_form_for_one_point():
    # One point, unit mass, lambda_n fixed by the normal: lambda_t = -mu lambda_n (2/pi) atan(nu (u0 + lambda_t)).
    ln, lt, _ = _solve(np.eye(2), [-1.0], [0.05], mu=0.5, iterations=100, law=Regularised(), nu_s=20.0)
    u_after = 0.05 + float(lt[0])
    assert float(lt[0]) == pytest.approx(-0.5 * float(ln[0]) * 2 / np.pi * np.arctan(20.0 * u_after), rel=1e-10)
    assert 0 < u_after < 0.05  # no true sticking: it creeps


def test_solver_is_differentiable_forward_and_reverse():
    G = np.eye(2) * 1.5

    def f(u):
        ln, lt, _ = _solve(G, [-1.0], [u], mu=0.5, iterations=30)
        return lt[0]

    for u in [0.3, 0.9]:  # stick and slip branch
        g_rev = jax.grad(f)(u)
        g_fwd = jax.jacfwd(f)(u)
        assert np.isfinite(g_rev) and float(g_rev) == pytest.approx(float(g_fwd), abs=1e-12)
    assert float(jax.grad(f)(0.3)) == pytest.approx(-1 / 1.5, rel=1e-10)  # stick: lam_t = -u/G
    assert float(jax.grad(f)(0.9)) == pytest.approx(0.0, abs=1e-12)  # slip: lam_t = -mu lam_n
