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

import typing
from typing import Callable, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .friction import AbstractFrictionLaw, Coulomb

__all__ = ["BodyCoupling", "Delassus", "PointProblem", "SolveSettings", "solve_contact", "solve_contact_coupled"]

_COULOMB = Coulomb()

Vec = Float[Array, "nc"]


@typing.final
class PointProblem(eqx.Module):
    """Each contact point's data of one step's complementarity problem."""

    u_free_n: Vec  # relative velocity without the step's contact impulses, normal and tangential
    u_free_t: Vec
    bias_n: Vec  # the normal law: 0 <= lam_n _|_ u_n + bias_n + compliance_n lam_n >= 0
    compliance_n: Vec
    mu: Vec  # friction coefficient
    point_mass: Vec | None = None  # the point's share of the belt's mass (the Newton solve's penalty scale)
    step: Float[Array, ""] | float | None = None  # the step h [s] (the Newton solve's penalties grow with it)

    def shifted(self, du_n, du_t) -> PointProblem:
        """The problem with the free velocities moved by ``(du_n, du_t)``."""
        return eqx.tree_at(lambda p: (p.u_free_n, p.u_free_t), self, (self.u_free_n + du_n, self.u_free_t + du_t))


@typing.final
class SolveSettings(eqx.Module):
    """How a step's contact problem is solved: a static trip count (both AD modes), the Jacobi sweeps'
    relaxation, the friction law and its coefficients besides ``mu`` (e.g. ``{"nu_s": ...}``)."""

    iterations: int = eqx.field(static=True)
    relaxation: float = eqx.field(static=True, default=1.0)
    friction_law: AbstractFrictionLaw = eqx.field(static=True, default=_COULOMB)
    friction_params: dict = eqx.field(default_factory=dict)
    batched: bool = eqx.field(static=True, default=False)  # DriveModel.batched: branches taken by the whole batch

    def law_params(self, mu) -> dict:
        return {"mu": mu, **self.friction_params}


class Delassus(NamedTuple):
    """The contact operator ``G = W^T M^-1 W``: its action on impulses ``apply(lam_n, lam_t) -> (du_n, du_t)``
    and its diagonal (with mass splitting: ``dynamics.step.delassus_diagonal``)."""

    apply: Callable[[Vec, Vec], tuple[Vec, Vec]]
    diag_n: Vec
    diag_t: Vec


class BodyCoupling(NamedTuple):
    """Body constraints solved with the contacts (tensioner pivots, clutches; ``pulleys.carriers.constraints``):
    their last impulses ``warm``, ``shift(lam_c) -> (du_n, du_t)`` the points' velocity change from them and
    ``local(lam_n, lam_t) -> lam_c`` the bodies' exact local solves with the contact impulses frozen."""

    warm: jax.Array
    shift: Callable
    local: Callable


def solve_contact(G: Delassus, problem: PointProblem, warm: tuple[Vec, Vec], settings: SolveSettings):
    """Return ``(lam_n, lam_t, residual)`` from the warm start ``(lam_n, lam_t)``; residual = max change of the
    last sweep / max impulse."""
    params = settings.law_params(problem.mu)
    lam, last = _sweeps(lambda lam: _contact_sweep(G, lam, problem, settings, params), tuple(warm), settings.iterations)
    return last[0], last[1], _residual(lam, last)


def _sweeps(sweep, lam0, iterations: int):
    """``iterations`` sweeps from ``lam0``: the last two iterates (the residual compares them). All sweeps in
    one loop: a sweep written outside it for the residual would be a second copy in the compiled program."""
    return jax.lax.fori_loop(0, iterations, lambda i, c: (c[1], sweep(c[1])), (lam0, lam0))


def _contact_sweep(G: Delassus, lam, problem: PointProblem, settings: SolveSettings, params: dict):
    """One Jacobi sweep over the contact points: each point's exact local update, relaxed."""
    lam_n, lam_t = lam
    law, relaxation = settings.friction_law, settings.relaxation
    du_n, du_t = G.apply(lam_n, lam_t)
    u_n = problem.u_free_n + du_n
    u_t = problem.u_free_t + du_t
    eps = problem.compliance_n
    new_n = jnp.maximum(0.0, lam_n - (u_n + problem.bias_n + eps * lam_n) / (G.diag_n + eps))
    new_n = lam_n + relaxation * (new_n - lam_n)
    bound = law.bound(new_n, params)
    new_t = law.local_update(lam_t, u_t, G.diag_t, new_n, params)
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
    G: Delassus, problem: PointProblem, warm: tuple[Vec, Vec], settings: SolveSettings, bodies: BodyCoupling
):
    """``solve_contact`` with body constraints (``BodyCoupling``): each sweep is the Jacobi sweep of the
    contacts, their free velocities shifted by the body impulses ``lam_c``, then the bodies' exact local solves
    with the new contact impulses frozen: a block Gauss-Seidel sweep. Returns ``(lam_n, lam_t, lam_c, residual)``."""
    params = settings.law_params(problem.mu)

    def sweep(lam):
        lam_n, lam_t, lam_c = lam
        new_n, new_t = _contact_sweep(G, (lam_n, lam_t), problem.shifted(*bodies.shift(lam_c)), settings, params)
        return new_n, new_t, bodies.local(new_n, new_t)

    lam, last = _sweeps(sweep, (*warm, bodies.warm), settings.iterations)
    return last[0], last[1], last[2], _residual(lam[:2], last[:2])
