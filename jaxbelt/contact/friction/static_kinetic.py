"""Static-kinetic friction (``contact.friction_law = "static-kinetic"``): distinct static and kinetic
coefficients, optionally joined by a Stribeck curve. Keys: ``contact.mu_kinetic`` (required),
``contact.stribeck_velocity`` (optional; absent: a sharp drop from mu_s to mu_k)."""

from __future__ import annotations

import typing
from collections.abc import Mapping

import equinox as eqx
import jax
import jax.numpy as jnp

from .base import AbstractFrictionLaw, LawKey, is_finite_number

__all__ = ["StaticKinetic"]


def _kinetic(value, mu) -> str | None:
    if is_finite_number(value) and 0 < value <= mu:
        return None
    return f"must be a finite number > 0 and <= contact.mu = {mu} (the static coefficient)"


@typing.final
class StaticKinetic(AbstractFrictionLaw):
    """Coulomb with distinct static and kinetic coefficients (``mu_s = contact.mu``, ``mu_k``).

    Sticking holds while ``|lam_t| <= mu_s lam_n``; a sliding point carries ``mu(v) lam_n`` against
    its slip velocity ``v``: ``mu(v) = mu_k`` (sharp drop) or, with a Stribeck velocity ``v_s``,
    ``mu_k + (mu_s - mu_k) exp(-(v/v_s)^2)`` at the slip velocity after the step (implicit).
    ``mu_k`` enters per point as ``mu * (mu_k / mu_s)``, so wedge factor and settle phase carry over.
    """

    stribeck: bool = eqx.field(static=True, default=False)
    iterations: int = eqx.field(static=True, default=8)

    keys = (
        LawKey("mu_kinetic", "-: kinetic (sliding) coefficient, 0 < mu_kinetic <= mu", required=True, check=_kinetic),
        LawKey("stribeck_velocity", "m/s: Stribeck velocity (absent: a sharp drop to mu_kinetic)"),
    )

    @classmethod
    def from_values(cls, values: Mapping[str, float]) -> StaticKinetic:
        return cls(stribeck="stribeck_velocity" in values)

    def coefficients(self, params) -> dict:
        out = {"kinetic_ratio": params.friction["mu_kinetic"] / params.mu}
        if self.stribeck:
            out["stribeck_velocity"] = params.friction["stribeck_velocity"]
        return out

    def slip_bound(self, lam_n, params):
        return params["mu"] * params["kinetic_ratio"] * lam_n

    def local_update(self, lam_t, u_t, d_t, lam_n, params):
        b_s = self.bound(lam_n, params)
        b_k = b_s * params["kinetic_ratio"]
        trial = lam_t - u_t / d_t  # the impulse that stops the point within the step
        size = jnp.abs(trial)
        slide = self._stribeck(size, d_t, b_s, b_k, params["stribeck_velocity"]) if self.stribeck else b_k
        return jnp.where(size <= b_s, trial, jnp.sign(trial) * slide)

    def _stribeck(self, size, d_t, b_s, b_k, v_s):
        """Solve g(m) = m - b(d_t (size - m)) = 0, b(v) = b_k + (b_s - b_k) exp(-(v/v_s)^2), for m.

        The slip velocity after the step is ``d_t (size - m)``; g(b_k) <= 0 <= g(b_s), so Newton steps
        safeguarded by bisection of [b_k, b_s] converge (as in ``Regularised``)."""

        def body(i, carry):
            m, lo, hi = carry
            z = d_t * (size - m) / v_s
            e = (b_s - b_k) * jnp.exp(-z * z)
            f = m - b_k - e
            df = 1.0 - e * 2.0 * z * d_t / v_s  # d/dm of -e, with dz/dm = -d_t/v_s
            lo = jnp.where(f <= 0, m, lo)
            hi = jnp.where(f >= 0, m, hi)
            newton = m - f / df
            inside = (newton >= lo) & (newton <= hi)
            return jnp.where(inside, newton, 0.5 * (lo + hi)), lo, hi

        m, _, _ = jax.lax.fori_loop(0, self.iterations, body, (b_k, b_k, b_s))
        return m
