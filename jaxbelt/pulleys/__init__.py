"""Pulleys: laws of time for prescribed speeds and torques (``timelaw``) and the carriers of pulley
centres (``carrier``: the abstract carrier and the per-pulley dispatch; ``fixed``, ``arm``,
``slider``: one kind each). ``CARRIERS`` maps a configuration's carrier name to its class."""

from . import timelaw as timelaw
from .arm import ArmCarrier as ArmCarrier
from .carrier import AbstractCarrier as AbstractCarrier, AbstractMovableCarrier as AbstractMovableCarrier
from .carrier import carrier_centers as carrier_centers, carrier_stored_energy as carrier_stored_energy
from .carrier import free_pulley_velocities as free_pulley_velocities, pulley_inverse_mass as pulley_inverse_mass
from .fixed import FixedCarrier as FixedCarrier
from .slider import SliderCarrier as SliderCarrier
from .timelaw import TimeLaw as TimeLaw

# name -> class: adding a carrier kind = one file here and one line in this table.
CARRIERS: dict[str, type[AbstractCarrier]] = {c.name: c for c in (FixedCarrier, ArmCarrier, SliderCarrier)}
