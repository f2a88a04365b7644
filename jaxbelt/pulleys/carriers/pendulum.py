"""The second idler of a pendulum (rocker) tensioner: belt-starter-generator drives carry two idlers on one arm
that pivots about the starter-generator's axis, one idler on each side of its pulley. The arm's coordinate,
spring, damper, inertia and losses belong to the first idler's carrier (an ``ArmCarrier``, wrapped in
``LossyCarrier`` when it has pivot friction or stops); this carrier puts the second idler on the same arm:

    centre = pivot + L (cos(psi_owner + offset), sin(psi_owner + offset)),

``psi_owner`` the arm angle of pulley ``owner`` (the first idler), ``offset`` the fixed angle between the two
idlers seen from the pivot. It has no coordinate of its own: the belt's force on it acts on the owner's
coordinate (``pulleys.carrier.to_coordinates``), its mass is in the owner's inertia."""

from __future__ import annotations

import typing
from typing import ClassVar

import equinox as eqx
from .arm import arm_center, arm_dcenter
from .base import AbstractHeldCarrier, CarrierKey

__all__ = ["PendulumCarrier"]


@typing.final
class PendulumCarrier(AbstractHeldCarrier):
    """``PulleyParams.center`` the pivot; ``owner`` the pulley whose arm this is (static)."""

    owner: int = eqx.field(static=True)
    name: ClassVar[str] = "pendulum"
    rides_another: ClassVar[bool] = True
    keys: ClassVar[tuple[CarrierKey, ...]] = (
        CarrierKey("length", "m: pivot to this idler's centre"),
        CarrierKey("offset", "rad: this idler's arm angle minus the owner's"),
    )

    def coordinate_of(self, k: int) -> int:
        return self.owner

    def center(self, pp, k, psi):
        n = self.numbers(pp, k)
        return arm_center(pp, k, n["length"], psi + n["offset"])

    def dcenter(self, pp, k, psi):
        n = self.numbers(pp, k)
        return arm_dcenter(n["length"], psi + n["offset"])
