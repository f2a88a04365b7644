"""A closed belt: ANCF elements joined into a loop by shared nodes.

Nodal coordinates ``q`` have shape ``(n, 2, 2)``: ``q[k, 0]`` is node k's position, ``q[k, 1]`` its
slope dr/dx (x the stress-free material coordinate). Element ``j`` runs from node ``j`` to node
``(j + 1) % n``, so the loop closes without constraint equations.

Because the element mass matrix is ``rhoA * kron(M_hat, I2)``, the global mass matrix is a
*scalar* ``(2n, 2n)`` matrix acting identically on x and y. Its inverse is constant and dense
(the loop is cyclic, so the banded structure does not survive inversion). Both are block-circulant
(equal elements on a ring), so ``belt_operators`` offers two forms: ``"dense"`` (matrices, one
``x @ A`` product: fastest for short belts) and ``"structured"`` (M as a 3-block stencil, M^-1 by FFT
on the node index from the closed-form inverse of M's 2x2 symbol: O(n log n)). ``"auto"`` picks by
the element count (``STRUCTURED_FROM``, measured crossover).
"""

from __future__ import annotations

import functools
import typing

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._linalg import (
    AbstractRingOperator,
    DenseRingOperator,
    FFTRingOperator,
    StencilRingOperator,
    circulant_symbol,
    symbol_inverse_2x2,
)
from .element import element_energy, element_forces, element_mass_unit, gauss_legendre, make_quadrature, shape_functions

__all__ = [
    "BeltParams",
    "BeltOperators",
    "belt_operators",
    "internal_forces",
    "elastic_energy",
    "gravity_forces",
    "element_coordinates",
    "scatter_to_nodes",
    "assemble_ring",
    "ring_mass_matrix",
    "ring_mass_inverse",
    "ring_operator_kind",
    "OPERATOR_KINDS",
    "STRUCTURED_FROM",
]

OPERATOR_KINDS = ("auto", "dense", "structured")
# Element count from which "auto" uses the structured operators. Benchmark A's time per step on the 2-core
# CPU (benchmarks/bench_scaling.py, best of 3 alternating runs, load average 4-6 from other sessions), dense
# / structured in us: 131 / 120 at 30 elements, 196 / 269 at 60, 541 / 342 at 120, 1299 / 266 at 240.
# 100 keeps the usual meshes (Benchmark A's 60, the serpentine's 64) on the dense path, bit-identical.
STRUCTURED_FROM = 100

Nodes = Float[Array, "n 2 2"]


@typing.final
class BeltParams(eqx.Module):
    """Differentiable belt data (all per *stress-free* length).

    EA: axial stiffness [N]; EI: bending stiffness [N m^2]; axial_damping: Kelvin–Voigt
    coefficient eta*A [N s]; bending_damping: Rayleigh stiffness-proportional coefficient [s];
    mass_per_length: rhoA [kg/m]; stress_free_length: L0 [m].
    """

    EA: Float[Array, ""]
    EI: Float[Array, ""]
    axial_damping: Float[Array, ""]
    bending_damping: Float[Array, ""]
    mass_per_length: Float[Array, ""]
    stress_free_length: Float[Array, ""]


@typing.final
class BeltOperators(eqx.Module):
    """Arrays derived once per simulation from the element count and BeltParams."""

    element_length: Float[Array, ""]
    mass: AbstractRingOperator  # scalar global mass matrix M (kg), on x or y components
    mass_inv: AbstractRingOperator  # M^-1
    quad: dict


def _element_dofs(n: int) -> np.ndarray:
    """Scalar DOF indices of each element: node j -> (2j, 2j+1)."""
    j = np.arange(n)
    k = (j + 1) % n
    return np.stack([2 * j, 2 * j + 1, 2 * k, 2 * k + 1], axis=1)


def assemble_ring(n: int, element_matrix: Float[Array, "4 4"]) -> Float[Array, "2*n 2*n"]:
    """Global scalar matrix of a closed loop of ``n`` equal elements, each contributing ``element_matrix``
    on its scalar coordinates ``(r0, r0', r1, r1')`` (the same for x and y)."""
    dofs = _element_dofs(n)
    rows = np.repeat(dofs, 4, axis=1).ravel()
    cols = np.tile(dofs, (1, 4)).ravel()
    vals = jnp.broadcast_to(element_matrix, (n, 4, 4)).reshape(-1)
    return jnp.zeros((2 * n, 2 * n), element_matrix.dtype).at[rows, cols].add(vals)


# Largest eigenvalues of a ring of equal elements, per element length L (rings of 24-120 elements at 0-5 %
# stretch, power iteration; dynamics.stability.largest_rates recomputes them exactly): M^-1 K <= AXIAL EA /
# (rhoA L^2) + BENDING EI / (rhoA L^4) (AXIAL also for a tension N in place of EA), M^-1 C <= DAMPING eta A /
# (rhoA L^2) with the 2-point damping rule.
AXIAL_CONSTANT = 42.0
BENDING_CONSTANT = 2500.0
DAMPING_CONSTANT = 13.6


def ring_mass_matrix(n: int, element_length, mass_per_length) -> Float[Array, "2*n 2*n"]:
    """Global scalar consistent mass matrix of a closed loop of ``n`` equal elements."""
    return assemble_ring(n, mass_per_length * element_mass_unit(element_length))


@functools.lru_cache(maxsize=None)
def _unit_ring_mass_inv(n: int) -> np.ndarray:
    """Inverse of the ring mass matrix for unit element length and unit mass per length (numpy, once per n).

    Symmetrised: round-off asymmetry would leak energy in long runs.
    """
    xg, wg = gauss_legendre(4)  # exact for the degree-6 integrand
    # element.shape_functions at L = 1, in float64 numpy whatever JAX's precision setting
    N = np.stack([1 - 3 * xg**2 + 2 * xg**3, xg - 2 * xg**2 + xg**3, 3 * xg**2 - 2 * xg**3, xg**3 - xg**2], -1)
    me = np.einsum("g,gi,gj->ij", wg, N, N)
    dofs = _element_dofs(n)
    M = np.zeros((2 * n, 2 * n))
    np.add.at(M, (np.repeat(dofs, 4, axis=1).ravel(), np.tile(dofs, (1, 4)).ravel()), np.tile(me.ravel(), n))
    Minv = np.linalg.inv(M)
    return 0.5 * (Minv + Minv.T)


def ring_mass_inverse(n: int, element_length, mass_per_length) -> Float[Array, "2*n 2*n"]:
    """Inverse of :func:`ring_mass_matrix` in closed form (traceable, no LU in the compiled program).

    Hermite slopes scale with the element length: ``M = rhoA L D Mhat D`` with ``D = diag(1, L, 1, L, ...)``
    and ``Mhat`` the matrix at ``L = 1``, so ``M^-1 = D^-1 Mhat^-1 D^-1 / (rhoA L)``. A batched
    ``jnp.linalg.inv`` here (a sweep over pretension or mass per length vmaps it) compiles to LAPACK's
    getrf kernel, which fans the batch out into XLA's intra-op thread pool while running on a worker of
    that same pool: with two CPU devices on two cores both workers waited on each other forever.
    """
    L = element_length
    unit = jnp.asarray(_unit_ring_mass_inv(n), dtype=jnp.result_type(L, mass_per_length))
    d = jnp.tile(jnp.stack([jnp.ones_like(L), 1.0 / L]), n)  # D^-1
    return unit * (d[:, None] * d[None, :]) / (mass_per_length * L)


def ring_operator_kind(n: int, kind: str = "auto") -> str:
    """Resolve ``kind`` ("auto", "dense" or "structured") for a belt of ``n`` elements."""
    if kind not in OPERATOR_KINDS:
        raise ValueError(f"ring operators {kind!r}: expected one of {', '.join(map(repr, OPERATOR_KINDS))}")
    if kind == "auto":
        return "structured" if n >= STRUCTURED_FROM else "dense"
    return kind


def _mass_stencil(n: int, element_length, mass_per_length) -> StencilRingOperator:
    """M as node blocks at offsets -1, 0, +1 (``y_j = sum_k x_{j+k} B_k``, see ``_linalg``)."""
    me = mass_per_length * element_mass_unit(element_length)
    blocks = jnp.stack([me[:2, 2:], me[:2, :2] + me[2:, 2:], me[2:, :2]])
    return StencilRingOperator(blocks, (-1, 0, 1), n)


def belt_operators(
    n: int, params: BeltParams, n_axial: int = 3, n_bend: int = 3, n_damp: int = 2, kind: str = "dense"
) -> BeltOperators:
    """The belt's constant operators; ``kind`` as in :func:`ring_operator_kind` (dense by default: the
    stability bound and the free-belt tools keep the matrices)."""
    L = params.stress_free_length / n
    quad = make_quadrature(L, n_axial, n_bend, n_damp)
    if ring_operator_kind(n, kind) == "structured":
        mass = _mass_stencil(n, L, params.mass_per_length)
        sym = symbol_inverse_2x2(circulant_symbol(mass.blocks, mass.offsets, n))
        # M is symmetric, so its symbol is Hermitian; keep M^-1's exactly so (energy in long runs)
        sym = 0.5 * (sym + jnp.conj(jnp.swapaxes(sym, -1, -2)))
        return BeltOperators(element_length=L, mass=mass, mass_inv=FFTRingOperator.from_symbol(sym), quad=quad)
    M = ring_mass_matrix(n, L, params.mass_per_length)
    Minv = ring_mass_inverse(n, L, params.mass_per_length)
    return BeltOperators(element_length=L, mass=DenseRingOperator(M), mass_inv=DenseRingOperator(Minv), quad=quad)


def element_coordinates(q: Nodes) -> Float[Array, "n 4 2"]:
    """Gather each element's 8 coordinates from the shared nodes."""
    return jnp.concatenate([q, jnp.roll(q, -1, axis=0)], axis=1)


def scatter_to_nodes(fe: Float[Array, "n 4 2"]) -> Nodes:
    """Sum element-level generalised forces onto the shared nodes (transpose of the gather)."""
    return fe[:, :2] + jnp.roll(fe[:, 2:], 1, axis=0)


def internal_forces(q: Nodes, v: Nodes, params: BeltParams, ops: BeltOperators):
    """Elastic + damping generalised forces on the nodes, and the total damping dissipation rate."""
    e, ed = element_coordinates(q), element_coordinates(v)
    fe, diss = jax.vmap(element_forces, in_axes=(0, 0, None, None, None, None, None, None))(
        e, ed, ops.element_length, params.EA, params.EI, params.axial_damping, params.bending_damping, ops.quad
    )
    return scatter_to_nodes(fe), jnp.sum(diss)


def elastic_energy(q: Nodes, params: BeltParams, ops: BeltOperators):
    e = element_coordinates(q)
    return jnp.sum(
        jax.vmap(element_energy, in_axes=(0, None, None, None, None))(
            e, ops.element_length, params.EA, params.EI, ops.quad
        )
    )


def gravity_forces(n: int, params: BeltParams, ops: BeltOperators, gravity) -> Nodes:
    """Consistent nodal forces of the belt's weight: rhoA g int S dx per element."""
    xg, wg = gauss_legendre(3)
    s, _, _ = shape_functions(jnp.asarray(xg), ops.element_length)
    sint = ops.element_length * jnp.asarray(wg) @ s  # (4,)
    fe = params.mass_per_length * sint[:, None] * jnp.asarray(gravity)[None, :]  # (4, 2)
    return scatter_to_nodes(jnp.broadcast_to(fe, (n, 4, 2)))
