"""Rigid pulleys and their carriers (fixed centre, pivoted tensioner arm, linear slider).

Each pulley has a rotation ``theta`` and a carrier coordinate ``psi`` (arm angle or slider
travel; unused for a fixed centre). Pulley and carrier are decoupled in inertia: the arm carries
the pulley's mass in ``carrier_inertia``, and the pulley's spin is its own coordinate.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from .._types import CARRIER_ARM, CARRIER_SLIDER, DriveModel, PulleyParams
from .timelaw import evaluate

__all__ = ["carrier_centers", "free_pulley_velocities", "pulley_inverse_mass"]


def carrier_centers(model: DriveModel, pp: PulleyParams, psi):
    """Pulley centres ``(p, 2)`` and d(centre)/d(psi) ``(p, 2)``."""
    kind = np.asarray(model.carrier_kind)
    arm = jnp.asarray(kind == CARRIER_ARM)[:, None]
    slider = jnp.asarray(kind == CARRIER_SLIDER)[:, None]
    u = jnp.stack([jnp.cos(psi), jnp.sin(psi)], axis=-1)
    du = jnp.stack([-jnp.sin(psi), jnp.cos(psi)], axis=-1)
    L = pp.arm_length[:, None]
    center = pp.center + jnp.where(arm, L * u, 0.0) + jnp.where(slider, psi[:, None] * pp.slider_direction, 0.0)
    dcenter = jnp.where(arm, L * du, 0.0) + jnp.where(slider, pp.slider_direction, 0.0)
    return center, dcenter


def pulley_inverse_mass(model: DriveModel, pp: PulleyParams, h):
    """Effective inverse inertias seen by contact impulses within one step.

    Spin: 1/J, zero for speed-prescribed pulleys. Carrier: 1/(m + h c + h^2 k) - the spring and
    damper are integrated implicitly, so stiff tensioner springs do not limit the step.
    """
    kinematic = jnp.asarray(np.asarray(model.kinematic))
    movable = jnp.asarray(np.asarray(model.carrier_kind) != 0)
    inv_spin = jnp.where(kinematic, 0.0, 1.0 / pp.inertia)
    m_eff = pp.carrier_inertia + h * pp.carrier_damping + h * h * pp.spring
    inv_carrier = jnp.where(movable, 1.0 / jnp.where(movable, m_eff, 1.0), 0.0)
    return inv_spin, inv_carrier


def free_pulley_velocities(model: DriveModel, pp: PulleyParams, theta, omega, psi, psi_dot, t, h, gravity):
    """Pulley spin and carrier velocities at the end of the step before contact impulses.

    Viscous loads and carrier spring/damper are implicit (unconditionally stable); prescribed
    speeds take their value at the end of the step.
    """
    kinematic = jnp.asarray(np.asarray(model.kinematic))
    movable = jnp.asarray(np.asarray(model.carrier_kind) != 0)
    t1 = t + h
    prescribed = jax.vmap(evaluate, in_axes=(0, None))(pp.speed, t1)
    applied = jax.vmap(evaluate, in_axes=(0, None))(pp.torque, t1)
    omega_free = (pp.inertia * omega + h * applied) / (pp.inertia + h * pp.viscous)
    omega_free = jnp.where(kinematic, prescribed, omega_free)

    _, dcenter = carrier_centers(model, pp, psi)
    gen_gravity = pp.carrier_mass * jnp.sum(dcenter * gravity, axis=-1)
    force = pp.preload - pp.spring * (psi - pp.rest) + gen_gravity
    m_eff = pp.carrier_inertia + h * pp.carrier_damping + h * h * pp.spring
    # M (psi_dot+ - psi_dot) = h [F - k h psi_dot+ - c psi_dot+]  (spring and damper implicit)
    psi_dot_free = (pp.carrier_inertia * psi_dot + h * force) / jnp.where(movable, m_eff, 1.0)
    psi_dot_free = jnp.where(movable, psi_dot_free, 0.0)
    return omega_free, psi_dot_free, applied, prescribed
