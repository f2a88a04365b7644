"""One-way clutch pulleys: the overrunning alternator pulley (OAP) and the decoupler (OAD).

The sheave (the pulley the belt wraps, ``PulleyParams.inertia``) drives a rotor (``psi``,
``psi_dot``, inertia ``carrier_inertia``) through a clutch that transmits torque in the running
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

from .constraints import AbstractClutchCarrier

__all__ = ["OverrunningClutch", "Decoupler"]


@typing.final
class OverrunningClutch(AbstractClutchCarrier):
    """OAP: a rigid one-way clutch. Locked, sheave and rotor turn as one body."""

    name: ClassVar[str] = "clutch"

    def constraint_impulse(self, pp, cp, k, v):
        overrun = self.sense * (v.psi_dot - v.omega)
        return jnp.maximum(0.0, -overrun / (v.inv_spin + v.inv_carrier))

    def deflection(self, cp, k, lam, v):
        return jnp.zeros_like(lam)


@typing.final
class Decoupler(AbstractClutchCarrier):
    """OAD: a torsion spring and damper (``ConstraintParams.clutch_stiffness``, ``clutch_damping``)
    in series with the one-way clutch."""

    name: ClassVar[str] = "decoupler"

    def _compliance(self, cp, k, h):
        return cp.clutch_stiffness[k] * h + cp.clutch_damping[k]

    def constraint_impulse(self, pp, cp, k, v):
        h, kc = v.h, cp.clutch_stiffness[k]
        a = h * self._compliance(cp, k, h)
        rate = self.sense * (v.omega - v.psi_dot)  # deflection rate without the clutch impulse
        locked = h * (kc * v.deflection + self._compliance(cp, k, h) * rate) / (1.0 + a * (v.inv_spin + v.inv_carrier))
        return jnp.maximum(0.0, locked)

    def deflection(self, cp, k, lam, v):
        """End-of-step spring deflection: from tau = lam / h = k d+ + c d'+ with d+ = d + h d'+."""
        rate = (lam / v.h - cp.clutch_stiffness[k] * v.deflection) / self._compliance(cp, k, v.h)
        return v.deflection + v.h * rate
