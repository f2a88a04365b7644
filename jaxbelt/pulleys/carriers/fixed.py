"""A pulley on a fixed centre (``PulleyParams.center``)."""

from __future__ import annotations

import typing
from typing import ClassVar

import jax.numpy as jnp

from .base import AbstractCarrier

__all__ = ["FixedCarrier"]


@typing.final
class FixedCarrier(AbstractCarrier):
    name: ClassVar[str] = "fixed"
    movable: ClassVar[bool] = False
    coordinate: ClassVar[str | None] = None

    def center(self, pp, k, psi):
        return jnp.broadcast_to(pp.center[k], jnp.shape(psi) + (2,))

    def dcenter(self, pp, k, psi):
        return jnp.zeros(jnp.shape(psi) + (2,), pp.center.dtype)

    def inverse_mass(self, pp, k, h):
        return jnp.zeros_like(pp.carrier_inertia[k])

    def free_velocity(self, pp, k, psi, psi_dot, h, gravity):
        return jnp.zeros_like(psi_dot)

    def stored_energy(self, pp, k, psi, gravity):
        return jnp.zeros_like(psi)

    def kinetic_energy(self, pp, k, psi_dot):
        return jnp.zeros_like(psi_dot)
