"""A pulley on a fixed centre (``PulleyParams.center``)."""

from __future__ import annotations

import typing
from typing import ClassVar

import jax.numpy as jnp

from .base import AbstractHeldCarrier

__all__ = ["FixedCarrier"]


@typing.final
class FixedCarrier(AbstractHeldCarrier):
    name: ClassVar[str] = "fixed"

    def center(self, pp, k, psi):
        return jnp.broadcast_to(pp.center[k], jnp.shape(psi) + (2,))

    def dcenter(self, pp, k, psi):
        return jnp.zeros(jnp.shape(psi) + (2,), pp.center.dtype)
