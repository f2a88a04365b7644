"""``lax.cond`` that stays a branch under ``vmap``.

Under ``vmap`` a ``lax.cond`` with a batched predicate becomes a ``select``: every point computes both branches.
Where one branch is rare or cheap (the spans tier's gross-slip projection; the Newton contact solve's iterations
after convergence, skipped by a cond) a batched run then pays the other on every step. ``batch_cond`` asks the
whole batch instead: the cheap branch alone where every point takes it, both (and a select) otherwise
(``jax.custom_batching.custom_vmap``; one copy of the costly branch in the program). The traced values the
branches close over become explicit arguments (traced once with ``jax.make_jaxpr``): ``custom_vmap`` refuses
batched closures.

Limit, which is why callers opt in (a sweep's runs): no reverse-mode differentiation (``custom_vmap`` has no
transpose). Forward mode and nested ``vmap`` work. The compiled program differs, so results agree with the
plain cond's to round-off, not bit for bit.
"""

from __future__ import annotations

from typing import Callable

import jax
import jax.numpy as jnp
from jax.custom_batching import custom_vmap

__all__ = ["batch_cond"]


def _hoisted(fn: Callable, operand):
    """``(run, consts)``: ``run(operand, consts) == fn(operand)`` with the values ``fn`` closes over as ``consts``."""
    closed, shape = jax.make_jaxpr(fn, return_shape=True)(operand)
    tree = jax.tree.structure(shape)

    def run(x, consts):
        return jax.tree.unflatten(tree, jax.core.eval_jaxpr(closed.jaxpr, consts, *jax.tree.leaves(x)))

    return run, list(closed.consts)


def batch_cond(pred, true_fn: Callable, false_fn: Callable, operand, false_alone: bool = False):
    """``lax.cond(pred, true_fn, false_fn, operand)``; under ``vmap`` ``true_fn`` alone (the cheap branch: nothing
    to do) where every point's ``pred`` holds, else both and a select per point (module docstring).
    ``false_alone``: also ``false_fn`` alone where no point's ``pred`` holds (a second copy of it in the program:
    for a small costly branch that whole batches often take)."""
    run_true, c_true = _hoisted(true_fn, operand)
    run_false, c_false = _hoisted(false_fn, operand)

    def cond(p, x, ct, cf):
        return jax.lax.cond(p, lambda y: run_true(y, ct), lambda y: run_false(y, cf), x)

    @custom_vmap
    def branch(p, x, ct, cf):
        return cond(p, x, ct, cf)

    @branch.def_vmap
    def _rule(axis_size, in_batched, p, x, ct, cf):
        p_batched, *rest = in_batched
        axes = tuple(jax.tree.map(lambda b: 0 if b else None, r) for r in rest)
        mixed = jax.vmap(cond, in_axes=(0 if p_batched else None, *axes), axis_size=axis_size)
        every_true = jax.vmap(lambda y, c: run_true(y, c), in_axes=(axes[0], axes[1]), axis_size=axis_size)
        # one copy of the costly branch in the program (compile time): where not every point takes the cheap one,
        # all take both and a select, as a plain cond under vmap does
        rest = mixed
        if false_alone:
            every_false = jax.vmap(lambda y, c: run_false(y, c), in_axes=(axes[0], axes[2]), axis_size=axis_size)

            def rest(q, y, a, b):  # noqa: F811 - no point takes the cheap branch: the costly one alone
                return jax.lax.cond(jnp.any(q), mixed, lambda q_, y_, a_, b_: every_false(y_, b_), q, y, a, b)

        out = jax.lax.cond(jnp.all(p), lambda q, y, a, b: every_true(y, a), rest, p, x, ct, cf)
        return out, jax.tree.map(lambda _: True, out)

    return branch(pred, operand, c_true, c_false)
