"""Laws of time for prescribed speeds and applied torques: padded tables, vmappable.

A law is a table of knots ``(times, values)`` of fixed length (padded by repeating the last knot)
plus a per-knot-interval blend: linear, or the cubic smooth step ``3s^2 - 2s^3`` (the one Exudyn
calls SmoothStep, C1 with zero slope at both knots). Constant, ramp, step and tabulated laws are
all tables, so every pulley's law has the same array shape and one ``vmap`` evaluates them all.
"""

from __future__ import annotations

import typing

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

__all__ = ["TimeLaw", "constant", "ramp", "smooth_step", "table", "stack_laws", "evaluate"]


@typing.final
class TimeLaw(eqx.Module):
    times: Float[Array, "*laws k"]
    values: Float[Array, "*laws k"]
    smooth: Float[Array, "*laws k"]  # 1.0: the interval ending at this knot blends with the smooth step


def table(times, values, smooth: bool = False) -> TimeLaw:
    t = np.asarray(times, dtype=float).ravel()
    v = np.asarray(values, dtype=float).ravel()
    if t.shape != v.shape or t.size == 0:
        raise ValueError(f"time law: times and values must be equal-length, non-empty (got {t.size} and {v.size})")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
        raise ValueError("time law: times and values must be finite numbers")
    if np.any(np.diff(t) <= 0):
        raise ValueError(f"time law: times must increase strictly (got {t.tolist()})")
    # host arrays put on the device: no eager device operation (each is compiled once per process)
    return TimeLaw(jax.device_put(t), jax.device_put(v), jax.device_put(np.full(t.shape, 1.0 if smooth else 0.0)))


def constant(value: float) -> TimeLaw:
    return table([0.0], [value])


def ramp(t0: float, t1: float, v0: float, v1: float) -> TimeLaw:
    """``v0`` until ``t0``, linear to ``v1`` at ``t1``, then constant."""
    return table([t0, t1], [v0, v1])


def smooth_step(t0: float, t1: float, v0: float, v1: float) -> TimeLaw:
    """``v0`` until ``t0``, cubic smooth step to ``v1`` at ``t1``, then constant."""
    return table([t0, t1], [v0, v1], smooth=True)


def stack_laws(laws: list[TimeLaw]) -> TimeLaw:
    """Pad every law to the longest and stack them (leading axis = pulley)."""
    k = max(int(l.times.shape[0]) for l in laws)

    def pad(x):
        x = np.asarray(x)
        return np.concatenate([x, np.repeat(x[-1:], k - x.size)])

    # Padded knots sit 1 s apart after the last one so times stay strictly increasing.
    def pad_t(t):
        t = np.asarray(t)
        return np.concatenate([t, t[-1] + np.arange(1, k - t.size + 1)])

    return TimeLaw(
        jax.device_put(np.stack([pad_t(l.times) for l in laws])),
        jax.device_put(np.stack([pad(l.values) for l in laws])),
        jax.device_put(np.stack([pad(l.smooth) for l in laws])),
    )


def evaluate(law: TimeLaw, t) -> Float[Array, ""]:
    """Value of one law at time ``t`` (held constant outside the knots)."""
    tk, vk = law.times, law.values
    # compare_all: a few knots, no binary-search loop inside every time step
    i = jnp.clip(jnp.searchsorted(tk, t, side="right", method="compare_all"), 1, tk.shape[0] - 1)
    t0, t1 = tk[i - 1], tk[i]
    s = jnp.clip((t - t0) / (t1 - t0), 0.0, 1.0)
    s = jnp.where(law.smooth[i] > 0.5, s * s * (3.0 - 2.0 * s), s)
    inside = vk[i - 1] + (vk[i] - vk[i - 1]) * s
    return jnp.where(t <= tk[0], vk[0], jnp.where(t >= tk[-1], vk[-1], inside))
