"""A pulley on a linear slider: centre = origin + psi d (d a unit vector)."""

from __future__ import annotations

import math
import typing
from typing import ClassVar

import jax.numpy as jnp
import numpy as np

from ..._quantity import Quantity
from .base import AbstractMovableCarrier, CarrierKey, SpecKey

__all__ = ["SliderCarrier", "slider_center", "slider_dcenter", "TRAVEL"]

TRAVEL = Quantity("travel", "m", "slider", "slider travel", "Slider travel")
GUIDE_FRICTION = Quantity("guide_friction", "N", "slider", "guide friction force", "Slider guide friction")
STOP_FORCE = Quantity("stop_force", "N", "slider", "stop reaction force", "Slider stop reactions")


def slider_center(pp, k, direction, psi):
    return pp.center[k] + jnp.asarray(psi)[..., None] * direction


def slider_dcenter(direction, psi):
    return jnp.broadcast_to(direction, jnp.shape(psi) + (2,))


@typing.final
class SliderCarrier(AbstractMovableCarrier):
    """``PulleyParams.center`` the installed centre; psi the travel [m] along ``direction``."""

    name: ClassVar[str] = "slider"
    coordinate: ClassVar[str | None] = TRAVEL.prefix
    coordinate_quantity: ClassVar[Quantity] = TRAVEL
    loss_quantities: ClassVar[tuple[Quantity, Quantity]] = (GUIDE_FRICTION, STOP_FORCE)
    keys: ClassVar[tuple[CarrierKey, ...]] = (
        *AbstractMovableCarrier.keys,
        CarrierKey("direction", "unit vector (x, y): the direction of positive travel", shape=(2,)),
    )
    spec_keys: ClassVar[tuple[SpecKey, ...]] = (
        *AbstractMovableCarrier.spec_keys,
        SpecKey(
            "direction",
            "(x, y): the direction of positive travel (any length; default (0, 1))",
            tuple[float, float],
            check="vector",
            elsewhere="is a slider's direction of travel: an arm swings about its pivot",
        ),
    )

    @classmethod
    def check_spec(cls, values, center, checks):
        d = values["direction"]
        checks(d is None or math.hypot(*d) > 0, "direction", d, "must be a non-zero vector (x, y)")

    @classmethod
    def anchor(cls, values, center):
        d = np.asarray(values["direction"] if values["direction"] is not None else (0.0, 1.0), dtype=float)
        return (float(center[0]), float(center[1])), dict(direction=d / np.linalg.norm(d)), 0.0

    @classmethod
    def dcenter_at(cls, numbers, psi):
        return np.asarray(numbers["direction"], dtype=float)

    def center(self, pp, k, psi):
        return slider_center(pp, k, self.numbers(pp, k)["direction"], psi)

    def dcenter(self, pp, k, psi):
        return slider_dcenter(self.numbers(pp, k)["direction"], psi)
