"""Stability limit of the explicit part of the step (elastic forces and belt damping).

Symplectic Euler on a mode ``x'' + c x' + w^2 x = 0`` is stable while ``h^2 w^2 / 4 + h c / 2 < 1``.
``w^2`` and ``c`` are the largest eigenvalues of ``M^-1 K`` and ``M^-1 C`` of the belt. All elements
are alike, so they scale exactly with the element length ``L``:

    w^2 <= 42 EA / (rhoA L^2) + 2500 EI / (rhoA L^4),   c <= 13.6 eta A / (rhoA L^2) + beta 2500 EI / (rhoA L^4)

(constants measured by power iteration on rings of 24-120 elements at 0-5 % stretch: 41.1-41.9,
2500, 13.4-13.55; ``largest_rates`` recomputes them exactly and the tests compare). The closed
form costs nothing, so the check runs before anything is compiled. Contact, friction, mass
damping and tensioner springs are implicit and do not enter; with ``DriveModel.implicit_damping`` the
Kelvin-Voigt axial damping is implicit too (``belt.implicit``) and drops out of ``c``: the step is then
bounded by the axial and bending waves (and the explicit Rayleigh bending damping) alone. With
``DriveModel.implicit_stiffness`` the belt's stiffness scales its own mass in the step
(``belt.implicit.mass_scaling_blocks``) and the belt bounds no step: the user gives one for accuracy.
"""

from __future__ import annotations

import typing
from functools import partial

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..belt.ring import AXIAL_CONSTANT, BENDING_CONSTANT, DAMPING_CONSTANT, BeltParams, belt_operators, internal_forces
from .._linalg import DenseRingOperator
from .._types import DriveModel, DriveParams

__all__ = ["stable_time_step", "largest_rates"]


def _power(apply, x0, iterations):
    def body(i, x):
        y = apply(x)
        return y / jnp.maximum(jnp.linalg.norm(y), 1e-300)

    x = jax.lax.fori_loop(0, iterations, body, x0)
    return jnp.vdot(x, apply(x)) / jnp.vdot(x, x)


@partial(jax.jit, static_argnums=2)
def _rates(q0, belt, n_axial_damp_bend, key):
    ops = belt_operators(q0.shape[0], belt, *n_axial_damp_bend)
    z = jnp.zeros_like(q0)

    def force(q, v):
        return internal_forces(q, v, belt, ops)[0]

    def minv(f):
        dense = typing.cast(DenseRingOperator, ops.mass_inv)  # every ring operator has .matrix (built on demand)
        return (dense.matrix @ f.reshape(-1, 2)).reshape(f.shape)  # dense: keeps dt bit-identical

    stiff = lambda x: -minv(jax.jvp(lambda qq: force(qq, z), (q0,), (x,))[1])
    damp = lambda x: -minv(jax.jvp(lambda vv: force(q0, vv), (z,), (x,))[1])
    x0 = jax.random.normal(key, q0.shape, dtype=q0.dtype)
    # The M-weighted Rayleigh quotient would be exact; the plain one of the converged vector is too.
    return _power(stiff, x0, 400), _power(damp, x0, 400)


def largest_rates(model: DriveModel, params: DriveParams, q0):
    """(omega_max^2, c_max): highest squared frequency and explicit damping rate of the free belt."""
    quad = (model.axial_quadrature, model.bending_quadrature, model.damping_quadrature)
    belt = params.belt
    if model.implicit_damping:
        belt = eqx.tree_at(lambda b: b.axial_damping, belt, jnp.zeros_like(belt.axial_damping))
    w2, c = _rates(jnp.asarray(q0), belt, quad, jax.random.PRNGKey(0))
    return float(w2), float(c)


class BeltNumbers(typing.NamedTuple):
    """A belt's data as host numbers (``BeltParams``' fields, same units): what the closed form of
    ``rate_bounds`` reads, also before any ``BeltParams`` exists (validation of a configuration)."""

    EA: float
    EI: float
    axial_damping: float
    bending_damping: float
    mass_per_length: float
    stress_free_length: float

    @classmethod
    def of(cls, belt: BeltParams) -> BeltNumbers:
        """The numbers of ``belt`` as Python floats."""
        return cls(*(float(getattr(belt, name)) for name in cls._fields))


def rate_bounds(
    n_elements: int, belt: BeltNumbers, implicit_damping: bool = False, implicit_stiffness: bool = False
) -> tuple[float, float]:
    """Closed-form (omega_max^2, c_max) of a belt of ``n_elements`` equal elements with the data ``belt``
    (``c_max`` of the explicit damping: without the axial term when it is implicit; both 0 with the mass
    scaling of ``implicit_stiffness``, which leaves no explicit stiffness or damping of the belt to bound
    the step)."""
    if implicit_stiffness:
        return 0.0, 0.0
    EA, EI, axial_damping, bending_damping, mass_per_length, stress_free_length = belt
    L = stress_free_length / n_elements
    bend = BENDING_CONSTANT * EI / (mass_per_length * L**4)
    w2 = AXIAL_CONSTANT * EA / (mass_per_length * L**2) + bend
    axial = 0.0 if implicit_damping else DAMPING_CONSTANT * axial_damping / (mass_per_length * L**2)
    c = axial + bending_damping * bend
    return w2, c


def step_limit(w2: float, c: float) -> float:
    """Largest h with h^2 w2 / 4 + h c / 2 <= 1."""
    w2, c = max(w2, 0.0), max(c, 0.0)
    if w2 == 0.0:
        return 2.0 / c if c > 0 else float("inf")
    return float((-c / 2 + np.sqrt(c * c / 4 + w2)) / (w2 / 2))


def stable_time_step(model: DriveModel, params: DriveParams, q0=None, exact: bool = False) -> float:
    """Largest stable step of the belt; ``exact=True`` uses power iteration instead of the closed form."""
    if not exact:
        belt = BeltNumbers.of(params.belt)
        return step_limit(*rate_bounds(model.n_elements, belt, model.implicit_damping, model.implicit_stiffness))
    w2, c = largest_rates(model, params, q0)
    w2, c = max(w2, 0.0), max(c, 0.0)
    if w2 == 0.0:
        return 2.0 / c if c > 0 else float("inf")
    return float((-c / 2 + np.sqrt(c * c / 4 + w2)) / (w2 / 2))
