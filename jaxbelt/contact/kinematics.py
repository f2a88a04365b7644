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

from .._linalg import (
    AbstractRingOperator,
    DenseRingOperator,
    FFTRingOperator,
    StencilRingOperator,
    circulant_symbol,
    from_xy,
    safe_norm,
    xy_components,
)
from ..belt.element import gauss_legendre, shape_functions
from ..belt.ring import BeltOperators

__all__ = [
    "ContactOperators",
    "contact_operators",
    "contact_points",
    "point_kinematics",
    "nearest_pulley",
    "ContactFrame",
    "xy_components",
    "from_xy",
]  # the x/y pair lives in _linalg (re-exported here)

Points = Float[Array, " nc"]


@typing.final
class ContactOperators(eqx.Module):
    length: Float[Array, " m"]  # stress-free belt length each point of an element represents (w_g L)
    # Row-vector operators ``x @ A`` (see _linalg.AbstractRingOperator):
    positions: AbstractRingOperator  # S^T (2n -> nc): point positions (velocities) = positions.apply(nodal)
    positions_and_slopes: AbstractRingOperator  # [S; dS/dx]^T (2n -> 2nc)
    impulse_response: AbstractRingOperator  # (S M_hat^-1)^T (nc -> 2n): nodal velocity change of impulses [1/kg]
    coupling: AbstractRingOperator  # C = S M_hat^-1 S^T (nc -> nc, symmetric) [1/kg]
    coupling_diag: Float[Array, " nc"]
    xi: Float[Array, " m"]
    shape: Float[Array, "m 4"]  # the shape functions at the m points of an element (S in node-vector form)


def contact_operators(n: int, m: int, ops: BeltOperators) -> ContactOperators:
    """The contact maps, in the form of the belt's mass inverse: dense matrices, or (FFT mass inverse)
    stencils for S and [S; dS] and FFT operators for (S M^-1)^T and S M^-1 S^T."""
    xg, wg = gauss_legendre(m)
    s, ds, _ = shape_functions(jnp.asarray(xg), ops.element_length)
    if isinstance(ops.mass_inv, FFTRingOperator):
        return _structured_contact_operators(n, m, ops.mass_inv, s, ds, ops.element_length * jnp.asarray(wg), xg)
    # Point (j, g) of element j depends on the scalar DOFs of nodes j and j + 1 (4 non-zeros per row).
    j = np.repeat(np.arange(n), m)
    k = (j + 1) % n
    dofs = np.stack([2 * j, 2 * j + 1, 2 * k, 2 * k + 1], axis=1)  # (nc, 4)
    rows = np.repeat(np.arange(n * m), 4)

    def dense(vals):  # (m, 4) per-element values -> (nc, 2n)
        return jnp.zeros((n * m, 2 * n), vals.dtype).at[rows, dofs.ravel()].add(jnp.tile(vals, (n, 1)).ravel())

    S = dense(s)
    minv = ops.mass_inv
    if not isinstance(minv, DenseRingOperator):  # a structured mass inverse would build these its own way
        raise NotImplementedError(f"contact operators from a {type(minv).__name__} mass inverse")
    B = minv.matrix @ S.T  # built dense once
    C = S @ B
    C = 0.5 * (C + C.T)
    coupling = DenseRingOperator(C)
    return ContactOperators(
        length=ops.element_length * jnp.asarray(wg),
        positions=DenseRingOperator(S.T),
        positions_and_slopes=DenseRingOperator(jnp.concatenate([S, dense(ds)]).T),
        impulse_response=DenseRingOperator(B.T),
        coupling=coupling,
        coupling_diag=coupling.diagonal(),
        xi=jnp.asarray(xg),
        shape=s,
    )


def _structured_contact_operators(n, m, minv: FFTRingOperator, s, ds, length, xg) -> ContactOperators:
    # Point g of element j reads nodes j (offset 0) and j + 1 (offset 1): y_j = x_j P0 + x_{j+1} P1.
    pos = jnp.stack([s[:, :2].T, s[:, 2:].T])  # (2, 2, m)
    both = jnp.concatenate([pos, jnp.stack([ds[:, :2].T, ds[:, 2:].T])], axis=-1)  # (2, 2, 2m)
    s_sym = circulant_symbol(pos, (0, 1), n)  # (F, 2, m)
    st_sym = jnp.conj(jnp.swapaxes(s_sym, -1, -2))  # S^T: the transpose's symbol is the conjugate transpose
    b_sym = st_sym @ minv.symbol  # points -> nodes: M^-1 S^T
    c_sym = b_sym @ s_sym  # S M^-1 S^T
    coupling = FFTRingOperator.from_symbol(0.5 * (c_sym + jnp.conj(jnp.swapaxes(c_sym, -1, -2))))
    return ContactOperators(
        length=length,
        positions=StencilRingOperator(pos, (0, 1), n),
        positions_and_slopes=StencilRingOperator(both, (0, 1), n, groups=2),
        impulse_response=FFTRingOperator.from_symbol(b_sym),
        coupling=coupling,
        coupling_diag=coupling.diagonal(),
        xi=jnp.asarray(xg),
        shape=s,
    )


def point_kinematics(q, cops: ContactOperators) -> tuple[Points, Points, Points]:
    """Positions ``(rx, ry)`` and local stretch ``|r'|`` of the contact points."""
    nc = cops.coupling.shape[0]
    qx, qy = xy_components(q)
    ax, ay = cops.positions_and_slopes.apply(qx), cops.positions_and_slopes.apply(qy)
    sx, sy = ax[nc:], ay[nc:]
    return ax[:nc], ay[:nc], safe_norm(sx, sy)


def contact_points(q, cops: ContactOperators):
    """Positions ``(nc, 2)`` and local stretch ``|r'|`` ``(nc,)`` of the contact points."""
    rx, ry, stretch = point_kinematics(q, cops)
    return jnp.stack([rx, ry], axis=-1), stretch


@typing.final
class ContactFrame(eqx.Module):
    """Each point's nearest pulley and its contact geometry (component-major)."""

    pulley: Int[Array, " nc"]
    gap: Points
    nx: Points  # outward unit normal of the pulley at the point
    ny: Points
    lx: Points  # lever arm r - c from the pulley centre
    ly: Points

    @property
    def tx(self):  # tangent: normal turned +90 degrees
        return -self.ny

    @property
    def ty(self):
        return self.nx


def nearest_pulley(rx: Points, ry: Points, centers, radii) -> ContactFrame:
    """Test each point against every pulley (a static loop over the few pulleys) and keep the nearest."""

    def candidate(k: int) -> tuple[Array, ...]:
        lx, ly = rx - centers[k, 0], ry - centers[k, 1]
        dist = safe_norm(lx, ly)
        return (jnp.full(rx.shape, k, jnp.int32), dist - radii[k], lx, ly, dist)

    best = candidate(0)
    for k in range(1, radii.shape[0]):
        cand = candidate(k)
        closer = cand[1] < best[1]  # strict: ties keep the lower index, like argmin
        best = tuple(jnp.where(closer, a, b) for a, b in zip(cand, best))
    pulley, gap, lx, ly, dist = best
    ok = dist > 0
    safe = jnp.where(ok, dist, 1.0)
    return ContactFrame(
        pulley=pulley, gap=gap, nx=jnp.where(ok, lx / safe, 1.0), ny=jnp.where(ok, ly / safe, 0.0), lx=lx, ly=ly
    )
