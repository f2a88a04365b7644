"""The belt's own stages of a time step, shared by the drive step and the free belt.

Belt vectors are component-major (two scalar vectors, see ``_linalg``); the mass operators act on
each component alike.
"""

from __future__ import annotations

import typing

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._linalg import AbstractRingOperator, from_xy, xy_components
from ..belt.damping import apply_blocks, from_node_vectors, implicit_blocks, node_vectors, solve_cyclic
from ..belt.ring import BeltOperators, BeltParams, internal_forces

__all__ = [
    "SmoothForces",
    "belt_smooth_forces",
    "belt_free_velocity",
    "ImplicitFreeVelocity",
    "belt_implicit_free_velocity",
    "advance_belt",
]

Dofs = Float[Array, " 2*n"]


@typing.final
class SmoothForces(eqx.Module):
    """Smooth (non-contact) nodal forces on the belt at the start of the step."""

    fx: Dofs  # internal + external forces, x component
    fy: Dofs
    internal: Float[Array, "n 2 2"]  # internal (elastic + damping) forces alone
    dissipation: Float[Array, ""]  # dissipation rate of the belt's internal damping [W]


def belt_smooth_forces(
    params: BeltParams, ops: BeltOperators, external, q, v, implicit_damping: bool = False
) -> SmoothForces:
    """Elastic, Kelvin-Voigt / Rayleigh damping and external (gravity) nodal forces; without the
    Kelvin-Voigt part when ``implicit_damping`` (``belt_implicit_free_velocity`` applies it)."""
    if implicit_damping:
        params = eqx.tree_at(lambda b: b.axial_damping, params, jnp.zeros_like(params.axial_damping))
    f_int, dissipation = internal_forces(q, v, params, ops)
    fx, fy = xy_components(f_int + external)
    return SmoothForces(fx=fx, fy=fy, internal=f_int, dissipation=dissipation)


def belt_free_velocity(mass_inv: AbstractRingOperator, forces: SmoothForces, vx: Dofs, vy: Dofs, h, mass_damping):
    """Belt velocity components at the end of the step before contact: mass damping implicit."""
    vfx = (vx + h * mass_inv.apply(forces.fx)) / (1.0 + h * mass_damping)
    vfy = (vy + h * mass_inv.apply(forces.fy)) / (1.0 + h * mass_damping)
    return vfx, vfy


@typing.final
class ImplicitFreeVelocity(eqx.Module):
    """Free belt velocity with the Kelvin-Voigt damping implicit, and that damping's force ``C(q) v``."""

    vx: Dofs
    vy: Dofs
    damping_x: Dofs  # C(q) v_free, x component (its work is booked by the energy audit)
    damping_y: Dofs


def belt_implicit_free_velocity(
    params: BeltParams, ops: BeltOperators, q, forces: SmoothForces, vx: Dofs, vy: Dofs, h, mass_damping
) -> ImplicitFreeVelocity:
    """Solve ``((1 + h alpha) M + h C(q)) v_free = M v + h f`` (``f`` without the Kelvin-Voigt force).

    Implicit Euler on the axial damping, whose explicit bound ``h < 2 / c_max`` shrinks like the element
    length squared; mass damping stays implicit as in ``belt_free_velocity`` (same formula when C = 0).
    """
    D, U, Cb = implicit_blocks(q, params, ops, 1.0 + h * mass_damping, h)
    rhs = node_vectors(ops.mass.apply(vx) + h * forces.fx, ops.mass.apply(vy) + h * forces.fy)
    u = solve_cyclic(D, U, rhs[..., None])[..., 0]
    vfx, vfy = from_node_vectors(u)
    cx, cy = from_node_vectors(apply_blocks(Cb, u))
    return ImplicitFreeVelocity(vx=vfx, vy=vfy, damping_x=cx, damping_y=cy)


def advance_belt(q, vx: Dofs, vy: Dofs, h):
    """End-of-step nodal velocities ``(n, 2, 2)`` and positions ``q + h v`` (symplectic Euler)."""
    v = from_xy(vx, vy)
    return v, q + h * v
