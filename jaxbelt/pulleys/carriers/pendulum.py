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

from .arm import ArmCarrier, arm_center, arm_dcenter, arm_geometry, check_arm
from .base import AbstractHeldCarrier, CarrierKey, Installed, SpecKey

__all__ = ["PendulumCarrier"]

PARTNER = "partner"  # the key that names the pulley riding a kind's carrier


@typing.final
class PendulumCarrier(AbstractHeldCarrier):
    """``PulleyParams.center`` the pivot; ``owner`` the pulley whose arm this is (static)."""

    owner: int = eqx.field(static=True)
    name: ClassVar[str] = "pendulum"
    rides_another: ClassVar[bool] = True
    pivoted: ClassVar[bool] = True
    keys: ClassVar[tuple[CarrierKey, ...]] = (
        CarrierKey("length", "m: pivot to this idler's centre"),
        CarrierKey("offset", "rad: this idler's arm angle minus the owner's"),
    )
    # the tensioner table of the first idler: an arm's keys, and the second idler
    spec_keys: ClassVar[tuple[SpecKey, ...]] = (
        *ArmCarrier.spec_keys,
        SpecKey(
            PARTNER,
            "the second idler: the name of a pulley of role 'idler' without a table of its own",
            str,
            elsewhere="names a pendulum's second idler: only kind = 'pendulum' has one",
        ),
    )

    @classmethod
    def check_spec(cls, values, center, checks):
        check_arm(
            values, center, checks, "a pendulum tensioner needs its pivot (x, y), usually the starter-generator's axis"
        )
        checks(
            values["inertia"] is not None,
            "inertia",
            values["inertia"],
            "a pendulum tensioner needs the inertia of its whole rocker (arm and both idlers) about the pivot [kg m^2]",
        )

    @classmethod
    def build(cls, values, center):
        """The first idler's carrier: the rocker's arm (its coordinate, spring, damper, inertia)."""
        return ArmCarrier.build(values, center)

    @classmethod
    def rider(cls, values, owner: int, owner_center, center) -> Installed:
        """The second idler (drawn at ``center``) on the arm of pulley ``owner`` (drawn at ``owner_center``): at
        its drawn angle from the first idler's."""
        pivot = (float(values["pivot"][0]), float(values["pivot"][1]))
        length, angle = arm_geometry(center, pivot)
        _, psi0 = arm_geometry(owner_center, pivot)
        return Installed(cls(owner=owner), pivot, dict(length=length, offset=angle - psi0), 0.0)

    @classmethod
    def dcenter_at(cls, numbers, psi):
        return ArmCarrier.dcenter_at(numbers, psi + numbers["offset"])

    def coordinate_of(self, k: int) -> int:
        return self.owner

    def center(self, pp, k, psi):
        n = self.numbers(pp, k)
        return arm_center(pp, k, n["length"], psi + n["offset"])

    def dcenter(self, pp, k, psi):
        n = self.numbers(pp, k)
        return arm_dcenter(n["length"], psi + n["offset"])
