"""The data types every room of jaxbelt shares: model, parameters, state, and named codes.

The three kinds of data, kept apart (as MuJoCo MJX keeps Model and Data apart).

* ``DriveModel``  - static: element count, contact-point layout, pulley roles and carriers,
  solver settings. Hashable; changing it recompiles.
* ``DriveParams`` - every float of the physics, a pytree of arrays: differentiate, vmap or shard
  over any leaf. Always passed as a function argument.
* ``DriveState``  - what changes in time: belt coordinates and velocities, pulley angles and
  speeds, carrier (tensioner arm / slider) coordinate, and the last step's contact impulses
  (warm start for the next solve, and the contact force output).

Named codes: the contact state of a belt point and the fault code of a run.

Both are ``IntEnum`` so they compare equal to (and mix into numpy / jnp expressions as) the plain
integers stored in arrays and files: ``state == ContactState.STICK`` on a ``contact_distribution``
array, ``DriveState.fault`` (a float: 0.0, 1.0, 2.0) against ``Fault.NONFINITE``.
"""

from __future__ import annotations

import enum
import typing

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import Array, Float

from .belt.ring import BeltParams
from .contact.friction import AbstractFrictionLaw, Coulomb
from .pulleys.carriers.base import AbstractCarrier
from .pulleys.excitation import Excitation
from .pulleys.carriers.constraints import ConstraintState
from .pulleys.timelaw import TimeLaw

__all__ = [
    "DriveModel",
    "DriveParams",
    "PulleyParams",
    "RunningStart",
    "DriveState",
    "WorkTerms",
    "ContactState",
    "Fault",
]


@typing.final
class DriveModel(eqx.Module):
    """Static description of a drive (compile-time constants)."""

    n_elements: int = eqx.field(static=True)
    pulley_names: tuple[str, ...] = eqx.field(static=True)
    kinematic: tuple[bool, ...] = eqx.field(static=True)  # speed prescribed (driver by speed)
    carriers: tuple[AbstractCarrier, ...] = eqx.field(static=True)  # one per pulley (pulleys/: fixed, arm, slider)
    wrap_side: tuple[int, ...] = eqx.field(static=True)  # +1 inner, -1 back side
    friction_factor: tuple[float, ...] = eqx.field(static=True)  # wedge factor 1/sin(beta/2) or 1
    # per pulley: its own friction coefficient (PulleyParams.mu) instead of DriveParams.mu; () = none has one
    own_mu: tuple[bool, ...] = eqx.field(static=True, default=())
    # per pulley: the running sense (+-1) of a brake (``load``/``power_kw``: dissipative, it stops the
    # pulley but never turns it backwards), 0.0 for an active torque; () = no pulley has a brake
    brake_sense: tuple[float, ...] = eqx.field(static=True, default=())
    contact_points_per_element: int = eqx.field(static=True, default=2)
    friction_law: AbstractFrictionLaw = eqx.field(static=True, default=Coulomb())  # _friction law (no numbers)
    lcp_iterations: int = eqx.field(static=True, default=8)
    lcp_relaxation: float = eqx.field(static=True, default=0.9)
    axial_quadrature: int = eqx.field(static=True, default=3)
    damping_quadrature: int = eqx.field(static=True, default=2)
    bending_quadrature: int = eqx.field(static=True, default=3)
    implicit_damping: bool = eqx.field(static=True, default=False)  # Kelvin-Voigt damping implicit (belt.implicit)
    # the step's belt mass scaled by theta h^2 K(q) (dynamics.stages.belt_implicit_free_velocity); implies
    # implicit_damping
    implicit_stiffness: bool = eqx.field(static=True, default=False)
    ring_operators: str = eqx.field(static=True, default="auto")  # belt.ring.OPERATOR_KINDS: dense/structured by n
    # the run is vmapped over many points and not reverse-differentiated (a sweep's, a duty study's): the Newton
    # contact solve skips its iterations once every point of the batch has converged (_branch.batch_cond)
    batched: bool = eqx.field(static=True, default=False)

    @property
    def n_pulleys(self) -> int:
        return len(self.pulley_names)

    @property
    def n_contacts(self) -> int:
        return self.n_elements * self.contact_points_per_element

    @property
    def movable(self) -> tuple[bool, ...]:
        """Per pulley: does its carrier move (tensioner arm, slider)?"""
        return tuple(c.movable for c in self.carriers)

    @property
    def constrained(self) -> bool:
        """Static: some carrier has a constraint impulse (pivot friction, stops, clutch)."""
        return any(c.constrained for c in self.carriers)

    @property
    def carrier_of(self) -> tuple[int, ...]:
        """Per pulley: the pulley whose carrier coordinate moves its centre (itself, but the second idler of a
        pendulum tensioner rides the first one's arm: ``pulleys.carriers.pendulum``)."""
        return tuple(c.coordinate_of(k) for k, c in enumerate(self.carriers))

    @property
    def shared_carriers(self) -> bool:
        """Static: some pulley rides another's carrier (its forces act on that coordinate)."""
        return self.carrier_of != tuple(range(self.n_pulleys))

    @property
    def any_movable(self) -> bool:
        """Static: the step skips every carrier term when no carrier moves."""
        return any(self.movable)


@typing.final
class PulleyParams(eqx.Module):
    """Per-pulley arrays (leading axis = pulley)."""

    radius: Float[Array, " p"]  # effective radius at the belt axis [m]
    center: Float[Array, "p 2"]  # fixed centre, arm pivot, or slider origin [m]
    inertia: Float[Array, " p"]  # polar inertia [kg m^2]
    speed: TimeLaw  # prescribed angular velocity [rad/s] (kinematic pulleys)
    torque: TimeLaw  # applied torque [N m], + in the sense of positive rotation
    viscous: Float[Array, " p"]  # viscous load coefficient [N m s/rad] (torque = -c omega)
    # one mapping per pulley: its carrier's numbers, keyed by the carrier's keys (``DriveModel.carriers[k].keys``;
    # a fixed pulley's is empty); scalars, a slider's direction a unit vector (2,)
    carrier: tuple[dict[str, Float[Array, "..."]], ...] = ()
    mu: Float[Array, " p"] | None = None  # own friction coefficients (where DriveModel.own_mu); None: none
    excitation: Excitation | None = None  # engine orders / laws over crank angle; None: laws of time only


@typing.final
class RunningStart(eqx.Module):
    """A run that starts at speed (``solver.start = "running"``): the settle phase spins every pulley at the
    belt speed its driver prescribes at t = 0 and pulls the belt towards that transport motion along its
    path instead of towards rest, so t = 0 finds belt and pulleys running (a duty point, not a start-up)."""

    sense: Float[Array, " p"]  # each pulley's running sense (+1 counter-clockwise)
    along: Float[Array, ""]  # +1: the belt travels towards increasing node numbers, -1 against them
    driver: int = eqx.field(static=True)  # the speed driver whose law at t = 0 sets the belt speed


@typing.final
class DriveParams(eqx.Module):
    belt: BeltParams
    pulleys: PulleyParams
    mu: Float[Array, ""]  # Coulomb friction coefficient (flat)
    contact_stiffness: Float[Array, ""]  # normal penalty stiffness per unit belt length [N/m^2]
    contact_damping: Float[Array, ""]  # normal penalty damping per unit belt length [N s/m^2]
    nu_s: Float[Array, ""]  # regularised-law steepness [s/m]
    gravity: Float[Array, "2"]  # [m/s^2]
    mass_damping: Float[Array, ""]  # Rayleigh mass-proportional belt damping [1/s] (air)
    settle_damping: Float[Array, ""]  # mass damping [1/s] during the settle phase (t < 0)
    # the friction law's own coefficients (its LawKey names, e.g. mu_kinetic); empty for Coulomb
    friction: dict[str, Float[Array, ""]] = eqx.field(default_factory=dict)
    start: RunningStart | None = None  # None: the run starts at rest (pulleys locked while settling)


@typing.final
class WorkTerms(eqx.Module):
    """Work accumulated since t = 0 [J] (scalars; see ``outputs.energy``)."""

    belt_damping: Float[Array, ""]  # dissipated by the belt's internal damping (Kelvin-Voigt, Rayleigh)
    mass_damping: Float[Array, ""]  # dissipated by mass-proportional damping (air)
    carrier_damping: Float[Array, ""]  # dissipated by the carriers' dampers
    normal: Float[Array, ""]  # work of the normal contact impulses
    friction: Float[Array, ""]  # work of the friction impulses (minus the slip dissipation)
    carrier_friction: Float[Array, ""]  # work of pivot friction, stops, unloading damping (minus their dissipation)
    clutch: Float[Array, ""]  # minus the dissipation of one-way clutches and decoupler dampers
    mass_scaling: Float[Array, ""]  # work of the mass-scaling term (implicit_stiffness; 0 without)
    # the normal contact law's dissipation at points in the entry window of their contact arc (the
    # landing loss of the discretisation, a part of -normal - penalty storage: see outputs.energy)
    contact_entry: Float[Array, ""]

    @classmethod
    def zeros(cls, dtype=None) -> WorkTerms:
        z = jnp.zeros((), dtype)
        return cls(
            belt_damping=z,
            mass_damping=z,
            carrier_damping=z,
            normal=z,
            friction=z,
            carrier_friction=z,
            clutch=z,
            mass_scaling=z,
            contact_entry=z,
        )


@typing.final
class DriveState(eqx.Module):
    q: Float[Array, "n 2 2"]
    v: Float[Array, "n 2 2"]
    theta: Float[Array, " p"]
    omega: Float[Array, " p"]
    psi: Float[Array, " p"]
    psi_dot: Float[Array, " p"]
    lam_n: Float[Array, " nc"]  # last step's normal impulses [N s]
    lam_t: Float[Array, " nc"]  # last step's tangential impulses [N s]
    contact_pulley: Float[Array, " nc"]  # pulley index each point was tested against (float: diffrax interpolates)
    belt_torque: Float[Array, " p"]  # torque the belt exerted on each pulley over the last step [N m]
    lcp_residual: Float[Array, ""]  # largest relative contact residual of the steps since the last save (macro step)
    work: WorkTerms  # dissipations and contact work accumulated since t = 0 [J]
    pulley_work: Float[Array, " p"]  # work of motors, applied torques and viscous loads on each pulley [J]
    angular_impulse: Float[Array, " p"]  # accumulated since t = 0: angular impulse of the belt on each pulley
    # [N m s] (its change over an interval / the interval = mean belt torque)
    fault: Float[Array, ""]  # a Fault code as a float: 0 OK, 1 NONFINITE, 2 PENETRATION (too deep)
    fault_time: Float[Array, ""]  # time of the first fault (inf if none)
    constraints: ConstraintState | None = None  # carrier constraint impulses (None: the drive has none)


class ContactState(enum.IntEnum):
    """State of a contact point: not touching, sticking, or slipping at the friction bound."""

    FREE = 0
    STICK = 1
    SLIP = 2

    @property
    def message(self) -> str:
        return _CONTACT_MESSAGES[self]


class Fault(enum.IntEnum):
    """Why a run stopped early (``DriveState.fault``); ``OK`` when it did not."""

    OK = 0
    NONFINITE = 1
    PENETRATION = 2  # belt penetrated a pulley by more than its allowance
    SAVES_LOST = 3  # the run went to its end without a fault but its saved history was not recorded

    @property
    def message(self) -> str:
        return _FAULT_MESSAGES[self]


_CONTACT_MESSAGES = {ContactState.FREE: "free", ContactState.STICK: "stick", ContactState.SLIP: "slip"}
_FAULT_MESSAGES = {
    Fault.OK: "ok",
    Fault.NONFINITE: "non-finite state",
    Fault.PENETRATION: "belt penetrated a pulley",
    Fault.SAVES_LOST: "saved history not recorded (the solver's save times failed its checks)",
}
