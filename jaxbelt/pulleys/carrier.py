"""Rigid pulleys on their carriers: the per-drive loops over pulleys (centres, free velocities, inverse
inertias, stored energy).

Each pulley has a rotation ``theta`` and a carrier coordinate ``psi`` (arm angle, slider travel;
unused for a fixed centre). Pulley and carrier are decoupled in inertia: the arm carries the
pulley's mass in its ``inertia``, and the pulley's spin is its own coordinate. The carrier kinds are
the room ``jaxbelt.pulleys.carriers``. The drives have a few pulleys: the functions below loop over them
in Python (unrolled at trace time).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Protocol

import jax
import jax.numpy as jnp
import numpy as np

from .carriers.constraints import AbstractClutchCarrier
from .excitation import pulley_laws
from .timelaw import evaluate

if TYPE_CHECKING:  # _types imports this module
    from .._types import DriveModel, PulleyParams

__all__ = [
    "PulleyMotion",
    "carrier_centers",
    "free_pulley_velocities",
    "loaded_velocity",
    "pulley_inverse_mass",
    "carrier_stored_energy",
    "carrier_damping",
    "without_losses",
    "at_coordinates",
    "to_coordinates",
    "carried_by",
    "take_carriers",
    "sum_onto_carriers",
]


def _stack(model: DriveModel, fn, axis=-1):
    """One value per pulley, stacked on ``axis``."""
    return jnp.stack([fn(c, k) for k, c in enumerate(model.carriers)], axis=axis)


def carrier_centers(model: DriveModel, pp: PulleyParams, psi):
    """Pulley centres ``(..., p, 2)`` and d(centre)/d(psi) ``(..., p, 2)``, each pulley's derivative with respect
    to the coordinate that carries it (``DriveModel.carrier_of``: its own, or the arm it rides)."""
    psi = at_coordinates(model, jnp.asarray(psi))
    center = _stack(model, lambda c, k: c.center(pp, k, psi[..., k]), axis=-2)
    dcenter = _stack(model, lambda c, k: c.dcenter(pp, k, psi[..., k]), axis=-2)
    return center, dcenter


def carried_by(model: DriveModel) -> tuple[int, ...] | None:
    """``DriveModel.carrier_of`` where some pulley rides another's carrier, else None (every pulley its own)."""
    return model.carrier_of if model.shared_carriers else None


def take_carriers(carrier_of: tuple[int, ...] | None, values):
    """Per pulley ``(..., p)``: the value of the carrier coordinate that carries it (``carried_by``)."""
    return values if carrier_of is None else values[..., np.asarray(carrier_of)]


def sum_onto_carriers(carrier_of: tuple[int, ...] | None, per_pulley):
    """Per-pulley generalised forces or impulses ``(..., p)`` (through each pulley's ``dcenter``) summed onto the
    coordinates that carry them (``carried_by``): a pendulum's second idler pushes its owner's arm."""
    if carrier_of is None:
        return per_pulley
    return jnp.zeros_like(per_pulley).at[..., np.asarray(carrier_of)].add(per_pulley)


def at_coordinates(model: DriveModel, values):
    """``take_carriers`` for ``model``."""
    return take_carriers(carried_by(model), values)


def to_coordinates(model: DriveModel, per_pulley):
    """``sum_onto_carriers`` for ``model``."""
    return sum_onto_carriers(carried_by(model), per_pulley)


def pulley_inverse_mass(model: DriveModel, pp: PulleyParams, h):
    """Effective inverse inertias seen by contact impulses within one step: spin ``1/(J + h c)`` (zero for
    speed-prescribed pulleys; ``c`` the viscous load where it acts on the sheave) and carrier (see
    ``AbstractCarrier.inverse_mass``).

    The viscous load is implicit (``loaded_velocity``), so it reacts to the impulses of the same step: with ``1/J``
    it acted at the free speed, before the belt's impulse, while the audit books it at the end-of-step speed. That
    took ``h c tau / J`` of the load's torque off (``tau`` the belt's torque): measured on a 2:1 reduction drive
    (Benchmark A's belt, c = 2 N m s, J = 0.01 kg m^2) a 6.5 W leak of the energy audit at 1e-4 s, the slack span
    +1.4 % from creep theory, both first order in the step."""
    kinematic = jnp.asarray(np.asarray(model.kinematic))
    on_rotor = np.array([c.load_on_carrier for c in model.carriers], dtype=bool)  # a clutch pulley: the rotor's
    sheave_viscous = jnp.where(jnp.asarray(on_rotor), 0.0, pp.viscous)
    inv_spin = jnp.where(kinematic, 0.0, 1.0 / (pp.inertia + h * sheave_viscous))
    inv_carrier = _stack(model, lambda c, k: c.inverse_mass(pp, k, h) * jnp.ones_like(pp.inertia[k]))
    return inv_spin, inv_carrier


class PulleyMotion(Protocol):
    """The pulleys' part of a step's state (``DriveState``, the spans tier's ``SpansState``): each pulley's
    rotation ``theta`` and spin ``omega``, each carrier's coordinate ``psi`` and its velocity ``psi_dot``."""

    @property
    def theta(self) -> jax.Array: ...

    @property
    def omega(self) -> jax.Array: ...

    @property
    def psi(self) -> jax.Array: ...

    @property
    def psi_dot(self) -> jax.Array: ...


def free_pulley_velocities(model: DriveModel, pp: PulleyParams, state: PulleyMotion, t, h, gravity):
    """Pulley spin and carrier velocities at the end of the step before contact impulses, from the pulleys'
    motion in ``state`` at the step's start ``t``.

    Viscous loads and carrier spring/damper are implicit (unconditionally stable); prescribed
    speeds take their value at the end of the step. Returns ``(omega_free, psi_dot_free, applied,
    prescribed)``.
    """
    theta, omega, psi, psi_dot = state.theta, state.omega, state.psi, state.psi_dot
    kinematic = jnp.asarray(np.asarray(model.kinematic))
    t1 = t + h
    if pp.excitation is None:
        prescribed = jax.vmap(evaluate, in_axes=(0, None))(pp.speed, t1)
        applied = jax.vmap(evaluate, in_axes=(0, None))(pp.torque, t1)
    else:  # laws over the crank angle (engine orders, angle tables)
        prescribed, applied = pulley_laws(pp.speed, pp.torque, pp.excitation, kinematic, theta, omega, t1, h)
    omega_free, spin_torque = loaded_velocity(model, pp.inertia, omega, applied, pp.viscous, h)
    omega_free = jnp.where(kinematic, prescribed, omega_free)
    psi_dot_free = _stack(
        model, lambda c, k: c.free_velocity(pp, k, psi[k], psi_dot[k], h, gravity) * jnp.ones_like(psi[k])
    )
    if any(c.load_on_carrier for c in model.carriers):  # static: clutch pulleys load their rotor
        on_rotor = jnp.asarray([c.load_on_carrier for c in model.carriers])
        rotor_inertia = _stack(
            model, lambda c, k: c.rotor_inertia(pp, k) if isinstance(c, AbstractClutchCarrier) else pp.inertia[k]
        )
        rotor, rotor_torque = loaded_velocity(model, rotor_inertia, psi_dot, applied, pp.viscous, h)
        psi_dot_free = jnp.where(on_rotor, rotor, psi_dot_free)
        omega_free = jnp.where(on_rotor & ~kinematic, omega, omega_free)
        spin_torque = jnp.where(on_rotor, rotor_torque, spin_torque)
    return omega_free, psi_dot_free, spin_torque, prescribed


def loaded_velocity(model: DriveModel, inertia, omega, applied, viscous, h):
    """Velocity after the applied torque and the viscous load (both implicit), and the torque that acted.

    A brake (``DriveModel.brake_sense``) is dissipative: a Coulomb torque of magnitude ``Q`` (the load in
    the running sense) that opposes the rotation and holds a standing pulley (true sticking, the
    backward-Euler projection): ``omega+ = sign(u) max(|u| - h Q, 0) / (I + h c)`` with ``u = I omega``.
    While the pulley turns faster than ``h Q / I`` this equals the constant torque; it never turns the
    pulley backwards (a constant torque would: an overloaded drive then ran in reverse). A negative load
    (the user's choice: driving) stays an active torque. Returns the torque consistent with the update,
    ``((I + h c) omega+ - I omega) / h`` (the energy audit's work)."""
    denom = inertia + h * viscous
    linear = (inertia * omega + h * applied) / denom
    if not model.brake_sense:  # static: no brakes in this drive
        return linear, applied
    sense = jnp.asarray(model.brake_sense, dtype=omega.dtype)
    braking = -sense * applied  # the load in the running sense; > 0 brakes
    u = inertia * omega
    held = jnp.sign(u) * jnp.maximum(jnp.abs(u) - h * braking, 0.0) / denom
    brake = (sense != 0.0) & (braking > 0.0)
    out = jnp.where(brake, held, linear)
    return out, jnp.where(brake, (denom * held - u) / h, applied)


def carrier_stored_energy(model: DriveModel, pp: PulleyParams, psi, gravity):
    """Per carrier ``(p,)``: spring, preload and gravity energy (kinetic: ``dynamics.kinetic``)."""
    return _stack(model, lambda c, k: c.stored_energy(pp, k, psi[k], gravity) * jnp.ones_like(psi[k]))


def carrier_damping(model: DriveModel, pp: PulleyParams):
    """Per carrier ``(p,)``: the viscous damping on its coordinate that the step integrates implicitly."""
    return _stack(model, lambda c, k: c.damping(pp, k) * jnp.ones_like(pp.inertia[k]))


def without_losses(model: DriveModel, pp: PulleyParams, losses: tuple[str, ...]) -> PulleyParams:
    """``pp`` with the carriers' numbers of the kinds ``losses`` (``CarrierKey.loss``: "friction", "damping")
    set to zero: the frictionless (undamped) carriers of a linearisation."""

    def one(c, n):
        zeroed = {key.name for key in c.keys if key.loss in losses}
        return {key: 0.0 * v if key in zeroed else v for key, v in n.items()}

    return dataclasses.replace(pp, carrier=tuple(one(c, n) for c, n in zip(model.carriers, pp.carrier)))
