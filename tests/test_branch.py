"""``_branch.batch_cond``: ``lax.cond`` under vmap without computing the rare branch for every point (the spans
tier's capstan projection in a sweep): the same values as ``lax.cond`` for batches where every, no or some point
takes the true branch, for an unbatched predicate, and the same forward-mode derivatives."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxbelt._branch import batch_cond

jax.config.update("jax_enable_x64", True)


def _true(o):
    x, a = o
    return x * jnp.sin(a)


def _false(o):
    x, a = o
    return 2.0 * x + jnp.cos(a * x)


def _ours(x, a, false_alone=False):
    return batch_cond(x > 0.0, _true, _false, (x, a), false_alone=false_alone)


def _lax(x, a):
    return jax.lax.cond(x > 0.0, _true, _false, (x, a))


@pytest.mark.parametrize("false_alone", [False, True])
@pytest.mark.parametrize("xs", [[1.0, 2.0, 3.0], [-1.0, -2.0, -3.0], [1.0, -2.0, 3.0]], ids=["all", "none", "mixed"])
def test_batch_cond_equals_lax_cond_under_vmap(xs, false_alone):
    x, a = jnp.asarray(xs), jnp.asarray([0.1, 0.2, 0.3])
    ours = lambda x, a: _ours(x, a, false_alone)  # noqa: E731
    np.testing.assert_array_equal(jax.jit(jax.vmap(ours))(x, a), jax.vmap(_lax)(x, a))
    np.testing.assert_array_equal(jax.vmap(ours, in_axes=(0, None))(x, 0.3), jax.vmap(_lax, in_axes=(0, None))(x, 0.3))
    # an unbatched predicate with batched operands: an ordinary branch for the whole batch
    np.testing.assert_array_equal(
        jax.vmap(ours, in_axes=(None, 0))(xs[0], a), jax.vmap(_lax, in_axes=(None, 0))(xs[0], a)
    )
    np.testing.assert_array_equal(jax.vmap(jax.vmap(ours))(x[None], a[None]), jax.vmap(_lax)(x, a)[None])


def test_batch_cond_forward_mode_equals_lax_cond():
    x = jnp.asarray([1.0, -2.0, 3.0])
    ours = jax.jacfwd(lambda a: jax.vmap(_ours, in_axes=(0, None))(x, a))(0.3)
    ref = jax.jacfwd(lambda a: jax.vmap(_lax, in_axes=(0, None))(x, a))(0.3)
    np.testing.assert_allclose(ours, ref, rtol=1e-15)
    # d/da (2 x + cos(a x)) = -x sin(a x) at x = -1, a = 0.3
    assert jax.jvp(lambda a: _ours(-1.0, a), (0.3,), (1.0,))[1] == pytest.approx(np.sin(-0.3), rel=1e-15)


def test_batch_cond_branches_may_close_over_batched_values():
    """The branches close over per-point values (a Newton solve's data): hoisted into arguments, same values."""

    def ours(x, a):
        s, c = jnp.sin(a), jnp.cos(a)
        return batch_cond(x > 0.0, lambda y: y * s, lambda y: 2.0 * y + c * y, x)

    def ref(x, a):
        s, c = jnp.sin(a), jnp.cos(a)
        return jax.lax.cond(x > 0.0, lambda y: y * s, lambda y: 2.0 * y + c * y, x)

    for xs in ([1.0, 2.0], [-1.0, -2.0], [1.0, -2.0]):
        x, a = jnp.asarray(xs), jnp.asarray([0.2, 0.7])
        np.testing.assert_array_equal(jax.jit(jax.vmap(ours))(x, a), jax.vmap(ref)(x, a))
