"""Small linear-algebra conventions shared by the belt, contact and dynamics rooms.

* ``safe_norm``: the one guarded Euclidean norm (double ``where``: the value is 0 at the origin and
  the gradient is 0 there instead of NaN).
* The one x/y convention for belt vectors: nodal arrays ``(n, 2, 2)`` (node, position/slope, x/y) are
  handled component-major as two scalar vectors of length ``2n`` (DOF ``2j`` = position, ``2j+1`` =
  slope of node ``j``). A trailing axis of length 2 defeats vectorisation on CPUs (measured 2x slower
  per step for a 64-variant batch), and the belt's operators act identically on x and y.
* Operators on those scalar vectors: ``AbstractRingOperator`` (``apply``, ``diagonal``, ``nbytes``,
  ``matrix``). ``DenseRingOperator`` stores the matrix. On a closed belt of equal elements every
  operator the step uses is *block-circulant* over the ``n`` elements (``p`` inputs and ``q`` outputs
  per element): ``y_j = sum_k x_{j+k} B_k`` (indices mod n). ``StencilRingOperator`` keeps the few
  non-zero blocks (O(n): the mass matrix, the contact-point maps); ``FFTRingOperator`` applies a
  full block column by FFT on the element index (O(n log n), exact to round-off: M^-1 and the
  contact coupling S M^-1 S^T, whose blocks never vanish on a ring). ``block_circulant`` picks one.
"""

from __future__ import annotations

import abc
import functools
import math
import operator
import typing

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

__all__ = [
    "safe_norm",
    "xy_components",
    "from_xy",
    "AbstractRingOperator",
    "DenseRingOperator",
    "StencilRingOperator",
    "FFTRingOperator",
    "block_circulant",
    "circulant_dense",
    "circulant_symbol",
    "symbol_inverse_2x2",
    "operator_bytes",
]


def safe_norm(x, y):
    """``sqrt(x^2 + y^2)``, 0 at the origin with a zero (not NaN) gradient there."""
    sq = x * x + y * y
    ok = sq > 0
    return jnp.where(ok, jnp.sqrt(jnp.where(ok, sq, 1.0)), 0.0)


def xy_components(x: Float[Array, "n 2 2"]) -> tuple[Float[Array, " 2*n"], Float[Array, " 2*n"]]:
    """Scalar nodal vectors (DOF 2j = position, 2j+1 = slope of node j) of the x and y components."""
    return x[..., 0].reshape(-1), x[..., 1].reshape(-1)


def from_xy(x: Float[Array, " 2*n"], y: Float[Array, " 2*n"]) -> Float[Array, "n 2 2"]:
    """Inverse of :func:`xy_components`."""
    return jnp.stack([x.reshape(-1, 2), y.reshape(-1, 2)], axis=-1)


class AbstractRingOperator(eqx.Module):
    """A constant linear map between scalar belt vectors (nodal DOFs or contact points).

    ``apply`` takes row vectors, ``x @ A``: the batch axis of vmap or of forward-mode tangents then
    leads, and XLA's CPU dot runs (B, N) @ (N, M) about 3x faster than (M, N) @ (N, B). The belt's
    operators (M, M^-1, S M^-1 S^T) are symmetric, so ``x @ A`` is also ``A x``.
    """

    @abc.abstractmethod
    def apply(self, x: Float[Array, "*b n"]) -> Float[Array, "*b m"]:
        """``x @ A``."""

    def apply_pair(self, x, y):
        """``(x @ A, y @ A)``: the x and y components of a belt vector (an operator may do both at once)."""
        return self.apply(x), self.apply(y)

    @abc.abstractmethod
    def diagonal(self) -> Float[Array, " n"]:
        """The diagonal (square operators)."""

    @property
    @abc.abstractmethod
    def shape(self) -> tuple[int, int]:
        """``(n, m)``: length of the input and of the output vectors."""

    @property
    @abc.abstractmethod
    def nbytes(self) -> int:
        """Bytes the operator stores (works on ``jax.eval_shape`` results too)."""

    @abc.abstractmethod
    def dense(self) -> Float[Array, "n m"]:
        """The matrix ``A`` (stored by DenseRingOperator, built on demand by the structured ones)."""


def _nbytes(a) -> int:
    return math.prod(a.shape) * np.dtype(a.dtype).itemsize


@typing.final
class DenseRingOperator(AbstractRingOperator):
    """The operator as a dense matrix: O(n^2) memory and work, fastest at today's sizes on a CPU."""

    matrix: Float[Array, "rows cols"]

    def apply(self, x):
        return x @ self.matrix

    def dense(self):
        return self.matrix

    def diagonal(self):
        return jnp.diagonal(self.matrix)

    @property
    def shape(self):
        return tuple(self.matrix.shape)

    @property
    def nbytes(self):
        return _nbytes(self.matrix)


def circulant_dense(blocks: Float[Array, "n r c"]) -> Float[Array, "n*r n*c"]:
    """Dense matrix of the block-circulant operator with block column ``blocks`` (``B_k``, k = 0..n-1):
    ``A[(j+k) p + a, j q + b] = B_k[a, b]``."""
    n, p, q = blocks.shape
    i = np.arange(n)
    a4 = blocks[(i[:, None] - i[None, :]) % n]  # (i, j, p, q): block of input cell i, output cell j
    return a4.transpose(0, 2, 1, 3).reshape(n * p, n * q)


@typing.final
class StencilRingOperator(AbstractRingOperator):
    """Block-circulant operator with few non-zero blocks: ``y_j = sum_k x_{j+o_k} B_k``, O(n K r c).

    One gather of the ``K`` shifted copies and one ``(n, K r) @ (K r, c)`` product: a loop of
    ``jnp.roll`` s would be ``K`` separate ops."""

    blocks: Float[Array, "K r c"]
    offsets: tuple[int, ...] = eqx.field(static=True)
    cells: int = eqx.field(static=True)
    # Output layout: the q outputs of a cell are ``groups`` groups; the result lists group 0 of every
    # cell, then group 1, ... (positions of all contact points, then all slopes).
    groups: int = eqx.field(static=True, default=1)

    def apply(self, x):
        n, (k, p, q), b = self.cells, self.blocks.shape, x.shape[:-1]
        xs = x.reshape(*b, n, p)
        if k <= 4:  # shifted copies by static slices fuse into one loop; a gather does not
            parts = [jnp.roll(xs, -o, axis=-2) @ self.blocks[i] for i, o in enumerate(self.offsets)]
            y = functools.reduce(operator.add, parts)
        else:
            idx = (np.arange(n)[:, None] + np.asarray(self.offsets)[None, :]) % n  # (n, K), static
            y = xs[..., idx, :].reshape(*b, n, k * p) @ self.blocks.reshape(k * p, q)
        g = self.groups
        return jnp.swapaxes(y.reshape(*b, n, g, q // g), -3, -2).reshape(*b, n * q)

    def diagonal(self):
        b0 = sum(self.blocks[i] for i, o in enumerate(self.offsets) if o % self.cells == 0)
        return jnp.tile(jnp.diagonal(b0), self.cells)

    @property
    def shape(self):
        _, p, q = self.blocks.shape
        return (self.cells * p, self.cells * q)

    @property
    def nbytes(self):
        return _nbytes(self.blocks)

    @property
    def matrix(self):  # the DenseRingOperator attribute, built on demand
        return self.dense()

    def dense(self):
        n, (_, p, q) = self.cells, self.blocks.shape
        full = jnp.zeros((n, p, q), self.blocks.dtype).at[np.asarray(self.offsets) % n].add(self.blocks)
        g = self.groups
        return circulant_dense(full).reshape(n * p, n, g, q // g).swapaxes(1, 2).reshape(n * p, n * q)


@typing.final
class FFTRingOperator(AbstractRingOperator):
    """Block-circulant operator applied by FFT on the cell index, O(n log n) and exact to round-off.

    ``y_j = sum_k x_{j+k} B_k`` is a cyclic correlation: ``Y_f = X_f S_f`` with the symbol
    ``S_f = sum_k B_k exp(2 pi i k f / n) = conj(fft(B))_f``, stored for all ``n`` frequencies as
    ``(n, p, q)``. One vector: a real FFT (half the symbol). Two vectors (``apply_pair``, the x and y
    components): one complex FFT of ``x + i y``, since the operator is real; XLA's FFT call costs a
    few microseconds whatever its size at these n, so pairing halves the calls."""

    # Real and imaginary parts of the complex (n, p, q) symbol: real leaves, because diffrax (which
    # carries the operators as arguments) warns about complex ones.
    symbol_re: Float[Array, "n r c"]
    symbol_im: Float[Array, "n r c"]
    cells: int = eqx.field(static=True)

    @staticmethod
    def from_symbol(symbol: Array) -> FFTRingOperator:
        return FFTRingOperator(jnp.real(symbol), jnp.imag(symbol), symbol.shape[0])

    @staticmethod
    def from_blocks(blocks: Float[Array, "n r c"]) -> FFTRingOperator:
        return FFTRingOperator.from_symbol(jnp.conj(jnp.fft.fft(blocks, axis=0)))

    @property
    def symbol(self) -> Array:
        return jax.lax.complex(self.symbol_re, self.symbol_im)

    def _times_symbol(self, xf, sym):
        # p, q <= 2: a broadcast multiply-add beats a batched 2x2 dot
        return sum(xf[..., :, a, None] * sym[:, a, :] for a in range(sym.shape[1]))

    def apply(self, x):
        n, (_, p, q) = self.cells, self.symbol_re.shape
        xf = jnp.fft.rfft(x.reshape(*x.shape[:-1], n, p), axis=-2)  # (..., n//2 + 1, p)
        yf = self._times_symbol(xf, self.symbol[: n // 2 + 1])
        return jnp.fft.irfft(yf, n=n, axis=-2).reshape(*x.shape[:-1], n * q)

    def apply_pair(self, x, y):
        n, (_, p, q) = self.cells, self.symbol_re.shape
        z = jax.lax.complex(x, y).reshape(*x.shape[:-1], n, p)
        w = jnp.fft.ifft(self._times_symbol(jnp.fft.fft(z, axis=-2), self.symbol), axis=-2)
        w = w.reshape(*x.shape[:-1], n * q)
        return jnp.real(w), jnp.imag(w)

    def blocks(self) -> Float[Array, "n r c"]:
        return jnp.real(jnp.fft.ifft(jnp.conj(self.symbol), axis=0))

    def diagonal(self):
        return jnp.tile(jnp.diagonal(self.blocks()[0]), self.cells)

    @property
    def shape(self):
        _, p, q = self.symbol_re.shape
        return (self.cells * p, self.cells * q)

    @property
    def nbytes(self):
        return _nbytes(self.symbol_re) + _nbytes(self.symbol_im)

    @property
    def matrix(self):  # the DenseRingOperator attribute, built on demand
        return self.dense()

    def dense(self):
        return circulant_dense(self.blocks())


def circulant_symbol(blocks: Float[Array, "K r c"], offsets, n: int) -> Array:
    """``conj(fft)`` of the block column with ``blocks`` at ``offsets`` (zero elsewhere): the per-frequency
    ``(p, q)`` matrices whose products compose operators (``x @ A @ B`` has symbol ``A^_f @ B^_f``)."""
    f = np.arange(n)
    w = np.exp(2j * np.pi * np.outer(f, np.asarray(offsets)) / n)  # (F, K), static
    cdtype = np.result_type(blocks.dtype, np.complex64)  # complex64 for float32 blocks, else complex128
    return jnp.einsum("fk,kpq->fpq", jnp.asarray(w, dtype=cdtype), blocks.astype(cdtype))


def symbol_inverse_2x2(sym: Array) -> Array:
    """Per-frequency inverse of a ``(F, 2, 2)`` symbol in closed form (no batched LAPACK call)."""
    a, b, c, d = sym[:, 0, 0], sym[:, 0, 1], sym[:, 1, 0], sym[:, 1, 1]
    det = a * d - b * c
    return jnp.stack([jnp.stack([d, -b], -1), jnp.stack([-c, a], -1)], -2) / det[:, None, None]


def block_circulant(blocks: Float[Array, "n r c"], kind: str) -> AbstractRingOperator:
    """The block-circulant operator with a full block column ``blocks`` as ``kind``, "dense" or "fft"
    (operators with few non-zero blocks are built as ``StencilRingOperator`` with static offsets)."""
    if kind == "dense":
        return DenseRingOperator(circulant_dense(blocks))
    if kind == "fft":
        return FFTRingOperator.from_blocks(blocks)
    raise ValueError(f"operator kind {kind!r}: expected 'dense' or 'fft'")


def operator_bytes(tree) -> int:
    """Bytes stored by every ``AbstractRingOperator`` in a pytree (e.g. ``DriveOperators``).

    Accepts the output of ``jax.eval_shape`` (nothing is computed), so a memory check can call it
    before building anything."""
    is_op = lambda x: isinstance(x, AbstractRingOperator)  # noqa: E731
    return sum(op.nbytes for op in jax.tree.leaves(tree, is_leaf=is_op) if is_op(op))
