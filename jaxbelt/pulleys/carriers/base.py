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
from typing import TYPE_CHECKING, ClassVar

import equinox as eqx
import jax.numpy as jnp

if TYPE_CHECKING:  # _types imports this module
    from ..._types import PulleyParams

__all__ = ["AbstractCarrier", "AbstractHeldCarrier", "AbstractMovableCarrier", "CarrierKey"]


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
    keys: ClassVar[tuple[CarrierKey, ...]] = (
        CarrierKey("stiffness", "N m/rad (slider: N/m): the spring", parameter=True),
        CarrierKey("preload", "N m (slider: N): the spring's torque (force) at its rest coordinate", parameter=True),
        CarrierKey("damping", "N m s/rad (slider: N s/m): the damper", parameter=True, loss="damping"),
        CarrierKey("inertia", "kg m^2 about the pivot (slider: kg): what moves with psi", parameter=True),
        CarrierKey("mass", "kg: the mass gravity pulls on the carrier"),
        CarrierKey("rest", "rad (slider: m): the spring's rest coordinate"),
    )

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
