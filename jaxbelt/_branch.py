"""``lax.cond`` that stays a branch under ``vmap``.

Under ``vmap`` a ``lax.cond`` with a batched predicate becomes a ``select``: every point computes both branches.
Where one branch is rare and costly (the spans tier's capstan projection: gross slip) a batched run then pays it
on every step. ``batch_cond`` asks the whole batch instead: the cheap branch alone where no point needs the
other, both (and a select) only where some point does (``jax.custom_batching.custom_vmap``).

Limits, which is why callers opt in: no reverse-mode differentiation (``custom_vmap`` has no transpose), and the
branch functions must not close over traced values (pass them in ``operand``; ``custom_vmap`` refuses batched
closures).
"""

from __future__ import annotations

from typing import Callable

import jax
import jax.numpy as jnp
from jax.custom_batching import custom_vmap

__all__ = ["batch_cond"]


def batch_cond(pred, true_fn: Callable, false_fn: Callable, operand):
    """``lax.cond(pred, true_fn, false_fn, operand)``; under ``vmap`` one branch for the whole batch where every
    point's ``pred`` agrees (module docstring)."""

    @custom_vmap
    def branch(p, x):
        return jax.lax.cond(p, true_fn, false_fn, x)

    @branch.def_vmap
    def _rule(axis_size, in_batched, p, x):
        p_batched, x_batched = in_batched
        axes = jax.tree.map(lambda b: 0 if b else None, x_batched)
        every = lambda fn: jax.vmap(fn, in_axes=(axes,), axis_size=axis_size)  # noqa: E731
        if not p_batched:  # one predicate for all: an ordinary branch
            out = jax.lax.cond(p, every(true_fn), every(false_fn), x)
            return out, jax.tree.map(lambda _: True, out)
        mixed = jax.vmap(lambda q, y: jax.lax.cond(q, true_fn, false_fn, y), in_axes=(0, axes), axis_size=axis_size)
        out = jax.lax.cond(
            jnp.all(p),
            lambda pp, y: every(true_fn)(y),
            lambda pp, y: jax.lax.cond(jnp.any(pp), mixed, lambda _, z: every(false_fn)(z), pp, y),
            p,
            x,
        )
        return out, jax.tree.map(lambda _: True, out)

    return branch(pred, operand)
