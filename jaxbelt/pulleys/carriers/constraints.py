"""Non-smooth constraints of a carrier, solved inside the contact sweeps of every step.

Two kinds: the wrapper ``lossy.LossyCarrier`` and the clutches (``AbstractClutchCarrier`` here, final classes in
``clutch.py``):

* ``LossyCarrier``: a tensioner arm (or slider) with Coulomb dry friction in its pivot
  (true sticking: the arm stays put while its net torque lies inside the friction band), damping
  that differs between loading and unloading, and hard stops (``psi`` limits as unilateral
  contacts). One impulse ``lam`` on ``psi`` per step holds all three.
* ``AbstractClutchCarrier``: a pulley (sheave) that drives a rotor of its own inertia through a
  one-way clutch (overrunning alternator pulley), optionally through a torsion spring and damper
  in series (decoupler). ``psi`` is the rotor angle, ``psi_dot`` its speed; the pulley's load acts
  on the rotor. ``lam`` is the clutch's angular impulse (>= 0 in the running sense).

Both are velocity-level complementarity problems like the belt's contacts (no regularisation):
``constraint_impulse`` is the exact local solve of one carrier with the belt impulses frozen, and
``constraint_response`` the velocity changes ``lam`` causes. The contact solve alternates the belt
sweep and these local solves (``contact.sweeps.solve_contact_coupled``); the step warm-starts
``lam`` from the last step (``ConstraintState.impulse``).
"""

from __future__ import annotations

import abc
import typing
from typing import TYPE_CHECKING, ClassVar

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from ..._quantity import Quantity
from .base import AbstractCarrier, CarrierKey

if TYPE_CHECKING:
    from ..._types import PulleyParams

__all__ = ["ConstraintState", "AbstractConstrainedCarrier", "AbstractClutchCarrier", "CarrierVelocity"]

ROTOR_OMEGA = Quantity("rotor_omega", "rad/s", "pulley", r"rotor $\omega$", "Clutch rotor speeds")  # ccw +
CLUTCH_TORQUE = Quantity("clutch_torque", "N m", "pulley", "clutch torque on the rotor", "Clutch torques")


@typing.final
class ConstraintState(eqx.Module):
    impulse: Float[Array, " p"]  # last step's constraint impulse [N m s] (warm start; / h = torque)
    deflection: Float[Array, " p"]  # decoupler spring deflection, sheave minus rotor side [rad]

    @classmethod
    def zeros(cls, p: int) -> ConstraintState:
        z = jnp.zeros(p)
        return cls(impulse=z, deflection=z)


class AbstractConstrainedCarrier(AbstractCarrier):
    """A carrier with a constraint impulse ``lam`` solved with the contacts."""

    constrained: ClassVar[bool] = True

    @abc.abstractmethod
    def constraint_impulse(self, pp: PulleyParams, k: int, v: CarrierVelocity):
        """The exact ``lam`` of carrier ``k`` given the velocities without it."""

    @abc.abstractmethod
    def constraint_response(self, pp: PulleyParams, k: int, lam, inv_spin, inv_carrier):
        """``(d_omega, d_psi_dot)`` caused by ``lam``."""

    @abc.abstractmethod
    def constraint_power(self, lam, omega_mid, psi_dot_mid):
        """Work of ``lam`` over the step on the bodies (omega, psi_dot at mid-step) [J]."""

    def deflection(self, pp: PulleyParams, k: int, lam, v: CarrierVelocity):
        """End-of-step deflection of a spring inside the constraint (decoupler); none here."""
        return v.deflection

    def spring_energy(self, pp: PulleyParams, k: int, deflection):
        """Energy of a spring inside the constraint at ``deflection`` [J] (decoupler); none here."""
        return jnp.zeros_like(deflection)


@typing.final
class CarrierVelocity(eqx.Module):
    """What a local solve sees of carrier ``k``: end-of-step velocities without its own impulse."""

    omega: Float[Array, ""]
    psi_dot: Float[Array, ""]
    psi: Float[Array, ""]  # start of step
    deflection: Float[Array, ""]  # start of step (decoupler)
    inv_spin: Float[Array, ""]
    inv_carrier: Float[Array, ""]
    h: Float[Array, ""]


class AbstractClutchCarrier(AbstractConstrainedCarrier):
    """A sheave on a fixed centre driving a rotor (``psi``: angle, ``psi_dot``: speed, ``rotor_inertia``) through
    a one-way clutch; ``sense`` (+1 counter-clockwise, -1 clockwise) is the running sense: the clutch drives the
    rotor forward, never back."""

    movable: ClassVar[bool] = False  # the centre is fixed: no carrier terms in the contacts
    coordinate: ClassVar[str | None] = None
    load_on_carrier: ClassVar[bool] = True  # the pulley's load and viscous torque act on the rotor
    # how an engaged clutch enters a linearisation (analysis.modes): "locked" (sheave and rotor one body) or
    # "spring" (the rotor on a spring of its own, ``spring_energy``)
    engaged: ClassVar[str] = "locked"
    keys: ClassVar[tuple[CarrierKey, ...]] = (
        CarrierKey("rotor_inertia", "kg m^2: the rotor the clutch drives (the pulley's load acts on it)", True),
    )
    prefix: ClassVar[str] = ""  # pulleys.<name>.rotor_inertia: a clutch is the pulley's own, not a tensioner's
    sense: int = eqx.field(static=True, default=1)

    def rotor_inertia(self, pp, k):
        return self.numbers(pp, k)["rotor_inertia"]

    def signals(self):
        """The rotor's speed and the clutch torque (the step's clutch impulse / h, >= 0: the clutch drives the
        rotor in the running sense)."""

        def torque(params, states, i, h):
            assert states.constraints is not None, "a constrained drive saves its ConstraintState"
            return states.constraints.impulse[:, i] / h

        return ((ROTOR_OMEGA, lambda params, states, i, h: states.psi_dot[:, i]), (CLUTCH_TORQUE, torque))

    @classmethod
    def quantities(cls):
        return (ROTOR_OMEGA, CLUTCH_TORQUE)

    def center(self, pp, k, psi):
        return jnp.broadcast_to(pp.center[k], jnp.shape(psi) + (2,))

    def dcenter(self, pp, k, psi):
        return jnp.zeros(jnp.shape(psi) + (2,), pp.center.dtype)

    def inverse_mass(self, pp, k, h):
        return 1.0 / (self.rotor_inertia(pp, k) + h * pp.viscous[k])  # the rotor's viscous load is implicit

    def free_velocity(self, pp, k, psi, psi_dot, h, gravity):
        return psi_dot  # the rotor's load is added by free_pulley_velocities (it needs the time)

    def stored_energy(self, pp, k, psi, gravity):
        return jnp.zeros_like(psi)

    def kinetic_energy(self, pp, k, psi_dot):
        return 0.5 * self.rotor_inertia(pp, k) * psi_dot**2

    def constraint_response(self, pp, k, lam, inv_spin, inv_carrier):
        return -self.sense * inv_spin * lam, self.sense * inv_carrier * lam

    def constraint_power(self, lam, omega_mid, psi_dot_mid):
        return self.sense * lam * (psi_dot_mid - omega_mid)
