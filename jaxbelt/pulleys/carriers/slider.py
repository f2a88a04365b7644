"""A pulley on a linear slider: centre = origin + psi d (d a unit vector)."""

from __future__ import annotations

import typing
from typing import ClassVar

import jax.numpy as jnp

from .base import AbstractMovableCarrier, CarrierKey

__all__ = ["SliderCarrier", "slider_center", "slider_dcenter"]


def slider_center(pp, k, direction, psi):
    return pp.center[k] + jnp.asarray(psi)[..., None] * direction


def slider_dcenter(direction, psi):
    return jnp.broadcast_to(direction, jnp.shape(psi) + (2,))


@typing.final
class SliderCarrier(AbstractMovableCarrier):
    """``PulleyParams.center`` the installed centre; psi the travel [m] along ``direction``."""

    name: ClassVar[str] = "slider"
    coordinate: ClassVar[str | None] = "travel"
    keys: ClassVar[tuple[CarrierKey, ...]] = (
        *AbstractMovableCarrier.keys,
        CarrierKey("direction", "unit vector (x, y): the direction of positive travel"),
    )

    def center(self, pp, k, psi):
        return slider_center(pp, k, self.numbers(pp, k)["direction"], psi)

    def dcenter(self, pp, k, psi):
        return slider_dcenter(self.numbers(pp, k)["direction"], psi)
