"""Pulleys: time laws of speeds and torques, and the carriers of pulley centres."""

from .arm import ArmCarrier
from .carrier import AbstractCarrier
from .fixed import FixedCarrier
from .slider import SliderCarrier

__all__ = ["AbstractCarrier", "FixedCarrier", "ArmCarrier", "SliderCarrier", "CARRIERS"]

# name -> class: adding a carrier kind = one file here and one line in this table.
CARRIERS: dict[str, type[AbstractCarrier]] = {c.name: c for c in (FixedCarrier, ArmCarrier, SliderCarrier)}
