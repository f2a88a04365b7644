"""Engine-order excitation: laws over a pulley's own rotation angle (the crank angle of a driver).

A crankshaft's speed is periodic in crank *angle*, not in time: ``omega(phi) = omega_mean(t) +
sum_k A_k cos(k phi + p_k)``, ``phi`` the crank angle, so an order ``k`` stays at ``k`` times the
crank frequency through a run-up. The crank angle is the pulley's rotation ``theta`` (zero at
``t = 0``: pulleys stand still while the drive settles) counted in its running sense; the step
integrates it (``theta+ = theta + h omega+``), so the law reads the angle predicted for the end of
the step, ``theta + h omega`` (error ``O(h^2)`` per step, no drift).

Per pulley the harmonics add to the law the pulley follows: the prescribed speed of a speed-driven
pulley, else the applied torque. An amplitude is either absolute (rad/s, N m) or an angular
oscillation ``X`` [deg] of the crank, whose speed amplitude is ``k omega_mean X pi/180`` (it grows
with the mean speed through a run-up). A law may also be a table over the crank angle (a measured
speed or torque over one engine cycle), repeated with its period.
"""

from __future__ import annotations

import typing

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .timelaw import TimeLaw, evaluate

__all__ = ["Excitation", "crank_angle", "law_argument", "harmonics", "pulley_laws"]


@typing.final
class Excitation(eqx.Module):
    """Per-pulley engine orders (leading axis pulley, ``m`` orders padded with zero amplitudes)."""

    sense: Float[Array, " p"]  # running sense, +1 counter-clockwise: crank angle = sense * theta
    over_angle: Float[Array, " p"]  # 1.0: the pulley's laws are tables over its crank angle [rad]
    angle_start: Float[Array, " p"]  # first angle of such a table [rad]
    period: Float[Array, " p"]  # its period [rad] (1.0 where unused)
    order: Float[Array, "p m"]  # engine order k > 0 (any real)
    amplitude: Float[Array, "p m"]  # as configured: rad/s or N m (absolute) or deg (angular oscillation)
    phase: Float[Array, "p m"]  # [rad]
    absolute: Float[Array, "p m"]  # 1.0: the amplitude is rad/s or N m in the running sense
    relative: Float[Array, "p m"]  # k pi/180 for an angular oscillation [deg]: amplitude x this x the law's value
    any_angle: bool = eqx.field(static=True, default=False)  # static: skip the angle wrap when no table uses it


def crank_angle(exc: Excitation, theta) -> Float[Array, " p"]:
    """Each pulley's rotation in its running sense [rad]."""
    return exc.sense * theta


def law_argument(exc: Excitation, t, angle) -> Float[Array, " p"]:
    """What each pulley's law is read at: the time, or its crank angle wrapped into the table's period."""
    t = jnp.broadcast_to(t, angle.shape)
    if not exc.any_angle:
        return t
    wrapped = exc.angle_start + jnp.mod(angle - exc.angle_start, exc.period)
    return jnp.where(exc.over_angle > 0.5, wrapped, t)


def harmonics(exc: Excitation, base, angle) -> Float[Array, " p"]:
    """The orders' sum per pulley, counter-clockwise positive, on top of the law's value ``base``."""
    if exc.order.shape[-1] == 0:
        return jnp.zeros_like(base)
    wave = jnp.cos(exc.order * angle[:, None] + exc.phase)
    scale = exc.absolute * exc.sense[:, None] + exc.relative * base[:, None]
    return jnp.sum(exc.amplitude * scale * wave, axis=-1)


def pulley_laws(speed: TimeLaw, torque: TimeLaw, exc: Excitation, kinematic, theta, omega, t1, h):
    """Prescribed speeds and applied torques at the end of a step ending at ``t1`` (``kinematic``:
    which pulleys follow their speed law; the orders add to that law, else to the torque)."""
    angle = crank_angle(exc, theta + h * omega)  # predicted end-of-step angle
    x = law_argument(exc, t1, angle)
    prescribed = jax.vmap(evaluate)(speed, x)
    applied = jax.vmap(evaluate)(torque, x)
    extra = harmonics(exc, jnp.where(kinematic, prescribed, applied), angle)
    return prescribed + jnp.where(kinematic, extra, 0.0), applied + jnp.where(kinematic, 0.0, extra)
