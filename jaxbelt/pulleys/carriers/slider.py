"""A pulley on a linear slider: centre = origin + psi d (d a unit vector)."""

from __future__ import annotations

import typing
from typing import ClassVar

import jax.numpy as jnp

from .base import AbstractMovableCarrier

__all__ = ["SliderCarrier", "slider_center", "slider_dcenter"]


def slider_center(pp, k, psi):
    return pp.center[k] + jnp.asarray(psi)[..., None] * pp.slider_direction[k]


def slider_dcenter(pp, k, psi):
    return jnp.broadcast_to(pp.slider_direction[k], jnp.shape(psi) + (2,))


@typing.final
class SliderCarrier(AbstractMovableCarrier):
    """``PulleyParams``: ``center`` the origin, ``slider_direction``, ``carrier_inertia`` [kg],
    ``spring`` [N/m], ``preload`` [N] and ``rest`` [m]."""

    name: ClassVar[str] = "slider"
    coordinate: ClassVar[str | None] = "travel"

    def center(self, pp, k, psi):
        return slider_center(pp, k, psi)

    def dcenter(self, pp, k, psi):
        return slider_dcenter(pp, k, psi)
