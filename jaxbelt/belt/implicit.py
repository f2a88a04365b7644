"""The step's implicit belt operator ``W = a M + h C(q) + S(q)`` in O(n): Kelvin-Voigt damping, mass scaling.

The axial damping force is linear in the velocities, ``f_d = -C(q) v`` with the exact tangent matrix

    C(q) = eta A  sum_g L w_g  (S'_g (x) r'_g)(S'_g (x) r'_g)^T / |r'_g|^2     (damping quadrature points g)

so an implicit Euler step on it is one linear solve with ``W = a M (x) I2 + h C(q)`` (SPD). ``C`` acts only
along the element tangents: transverse (span) motion sees the plain mass, unlike a constant isotropic
operator. ``solver.implicit_stiffness`` adds the mass scaling ``S ~ theta h^2 K(q)`` (``mass_scaling_blocks``:
axial, tension and bending stiffness), the same kind of element blocks. ``W`` couples only neighbouring
nodes, so it is a cyclic block-tridiagonal matrix with 4x4 node blocks (x position, x slope, y position,
y slope). ``factor_cyclic`` eliminates every other node in parallel (cyclic reduction: the kept nodes
again form a cyclic block-tridiagonal system) until two nodes remain: about log2(n) vectorised levels,
no LAPACK call (a batched getrf deadlocks XLA's CPU pool, see ``ring_mass_inverse``); ``solve_factored``
reuses it for every right-hand side (the contact solve) and is differentiated implicitly, in both modes
(``jax.lax.custom_linear_solve``: a solution's tangent is one more solve with the same factor, so derivative
programs carry no tangent of the factorisation: a forward-mode Jacobian of Benchmark A 9.5 -> 5.6 forward runs,
its reverse-mode gradient 18.1 -> 8.2). ``point_values`` / ``point_loads`` are the contact points' S and S^T on
node vectors.
"""

from __future__ import annotations

import typing

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._linalg import safe_norm
from .element import element_mass_unit
from .ring import AXIAL_CONSTANT, BENDING_CONSTANT, BeltOperators, BeltParams, element_coordinates

__all__ = [
    "damping_blocks",
    "stiffness_blocks",
    "mass_scaling_blocks",
    "implicit_blocks",
    "implicit_element_blocks",
    "node_blocks",
    "apply_blocks",
    "CyclicFactor",
    "factor_cyclic",
    "solve_factored",
    "solve_cyclic",
    "apply_cyclic",
    "point_values",
    "point_loads",
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


def _kron_blocks(P: Float[Array, "g 4 4"], A: Float[Array, "n g 2 2"]) -> Float[Array, "n 2 2 4 4"]:
    """``sum_g P_g (x) A_g`` per element as 2x2 node blocks: ``P_g`` acts on the scalar element DOFs
    (r_j, r_j', r_j+1, r_j+1'), ``A_g`` on the two components. A strain gradient ``S'_g (x) u_g`` gives the
    term ``P_g = S'_g S'_g^T``, ``A_g = u_g u_g^T``: one small contraction over the points instead of 8 x 8
    outer products."""
    n = A.shape[0]
    E = jnp.einsum("gij,ngce->nijce", P, A).reshape(n, 2, 2, 2, 2, 2, 2)  # n, k, d, l, d', c, c'
    return E.transpose(0, 1, 3, 5, 2, 6, 4).reshape(n, 2, 2, 4, 4)  # n, k, l, (c, d), (c', d')


def _outer(u, v):
    return u[..., :, None] * v[..., None, :]


def _unit_slopes(dS, q):
    """Slopes r' at the points ``dS`` of every element, their length and the unit tangent."""
    e = element_coordinates(q)  # (n, 4, 2)
    r = jnp.sum(dS[None, :, :, None] * e[:, None, :, :], axis=2)  # (n, g, 2)
    s = safe_norm(r[..., 0], r[..., 1])
    return r, s, r / jnp.where(s > 0, s, 1.0)[..., None]


def damping_blocks(q, params: BeltParams, ops: BeltOperators) -> Float[Array, "n 2 2 4 4"]:
    """Per element the 2x2 node blocks (4x4 each) of the tangent damping matrix C(q)."""
    dS, w = ops.quad["dS_damp"], ops.quad["w_damp"]  # (g, 4), (g,)
    _, _, t = _unit_slopes(dS, q)  # r'/|r'|: C = sum coef (S' (x) t)(S' (x) t)^T
    coef = ops.element_length * params.axial_damping * w
    return _kron_blocks(_outer(dS, dS), coef[None, :, None, None] * _outer(t, t))


def stiffness_blocks(q, params: BeltParams, ops: BeltOperators) -> Float[Array, "n 2 2 4 4"]:
    """Per element the node blocks of a positive semi-definite belt stiffness ``K(q)``: the axial tangent
    stiffness (material ``EA t t^T`` and, for tension only, geometric ``N / |r'| n n^T``) and the
    Gauss-Newton part of the bending stiffness ``EI dK dK^T``.

    It leaves out only the indefinite terms (compression, the curvature's second derivatives), so it
    bounds every stiff belt frequency."""
    return _stiffness(q, params, ops, lambda tension: (1.0, 1.0, 1.0))


SCALED_PARTS = 3  # material, tension, bending: each keeps 1/3 of the stability margin


def mass_scaling_blocks(q, params: BeltParams, ops: BeltOperators, h, theta) -> Float[Array, "n 2 2 4 4"]:
    """The mass scaling ``S`` of ``implicit_stiffness``: each part k of ``K`` (material, tension, bending)
    scaled by ``theta_k h^2`` with ``theta_k = max(0, theta - 1 / (3 h^2 omega_k^2))``, ``omega_k`` the part's
    largest frequency per element (the tension part's per axial point), plus ``h beta`` on the bending part
    (Rayleigh bending damping, explicit). A part that explicit symplectic Euler already integrates stably
    (``h^2 omega_k^2 <= 1 / (3 theta)``) is not scaled at all, and one far above that is scaled by ``theta``:
    for any mix of the parts ``h^2 lambda(M_S^-1 K) <= 1 / theta``, the stability bound's margin of 2 at
    ``theta = 1/2``. So coarse meshes and short steps leave the spans' string modes unscaled."""
    L, m = ops.element_length, params.mass_per_length
    h2 = h * h

    def part(omega2):  # theta_k h^2, with a double where: omega2 may be 0 (a slack point)
        safe = jnp.where(omega2 > 0, omega2, 1.0)
        return jnp.where(omega2 > 0, h2 * jnp.maximum(0.0, theta - 1.0 / (SCALED_PARTS * h2 * safe)), 0.0)

    def coefficients(tension):
        material = part(AXIAL_CONSTANT * params.EA / (m * L**2))
        geometric = part(AXIAL_CONSTANT * tension / (m * L**2))
        bending = part(BENDING_CONSTANT * params.EI / (m * L**4)) + h * params.bending_damping
        return material, geometric, bending

    return _stiffness(q, params, ops, coefficients)


def _stiffness(q, params: BeltParams, ops: BeltOperators, coefficients) -> Float[Array, "n 2 2 4 4"]:
    """The parts of :func:`stiffness_blocks`, each times its coefficient: ``coefficients(tension)`` gives
    (material, tension part (per axial point), bending)."""
    L, quad = ops.element_length, ops.quad
    dS, w = quad["dS_axial"], quad["w_axial"]
    _, s, t = _unit_slopes(dS, q)
    normal = jnp.stack([-t[..., 1], t[..., 0]], axis=-1)
    tension = params.EA * jnp.maximum(s - 1.0, 0.0) / jnp.where(s > 0, s, 1.0)  # N / |r'|, tension only
    c_material, c_geometric, c_bending = coefficients(tension)
    A_axial = (L * w)[None, :, None, None] * (
        (c_material * params.EA) * _outer(t, t) + (c_geometric * tension)[..., None, None] * _outer(normal, normal)
    )
    # bending: K = (r' x r'') / |r'|^2; its gradient is S' (x) dK/dr' + S'' (x) dK/dr''
    dSb, ddSb = quad["dS_bend"], quad["ddS_bend"]
    e = element_coordinates(q)
    c = jnp.sum(dSb[None, :, :, None] * e[:, None, :, :], axis=2)  # (n, g, 2): r'
    d = jnp.sum(ddSb[None, :, :, None] * e[:, None, :, :], axis=2)  # r''
    sq = c[..., 0] ** 2 + c[..., 1] ** 2
    inv_sq = 1.0 / jnp.where(sq > 0, sq, 1.0)
    curv = (c[..., 0] * d[..., 1] - c[..., 1] * d[..., 0]) * inv_sq
    a = jnp.stack([d[..., 1] - 2.0 * curv * c[..., 0], -d[..., 0] - 2.0 * curv * c[..., 1]], -1) * inv_sq[..., None]
    b = jnp.stack([-c[..., 1], c[..., 0]], -1) * inv_sq[..., None]
    cb = (c_bending * L * params.EI * quad["w_bend"])[None, :, None, None]
    P = jnp.concatenate([_outer(dS, dS), _outer(dSb, dSb), _outer(dSb, ddSb), _outer(ddSb, dSb), _outer(ddSb, ddSb)])
    A = jnp.concatenate([A_axial, cb * _outer(a, a), cb * _outer(a, b), cb * _outer(b, a), cb * _outer(b, b)], axis=1)
    return _kron_blocks(P, A)


def _mass_blocks(params: BeltParams, ops: BeltOperators) -> Float[Array, "2 2 4 4"]:
    me = params.mass_per_length * element_mass_unit(ops.element_length)  # over (r0, r0', r1, r1')
    blk = jnp.transpose(me.reshape(2, 2, 2, 2), (0, 2, 1, 3))  # (k, l, d, d')
    eye = jnp.eye(2, dtype=me.dtype)
    return (eye[None, None, :, None, :, None] * blk[:, :, None, :, None, :]).reshape(2, 2, 4, 4)


def implicit_element_blocks(q, params: BeltParams, ops: BeltOperators, mass_factor, h, scaling=None):
    """Element blocks of ``W = mass_factor M + h C(q) (+ scaling)`` ``(n, 2, 2, 4, 4)`` and those of ``C``.
    ``scaling``: element blocks added to the mass (``implicit_stiffness``'s ``theta h^2 K``)."""
    Cb = damping_blocks(q, params, ops)
    We = mass_factor * _mass_blocks(params, ops)[None] + h * Cb
    if scaling is not None:
        We = We + scaling
    return We, Cb


def node_blocks(We: Float[Array, "n 2 2 4 4"]) -> tuple[Blocks, Blocks]:
    """Assembled node blocks of element blocks: diagonal ``D (n, 4, 4)`` and upper ``U (n, 4, 4)`` (``U[j]``
    couples node j to node j + 1), the form :func:`factor_cyclic` takes."""
    return We[:, 0, 0] + jnp.roll(We[:, 1, 1], 1, axis=0), We[:, 0, 1]


def implicit_blocks(q, params: BeltParams, ops: BeltOperators, mass_factor, h, scaling=None):
    """Node blocks ``D, U`` (:func:`node_blocks`) of ``W = mass_factor M + h C(q) (+ scaling)`` and the damping
    blocks for :func:`apply_blocks`."""
    We, Cb = implicit_element_blocks(q, params, ops, mass_factor, h, scaling)
    D, U = node_blocks(We)
    return D, U, Cb


def apply_blocks(Eb: Float[Array, "n 2 2 4 4"], u: Float[Array, "n 4"]) -> Float[Array, "n 4"]:
    """Product of an assembled element-block matrix (e.g. C(q)) with per-node vectors."""
    ue = jnp.stack([u, jnp.roll(u, -1, axis=0)], axis=1)  # (n, 2, 4)
    ye = jnp.sum(Eb * ue[:, None, :, None, :], axis=(2, 4))  # (n, 2, 4)
    return ye[:, 0] + jnp.roll(ye[:, 1], 1, axis=0)


def _mt(x):
    return jnp.swapaxes(x, -1, -2)


def _neighbours(m: int, ndim: int):
    """Where the kept node after each eliminated odd node sits among the kept nodes (``right``: the node
    before it, ``left``: after it). With m odd, nodes m-1 and 0 are both kept and stay neighbours."""
    if m % 2 == 0:  # o + 1 at positions 1, ..., no-1, 0
        return (lambda x: x), (lambda x: jnp.roll(x, 1, axis=0))
    pad = [(0, 0)] * (ndim - 1)  # positions of o + 1: 1 ... no; the last kept node (m-1) keeps its link to 0
    return (lambda x: jnp.pad(x, [(0, 1)] + pad[: x.ndim - 1])), (lambda x: jnp.pad(x, [(1, 0)] + pad[: x.ndim - 1]))


def _inverse2(M):
    """Inverses of a stack of 2 x 2 matrices (adjugate over determinant)."""
    a, b, c, d = M[..., 0, 0], M[..., 0, 1], M[..., 1, 0], M[..., 1, 1]
    det = a * d - b * c
    return jnp.stack([jnp.stack([d, -b], -1), jnp.stack([-c, a], -1)], -2) / det[..., None, None]


def _inverse(A):
    """Inverses of a stack of SPD 4 x 4 matrices by 2 x 2 blocks (Schur complement; SPD, so no pivoting):
    a few fused elementwise operations, where an unrolled elimination made the factorisation most of the
    step's program (and of its compile time, three times over in reverse mode)."""
    P, Q, R = A[..., :2, :2], A[..., :2, 2:], A[..., 2:, 2:]
    Pi = _inverse2(P)
    PiQ = _mm(Pi, Q)
    Si = _inverse2(R - _mm(_mt(Q), PiQ))
    top_right = -_mm(PiQ, Si)
    top_left = Pi - _mm(top_right, _mt(PiQ))
    return jnp.concatenate([jnp.concatenate([top_left, top_right], -1), jnp.concatenate([_mt(top_right), Si], -1)], -2)


@typing.final
class CyclicFactor(eqx.Module):
    """Cyclic reduction of ``W`` (:func:`factor_cyclic`), reusable for any number of right-hand sides:
    per level the eliminated nodes' inverse diagonal blocks and couplings, then the last one or two nodes
    (4 x 4 inverses only: an unrolled 8 x 8 one would be most of the program)."""

    D: Blocks  # the matrix factored (its node blocks: the solves' derivatives go through them, not the factor)
    U: Blocks
    levels: tuple  # per level (inverse D_o, U_{o-1}, U_o^T, D_o^-1 U_{o-1}^T, D_o^-1 U_o)
    last: Float[Array, "4 4"]  # inverse of the last node's block (its Schur complement when two remain)
    pair: tuple | None = None  # two nodes left: (D_1^-1, their coupling, D_1^-1 coupling^T)


def factor_cyclic(D: Blocks, U: Blocks) -> CyclicFactor:
    """Factor the SPD cyclic block-tridiagonal matrix ``U_{j-1}^T x_{j-1} + D_j x_j + U_j x_{j+1}``.

    The factor is not differentiated: :func:`solve_factored` differentiates its solutions implicitly (the
    derivative of ``W^-1 b`` is ``W^-1 (db - dW x)``, one more solve with this factor), so derivative programs
    carry no tangent of the factorisation."""
    blocks = (D, U)
    D, U = jax.lax.stop_gradient(D), jax.lax.stop_gradient(U)
    levels = []
    while D.shape[0] > 2:
        m = D.shape[0]
        no = m // 2  # eliminated odd nodes o = 1, 3, ...; each has kept neighbours o-1 and o+1 (mod m)
        Do, Uo, Um = D[1::2][:no], U[1::2][:no], U[0::2][:no]  # Um: coupling (o-1) -> o
        Dinv = _inverse(Do)
        UoT = _mt(Uo)
        Xl, Xr = _mm(Dinv, _mt(Um)), _mm(Dinv, Uo)
        right, left = _neighbours(m, D.ndim)
        through = -_mm(Um, Xr)  # kept node -> next kept node through o
        D = D[0::2] - right(_mm(Um, Xl)) - left(_mm(UoT, Xr))
        U = through if m % 2 == 0 else jnp.concatenate([through, U[m - 1 :]], axis=0)
        levels.append((Dinv, Um, UoT, Xl, Xr))
    if D.shape[0] == 2:  # both links join the same two nodes: node 1 eliminated into node 0's Schur complement
        off = U[0] + _mt(U[1])
        D1inv = _inverse(D[1])
        X1 = _mm(D1inv, _mt(off))
        return CyclicFactor(*blocks, levels=tuple(levels), last=_inverse(D[0] - _mm(off, X1)), pair=(D1inv, off, X1))
    return CyclicFactor(*blocks, levels=tuple(levels), last=_inverse(D[0] + U[0] + _mt(U[0])))  # one node, to itself


def apply_cyclic(D: Blocks, U: Blocks, x: Float[Array, "n 4 r"]) -> Float[Array, "n 4 r"]:
    """``W x`` for the cyclic block-tridiagonal ``W`` of :func:`factor_cyclic` (row j: ``U_{j-1}^T x_{j-1} + D_j x_j
    + U_j x_{j+1}``; with one node, ``(D + U + U^T) x``)."""
    return _mm(D, x) + _mm(U, jnp.roll(x, -1, axis=0)) + jnp.roll(_mm(_mt(U), x), 1, axis=0)


def solve_factored(F: CyclicFactor, b: Float[Array, "n 4 r"]) -> Float[Array, "n 4 r"]:
    """Solve ``W x = b`` with the factor of :func:`factor_cyclic`; derivatives (both modes) by implicit
    differentiation of the solve (``jax.lax.custom_linear_solve``, W symmetric): with respect to ``b`` and to W's
    blocks, whatever they depend on."""
    return jax.lax.custom_linear_solve(
        lambda x: apply_cyclic(F.D, F.U, x), b, lambda _, c: _solve_levels(F, c), symmetric=True
    )


def _solve_levels(F: CyclicFactor, b: Float[Array, "n 4 r"]) -> Float[Array, "n 4 r"]:
    """The cyclic reduction's forward and back substitution (not differentiated: see :func:`solve_factored`)."""
    stack = []
    for Dinv, Um, UoT, _, _ in F.levels:
        m = b.shape[0]
        no = m // 2
        Xb = _mm(Dinv, b[1::2][:no])
        right, left = _neighbours(m, b.ndim)
        b = b[0::2] - right(_mm(Um, Xb)) - left(_mm(UoT, Xb))
        stack.append((m, Xb))
    if F.pair is None:
        x = _mm(F.last, b[0])[None]
    else:
        D1inv, off, X1 = F.pair
        x0 = _mm(F.last, b[0] - _mm(off, _mm(D1inv, b[1])))
        x = jnp.stack([x0, _mm(D1inv, b[1]) - _mm(X1, x0)])
    for (m, Xb), (_, _, _, Xl, Xr) in zip(reversed(stack), reversed(F.levels)):
        no = m // 2
        nxt = jnp.roll(x, -1, axis=0)[:no] if m % 2 == 0 else x[1:]
        uo = Xb - _mm(Xl, x[:no]) - _mm(Xr, nxt)
        pairs = jnp.stack([x[:no], uo], axis=1).reshape((2 * no,) + uo.shape[1:])
        x = pairs if m % 2 == 0 else jnp.concatenate([pairs, x[no:]], axis=0)
    return x


def solve_cyclic(D: Blocks, U: Blocks, b: Float[Array, "n 4 r"]) -> Float[Array, "n 4 r"]:
    """Solve the SPD cyclic block-tridiagonal system ``U_{j-1}^T x_{j-1} + D_j x_j + U_j x_{j+1} = b_j``."""
    return solve_factored(factor_cyclic(D, U), b)


def point_values(u: Float[Array, "n 4"], shape: Float[Array, "m 4"]):
    """Components ``(x, y)`` at the ``m`` points of every element (``shape``: the shape functions there)
    of a field given as node 4-vectors: ``S u`` in the contact points' order (element-major)."""
    ue = jnp.concatenate([u, jnp.roll(u, -1, axis=0)], axis=-1)  # (n, 8): node j then node j + 1
    ex = jnp.concatenate([ue[:, 0:2], ue[:, 4:6]], axis=-1)  # (n, 4): the element's x DOFs
    ey = jnp.concatenate([ue[:, 2:4], ue[:, 6:8]], axis=-1)
    # broadcast multiply-adds, not dots: XLA's CPU dot on (n, 4) x (4, m) was most of a contact sweep
    x = jnp.sum(ex[:, None, :] * shape[None], axis=-1)  # (n, m)
    y = jnp.sum(ey[:, None, :] * shape[None], axis=-1)
    return x.reshape(-1), y.reshape(-1)


def point_loads(Px, Py, shape: Float[Array, "m 4"]) -> Float[Array, "n 4"]:
    """Nodal generalised forces (node 4-vectors) of point forces ``(Px, Py)``: ``S^T P``, the transpose of
    :func:`point_values`."""
    m = shape.shape[0]
    fx = jnp.sum(Px.reshape(-1, m, 1) * shape[None], axis=1)  # (n, 4): node j (0:2), node j + 1 (2:4)
    fy = jnp.sum(Py.reshape(-1, m, 1) * shape[None], axis=1)
    mine = jnp.concatenate([fx[:, :2], fy[:, :2]], axis=-1)
    nxt = jnp.concatenate([fx[:, 2:], fy[:, 2:]], axis=-1)
    return mine + jnp.roll(nxt, 1, axis=0)
