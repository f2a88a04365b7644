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
from ..belt.implicit import (
    CyclicFactor,
    apply_blocks,
    factor_cyclic,
    from_node_vectors,
    implicit_element_blocks,
    node_blocks,
    node_vectors,
    point_loads,
    point_values,
    solve_factored,
    mass_scaling_blocks,
)
from ..belt.ring import BeltOperators, BeltParams, internal_forces

__all__ = [
    "SmoothForces",
    "belt_smooth_forces",
    "belt_free_velocity",
    "ImplicitBelt",
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


MASS_SCALING_THETA = 0.5  # >= 1/4 keeps every scaled mode stable; 1/2 leaves room for what stays explicit
# The scaled modes lose this fraction of their energy per step (``belt_implicit_free_velocity``): symplectic Euler
# leaves them undamped, and with sticking contact on light pulleys they grew (measured: the accessory example
# diverged at h = 2e-4 s, a 6-pulley serpentine with EA 88 kN at 1.5e-4 s, its short span's tension ringing at
# 1.8 kHz, the scaled band's top; with 0.02 both run at 3e-4 s)
MASS_SCALING_DISSIPATION = 0.02


@typing.final
class ImplicitBelt(eqx.Module):
    """The step's belt operator ``W = (1 + h alpha) M + h C(q) + S(q)`` of ``implicit_stiffness``, factored,
    with the blocks of ``C`` and ``S`` that the energy audit reads the forces from."""

    factor: CyclicFactor
    damping: Float[Array, "n 2 2 4 4"]  # C(q): Kelvin-Voigt
    scaling: Float[Array, "n 2 2 4 4"]  # S(q) ~ theta h^2 K(q) + h beta K_bending(q): the mass scaling
    shape: Float[Array, "m 4"]  # shape functions at the contact points of an element
    blocks: Float[Array, "n 2 2 4 4"]  # W's element blocks (the Newton contact solve adds its own to them)

    def response(self, Px, Py):
        """Belt velocity change of point impulses: ``W^-1 S^T P`` as node 4-vectors."""
        return solve_factored(self.factor, point_loads(Px, Py, self.shape)[..., None])[..., 0]

    def at_points(self, u: Float[Array, "n 4"]):
        return point_values(u, self.shape)


@typing.final
class ImplicitFreeVelocity(eqx.Module):
    """Free belt velocity with the Kelvin-Voigt damping implicit and that damping's force ``C(q) v_free``;
    with ``implicit_stiffness`` the factored operator instead (contact impulses act through it too)."""

    vx: Dofs
    vy: Dofs
    damping_x: Dofs | None  # C(q) v_free, x component (its work is booked by the energy audit)
    damping_y: Dofs | None
    operator: ImplicitBelt | None = None


def belt_implicit_free_velocity(
    params: BeltParams,
    ops: BeltOperators,
    q,
    forces: SmoothForces,
    vx: Dofs,
    vy: Dofs,
    h,
    mass_damping,
    contact_shape=None,
) -> ImplicitFreeVelocity:
    """Solve ``((1 + h alpha) M + h C(q) + S) v_free = (M + (1 - eps) S) v + h f`` (``f`` without the
    Kelvin-Voigt force, ``eps = MASS_SCALING_DISSIPATION``).

    Implicit Euler on the axial damping, whose explicit bound ``h < 2 / c_max`` shrinks like the element
    length squared; mass damping stays implicit as in ``belt_free_velocity`` (same formula when C = 0).

    ``contact_shape`` (the shape functions at the contact points) turns on ``implicit_stiffness``: the step's
    mass is scaled by ``S ~ theta h^2 K(q)`` (``belt.implicit.mass_scaling_blocks``: axial, tension and
    bending stiffness, each part only as far as explicit integration of it would not be stable; plus
    ``h beta K_b`` for the Rayleigh bending damping). The elastic forces stay explicit and exact, but a
    mode of stiffness k and mass m moves as if its mass were ``m + theta h^2 k``: symplectic Euler on it is
    stable at any h for theta >= 1/4, its frequency lowered by about ``(theta / 2 - 1 / 24) (h omega)^2`` (0.36 %
    for a span's third string mode at 96 Hz and h = 2e-4 s). The ``- eps S v`` term damps it: its energy falls
    by the factor ``(1 + (1 - eps) theta x) / (1 + theta x)`` per step, ``x = (h omega)^2`` (about ``1 - eps``
    for the scaled band near ``1 / (h sqrt(theta))``, a damping ratio ``eps theta h omega / 2`` below it: 0.08 %
    at 250 Hz, h = 1e-4 s), a stiffness-proportional damping ``eps theta_k h K`` on the scaled parts only.
    Translation is in K's null space, rotation and transport along the belt in that of its axial and bending
    parts. The contact impulses act through the same ``W`` (``ImplicitBelt.response``): applied with the plain
    mass, their stretching part escapes the scaling and the speed loss of Benchmark A grew with the step (+4.4 %
    of creep theory at h = 2e-4 s, +0.14 % through W).

    Parameters: nine: those of ``belt_free_velocity`` (forces, ``vx``, ``vy``, ``h``, ``mass_damping``, in its
    order) with the belt's data, operators and coordinates ``q`` that the implicit damping needs, and the
    optional ``contact_shape`` that turns on the mass scaling; each is a separate array of the step (the belt's
    data and operators already records), so a record of some of them would only rename them.
    """
    scaling = None if contact_shape is None else mass_scaling_blocks(q, params, ops, h, MASS_SCALING_THETA)
    We, Cb = implicit_element_blocks(q, params, ops, 1.0 + h * mass_damping, h, scaling)
    factor = factor_cyclic(*node_blocks(We))
    rhs = node_vectors(ops.mass.apply(vx) + h * forces.fx, ops.mass.apply(vy) + h * forces.fy)
    if scaling is not None:
        rhs = rhs + (1.0 - MASS_SCALING_DISSIPATION) * apply_blocks(scaling, node_vectors(vx, vy))
    u = solve_factored(factor, rhs[..., None])[..., 0]
    vfx, vfy = from_node_vectors(u)
    if scaling is None:
        cx, cy = from_node_vectors(apply_blocks(Cb, u))
        return ImplicitFreeVelocity(vx=vfx, vy=vfy, damping_x=cx, damping_y=cy)
    op = ImplicitBelt(factor=factor, damping=Cb, scaling=scaling, shape=contact_shape, blocks=We)
    return ImplicitFreeVelocity(vx=vfx, vy=vfy, damping_x=None, damping_y=None, operator=op)


def advance_belt(q, vx: Dofs, vy: Dofs, h):
    """End-of-step nodal velocities ``(n, 2, 2)`` and positions ``q + h v`` (symplectic Euler)."""
    v = from_xy(vx, vy)
    return v, q + h * v
