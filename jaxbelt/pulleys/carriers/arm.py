"""A pulley on a pivoted tensioner arm: centre = pivot + L (cos psi, sin psi)."""

from __future__ import annotations

import math
import typing
from typing import ClassVar

import jax.numpy as jnp
import numpy as np

from ..._quantity import Quantity
from .base import AbstractMovableCarrier, CarrierKey, SpecKey

__all__ = ["ArmCarrier", "arm_center", "arm_dcenter", "arm_geometry", "check_arm", "MAX_ARM_ANGLE", "ARM_ANGLE"]

ARM_ANGLE = Quantity("arm_angle", "rad", "tensioner", "tensioner arm angle", "Tensioner arm angles")
PIVOT_FRICTION = Quantity("pivot_friction", "N m", "tensioner", "pivot friction torque", "Tensioner pivot friction")
STOP_TORQUE = Quantity("stop_torque", "N m", "tensioner", "stop reaction torque", "Tensioner stop reactions")
MAX_ARM_ANGLE = 2 * math.pi  # |rest| of an arm [rad]; beyond a full turn it was meant in degrees


def arm_center(pp, k, length, psi):
    return pp.center[k] + length * jnp.stack([jnp.cos(psi), jnp.sin(psi)], axis=-1)


def arm_dcenter(length, psi):
    return length * jnp.stack([-jnp.sin(psi), jnp.cos(psi)], axis=-1)


def arm_geometry(center, pivot) -> tuple[float, float]:
    """An arm's length [m] and installed angle [rad] from its pivot to the pulley centre."""
    dx, dy = center[0] - pivot[0], center[1] - pivot[1]
    return math.hypot(dx, dy), math.atan2(dy, dx)


def check_arm(values, center, checks, pivot_needed: str) -> None:
    """An arm's pivot (``pivot_needed``: why it is required) and its rest angle, in radians or degrees."""
    checks(values["pivot"] is not None, "pivot", values["pivot"], pivot_needed)
    checks(arm_geometry(center, values["pivot"])[0] > 0, "pivot", values["pivot"], "must differ from the pulley centre")
    rest, rest_deg = values["rest"], values["rest_deg"]
    if rest_deg is not None:
        checks(
            rest is None,
            "rest/rest_deg",
            (rest, rest_deg),
            "give the rest angle once: rest in rad or rest_deg in degrees",
        )
        checks(
            abs(rest_deg) <= 360.0,
            "rest_deg",
            rest_deg,
            "must be within [-360, 360] deg (an arm angle; a wound-up spring is given by preload)",
        )
    elif rest is not None:
        checks(
            abs(rest) <= MAX_ARM_ANGLE,
            "rest",
            rest,
            f"an arm's rest angle is in radians and must be within [-2π, 2π] ({rest:g} rad is "
            f"{math.degrees(rest):.4g} deg); for degrees write rest_deg = {rest:g} ({math.radians(rest):.4g} rad)",
        )


@typing.final
class ArmCarrier(AbstractMovableCarrier):
    """``PulleyParams.center`` the pivot; psi the arm angle [rad] from the pivot to the pulley centre."""

    name: ClassVar[str] = "arm"
    coordinate: ClassVar[str | None] = ARM_ANGLE.prefix
    coordinate_quantity: ClassVar[Quantity] = ARM_ANGLE
    loss_quantities: ClassVar[tuple[Quantity, Quantity]] = (PIVOT_FRICTION, STOP_TORQUE)
    pivoted: ClassVar[bool] = True
    keys: ClassVar[tuple[CarrierKey, ...]] = (
        *AbstractMovableCarrier.keys,
        CarrierKey("length", "m: pivot to pulley centre"),
    )
    spec_keys: ClassVar[tuple[SpecKey, ...]] = (
        *AbstractMovableCarrier.spec_keys,
        SpecKey(
            "pivot",
            "(x, y) m: the arm's pivot (with the drawn centre it fixes the arm's length and installed angle)",
            tuple[float, float],
            check="point",
            elsewhere="is an arm's pivot: a slider moves along its direction",
        ),
        SpecKey(
            "rest_deg",
            "deg: the rest angle in degrees (instead of rest)",
            check="finite",
            elsewhere="is an arm's rest angle in degrees; a slider's rest is a travel: give rest in m",
        ),
    )

    @classmethod
    def check_spec(cls, values, center, checks):
        check_arm(values, center, checks, "an arm tensioner needs its pivot (x, y)")

    @classmethod
    def anchor(cls, values, center):
        length, psi0 = arm_geometry(center, values["pivot"])
        return (float(values["pivot"][0]), float(values["pivot"][1])), dict(length=length), psi0

    @classmethod
    def dcenter_at(cls, numbers, psi):
        return numbers["length"] * np.array([-math.sin(psi), math.cos(psi)])

    @classmethod
    def rest_of(cls, values):
        if values["rest_deg"] is not None:
            return math.radians(values["rest_deg"])
        return super().rest_of(values)

    @classmethod
    def default_inertia(cls, values, numbers):
        return max(values["mass"], 1e-3) * numbers["length"] ** 2

    def center(self, pp, k, psi):
        return arm_center(pp, k, self.numbers(pp, k)["length"], psi)

    def dcenter(self, pp, k, psi):
        return arm_dcenter(self.numbers(pp, k)["length"], psi)
