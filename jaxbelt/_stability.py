"""Stability limit of the explicit part of the step (elastic forces and belt damping).

Symplectic Euler on a mode ``x'' + c x' + w^2 x = 0`` is stable while ``h^2 w^2 / 4 + h c / 2 < 1``.
We bound ``w^2`` and ``c`` by the largest eigenvalues of ``M^-1 K`` and ``M^-1 C`` of the belt
linearised about its installed shape (power iteration on Jacobian-vector products), and solve
for ``h``. Contact, friction, mass damping and tensioner springs are implicit and do not enter.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from ._belt import belt_operators, internal_forces
from ._model import DriveModel, DriveParams

__all__ = ["stable_time_step", "largest_rates"]


def _power(apply, x0, iterations):
    def body(i, x):
        y = apply(x)
        return y / jnp.maximum(jnp.linalg.norm(y), 1e-300)

    x = jax.lax.fori_loop(0, iterations, body, x0)
    return jnp.vdot(x, apply(x)) / jnp.vdot(x, x)


from functools import partial


@partial(jax.jit, static_argnums=2)
def _rates(q0, belt, n_axial_damp_bend, key):
    ops = belt_operators(q0.shape[0], belt, *n_axial_damp_bend)
    z = jnp.zeros_like(q0)

    def force(q, v):
        return internal_forces(q, v, belt, ops)[0]

    def minv(f):
        return (ops.mass_inv @ f.reshape(-1, 2)).reshape(f.shape)

    stiff = lambda x: -minv(jax.jvp(lambda qq: force(qq, z), (q0,), (x,))[1])
    damp = lambda x: -minv(jax.jvp(lambda vv: force(q0, vv), (z,), (x,))[1])
    x0 = jax.random.normal(key, q0.shape, dtype=q0.dtype)
    # The M-weighted Rayleigh quotient would be exact; the plain one of the converged vector is too.
    return _power(stiff, x0, 400), _power(damp, x0, 400)


def largest_rates(model: DriveModel, params: DriveParams, q0):
    """(omega_max^2, c_max): highest squared frequency and damping rate of the free belt."""
    quad = (model.axial_quadrature, model.bending_quadrature, model.damping_quadrature)
    w2, c = _rates(jnp.asarray(q0), params.belt, quad, jax.random.PRNGKey(0))
    return float(w2), float(c)


def stable_time_step(model: DriveModel, params: DriveParams, q0) -> float:
    w2, c = largest_rates(model, params, q0)
    w2, c = max(w2, 0.0), max(c, 0.0)
    if w2 == 0.0:
        return 2.0 / c if c > 0 else float("inf")
    return float((-c / 2 + np.sqrt(c * c / 4 + w2)) / (w2 / 2))
