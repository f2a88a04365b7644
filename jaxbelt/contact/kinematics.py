"""Belt–pulley contact kinematics at fixed material points (Gauss points of every element).

Contact is tested at ``m`` Gauss points per element. Because the belt mass matrix is
``M_hat (x) I2`` and the points are fixed in the material, every linear map between nodal
coordinates and contact points is a *constant scalar* matrix acting identically on x and y:
positions and slopes ``S q``, the velocity change of an impulse ``M_hat^-1 S^T``, and the belt's
share of the Delassus operator ``C = S M_hat^-1 S^T``. Only the contact directions change from
step to step.

The hot path works component-major ("structure of arrays": x and y as separate ``(nc,)`` vectors).
A trailing axis of length 2 defeats vectorisation on CPUs and turns every dot product into a tiny
reduction: measured 2x slower per step for a 64-variant batch.
"""

from __future__ import annotations

import typing

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float, Int

from ..belt.element import gauss_legendre, shape_functions
from ..belt.ring import BeltOperators

__all__ = ["ContactOperators", "contact_operators", "contact_points", "point_kinematics", "nearest_pulley",
           "ContactFrame"]

Points = Float[Array, " nc"]


@typing.final
class ContactOperators(eqx.Module):
    length: Float[Array, " m"]               # stress-free belt length each point of an element represents (w_g L)
    # Stored for row-vector products ``x @ A`` (the batch axis of vmap or of forward-mode tangents then
    # leads, and XLA's CPU dot runs (B, N) @ (N, N) about 3x faster than (N, N) @ (N, B)):
    positions: Float[Array, "2*n nc"]        # S^T: point positions (velocities) = nodal @ positions
    positions_and_slopes: Float[Array, "2*n 2*nc"]  # [S; dS/dx]^T
    impulse_response: Float[Array, "nc 2*n"]  # S M_hat^-1: nodal velocity change = impulses @ this [1/kg]
    coupling: Float[Array, "nc nc"]         # C = S M_hat^-1 S^T (symmetric) [1/kg]
    coupling_diag: Float[Array, " nc"]
    xi: Float[Array, " m"]


def contact_operators(n: int, m: int, ops: BeltOperators) -> ContactOperators:
    xg, wg = gauss_legendre(m)
    s, ds, _ = shape_functions(jnp.asarray(xg), ops.element_length)
    # Point (j, g) of element j depends on the scalar DOFs of nodes j and j + 1 (4 non-zeros per row).
    j = np.repeat(np.arange(n), m)
    k = (j + 1) % n
    dofs = np.stack([2 * j, 2 * j + 1, 2 * k, 2 * k + 1], axis=1)  # (nc, 4)
    rows = np.repeat(np.arange(n * m), 4)

    def dense(vals):  # (m, 4) per-element values -> (nc, 2n)
        return jnp.zeros((n * m, 2 * n), vals.dtype).at[rows, dofs.ravel()].add(jnp.tile(vals, (n, 1)).ravel())

    S = dense(s)
    B = ops.mass_inv @ S.T
    C = S @ B
    C = 0.5 * (C + C.T)
    return ContactOperators(length=ops.element_length * jnp.asarray(wg), positions=S.T,
                            positions_and_slopes=jnp.concatenate([S, dense(ds)]).T,
                            impulse_response=B.T, coupling=C, coupling_diag=jnp.diagonal(C), xi=jnp.asarray(xg))


def xy_components(x: Float[Array, "n 2 2"]) -> tuple[Float[Array, " 2*n"], Float[Array, " 2*n"]]:
    """Scalar nodal vectors (DOF 2j = position, 2j+1 = slope of node j) of the x and y components."""
    return x[..., 0].reshape(-1), x[..., 1].reshape(-1)


def from_xy(x: Float[Array, " 2*n"], y: Float[Array, " 2*n"]) -> Float[Array, "n 2 2"]:
    return jnp.stack([x.reshape(-1, 2), y.reshape(-1, 2)], axis=-1)


def point_kinematics(q, cops: ContactOperators) -> tuple[Points, Points, Points]:
    """Positions ``(rx, ry)`` and local stretch ``|r'|`` of the contact points."""
    nc = cops.coupling.shape[0]
    qx, qy = xy_components(q)
    ax, ay = qx @ cops.positions_and_slopes, qy @ cops.positions_and_slopes
    sx, sy = ax[nc:], ay[nc:]
    return ax[:nc], ay[:nc], jnp.sqrt(sx * sx + sy * sy)


def contact_points(q, cops: ContactOperators):
    """Positions ``(nc, 2)`` and local stretch ``|r'|`` ``(nc,)`` of the contact points."""
    rx, ry, stretch = point_kinematics(q, cops)
    return jnp.stack([rx, ry], axis=-1), stretch


def _safe_norm(x, y):
    sq = x * x + y * y
    ok = sq > 0
    return jnp.where(ok, jnp.sqrt(jnp.where(ok, sq, 1.0)), 0.0)


@typing.final
class ContactFrame(eqx.Module):
    """Each point's nearest pulley and its contact geometry (component-major)."""

    pulley: Int[Array, " nc"]
    gap: Points
    nx: Points       # outward unit normal of the pulley at the point
    ny: Points
    lx: Points       # lever arm r - c from the pulley centre
    ly: Points

    @property
    def tx(self):  # tangent: normal turned +90 degrees
        return -self.ny

    @property
    def ty(self):
        return self.nx


def nearest_pulley(rx: Points, ry: Points, centers, radii) -> ContactFrame:
    """Test each point against every pulley (a static loop over the few pulleys) and keep the nearest."""
    best = None
    for k in range(radii.shape[0]):
        lx, ly = rx - centers[k, 0], ry - centers[k, 1]
        dist = _safe_norm(lx, ly)
        cand = (jnp.full(rx.shape, k, jnp.int32), dist - radii[k], lx, ly, dist)
        if best is None:
            best = cand
        else:
            closer = cand[1] < best[1]  # strict: ties keep the lower index, like argmin
            best = tuple(jnp.where(closer, a, b) for a, b in zip(cand, best))
    pulley, gap, lx, ly, dist = best
    ok = dist > 0
    safe = jnp.where(ok, dist, 1.0)
    return ContactFrame(pulley=pulley, gap=gap, nx=jnp.where(ok, lx / safe, 1.0), ny=jnp.where(ok, ly / safe, 0.0),
                        lx=lx, ly=ly)
