"""Coulomb friction with true sticking (``contact.friction_law = "coulomb"``): no keys besides ``mu``."""

from __future__ import annotations

import typing

import jax.numpy as jnp

from .base import AbstractFrictionLaw

__all__ = ["Coulomb"]


@typing.final
class Coulomb(AbstractFrictionLaw):
    """Discontinuous Coulomb with true sticking: ``|lam_t| <= mu lam_n``, slip at the bound."""

    def local_update(self, lam_t, u_t, d_t, lam_n, params):
        b = self.bound(lam_n, params)
        return jnp.clip(lam_t - u_t / d_t, -b, b)
