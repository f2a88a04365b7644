"""A carrier alone, without a belt: a test rig for tensioner arms and sliders.

The same implicit spring/damper step and the same constraint solve as inside a drive step
(``AbstractCarrier.free_velocity``, ``AbstractConstrainedCarrier.constraint_impulse``), with a
constant applied generalised force ``load`` (torque on an arm, force on a slider) standing in for
the belt. Closed forms (the free arm with dry friction, an arm held inside its friction band, a
stop's reaction) are checked against it.
"""

from __future__ import annotations

import typing

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .carriers.constraints import AbstractConstrainedCarrier, CarrierVelocity

__all__ = ["RigHistory", "simulate_carrier"]


@typing.final
class RigHistory(eqx.Module):
    t: Float[Array, " s"]  # end of each step [s]
    psi: Float[Array, " s"]
    psi_dot: Float[Array, " s"]
    impulse: Float[Array, " s"]  # constraint impulse of each step [N m s] (/ h: its torque)
    dissipated: Float[Array, ""]  # minus the work of the constraint impulses [J]


def simulate_carrier(carrier, pp, k: int, psi0, psi_dot0, h, steps: int, load=0.0):
    """``steps`` steps of ``h`` of carrier ``k`` (its numbers ``pp.carrier[k]``) from ``(psi0, psi_dot0)``,
    no gravity. Traceable in every number (gradients of friction, stops, springs)."""
    h = jnp.asarray(h, dtype=jnp.result_type(float))
    inv = carrier.inverse_mass(pp, k, h)
    gravity = jnp.zeros(2, h.dtype)
    constrained = isinstance(carrier, AbstractConstrainedCarrier)

    def step(carry, _):
        psi, psi_dot, dissipated = carry
        free = carrier.free_velocity(pp, k, psi, psi_dot, h, gravity) + h * load * inv
        if constrained:
            zero = jnp.zeros_like(psi)
            v = CarrierVelocity(omega=zero, psi_dot=free, psi=psi, deflection=zero, inv_spin=zero, inv_carrier=inv, h=h)
            lam = carrier.constraint_impulse(pp, k, v)
            new = free + carrier.constraint_response(pp, k, lam, zero, inv)[1]
            dissipated = dissipated - carrier.constraint_power(lam, zero, 0.5 * (psi_dot + new))
        else:
            lam, new = jnp.zeros_like(psi), free
        psi = psi + h * new
        return (psi, new, dissipated), (psi, new, lam)

    z = jnp.zeros((), h.dtype)
    init = (jnp.asarray(psi0, h.dtype), jnp.asarray(psi_dot0, h.dtype), z)
    (_, _, dissipated), (psi, psi_dot, lam) = jax.lax.scan(step, init, None, length=steps)
    return RigHistory(
        t=h * jnp.arange(1, steps + 1, dtype=h.dtype), psi=psi, psi_dot=psi_dot, impulse=lam, dissipated=dissipated
    )
