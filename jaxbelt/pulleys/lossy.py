"""Tensioner carriers with pivot friction, loading/unloading damping and hard stops (see
``constraints.AbstractLossyCarrier``): the arm and the slider of ``arm.py`` / ``slider.py``."""

from __future__ import annotations

import typing
from typing import ClassVar

from .arm import arm_center, arm_dcenter
from .constraints import AbstractLossyCarrier
from .slider import slider_center, slider_dcenter

__all__ = ["LossyArmCarrier", "LossySliderCarrier"]


@typing.final
class LossyArmCarrier(AbstractLossyCarrier):
    """A tensioner arm (as ``ArmCarrier``) with Coulomb pivot friction [N m], stops [rad] and
    unloading damping."""

    name: ClassVar[str] = "lossy_arm"
    coordinate: ClassVar[str | None] = "arm_angle"

    def center(self, pp, k, psi):
        return arm_center(pp, k, psi)

    def dcenter(self, pp, k, psi):
        return arm_dcenter(pp, k, psi)


@typing.final
class LossySliderCarrier(AbstractLossyCarrier):
    """A slider (as ``SliderCarrier``) with Coulomb guide friction [N], stops [m] and unloading damping."""

    name: ClassVar[str] = "lossy_slider"
    coordinate: ClassVar[str | None] = "travel"

    def center(self, pp, k, psi):
        return slider_center(pp, k, psi)

    def dcenter(self, pp, k, psi):
        return slider_dcenter(pp, k, psi)
