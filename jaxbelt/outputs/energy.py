"""Energy audit of a drive run: stored energy against the work of every force.

    E_stored = T_belt + U_elastic + V_gravity + T_pulleys + T_carriers + U_springs + V_carriers + U_contact
    E_stored(t) - E_stored(0) = W_pulleys + W_normal + W_friction - D_belt - D_mass - D_carrier
                                - D_carrier_friction - D_clutch + W_scaling

``W_pulleys`` is the work of motors, applied torques and viscous loads, ``W_normal`` and
``W_friction`` that of the contact impulses (penalty storage plus contact damping, and friction:
minus the slip dissipation), ``D_*`` the damping dissipations; ``D_carrier_friction`` that of tensioner
pivot friction, stops and unloading damping, ``D_clutch`` that of one-way clutches (engagement) and
decoupler dampers (``U_springs`` holds the decoupler springs), ``W_scaling`` that of the step's mass
scaling (``solver.implicit_stiffness``: ``-S (v+ - v)``, a numerical term of order h^2, reported so that
it is seen). Works are accumulated inside the step with mid-step velocities; the stored energy is
computed here from the saved states, so the balance is an independent check of the integrator
(explicit internal damping is booked at the start-of-step velocity: O(h) of its own, small, share).
"""

from __future__ import annotations

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..belt.ring import elastic_energy
from ..contact.kinematics import nearest_pulley, point_kinematics
from .._drive import Drive
from .._types import DriveModel, DriveParams, DriveState
from ..dynamics.kinetic import kinetic_energy
from ..dynamics.step import drive_operators
from ..pulleys.carrier import carrier_centers, carrier_stored_energy

__all__ = ["stored_energy", "energy_audit"]


@eqx.filter_jit
def _stored(model: DriveModel, params: DriveParams, states: DriveState):
    ops = drive_operators(model, params)
    pp = params.pulleys

    def one(s: DriveState):
        T = kinetic_energy(ops.belt.mass, s.v, model, pp, s.omega, s.psi_dot)
        U_el = elastic_energy(s.q, params.belt, ops.belt)
        V_g = -jnp.sum(ops.gravity * s.q)
        centers, _ = carrier_centers(model, pp, s.psi)
        U_spr = jnp.sum(carrier_stored_energy(model, pp, s.psi, params.gravity))
        if s.constraints is not None and pp.constraints is not None:  # decoupler springs (deflection 0 elsewhere)
            U_spr = U_spr + 0.5 * jnp.sum(pp.constraints.clutch_stiffness * s.constraints.deflection**2)
        rx, ry, stretch = point_kinematics(s.q, ops.contact)
        gap = nearest_pulley(rx, ry, centers, pp.radius).gap
        k_pt = params.contact_stiffness * jnp.tile(ops.contact.length, model.n_elements) * stretch
        U_c = 0.5 * jnp.sum(k_pt * jnp.minimum(gap, 0.0) ** 2)
        return jnp.stack([T.belt, U_el, V_g, T.pulleys, T.carriers, U_spr, U_c])

    return jax.vmap(one)(states)


def stored_energy(drive: Drive, states: DriveState) -> np.ndarray:
    """Stored energy terms per saved state ``(T, 7)``: belt kinetic, elastic, gravity, pulley spin,
    carrier kinetic, carrier springs/preload/gravity, contact penalty."""
    return np.asarray(_stored(drive.model, drive.params, states))


def energy_audit(drive: Drive, ts, states: DriveState, *, stored=None) -> dict:
    """Terms of the energy balance from t = 0 to the last saved state, and the residual.

    The residual is reported relative to the total work supplied by motors and applied torques.
    ``stored``: ``stored_energy(drive, states)`` if already computed.
    """
    E = stored_energy(drive, states) if stored is None else np.asarray(stored)
    dE = E[-1] - E[0]
    w = jax.tree.map(lambda x: float(np.asarray(x)[-1] - np.asarray(x)[0]), states.work)
    wp = np.asarray(states.pulley_work[-1]) - np.asarray(states.pulley_work[0])
    names = drive.model.pulley_names
    supplied = float(wp[wp > 0].sum())
    absorbed = float(-wp[wp < 0].sum())
    d_belt, d_mass, d_carrier, w_normal, w_friction = (
        w.belt_damping,
        w.mass_damping,
        w.carrier_damping,
        w.normal,
        w.friction,
    )
    d_contact_normal = -w_normal - float(dE[6])
    w_constraints = w.carrier_friction + w.clutch  # minus the dissipation of pivots, stops, clutches
    w_scaling = w.mass_scaling  # the mass scaling's work (implicit_stiffness; 0 without): O(h^2), no physics
    residual = float(dE.sum()) - (
        float(wp.sum()) + w_normal + w_friction + w_constraints + w_scaling - d_belt - d_mass - d_carrier
    )
    return dict(
        interval_s=[float(np.asarray(ts)[0]), float(np.asarray(ts)[-1])],
        pulley_work_J={n: float(x) for n, x in zip(names, wp)},
        work_supplied_J=supplied,
        work_absorbed_by_loads_J=absorbed,
        belt_damping_J=d_belt,
        mass_damping_J=d_mass,
        carrier_damping_J=d_carrier,
        friction_slip_J=-w_friction,
        carrier_friction_J=-w.carrier_friction,
        clutch_J=-w.clutch,
        contact_damping_J=d_contact_normal,
        mass_scaling_J=w_scaling,
        stored_change_J=dict(
            zip(
                [
                    "belt_kinetic",
                    "belt_elastic",
                    "belt_gravity",
                    "pulley_spin",
                    "carrier_kinetic",
                    "carrier_potential",
                    "contact_penalty",
                ],
                (float(x) for x in dE),
            )
        ),
        residual_J=residual,
        residual_relative=residual / max(supplied, 1e-300),
    )
