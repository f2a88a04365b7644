"""Small linear-algebra conventions shared by the belt, contact and dynamics rooms.

* ``safe_norm``: the one guarded Euclidean norm (double ``where``: the value is 0 at the origin and
  the gradient is 0 there instead of NaN).
* The one x/y convention for belt vectors: nodal arrays ``(n, 2, 2)`` (node, position/slope, x/y) are
  handled component-major as two scalar vectors of length ``2n`` (DOF ``2j`` = position, ``2j+1`` =
  slope of node ``j``). A trailing axis of length 2 defeats vectorisation on CPUs (measured 2x slower
  per step for a 64-variant batch), and the belt's operators act identically on x and y.
* Operators on those scalar vectors: ``AbstractRingOperator`` (``apply``, ``diagonal``, ``nbytes``).
  ``DenseRingOperator`` stores the matrix; structured O(n) operators (block-circulant, banded) can
  replace it later without touching the step.
"""

from __future__ import annotations

import abc
import math
import typing

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

__all__ = ["safe_norm", "xy_components", "from_xy", "AbstractRingOperator", "DenseRingOperator", "operator_bytes"]


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


def _nbytes(a) -> int:
    return math.prod(a.shape) * np.dtype(a.dtype).itemsize


@typing.final
class DenseRingOperator(AbstractRingOperator):
    """The operator as a dense matrix: O(n^2) memory and work, fastest at today's sizes on a CPU."""

    matrix: Float[Array, "rows cols"]

    def apply(self, x):
        return x @ self.matrix

    def diagonal(self):
        return jnp.diagonal(self.matrix)

    @property
    def shape(self):
        return tuple(self.matrix.shape)

    @property
    def nbytes(self):
        return _nbytes(self.matrix)


def operator_bytes(tree) -> int:
    """Bytes stored by every ``AbstractRingOperator`` in a pytree (e.g. ``DriveOperators``).

    Accepts the output of ``jax.eval_shape`` (nothing is computed), so a memory check can call it
    before building anything."""
    is_op = lambda x: isinstance(x, AbstractRingOperator)  # noqa: E731
    return sum(op.nbytes for op in jax.tree.leaves(tree, is_leaf=is_op) if is_op(op))
