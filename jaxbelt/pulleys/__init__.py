"""Pulleys: laws of time for prescribed speeds and torques (``timelaw``), engine orders and laws over
the crank angle (``excitation``), the per-drive loops over pulleys (``carrier``) and the carriers room
(``carriers``: one class per kind of what holds a pulley's centre; ``CARRIERS`` maps a name to its class)."""

from . import carriers as carriers, excitation as excitation, timelaw as timelaw
from .carrier import carrier_centers as carrier_centers, carrier_stored_energy as carrier_stored_energy
from .carrier import free_pulley_velocities as free_pulley_velocities, pulley_inverse_mass as pulley_inverse_mass
from .carriers import CARRIERS as CARRIERS, AbstractCarrier as AbstractCarrier
from .carriers import AbstractMovableCarrier as AbstractMovableCarrier, ArmCarrier as ArmCarrier
from .carriers import AbstractClutchCarrier as AbstractClutchCarrier, LossyCarrier as LossyCarrier
from .carriers import CarrierKey as CarrierKey, ConstraintState as ConstraintState
from .carriers import Decoupler as Decoupler, FixedCarrier as FixedCarrier, OverrunningClutch as OverrunningClutch
from .carriers import SliderCarrier as SliderCarrier
from .excitation import Excitation as Excitation
from .timelaw import TimeLaw as TimeLaw
