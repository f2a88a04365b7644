"""Belt–pulley contact kinematics at fixed material points (Gauss points of every element).

Contact is tested at ``m`` Gauss points per element. Because the belt mass matrix is
``M_hat (x) I2`` and the points are fixed in the material, the belt's share of the Delassus
operator is ``C (x) I2`` with the *constant* scalar matrix ``C = S M_hat^-1 S^T``; only the contact
directions change from step to step. Each point is tested against its nearest pulley.
"""

from __future__ import annotations

import typing

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from ._ancf import gauss_legendre, shape_functions
from ._belt import BeltOperators, element_coordinates, scatter_to_nodes

__all__ = ["ContactOperators", "contact_operators", "contact_points", "impulses_to_nodes", "contact_frames"]


@typing.final
class ContactOperators(eqx.Module):
    shape: Float[Array, "m 4"]       # shape functions at the contact points of one element
    dshape: Float[Array, "m 4"]      # their x-derivatives
    length: Float[Array, "m"]        # stress-free belt length each point represents (w_g L)
    coupling: Float[Array, "nc nc"]  # C = S M_hat^-1 S^T [1/kg]
    xi: Float[Array, "m"]


def contact_operators(n: int, m: int, ops: BeltOperators) -> ContactOperators:
    xg, wg = gauss_legendre(m)
    s, ds, _ = shape_functions(jnp.asarray(xg), ops.element_length)
    # Rows of S in scalar-DOF space; S M^-1 S^T without forming S (4 non-zeros per row).
    j = np.repeat(np.arange(n), m)
    k = (j + 1) % n
    dofs = np.stack([2 * j, 2 * j + 1, 2 * k, 2 * k + 1], axis=1)  # (nc, 4)
    vals = jnp.tile(s, (n, 1))                                        # (nc, 4)
    Minv_rows = ops.mass_inv[dofs]                                    # (nc, 4, 2n)
    SMinv = jnp.einsum("ak,akd->ad", vals, Minv_rows)                 # (nc, 2n)
    C = jnp.sum(SMinv[:, dofs] * vals[None], axis=-1)                 # (nc, nc)
    C = 0.5 * (C + C.T)
    return ContactOperators(shape=s, dshape=ds, length=ops.element_length * jnp.asarray(wg), coupling=C,
                            xi=jnp.asarray(xg))


def contact_points(q, cops: ContactOperators):
    """Positions ``(nc, 2)`` and local stretch ``|r'|`` ``(nc,)`` of the contact points."""
    e = element_coordinates(q)
    r = jnp.einsum("gk,jkd->jgd", cops.shape, e).reshape(-1, 2)
    rp = jnp.einsum("gk,jkd->jgd", cops.dshape, e).reshape(-1, 2)
    return r, jnp.sqrt(jnp.sum(rp * rp, axis=-1))


def point_velocities(v, cops: ContactOperators):
    e = element_coordinates(v)
    return jnp.einsum("gk,jkd->jgd", cops.shape, e).reshape(-1, 2)


def impulses_to_nodes(P, cops: ContactOperators, n: int):
    """Generalised nodal impulses ``S^T P`` of point impulses ``P`` ``(nc, 2)``."""
    m = cops.shape.shape[0]
    fe = jnp.einsum("gk,jgd->jkd", cops.shape, P.reshape(n, m, 2))
    return scatter_to_nodes(fe)


def _safe_unit(d):
    sq = jnp.sum(d * d, axis=-1, keepdims=True)
    ok = sq > 0
    norm = jnp.where(ok, jnp.sqrt(jnp.where(ok, sq, 1.0)), 1.0)
    return jnp.where(ok, d / norm, jnp.array([1.0, 0.0])), jnp.where(ok[..., 0], norm[..., 0], 0.0)


def contact_frames(r, centers, radii):
    """For each point: nearest pulley index, gap, outward normal, tangent, lever arm r - c."""
    d_all = r[:, None, :] - centers[None, :, :]                     # (nc, p, 2)
    dist_all = jnp.sqrt(jnp.sum(d_all * d_all, axis=-1) + 1e-300)
    gaps_all = dist_all - radii[None, :]
    pulley = jnp.argmin(gaps_all, axis=1)
    lever = r - centers[pulley]
    normal, dist = _safe_unit(lever)
    gap = dist - radii[pulley]
    tangent = jnp.stack([-normal[:, 1], normal[:, 0]], axis=-1)
    return pulley, gap, normal, tangent, lever
