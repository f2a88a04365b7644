"""The carriers room: what holds a pulley's centre, one final class per kind, the twin of
``contact.friction``.

``base``: the abstract carrier and the movable one (spring, preload, damper, weight); ``fixed``, ``arm``,
``slider``: the kinds of a pulley's centre; ``lossy``: pivot friction, unloading damping and stops as one wrapper
around any movable carrier; ``constraints``: carriers with an impulse solved with the contacts, and ``clutch``
(one-way clutch, decoupler). Adding a kind: one file here and one line in ``CARRIERS``."""

from .arm import ArmCarrier as ArmCarrier
from .base import AbstractCarrier as AbstractCarrier, AbstractMovableCarrier as AbstractMovableCarrier
from .base import AbstractHeldCarrier as AbstractHeldCarrier, CarrierKey as CarrierKey
from .base import Installed as Installed, SpecKey as SpecKey
from .clutch import Decoupler as Decoupler, OverrunningClutch as OverrunningClutch
from .constraints import AbstractClutchCarrier as AbstractClutchCarrier
from .constraints import AbstractConstrainedCarrier as AbstractConstrainedCarrier, CarrierVelocity as CarrierVelocity
from .constraints import ConstraintState as ConstraintState
from .fixed import FixedCarrier as FixedCarrier
from .lossy import LossyCarrier as LossyCarrier
from .pendulum import PendulumCarrier as PendulumCarrier
from .slider import SliderCarrier as SliderCarrier

# name -> class: adding a carrier kind = one file here and one line in this table.
CARRIERS: dict[str, type[AbstractCarrier]] = {
    c.name: c
    for c in (FixedCarrier, ArmCarrier, SliderCarrier, LossyCarrier, OverrunningClutch, Decoupler, PendulumCarrier)
}


DEFAULT_TENSIONER_KIND = ArmCarrier.name  # a tensioner table without ``kind``


def tensioner_kinds() -> tuple[str, ...]:
    """The kinds a tensioner's carrier can be (``tensioner.kind``): the movable carriers a pulley is built on
    (the wrapper and the clutches are not), and the carriers that put a second pulley on another's
    (``pendulum``: the tensioner's own pulley on an arm, its ``partner`` on the same arm)."""
    return tuple(
        n
        for n, c in CARRIERS.items()
        if (issubclass(c, AbstractMovableCarrier) and not issubclass(c, LossyCarrier)) or c.rides_another
    )


def tensioner_spec_keys() -> dict[str, SpecKey]:
    """Every key a tensioner table may hold (table order): the tensioner kinds' and the lossy wrapper's. A name
    declared by several kinds has one meaning: one record."""
    out: dict[str, SpecKey] = {}
    classes: list[type[AbstractCarrier]] = [*(CARRIERS[k] for k in tensioner_kinds()), LossyCarrier]
    for cls in classes:
        for key in cls.spec_keys:
            assert out.setdefault(key.name, key) == key, f"{key.name!r} declared twice with different meanings"
    return out


def carrier_quantities() -> tuple:
    """Every quantity the carriers' signals can have, from the table (each once, table order)."""
    out: dict = {}
    for cls in CARRIERS.values():
        for q in cls.quantities():
            out.setdefault(q.prefix, q)
    return tuple(out.values())
