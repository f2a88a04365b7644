"""The abstract carrier: what carries a pulley's centre, its coordinate ``psi``, its numbers and the terms it adds
to a step; and the movable carrier with one coordinate, a linear spring with preload, a damper and a weight.

A carrier kind is one final class in this room (``fixed.py``, ``arm.py``, ``slider.py``, ``clutch.py``,
``pendulum.py``; pivot friction, stops and unloading damping wrap any movable carrier, ``lossy.py``) and one line
in ``CARRIERS`` (``__init__.py``). ``DriveModel.carriers`` holds one instance per pulley (static, number-free);
its numbers are the pulley's mapping ``PulleyParams.carrier[k]``, keyed by the class's ``keys`` (the way a
friction law's coefficients are ``DriveParams.friction``), so a carrier method reads ``self.numbers(pp, k)``.
"""

from __future__ import annotations

import abc
import dataclasses
import typing
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, ClassVar, Protocol

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from ..._errors import is_finite_number
from ..._quantity import Quantity

if TYPE_CHECKING:  # _types imports this module
    from ..._types import DriveParams, DriveState, PulleyParams

# A carrier's own signal: its quantity and its values from (params, saved states, the pulley's index, the step h)
CarrierSignal = tuple[Quantity, Callable[["DriveParams", "DriveState", int, float], typing.Any]]

__all__ = [
    "AbstractCarrier",
    "AbstractHeldCarrier",
    "AbstractMovableCarrier",
    "CarrierKey",
    "CarrierSignal",
    "SpecKey",
    "Installed",
]


@typing.final
@dataclasses.dataclass(frozen=True)
class CarrierKey:
    """One number of a carrier (a key of ``PulleyParams.carrier[k]``).

    ``parameter``: a parameter key of the drive (``pulleys.<name>.<prefix><name>``, differentiable and varied by
    sweeps and fits); ``loss``: ``"damping"`` or ``"friction"``, what the undamped, frictionless linearisations of
    the modes set to zero."""

    name: str
    doc: str  # unit and meaning
    parameter: bool = False
    loss: typing.Literal["damping", "friction"] | None = None
    shape: tuple[int, ...] = ()  # a scalar; a slider's direction (2,)


class Checks(Protocol):
    """The configuration's refusal, bound to one carrier's table (``config.carrier_keys``): a ``ConfigError``
    that reads ``<pulley>.tensioner.<key> = value: allowed`` unless ``ok``; plain Python and numpy only."""

    def __call__(self, ok: bool, key: str, value, allowed: str) -> None: ...


# The checks a key's value may name (``SpecKey.check``): the text of its refusal, or None.
def _pair(what: str) -> Callable[[Any], str | None]:
    def check(x) -> str | None:
        ok = isinstance(x, (list, tuple, np.ndarray)) and len(x) == 2 and all(is_finite_number(v) for v in x)
        return None if ok else f"must be two finite numbers {what}"

    return check


VALUE_CHECKS: dict[str, Callable[[Any], str | None]] = {
    "finite": lambda x: None if is_finite_number(x) else "must be a finite number",
    "non_negative": lambda x: None if is_finite_number(x) and x >= 0 else "must be a finite number >= 0",
    "positive": lambda x: None if is_finite_number(x) and x > 0 else "must be a finite number > 0",
    "point": _pair("(x, y) in m"),
    "vector": _pair("(x, y)"),
    "interval": _pair("(min, max)"),
    "coordinate": lambda x: None if is_finite_number(x) else "must be a finite number (rad for an arm, m for a slider)",
}


@typing.final
@dataclasses.dataclass(frozen=True)
class SpecKey:
    """One key of a carrier's configuration table (``[pulleys.tensioner]``), declared by its class.

    ``hint``: what the file holds (``float``, ``tuple[float, float]``, ``str``); ``default``: its value when not
    given (None: absent); ``check``: a name in ``VALUE_CHECKS`` for a given value (kind-wide checks are the
    class's ``check_spec``); ``elsewhere``: why a kind that does not declare the key refuses it."""

    name: str
    doc: str  # unit and meaning
    hint: Any = float
    default: Any = None
    check: str | None = None
    elsewhere: str = ""


@typing.final
@dataclasses.dataclass(frozen=True)
class Installed:
    """A carrier built from its configuration at the drawn layout: the instance, its anchor
    (``PulleyParams.center``: fixed centre, pivot, slider origin), its numbers and its installed coordinate."""

    carrier: AbstractCarrier
    origin: tuple[float, float]
    numbers: dict[str, Any]
    psi0: float


class AbstractCarrier(eqx.Module):
    """What carries a pulley's centre. Methods take the drive's ``PulleyParams``, the pulley index
    ``k`` and its coordinate ``psi`` (any leading batch shape ``...``)."""

    name: ClassVar[str]  # the config name ("fixed", "arm", "slider")
    movable: ClassVar[bool]  # False: psi stays 0 and the carrier terms are skipped
    coordinate: ClassVar[str | None]  # signal name of psi ("arm_angle", "travel"); None if not movable
    keys: ClassVar[tuple[CarrierKey, ...]] = ()  # its numbers, PulleyParams.carrier[k]
    prefix: ClassVar[str] = "tensioner."  # its parameter keys: pulleys.<name>.<prefix><key>
    constrained: ClassVar[bool] = False  # a constraint impulse solved with the contacts (constraints.py)
    load_on_carrier: ClassVar[bool] = False  # the pulley's load acts on psi (a clutch's rotor), not the sheave
    rides_another: ClassVar[bool] = False  # the centre moves with another pulley's coordinate (coordinate_of)
    pivoted: ClassVar[bool] = False  # the centre swings about a pivot (its anchor): psi an angle [rad]
    spec_keys: ClassVar[tuple[SpecKey, ...]] = ()  # its configuration keys (a tensioner kind's table)

    @classmethod
    def check_spec(cls, values: Mapping[str, Any], center: tuple[float, float], checks: Checks) -> None:
        """What its keys must satisfy together (each given key's own ``check`` has passed)."""

    @classmethod
    def build(cls, values: Mapping[str, Any], center: tuple[float, float]) -> Installed:
        """The carrier of a pulley drawn at ``center`` from its checked configuration ``values`` (every key of
        ``spec_keys``, given or its default)."""
        raise NotImplementedError(f"the carrier {cls.__name__!r} is not built from a tensioner table")

    def coordinate_of(self, k: int) -> int:
        """The pulley whose coordinate ``psi`` moves pulley ``k``'s centre: its own, or another's where two
        pulleys ride one carrier (``pendulum.py``); ``center``/``dcenter`` receive that coordinate."""
        return k

    def numbers(self, pp: PulleyParams, k: int) -> dict:
        """The carrier's numbers of pulley ``k``: ``PulleyParams.carrier[k]`` (keys: ``keys``)."""
        return pp.carrier[k]

    @abc.abstractmethod
    def center(self, pp: PulleyParams, k: int, psi):
        """Pulley centre ``(..., 2)``."""

    @abc.abstractmethod
    def dcenter(self, pp: PulleyParams, k: int, psi):
        """d(centre)/d(psi) ``(..., 2)``."""

    @abc.abstractmethod
    def inverse_mass(self, pp: PulleyParams, k: int, h):
        """Inverse inertia of psi seen by contact impulses within a step of ``h``."""

    @abc.abstractmethod
    def free_velocity(self, pp: PulleyParams, k: int, psi, psi_dot, h, gravity):
        """psi_dot at the end of the step before contact impulses."""

    @abc.abstractmethod
    def stored_energy(self, pp: PulleyParams, k: int, psi, gravity):
        """Spring, preload and gravity potential of the carrier [J]."""

    @abc.abstractmethod
    def kinetic_energy(self, pp: PulleyParams, k: int, psi_dot):
        """Kinetic energy of the carrier [J]."""

    def damping(self, pp: PulleyParams, k: int):
        """The viscous damping on psi that the step integrates implicitly (the energy audit's carrier damping)."""
        return jnp.zeros_like(pp.inertia[k])

    def signals(self) -> tuple[CarrierSignal, ...]:
        """Its own signals (columns ``<prefix>:<pulley>``, ``outputs.signals``); none by default."""
        return ()

    def followers(self, name: str) -> tuple[str, ...]:
        """Its numbers that follow number ``name`` in this drive (set with it, as editing the file would): none by
        default; a lossy carrier whose file gives no ``damping_unload`` unloads with ``damping``."""
        return ()

    @classmethod
    def quantities(cls) -> tuple[Quantity, ...]:
        """Every quantity its signals can have (the registry's table)."""
        return ()


class AbstractHeldCarrier(AbstractCarrier):
    """A carrier without a coordinate of its own (a fixed centre, a pendulum's second idler): nothing to integrate,
    no inertia seen by the impulses, no energy."""

    movable: ClassVar[bool] = False
    coordinate: ClassVar[str | None] = None

    def inverse_mass(self, pp, k, h):
        return jnp.zeros_like(pp.inertia[k])

    def free_velocity(self, pp, k, psi, psi_dot, h, gravity):
        return jnp.zeros_like(psi_dot)

    def stored_energy(self, pp, k, psi, gravity):
        return jnp.zeros_like(psi)

    def kinetic_energy(self, pp, k, psi_dot):
        return jnp.zeros_like(psi_dot)


class AbstractMovableCarrier(AbstractCarrier):
    """A carrier with one coordinate, a linear spring with preload, a damper and a weight.

    The spring and damper are integrated implicitly (``1/(m + h c + h^2 k)``), so stiff tensioner
    springs do not limit the step."""

    movable: ClassVar[bool] = True
    coordinate_quantity: ClassVar[Quantity]  # the signal of psi (its prefix is ``coordinate``)
    # the signals of the losses of a LossyCarrier around it: friction, stop reaction (lossy.py)
    loss_quantities: ClassVar[tuple[Quantity, Quantity]]
    keys: ClassVar[tuple[CarrierKey, ...]] = (
        CarrierKey("stiffness", "N m/rad (slider: N/m): the spring", parameter=True),
        CarrierKey("preload", "N m (slider: N): the spring's torque (force) at its rest coordinate", parameter=True),
        CarrierKey("damping", "N m s/rad (slider: N s/m): the damper", parameter=True, loss="damping"),
        CarrierKey("inertia", "kg m^2 about the pivot (slider: kg): what moves with psi", parameter=True),
        CarrierKey("mass", "kg: the mass gravity pulls on the carrier"),
        CarrierKey("rest", "rad (slider: m): the spring's rest coordinate"),
    )

    spec_keys: ClassVar[tuple[SpecKey, ...]] = (
        SpecKey("stiffness", "N m/rad (slider: N/m): the spring", default=0.0, check="non_negative"),
        SpecKey("damping", "N m s/rad (slider: N s/m): the damper", default=0.0, check="non_negative"),
        SpecKey("mass", "kg: pulley and arm (slider) mass that gravity pulls on", default=0.0, check="non_negative"),
        SpecKey(
            "preload", "N m (slider: N): spring torque (force) at the rest coordinate", default=0.0, check="finite"
        ),
        SpecKey("inertia", "kg m^2 about the pivot (slider: kg); default: from mass", check="positive"),
        SpecKey(
            "rest", "rad (slider: m): the spring's rest coordinate; default: the installed one", check="coordinate"
        ),
    )

    @classmethod
    def anchor(cls, values: Mapping[str, Any], center: tuple[float, float]) -> tuple[tuple[float, float], dict, float]:
        """Where the carrier sits at the drawn layout: its anchor (``PulleyParams.center``), its geometric numbers
        and the installed coordinate (numpy, from checked values). A kind built from a table defines it."""
        raise NotImplementedError(cls.__name__)

    @classmethod
    def dcenter_at(cls, numbers: Mapping[str, Any], psi) -> np.ndarray:
        """d(centre)/d(psi) at ``psi`` from the built numbers (numpy: statics of the drawn layout)."""
        raise NotImplementedError(cls.__name__)

    @classmethod
    def rest_of(cls, values: Mapping[str, Any]) -> float | None:
        """The spring's rest coordinate in model units (None: the installed one)."""
        return None if values["rest"] is None else float(values["rest"])

    @classmethod
    def default_inertia(cls, values: Mapping[str, Any], numbers: Mapping[str, Any]) -> float:
        """The inertia of psi when none is given (from the mass)."""
        return max(values["mass"], 1e-2)

    @classmethod
    def build(cls, values, center):
        origin, where, psi0 = cls.anchor(values, center)
        rest = cls.rest_of(values)
        inertia = values["inertia"] if values["inertia"] is not None else cls.default_inertia(values, where)
        numbers = dict(
            stiffness=values["stiffness"],
            preload=values["preload"],
            damping=values["damping"],
            inertia=inertia,
            mass=values["mass"],
            rest=psi0 if rest is None else rest,
            **where,
        )
        return Installed(cls(), origin, numbers, psi0)

    @classmethod
    def installed_load(cls, values: Mapping[str, Any], center: tuple[float, float]) -> float:
        """The spring's torque (force) on the carrier at installation, ``preload + stiffness (rest - installed)``."""
        psi0, rest = cls.anchor(values, center)[2], cls.rest_of(values)
        return values["preload"] + values["stiffness"] * ((psi0 if rest is None else rest) - psi0)

    def _m_eff(self, pp, k, h):
        n = self.numbers(pp, k)
        return n["inertia"] + h * n["damping"] + h * h * n["stiffness"]

    def generalised_force(self, pp: PulleyParams, k: int, psi, gravity):
        """Spring, preload and weight as a force on psi: minus the derivative of ``stored_energy``."""
        n = self.numbers(pp, k)
        gen_gravity = n["mass"] * jnp.sum(self.dcenter(pp, k, psi) * gravity, axis=-1)
        return n["preload"] - n["stiffness"] * (psi - n["rest"]) + gen_gravity

    def inverse_mass(self, pp, k, h):
        return 1.0 / self._m_eff(pp, k, h)

    def free_velocity(self, pp, k, psi, psi_dot, h, gravity):
        # M (psi_dot+ - psi_dot) = h [F - k h psi_dot+ - c psi_dot+]  (spring and damper implicit)
        force = self.generalised_force(pp, k, psi, gravity)
        return (self.numbers(pp, k)["inertia"] * psi_dot + h * force) / self._m_eff(pp, k, h)

    def stored_energy(self, pp, k, psi, gravity):
        n = self.numbers(pp, k)
        return (
            0.5 * n["stiffness"] * (psi - n["rest"]) ** 2
            - n["preload"] * psi
            - n["mass"] * jnp.sum(self.center(pp, k, psi) * gravity, -1)
        )

    def kinetic_energy(self, pp, k, psi_dot):
        return 0.5 * self.numbers(pp, k)["inertia"] * psi_dot**2

    def damping(self, pp, k):
        return self.numbers(pp, k)["damping"]

    def signals(self):
        return ((self.coordinate_quantity, lambda params, states, i, h: states.psi[:, i]),)

    @classmethod
    def quantities(cls):
        return (cls.coordinate_quantity, *cls.loss_quantities) if hasattr(cls, "coordinate_quantity") else ()
