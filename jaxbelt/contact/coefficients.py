"""Friction coefficients per pulley and per contact point: ``contact.mu``, or a pulley's own ``mu``
(a grooved sheave and the flat back of the belt grip differently), times the pulley's wedge factor.

A drive without per-pulley coefficients (``DriveModel.own_mu`` empty) takes the plain product, the
expression the step always used, so its numbers do not change by a bit. A friction law's other
coefficients follow the point's ``mu`` (static-kinetic: ``mu_kinetic / mu`` is kept per point).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import jax.numpy as jnp
import numpy as np

if TYPE_CHECKING:  # _types imports contact.friction
    from .._types import DriveModel, DriveParams

__all__ = ["pulley_mu", "point_mu"]


def _wedge(model: DriveModel):
    return jnp.asarray(np.asarray(model.friction_factor))


def pulley_mu(model: DriveModel, params: DriveParams):
    """Effective static coefficient of each pulley ``(p,)``: its own ``mu`` or ``contact.mu``, times
    its wedge factor (traceable; numpy callers wrap it in ``np.asarray``)."""
    if not any(model.own_mu) or params.pulleys.mu is None:
        return params.mu * _wedge(model)
    return jnp.where(jnp.asarray(model.own_mu), params.pulleys.mu, params.mu) * _wedge(model)


def point_mu(model: DriveModel, params: DriveParams, at_points, settling):
    """The coefficient at each contact point (``at_points``: per pulley -> per point), zero while the
    drive settles (friction off, so the belt finds its installed equilibrium)."""
    if not any(model.own_mu) or params.pulleys.mu is None:
        return jnp.where(settling, 0.0, params.mu) * at_points(_wedge(model))
    return jnp.where(settling, 0.0, 1.0) * at_points(pulley_mu(model, params))
