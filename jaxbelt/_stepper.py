"""One time step of a belt drive (Moreau–Jean style, velocity level), and its diffrax solver.

    1. smooth forces (elastic, Kelvin–Voigt/Rayleigh damping, gravity, loads) -> free velocities
    2. contact frames at the start-of-step positions; contact impulses from the LCP (_lcp)
    3. velocities  v+ = v_free + M^-1 W lam;   positions  q+ = q + h v+

Sticking is exact (zero relative tangential velocity at the end of the step) and the compliant
normal law is implicit, so neither friction nor contact stiffness limits the step; the belt's
own axial waves (and explicit damping) do, see ``stable_time_step``.
"""

from __future__ import annotations

import typing

from typing import ClassVar

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._belt import BeltOperators, accelerations, apply_xy, belt_operators, gravity_forces, internal_forces
from ._fixed_step import FixedStepSolver
from ._contact import ContactOperators, contact_frames, contact_operators, contact_points, impulses_to_nodes, point_velocities
from ._lcp import solve_contact
from ._model import DriveModel, DriveParams, DriveState
from ._pulley import carrier_centers, free_pulley_velocities, pulley_inverse_mass

__all__ = ["DriveOperators", "drive_operators", "drive_step", "MoreauJean", "MAX_PENETRATION_FRACTION"]

# A point deeper than this fraction of its pulley's radius means the contact has failed.
MAX_PENETRATION_FRACTION = 0.05


@typing.final
class DriveOperators(eqx.Module):
    belt: BeltOperators
    contact: ContactOperators
    gravity: jax.Array  # nodal weight forces (n, 2, 2)


def drive_operators(model: DriveModel, params: DriveParams) -> DriveOperators:
    """Everything derived once per simulation from the model and parameters (traceable)."""
    n = model.n_elements
    bops = belt_operators(n, params.belt, model.axial_quadrature, model.bending_quadrature,
                          model.damping_quadrature)
    cops = contact_operators(n, model.contact_points_per_element, bops)
    return DriveOperators(belt=bops, contact=cops, gravity=gravity_forces(n, params.belt, bops, params.gravity))


def drive_step(model: DriveModel, params: DriveParams, ops: DriveOperators, state: DriveState, t, h) -> DriveState:
    n = model.n_elements
    pp = params.pulleys
    q, v = state.q, state.v
    # Settle phase (t < 0): pulleys locked, friction off, strong mass damping -> static equilibrium.
    settling = t < 0.0
    recording = jnp.where(settling, 0.0, 1.0)
    mass_damping = jnp.where(settling, params.settle_damping, params.mass_damping)

    # 1. free velocities
    f_int, dissipation = internal_forces(q, v, params.belt, ops.belt)
    a = accelerations(f_int + ops.gravity, ops.belt)
    v_free = (v + h * a) / (1.0 + h * mass_damping)  # mass damping implicit
    omega_free, psi_dot_free, applied, prescribed = free_pulley_velocities(
        model, pp, state.theta, state.omega, state.psi, state.psi_dot, t, h, params.gravity)
    inv_spin, inv_carrier = pulley_inverse_mass(model, pp, h)
    omega_free = jnp.where(settling, 0.0, omega_free)
    inv_spin = jnp.where(settling, 0.0, inv_spin)

    # 2. contact frames and the complementarity problem
    centers, dcenter = carrier_centers(model, pp, state.psi)
    r, stretch = contact_points(q, ops.contact)
    pulley, gap, normal, tangent, lever = contact_frames(r, centers, pp.radius)
    nc = r.shape[0]
    onehot = jax.nn.one_hot(pulley, model.n_pulleys, dtype=r.dtype)  # (nc, p)

    def pulley_point_velocity(omega, psi_dot):
        w, pd = onehot @ omega, onehot @ psi_dot
        spin = jnp.stack([-lever[:, 1], lever[:, 0]], axis=-1) * w[:, None]
        return spin + (onehot @ dcenter) * pd[:, None]

    u_free = point_velocities(v_free, ops.contact) - pulley_point_velocity(omega_free, psi_dot_free)
    u_free_n = jnp.sum(u_free * normal, -1)
    u_free_t = jnp.sum(u_free * tangent, -1)

    def pulley_response(P):
        """Pulley spin / carrier velocity changes from belt impulses P (reaction -P on the pulley)."""
        torque = -onehot.T @ (lever[:, 0] * P[:, 1] - lever[:, 1] * P[:, 0])
        carrier = -onehot.T @ jnp.sum((onehot @ dcenter) * P, -1)
        return inv_spin * torque, inv_carrier * carrier, torque

    def apply_G(lam_n, lam_t):
        P = lam_n[:, None] * normal + lam_t[:, None] * tangent
        dv = apply_xy(ops.contact.coupling, P)
        d_omega, d_psi_dot, _ = pulley_response(P)
        du = dv - pulley_point_velocity(d_omega, d_psi_dot)
        return jnp.sum(du * normal, -1), jnp.sum(du * tangent, -1)

    # Diagonal with mass splitting: a pulley shared by N active points counts N times, which keeps
    # the Jacobi sweep convergent even for idlers lighter than the belt they carry.
    active = (gap < 0.0) | (state.lam_n > 0.0)
    n_active = jnp.maximum(onehot.T @ active.astype(r.dtype), 1.0)
    split = onehot @ n_active
    Cdiag = jnp.diagonal(ops.contact.coupling)
    lever_n = lever[:, 0] * normal[:, 1] - lever[:, 1] * normal[:, 0]
    lever_t = lever[:, 0] * tangent[:, 1] - lever[:, 1] * tangent[:, 0]
    dc = onehot @ dcenter
    spin_inv = onehot @ inv_spin
    carr_inv = onehot @ inv_carrier
    diag_n = Cdiag + split * (spin_inv * lever_n**2 + carr_inv * jnp.sum(dc * normal, -1) ** 2)
    diag_t = Cdiag + split * (spin_inv * lever_t**2 + carr_inv * jnp.sum(dc * tangent, -1) ** 2)

    seg = jnp.tile(ops.contact.length, n) * stretch  # current belt length per point
    k_pt = params.contact_stiffness * seg
    d_pt = params.contact_damping * seg
    c_eff = h * h * k_pt + h * d_pt
    compliance = 1.0 / c_eff
    bias = k_pt * gap / (h * k_pt + d_pt)
    mu = jnp.where(settling, 0.0, params.mu) * jnp.asarray(np.asarray(model.friction_factor))[pulley]

    same = state.contact_pulley == pulley.astype(r.dtype)
    lam_n, lam_t, residual = solve_contact(
        apply_G, diag_n, diag_t, u_free_n, u_free_t, bias, compliance, mu,
        jnp.where(same, state.lam_n, 0.0), jnp.where(same, state.lam_t, 0.0),
        iterations=model.lcp_iterations, relaxation=model.lcp_relaxation,
        friction_law=model.friction_law, nu_s=params.nu_s)

    # 3. velocity and position update
    P = lam_n[:, None] * normal + lam_t[:, None] * tangent
    v_new = v_free + accelerations(impulses_to_nodes(P, ops.contact, n), ops.belt)
    d_omega, d_psi_dot, torque_impulse = pulley_response(P)
    omega_new = omega_free + d_omega
    psi_dot_new = psi_dot_free + d_psi_dot
    q_new = q + h * v_new

    # Energy audit: works with mid-step velocities, the ones the scheme's kinetic energy change uses
    # (T+ - T = h v_mid . F). Contact impulses act at the start-of-step geometry on the relative
    # velocity u = v_belt - v_pulley, so their work on belt and pulleys together is lam . u_mid.
    kin = jnp.asarray(np.asarray(model.kinematic))
    omega_mid = 0.5 * (state.omega + omega_new)
    motor = jnp.where(kin, pp.inertia * (omega_new - state.omega) / h - torque_impulse / h,
                      applied - pp.viscous * omega_new)
    pulley_work = state.pulley_work + recording * h * motor * omega_mid
    u_pre = point_velocities(v, ops.contact) - pulley_point_velocity(state.omega, state.psi_dot)
    u_post = point_velocities(v_new, ops.contact) - pulley_point_velocity(omega_new, psi_dot_new)
    u_mid = 0.5 * (u_pre + u_post)
    w_normal = jnp.sum(lam_n * jnp.sum(u_mid * normal, -1))
    w_friction = jnp.sum(lam_t * jnp.sum(u_mid * tangent, -1))
    v_mid = 0.5 * (v + v_new).reshape(-1, 2)
    mass_diss = mass_damping * jnp.sum(v_mid * apply_xy(ops.belt.mass, v_new.reshape(-1, 2))) * h
    carrier_diss = jnp.sum(pp.carrier_damping * psi_dot_new * 0.5 * (state.psi_dot + psi_dot_new)) * h
    work = state.work + recording * jnp.stack([dissipation * h, mass_diss, carrier_diss, w_normal, w_friction])

    new = DriveState(
        q=q_new, v=v_new, theta=state.theta + h * omega_new, omega=omega_new,
        psi=state.psi + h * psi_dot_new, psi_dot=psi_dot_new,
        lam_n=lam_n, lam_t=lam_t, contact_pulley=pulley.astype(r.dtype),
        belt_torque=torque_impulse / h, lcp_residual=residual, work=work, pulley_work=pulley_work,
        fault=state.fault, fault_time=state.fault_time)

    # Fault detection: keep the last good state (so the history stays usable) and flag the time.
    finite = jnp.all(jnp.isfinite(q_new)) & jnp.all(jnp.isfinite(v_new)) & jnp.all(jnp.isfinite(omega_new))
    too_deep = jnp.any(gap < -MAX_PENETRATION_FRACTION * pp.radius[pulley])
    code = jnp.where(~finite, 1.0, jnp.where(too_deep, 2.0, 0.0))
    first = (state.fault == 0) & (code > 0)
    frozen = eqx.tree_at(lambda s: (s.fault, s.fault_time), state,
                         (jnp.where(state.fault > 0, state.fault, code), jnp.where(first, t, state.fault_time)))
    return jax.tree.map(lambda a_, b_: jnp.where((code > 0) | (state.fault > 0), a_, b_), frozen, new)


@typing.final
class MoreauJean(FixedStepSolver):
    """diffrax solver wrapping ``drive_step``; ``args = (model, params, ops)``.

    Fixed steps only (use ``diffrax.ConstantStepSize``): the stick/slip switch lives inside the
    step, which is what makes true sticking possible and what adaptive error control cannot see.
    """

    def advance(self, args, t0, h, y0):
        model, params, ops = args
        return drive_step(model, params, ops, y0, t0, h)
