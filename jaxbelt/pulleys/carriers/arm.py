"""A pulley on a pivoted tensioner arm: centre = pivot + L (cos psi, sin psi)."""

from __future__ import annotations

import typing
from typing import ClassVar

import jax.numpy as jnp

from .base import AbstractMovableCarrier, CarrierKey

__all__ = ["ArmCarrier", "arm_center", "arm_dcenter"]


def arm_center(pp, k, length, psi):
    return pp.center[k] + length * jnp.stack([jnp.cos(psi), jnp.sin(psi)], axis=-1)


def arm_dcenter(length, psi):
    return length * jnp.stack([-jnp.sin(psi), jnp.cos(psi)], axis=-1)


@typing.final
class ArmCarrier(AbstractMovableCarrier):
    """``PulleyParams.center`` the pivot; psi the arm angle [rad] from the pivot to the pulley centre."""

    name: ClassVar[str] = "arm"
    coordinate: ClassVar[str | None] = "arm_angle"
    keys: ClassVar[tuple[CarrierKey, ...]] = (
        *AbstractMovableCarrier.keys,
        CarrierKey("length", "m: pivot to pulley centre"),
    )

    def center(self, pp, k, psi):
        return arm_center(pp, k, self.numbers(pp, k)["length"], psi)

    def dcenter(self, pp, k, psi):
        return arm_dcenter(self.numbers(pp, k)["length"], psi)
