"""Velocity-level frictional contact problem, solved by projected Jacobi (fixed-point) sweeps.

For contact points ``a`` with normal and tangential impulses ``(lam_n, lam_t)`` and post-step
relative velocities ``u = u_free + G lam`` (G = W^T M^-1 W, symmetric positive semi-definite):

* normal, compliant complementarity (penalty stiffness/damping folded into the step):
  ``0 <= lam_n  _|_  u_n + b + eps * lam_n >= 0``. With ``eps = 0`` this is the rigid
  Signorini condition at velocity level; ``eps > 0`` is a spring-damper that acts only in
  compression, integrated implicitly, so the contact stiffness does not limit the time step.
* friction, discontinuous Coulomb with true sticking: ``|lam_t| <= mu lam_n``; if strictly inside,
  ``u_t = 0`` (stick), else ``lam_t = -mu lam_n sign(u_t)`` (slip); or another law of
  ``contact.friction`` (regularised, static-kinetic), passed as an object.

Each sweep solves every point's local problem exactly with the others frozen (Jacobi), then relaxes.
The trip count is static so forward- and reverse-mode differentiation both work; callers warm-start
from the previous step. Convergence needs ``2 D / relax - G`` positive definite; callers pass a
``D`` that includes mass splitting for bodies shared by many points (see ``dynamics.step``).
"""

from __future__ import annotations

from typing import Callable

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .friction import AbstractFrictionLaw, Coulomb

__all__ = ["solve_contact", "solve_contact_coupled"]

_COULOMB = Coulomb()

Vec = Float[Array, "nc"]


def solve_contact(
    apply_G: Callable[[Vec, Vec], tuple[Vec, Vec]],
    diag_n: Vec,
    diag_t: Vec,
    u_free_n: Vec,
    u_free_t: Vec,
    bias_n: Vec,
    compliance_n: Vec,
    mu: Vec,
    lam_n0: Vec,
    lam_t0: Vec,
    *,
    iterations: int,
    relaxation: float = 1.0,
    friction_law: AbstractFrictionLaw = _COULOMB,
    friction_params: dict | None = None,
):
    """Return ``(lam_n, lam_t, residual)``; residual = max change of the last sweep / max impulse.

    ``friction_params``: the law's coefficients besides ``mu`` (e.g. ``{"nu_s": ...}``)."""
    params = {"mu": mu, **(friction_params or {})}

    def sweep(lam):
        return _contact_sweep(
            apply_G, lam, diag_n, diag_t, u_free_n, u_free_t, bias_n, compliance_n, relaxation, friction_law, params
        )

    lam, last = _sweeps(sweep, (lam_n0, lam_t0), iterations)
    return last[0], last[1], _residual(lam, last)


def _sweeps(sweep, lam0, iterations: int):
    """``iterations`` sweeps from ``lam0``: the last two iterates (the residual compares them). All sweeps in
    one loop: a sweep written outside it for the residual would be a second copy in the compiled program."""
    return jax.lax.fori_loop(0, iterations, lambda i, c: (c[1], sweep(c[1])), (lam0, lam0))


def _contact_sweep(apply_G, lam, diag_n, diag_t, u_free_n, u_free_t, bias_n, compliance_n, relaxation, law, params):
    """One Jacobi sweep over the contact points: each point's exact local update, relaxed."""
    lam_n, lam_t = lam
    du_n, du_t = apply_G(lam_n, lam_t)
    u_n = u_free_n + du_n
    u_t = u_free_t + du_t
    new_n = jnp.maximum(0.0, lam_n - (u_n + bias_n + compliance_n * lam_n) / (diag_n + compliance_n))
    new_n = lam_n + relaxation * (new_n - lam_n)
    bound = law.bound(new_n, params)
    new_t = law.local_update(lam_t, u_t, diag_t, new_n, params)
    new_t = jnp.clip(lam_t + relaxation * (new_t - lam_t), -bound, bound)
    return new_n, new_t


def _residual(lam, last):
    """Max change of the last sweep over the largest normal impulse (not differentiated)."""
    change = jnp.maximum(
        jnp.max(jnp.abs(last[0] - lam[0]), initial=0.0), jnp.max(jnp.abs(last[1] - lam[1]), initial=0.0)
    )
    scale = jnp.maximum(jnp.max(jnp.abs(last[0]), initial=0.0), 1e-300)
    residual = jnp.where(scale > 1e-300, change / scale, 0.0)
    return jax.lax.stop_gradient(residual)


def solve_contact_coupled(
    apply_G: Callable[[Vec, Vec], tuple[Vec, Vec]],
    diag_n: Vec,
    diag_t: Vec,
    u_free_n: Vec,
    u_free_t: Vec,
    bias_n: Vec,
    compliance_n: Vec,
    mu: Vec,
    lam_n0: Vec,
    lam_t0: Vec,
    lam_c0,
    shift: Callable,
    local: Callable,
    *,
    iterations: int,
    relaxation: float = 1.0,
    friction_law: AbstractFrictionLaw = _COULOMB,
    friction_params: dict | None = None,
):
    """``solve_contact`` with body constraints (tensioner pivots, clutches; ``pulleys.carriers.constraints``):
    each sweep is the Jacobi sweep of the contacts, their free velocities shifted by the body
    impulses ``lam_c`` (``shift(lam_c) -> (du_n, du_t)``), then the bodies' exact local solves with
    the new contact impulses frozen (``local(lam_n, lam_t) -> lam_c``): a block Gauss-Seidel sweep.
    Returns ``(lam_n, lam_t, lam_c, residual)``."""
    params = {"mu": mu, **(friction_params or {})}

    def sweep(lam):
        lam_n, lam_t, lam_c = lam
        sn, st = shift(lam_c)
        new_n, new_t = _contact_sweep(
            apply_G,
            (lam_n, lam_t),
            diag_n,
            diag_t,
            u_free_n + sn,
            u_free_t + st,
            bias_n,
            compliance_n,
            relaxation,
            friction_law,
            params,
        )
        return new_n, new_t, local(new_n, new_t)

    lam, last = _sweeps(sweep, (lam_n0, lam_t0, lam_c0), iterations)
    return last[0], last[1], last[2], _residual(lam[:2], last[:2])
