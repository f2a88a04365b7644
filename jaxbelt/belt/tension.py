"""The belt's axial force: its profile along the loop and its value at chosen points (span middles).

Post-processing of states (traceable, vmappable over time); the time step computes its internal
forces in ``ring.py`` and never calls this.
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .element import shape_functions
from .ring import BeltParams, element_coordinates

__all__ = ["axial_force_profile", "sample_nearest", "tension_at"]


def axial_force_profile(n_elements: int, belt: BeltParams, q, v) -> tuple[Float[Array, " n"], Float[Array, "n 2"]]:
    """Axial force ``EA eps + eta A d(eps)/dt`` at every element midpoint, and those midpoints."""
    L = belt.stress_free_length / n_elements
    s, ds, _ = shape_functions(jnp.asarray([0.5]), L)
    e, ed = element_coordinates(q), element_coordinates(v)
    r = jnp.einsum("k,jkd->jd", s[0], e)
    rp = jnp.einsum("k,jkd->jd", ds[0], e)
    rpd = jnp.einsum("k,jkd->jd", ds[0], ed)
    stretch = jnp.sqrt(jnp.sum(rp * rp, -1))  # never 0 for a belt that exists
    rate = jnp.sum(rp * rpd, -1) / stretch
    return belt.EA * (stretch - 1.0) + belt.axial_damping * rate, r


def sample_nearest(
    values: Float[Array, " n"], where: Float[Array, "n 2"], points: Float[Array, "k 2"]
) -> Float[Array, " k"]:
    """``values`` of the element whose midpoint (``where``) lies nearest to each of ``points``."""
    d = jnp.sum((where[:, None, :] - points[None]) ** 2, -1)  # (n, k)
    return values[jnp.argmin(d, axis=0)]


@eqx.filter_jit  # compiled once per shape: post-processing calls it outside any jit (n_elements is static)
def tension_at(n_elements: int, belt: BeltParams, points: Float[Array, "k 2"], q, v) -> Float[Array, "T k"]:
    """Axial force near each of ``points`` for stacked states ``q``, ``v`` of shape ``(T, n, 2, 2)``."""

    def one(q, v):
        N, r = axial_force_profile(n_elements, belt, q, v)
        return sample_nearest(N, r, points)

    return jax.vmap(one)(q, v)
