"""Structured (block-circulant) ring operators against the dense matrices they replace.

On a closed belt of equal elements M, M^-1, the contact-point maps and S M^-1 S^T are block-circulant;
the structured forms (stencils, FFT on the element index) must equal the dense ones to round-off, in
value, in ``apply_pair`` and in derivatives with respect to the belt parameters."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import build_quietly

import jaxbelt as jb
from jaxbelt._linalg import FFTRingOperator, StencilRingOperator, circulant_dense
from jaxbelt.belt.ring import STRUCTURED_FROM, belt_operators, ring_operator_kind
from jaxbelt.contact.kinematics import contact_operators

N = 12  # structure, not size, is under test
FIELDS = ("positions", "positions_and_slopes", "impulse_response", "coupling")


@pytest.fixture(scope="module")
def belt():
    return build_quietly(jb.benchmark_a(n_elements=N)).params.belt


def _operators(belt, kind, m):
    ops = belt_operators(N, belt, kind=kind)
    return ops, contact_operators(N, m, ops)


@pytest.mark.parametrize("m", [1, 2, 3])
def test_structured_operators_equal_dense_to_round_off(belt, m):
    (bd, cd), (bs, cs) = _operators(belt, "dense", m), _operators(belt, "structured", m)
    assert isinstance(bs.mass, StencilRingOperator) and isinstance(cs.coupling, FFTRingOperator)
    rng = np.random.default_rng(m)
    pairs = [(bd.mass, bs.mass), (bd.mass_inv, bs.mass_inv)] + [(getattr(cd, f), getattr(cs, f)) for f in FIELDS]
    for dense, structured in pairs:
        A = np.asarray(dense.matrix)
        assert structured.shape == A.shape
        np.testing.assert_allclose(np.asarray(structured.matrix), A, rtol=0, atol=1e-14 * np.abs(A).max())
        x, y = (jnp.asarray(rng.normal(size=(3, A.shape[0]))) for _ in range(2))
        ref = np.abs(x @ A).max()
        for got, want in zip(structured.apply_pair(x, y), (x @ A, y @ A)):
            np.testing.assert_allclose(np.asarray(got), np.asarray(want), rtol=0, atol=1e-14 * ref)
        np.testing.assert_allclose(np.asarray(structured.apply(x)), np.asarray(x @ A), rtol=0, atol=1e-14 * ref)
    np.testing.assert_allclose(np.asarray(cs.coupling_diag), np.asarray(cd.coupling_diag), rtol=1e-14)


def test_mass_inverse_inverts_the_mass_matrix(belt):
    bs = belt_operators(N, belt, kind="structured")
    x = jnp.asarray(np.random.default_rng(0).normal(size=2 * N))
    np.testing.assert_allclose(np.asarray(bs.mass_inv.apply(bs.mass.apply(x))), np.asarray(x), rtol=0, atol=1e-12)


def test_circulant_dense_layout():
    """``y_j = sum_k x_{j+k} B_k``: a single non-zero block at offset 1 reads the next cell."""
    blocks = jnp.zeros((4, 1, 1)).at[1, 0, 0].set(1.0)
    x = jnp.arange(4.0)
    np.testing.assert_array_equal(np.asarray(x @ circulant_dense(blocks)), [1.0, 2.0, 3.0, 0.0])
    np.testing.assert_array_equal(np.asarray(FFTRingOperator.from_blocks(blocks).apply(x)).round(12), [1, 2, 3, 0])


def test_gradients_through_structured_operators_match_dense(belt):
    """d/d(rhoA, L0) of a scalar built from every contact operator: forward and reverse, both forms."""
    rng = np.random.default_rng(1)
    x = jnp.asarray(rng.normal(size=2 * N))

    def f(theta, kind):
        b = dataclasses.replace(belt, mass_per_length=theta[0], stress_free_length=theta[1])
        ops, cops = _operators(b, kind, 2)
        u = cops.impulse_response.apply(cops.coupling.apply(cops.positions.apply(ops.mass_inv.apply(x))))
        return jnp.sum(u * u) + jnp.sum(cops.coupling_diag)

    theta = jnp.stack([belt.mass_per_length, belt.stress_free_length])
    # jitted (eagerly, every primitive of the operator builds compiles apart), the operator kind static
    grad, jacfwd = (jax.jit(d(f), static_argnums=1) for d in (jax.grad, jax.jacfwd))
    g_dense = grad(theta, "dense")
    g_rev = grad(theta, "structured")
    g_fwd = jacfwd(theta, "structured")
    np.testing.assert_allclose(np.asarray(g_rev), np.asarray(g_dense), rtol=1e-12)
    np.testing.assert_allclose(np.asarray(g_fwd), np.asarray(g_rev), rtol=1e-12)


def test_operator_kind_choice_and_bad_value():
    assert ring_operator_kind(STRUCTURED_FROM - 1) == "dense"
    assert ring_operator_kind(STRUCTURED_FROM) == "structured"
    assert ring_operator_kind(10, "structured") == "structured"
    with pytest.raises(ValueError, match=r"'fast'.*'auto', 'dense', 'structured'"):
        ring_operator_kind(10, "fast")
