"""The belt's Kelvin-Voigt axial damping as an implicit operator: ``(a M + h C(q)) v = b`` in O(n).

The axial damping force is linear in the velocities, ``f_d = -C(q) v`` with the exact tangent matrix

    C(q) = eta A  sum_g L w_g  (S'_g (x) r'_g)(S'_g (x) r'_g)^T / |r'_g|^2     (damping quadrature points g)

so an implicit Euler step on it is one linear solve with ``W = a M (x) I2 + h C(q)`` (SPD). ``C`` acts only
along the element tangents: transverse (span) motion sees the plain mass, unlike a constant isotropic
operator. ``W`` couples only neighbouring nodes, so it is a cyclic block-tridiagonal matrix with 4x4 node
blocks (x position, x slope, y position, y slope). ``solve_cyclic`` eliminates every other node in parallel
(cyclic reduction: the kept nodes again form a cyclic block-tridiagonal system) until two nodes remain:
about log2(n) vectorised levels, no LAPACK call (a batched getrf deadlocks XLA's CPU pool, see
``ring_mass_inverse``), plain jnp operations for both differentiation modes.
"""

from __future__ import annotations

import jax.numpy as jnp
from jaxtyping import Array, Float

from .._linalg import safe_norm
from .element import element_mass_unit
from .ring import BeltOperators, BeltParams, element_coordinates

__all__ = [
    "damping_blocks",
    "implicit_blocks",
    "apply_blocks",
    "solve_cyclic",
    "node_vectors",
    "from_node_vectors",
]

Blocks = Float[Array, "n 4 4"]


def node_vectors(vx: Float[Array, " 2*n"], vy: Float[Array, " 2*n"]) -> Float[Array, "n 4"]:
    """Component-major belt vectors as per-node 4-vectors (x position, x slope, y position, y slope)."""
    return jnp.concatenate([vx.reshape(-1, 2), vy.reshape(-1, 2)], axis=-1)


def from_node_vectors(u: Float[Array, "n 4"]):
    """Inverse of :func:`node_vectors`."""
    return u[:, :2].reshape(-1), u[:, 2:].reshape(-1)


def _mm(A, B):
    """Stacked small matrix products as broadcast multiply-adds: XLA's CPU dot on 4x4 batches is several
    times slower than one fused elementwise loop."""
    return jnp.sum(A[..., :, :, None] * B[..., None, :, :], axis=-2)


def damping_blocks(q, params: BeltParams, ops: BeltOperators) -> Float[Array, "n 2 2 4 4"]:
    """Per element the 2x2 node blocks (4x4 each) of the tangent damping matrix C(q)."""
    dS, w = ops.quad["dS_damp"], ops.quad["w_damp"]  # (g, 4), (g,)
    e = element_coordinates(q)  # (n, 4, 2)
    r = jnp.sum(dS[None, :, :, None] * e[:, None, :, :], axis=2)  # (n, g, 2): slopes r' at the damping points
    s = safe_norm(r[..., 0], r[..., 1])
    t = r / jnp.where(s > 0, s, 1.0)[..., None]  # r'/|r'|: C = sum coef (S' (x) t)(S' (x) t)^T
    coef = ops.element_length * params.axial_damping * w  # (g,)
    # A[j, g, k, 2c + d] = S'_g[2k + d] t_g[c]
    A = (dS.reshape(1, -1, 2, 1, 2) * t[:, :, None, :, None]).reshape(t.shape[0], dS.shape[0], 2, 4)
    Ac = coef[None, :, None, None] * A
    return jnp.sum(Ac[:, :, :, None, :, None] * A[:, :, None, :, None, :], axis=1)


def _mass_blocks(params: BeltParams, ops: BeltOperators) -> Float[Array, "2 2 4 4"]:
    me = params.mass_per_length * element_mass_unit(ops.element_length)  # over (r0, r0', r1, r1')
    blk = jnp.transpose(me.reshape(2, 2, 2, 2), (0, 2, 1, 3))  # (k, l, d, d')
    eye = jnp.eye(2, dtype=me.dtype)
    return (eye[None, None, :, None, :, None] * blk[:, :, None, :, None, :]).reshape(2, 2, 4, 4)


def implicit_blocks(q, params: BeltParams, ops: BeltOperators, mass_factor, h):
    """Node blocks of ``W = mass_factor M + h C(q)``: diagonal ``D (n, 4, 4)``, upper ``U (n, 4, 4)``
    (``U[j]`` couples node j to node j + 1), and the damping blocks for :func:`apply_blocks`."""
    Cb = damping_blocks(q, params, ops)
    We = mass_factor * _mass_blocks(params, ops)[None] + h * Cb
    D = We[:, 0, 0] + jnp.roll(We[:, 1, 1], 1, axis=0)
    return D, We[:, 0, 1], Cb


def apply_blocks(Eb: Float[Array, "n 2 2 4 4"], u: Float[Array, "n 4"]) -> Float[Array, "n 4"]:
    """Product of an assembled element-block matrix (e.g. C(q)) with per-node vectors."""
    ue = jnp.stack([u, jnp.roll(u, -1, axis=0)], axis=1)  # (n, 2, 4)
    ye = jnp.sum(Eb * ue[:, None, :, None, :], axis=(2, 4))  # (n, 2, 4)
    return ye[:, 0] + jnp.roll(ye[:, 1], 1, axis=0)


def _spd_solve(A, B):
    """Solve ``A X = B`` for a stack of small SPD matrices: elimination without pivoting (SPD), unrolled
    over scalar entries so that XLA fuses it into one elementwise loop."""
    k = A.shape[-1]
    a = [[A[..., i, j] for j in range(k)] for i in range(k)]
    b = [B[..., i, :] for i in range(k)]
    for i in range(k):  # forward: rows below i lose column i
        inv = 1.0 / a[i][i]
        for r in range(i + 1, k):
            f = a[r][i] * inv
            for c in range(i + 1, k):
                a[r][c] = a[r][c] - f * a[i][c]
            b[r] = b[r] - f[..., None] * b[i]
    x: list = [None] * k
    for i in reversed(range(k)):
        acc = b[i]
        for c in range(i + 1, k):
            acc = acc - a[i][c][..., None] * x[c]
        x[i] = acc / a[i][i][..., None]
    return jnp.stack(x, axis=-2)


def _mt(x):
    return jnp.swapaxes(x, -1, -2)


def _reduce(D, U, b):
    """One cyclic-reduction level: eliminate the odd nodes; returns the kept system and what
    back-substitution needs. With m odd, nodes m-1 and 0 are both kept and stay neighbours."""
    m = D.shape[0]
    no = m // 2  # eliminated odd nodes o = 1, 3, ...; each has kept neighbours o-1 and o+1 (mod m)
    Do, Uo, b_o = D[1::2][:no], U[1::2][:no], b[1::2][:no]
    Um = U[0::2][:no]  # coupling (o-1) -> o
    X = _spd_solve(Do, jnp.concatenate([_mt(Um), Uo, b_o], axis=-1))  # D_o^-1 [U_{o-1}^T | U_o | b_o]
    Xl, Xr, Xb = X[..., :4], X[..., 4:8], X[..., 8:]
    UoT = _mt(Uo)
    # kept node o-1 (positions 0..no-1) loses its right link to o, kept node o+1 its left link
    if m % 2 == 0:  # o + 1 at positions 1, ..., no-1, 0
        right = lambda x: x  # noqa: E731
        left = lambda x: jnp.roll(x, 1, axis=0)  # noqa: E731
    else:  # positions of o + 1: 1 ... no; the last kept node (m-1) keeps its link to node 0
        pad = [(0, 0)] * (D.ndim - 1)
        right = lambda x: jnp.pad(x, [(0, 1)] + pad[: x.ndim - 1])  # noqa: E731
        left = lambda x: jnp.pad(x, [(1, 0)] + pad[: x.ndim - 1])  # noqa: E731
    D2 = D[0::2] - right(_mm(Um, Xl)) - left(_mm(UoT, Xr))
    b2 = b[0::2] - right(_mm(Um, Xb)) - left(_mm(UoT, Xb))
    through = -_mm(Um, Xr)  # k -> next kept node through o
    U2 = through if m % 2 == 0 else jnp.concatenate([through, U[m - 1 :]], axis=0)
    return D2, U2, b2, (Xl, Xr, Xb)


def _back(u_keep, m, saved):
    Xl, Xr, Xb = saved
    no = m // 2
    nxt = jnp.roll(u_keep, -1, axis=0)[:no] if m % 2 == 0 else u_keep[1:]
    uo = Xb - _mm(Xl, u_keep[:no]) - _mm(Xr, nxt)
    pairs = jnp.stack([u_keep[:no], uo], axis=1).reshape((2 * no,) + uo.shape[1:])
    return pairs if m % 2 == 0 else jnp.concatenate([pairs, u_keep[no:]], axis=0)


def solve_cyclic(D: Blocks, U: Blocks, b: Float[Array, "n 4 r"]) -> Float[Array, "n 4 r"]:
    """Solve the SPD cyclic block-tridiagonal system ``U_{j-1}^T x_{j-1} + D_j x_j + U_j x_{j+1} = b_j``."""
    stack = []
    while D.shape[0] > 2:
        m = D.shape[0]
        D, U, b, saved = _reduce(D, U, b)
        stack.append((m, saved))
    if D.shape[0] == 2:  # both links join the same two nodes
        off = U[0] + _mt(U[1])
        A = jnp.concatenate([jnp.concatenate([D[0], off], 1), jnp.concatenate([_mt(off), D[1]], 1)], 0)
        x = _spd_solve(A, b.reshape(8, -1)).reshape(2, 4, -1)
    else:
        x = _spd_solve(D + U + _mt(U), b)  # a single node linked to itself
    for m, saved in reversed(stack):
        x = _back(x, m, saved)
    return x
