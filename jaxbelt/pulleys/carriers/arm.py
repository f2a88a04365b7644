"""A pulley on a pivoted tensioner arm: centre = pivot + L (cos psi, sin psi)."""

from __future__ import annotations

import typing
from typing import ClassVar

import jax.numpy as jnp

from .base import AbstractMovableCarrier

__all__ = ["ArmCarrier", "arm_center", "arm_dcenter"]


def arm_center(pp, k, psi):
    return pp.center[k] + pp.arm_length[k] * jnp.stack([jnp.cos(psi), jnp.sin(psi)], axis=-1)


def arm_dcenter(pp, k, psi):
    return pp.arm_length[k] * jnp.stack([-jnp.sin(psi), jnp.cos(psi)], axis=-1)


@typing.final
class ArmCarrier(AbstractMovableCarrier):
    """``PulleyParams``: ``center`` the pivot, ``arm_length``, ``carrier_inertia`` about the pivot
    [kg m^2], ``spring`` [N m/rad], ``preload`` [N m] and ``rest`` [rad]."""

    name: ClassVar[str] = "arm"
    coordinate: ClassVar[str | None] = "arm_angle"

    def center(self, pp, k, psi):
        return arm_center(pp, k, psi)

    def dcenter(self, pp, k, psi):
        return arm_dcenter(pp, k, psi)
