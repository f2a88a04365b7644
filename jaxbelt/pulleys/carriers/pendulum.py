"""The second idler of a pendulum (rocker) tensioner: belt-starter-generator drives carry two idlers on one arm
that pivots about the starter-generator's axis, one idler on each side of its pulley. The arm's coordinate,
spring, damper, inertia and losses belong to the first idler's carrier (an ``ArmCarrier``, wrapped in
``LossyCarrier`` when it has pivot friction or stops); this carrier puts the second idler on the same arm:

    centre = pivot + L (cos(psi_owner + offset), sin(psi_owner + offset)),

``psi_owner`` the arm angle of pulley ``owner`` (the first idler), ``offset`` the fixed angle between the two
idlers seen from the pivot. It has no coordinate of its own: the belt's force on it acts on the owner's
coordinate (``pulleys.carrier.to_coordinates``), its mass is in the owner's inertia."""

from __future__ import annotations

import typing
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp

from .base import AbstractCarrier

__all__ = ["PendulumCarrier"]


@typing.final
class PendulumCarrier(AbstractCarrier):
    """``PulleyParams``: ``center`` the pivot, ``arm_length`` (pivot to this idler) and ``arm_offset`` [rad]
    (this idler's arm angle minus the owner's); ``owner`` the pulley whose arm this is (static)."""

    owner: int = eqx.field(static=True)
    name: ClassVar[str] = "pendulum"
    movable: ClassVar[bool] = False  # no coordinate of its own: psi stays 0, the owner's moves the centre
    coordinate: ClassVar[str | None] = None
    rides_another: ClassVar[bool] = True

    def coordinate_of(self, k: int) -> int:
        return self.owner

    def center(self, pp, k, psi):
        assert pp.arm_offset is not None, "a drive with a pendulum tensioner has PulleyParams.arm_offset"
        a = psi + pp.arm_offset[k]
        return pp.center[k] + pp.arm_length[k] * jnp.stack([jnp.cos(a), jnp.sin(a)], axis=-1)

    def dcenter(self, pp, k, psi):
        assert pp.arm_offset is not None
        a = psi + pp.arm_offset[k]
        return pp.arm_length[k] * jnp.stack([-jnp.sin(a), jnp.cos(a)], axis=-1)

    def inverse_mass(self, pp, k, h):
        return jnp.zeros_like(pp.carrier_inertia[k])

    def free_velocity(self, pp, k, psi, psi_dot, h, gravity):
        return jnp.zeros_like(psi_dot)

    def stored_energy(self, pp, k, psi, gravity):
        return jnp.zeros_like(psi)

    def kinetic_energy(self, pp, k, psi_dot):
        return jnp.zeros_like(psi_dot)
