"""One-way clutch pulleys: the overrunning alternator pulley (OAP) and the decoupler (OAD).

The sheave (the pulley the belt wraps, ``PulleyParams.inertia``) drives a rotor (``psi``,
``psi_dot``, inertia ``rotor_inertia``) through a clutch that transmits torque in the running
sense only: when the belt slows, the rotor overruns with zero clutch torque. The clutch impulse
``lam >= 0`` is complementary to the rotor's overrun ``sense (psi_dot - omega) >= 0`` (OAP) or,
for the decoupler, to the overrun of the rotor over the end of a torsion spring (stiffness ``k``,
damper ``c``) that sits in series between sheave and clutch, with a massless clutch ring:

    locked:  lam = h tau,  tau = k d+ + c d'+,  d' = sense (omega - psi_dot)  (d: spring deflection)
    overrun: lam = 0 and the spring relaxes, k d+ + c d'+ = 0

both integrated implicitly (``d+ = d + h d'+``), so the spring does not limit the step.
"""

from __future__ import annotations

import typing
from typing import ClassVar

import jax.numpy as jnp

from .base import CarrierKey
from .constraints import AbstractClutchCarrier

__all__ = ["OverrunningClutch", "Decoupler"]


@typing.final
class OverrunningClutch(AbstractClutchCarrier):
    """OAP: a rigid one-way clutch. Locked, sheave and rotor turn as one body."""

    name: ClassVar[str] = "clutch"

    def constraint_impulse(self, pp, k, v):
        overrun = self.sense * (v.psi_dot - v.omega)
        return jnp.maximum(0.0, -overrun / (v.inv_spin + v.inv_carrier))

    def deflection(self, pp, k, lam, v):
        return jnp.zeros_like(lam)


@typing.final
class Decoupler(AbstractClutchCarrier):
    """OAD: a torsion spring and damper (``clutch_stiffness``, ``clutch_damping``) in series with the one-way
    clutch."""

    name: ClassVar[str] = "decoupler"
    engaged: ClassVar[str] = "spring"
    keys: ClassVar[tuple[CarrierKey, ...]] = (
        *AbstractClutchCarrier.keys,
        CarrierKey("clutch_stiffness", "N m/rad: the torsion spring", True),
        CarrierKey("clutch_damping", "N m s/rad: the damper beside the spring", True, loss="damping"),
    )

    def _compliance(self, pp, k, h):
        n = self.numbers(pp, k)
        return n["clutch_stiffness"] * h + n["clutch_damping"]

    def constraint_impulse(self, pp, k, v):
        h, kc = v.h, self.numbers(pp, k)["clutch_stiffness"]
        a = h * self._compliance(pp, k, h)
        rate = self.sense * (v.omega - v.psi_dot)  # deflection rate without the clutch impulse
        locked = h * (kc * v.deflection + self._compliance(pp, k, h) * rate) / (1.0 + a * (v.inv_spin + v.inv_carrier))
        return jnp.maximum(0.0, locked)

    def deflection(self, pp, k, lam, v):
        """End-of-step spring deflection: from tau = lam / h = k d+ + c d'+ with d+ = d + h d'+."""
        rate = (lam / v.h - self.numbers(pp, k)["clutch_stiffness"] * v.deflection) / self._compliance(pp, k, v.h)
        return v.deflection + v.h * rate

    def spring_energy(self, pp, k, deflection):
        return 0.5 * self.numbers(pp, k)["clutch_stiffness"] * deflection**2
