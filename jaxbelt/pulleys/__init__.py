"""Pulleys: laws of time for prescribed speeds and torques (``timelaw``), engine orders and laws over
the crank angle (``excitation``) and the carriers of pulley
centres (``carrier``: the abstract carrier and the per-pulley dispatch; ``fixed``, ``arm``,
``slider``: one kind each; ``constraints``: carriers with an impulse solved with the contacts,
``lossy`` (pivot friction, stops) and ``clutch`` (one-way clutch, decoupler)). ``CARRIERS`` maps a
carrier's name to its class."""

from . import excitation as excitation, timelaw as timelaw
from .arm import ArmCarrier as ArmCarrier
from .carrier import AbstractCarrier as AbstractCarrier, AbstractMovableCarrier as AbstractMovableCarrier
from .carrier import carrier_centers as carrier_centers, carrier_stored_energy as carrier_stored_energy
from .carrier import free_pulley_velocities as free_pulley_velocities, pulley_inverse_mass as pulley_inverse_mass
from .excitation import Excitation as Excitation
from .clutch import Decoupler as Decoupler, OverrunningClutch as OverrunningClutch
from .constraints import AbstractClutchCarrier as AbstractClutchCarrier, AbstractLossyCarrier as AbstractLossyCarrier
from .constraints import ConstraintParams as ConstraintParams, ConstraintState as ConstraintState
from .fixed import FixedCarrier as FixedCarrier
from .lossy import LossyArmCarrier as LossyArmCarrier, LossySliderCarrier as LossySliderCarrier
from .slider import SliderCarrier as SliderCarrier
from .timelaw import TimeLaw as TimeLaw

# name -> class: adding a carrier kind = one file here and one line in this table.
CARRIERS: dict[str, type[AbstractCarrier]] = {
    c.name: c
    for c in (
        FixedCarrier,
        ArmCarrier,
        SliderCarrier,
        LossyArmCarrier,
        LossySliderCarrier,
        OverrunningClutch,
        Decoupler,
    )
}
