"""The belt's own stages of a time step, shared by the drive step and the free belt.

Belt vectors are component-major (two scalar vectors, see ``_linalg``); the mass operators act on
each component alike.
"""

from __future__ import annotations

import typing

import equinox as eqx
from jaxtyping import Array, Float

from .._linalg import AbstractRingOperator, from_xy, xy_components
from ..belt.ring import BeltOperators, BeltParams, internal_forces

__all__ = ["SmoothForces", "belt_smooth_forces", "belt_free_velocity", "advance_belt"]

Dofs = Float[Array, " 2*n"]


@typing.final
class SmoothForces(eqx.Module):
    """Smooth (non-contact) nodal forces on the belt at the start of the step."""

    fx: Dofs  # internal + external forces, x component
    fy: Dofs
    internal: Float[Array, "n 2 2"]  # internal (elastic + damping) forces alone
    dissipation: Float[Array, ""]  # dissipation rate of the belt's internal damping [W]


def belt_smooth_forces(params: BeltParams, ops: BeltOperators, external, q, v) -> SmoothForces:
    """Elastic, Kelvin-Voigt / Rayleigh damping and external (gravity) nodal forces."""
    f_int, dissipation = internal_forces(q, v, params, ops)
    fx, fy = xy_components(f_int + external)
    return SmoothForces(fx=fx, fy=fy, internal=f_int, dissipation=dissipation)


def belt_free_velocity(mass_inv: AbstractRingOperator, forces: SmoothForces, vx: Dofs, vy: Dofs, h, mass_damping):
    """Belt velocity components at the end of the step before contact: mass damping implicit."""
    vfx = (vx + h * mass_inv.apply(forces.fx)) / (1.0 + h * mass_damping)
    vfy = (vy + h * mass_inv.apply(forces.fy)) / (1.0 + h * mass_damping)
    return vfx, vfy


def advance_belt(q, vx: Dofs, vy: Dofs, h):
    """End-of-step nodal velocities ``(n, 2, 2)`` and positions ``q + h v`` (symplectic Euler)."""
    v = from_xy(vx, vy)
    return v, q + h * v
