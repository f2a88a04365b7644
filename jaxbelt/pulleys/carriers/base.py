"""The abstract carrier: what carries a pulley's centre, its coordinate ``psi`` and the terms it adds to a
step; and the movable carrier with one coordinate, a linear spring with preload, a damper and a weight.

A carrier kind is one final class in this room (``fixed.py``, ``arm.py``, ``slider.py``, ``clutch.py``; pivot
friction, stops and unloading damping wrap any movable carrier, ``lossy.py``) and one line in ``CARRIERS``
(``__init__.py``). ``DriveModel.carriers`` holds one instance per pulley (static); its numbers stay in the
``PulleyParams`` arrays, so a carrier method reads row ``k`` of them.
"""

from __future__ import annotations

import abc
from typing import TYPE_CHECKING, ClassVar

import equinox as eqx
import jax.numpy as jnp

if TYPE_CHECKING:  # _types imports this module
    from ..._types import PulleyParams

__all__ = ["AbstractCarrier", "AbstractHeldCarrier", "AbstractMovableCarrier"]


class AbstractCarrier(eqx.Module):
    """What carries a pulley's centre. Methods take the drive's ``PulleyParams``, the pulley index
    ``k`` and its coordinate ``psi`` (any leading batch shape ``...``)."""

    name: ClassVar[str]  # the config name ("fixed", "arm", "slider")
    movable: ClassVar[bool]  # False: psi stays 0 and the carrier terms are skipped
    coordinate: ClassVar[str | None]  # signal name of psi ("arm_angle", "travel"); None if not movable
    constrained: ClassVar[bool] = False  # a constraint impulse solved with the contacts (constraints.py)
    load_on_carrier: ClassVar[bool] = False  # the pulley's load acts on psi (a clutch's rotor), not the sheave
    rides_another: ClassVar[bool] = False  # the centre moves with another pulley's coordinate (coordinate_of)

    def coordinate_of(self, k: int) -> int:
        """The pulley whose coordinate ``psi`` moves pulley ``k``'s centre: its own, or another's where two
        pulleys ride one carrier (``pendulum.py``); ``center``/``dcenter`` receive that coordinate."""
        return k

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


class AbstractHeldCarrier(AbstractCarrier):
    """A carrier without a coordinate of its own (a fixed centre, a pendulum's second idler): nothing to integrate,
    no inertia seen by the impulses, no energy."""

    movable: ClassVar[bool] = False
    coordinate: ClassVar[str | None] = None

    def inverse_mass(self, pp, k, h):
        return jnp.zeros_like(pp.carrier_inertia[k])

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

    def _m_eff(self, pp, k, h):
        return pp.carrier_inertia[k] + h * pp.carrier_damping[k] + h * h * pp.spring[k]

    def generalised_force(self, pp: PulleyParams, k: int, psi, gravity):
        """Spring, preload and weight as a force on psi: minus the derivative of ``stored_energy``."""
        gen_gravity = pp.carrier_mass[k] * jnp.sum(self.dcenter(pp, k, psi) * gravity, axis=-1)
        return pp.preload[k] - pp.spring[k] * (psi - pp.rest[k]) + gen_gravity

    def inverse_mass(self, pp, k, h):
        return 1.0 / self._m_eff(pp, k, h)

    def free_velocity(self, pp, k, psi, psi_dot, h, gravity):
        # M (psi_dot+ - psi_dot) = h [F - k h psi_dot+ - c psi_dot+]  (spring and damper implicit)
        force = self.generalised_force(pp, k, psi, gravity)
        return (pp.carrier_inertia[k] * psi_dot + h * force) / self._m_eff(pp, k, h)

    def stored_energy(self, pp, k, psi, gravity):
        return (
            0.5 * pp.spring[k] * (psi - pp.rest[k]) ** 2
            - pp.preload[k] * psi
            - pp.carrier_mass[k] * jnp.sum(self.center(pp, k, psi) * gravity, -1)
        )

    def kinetic_energy(self, pp, k, psi_dot):
        return 0.5 * pp.carrier_inertia[k] * psi_dot**2
