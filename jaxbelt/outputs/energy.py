"""Energy audit of a drive run: stored energy against the work of every force.

    E_stored = T_belt + U_elastic + V_gravity + T_pulleys + T_carriers + U_springs + V_carriers + U_contact
    E_stored(t) - E_stored(0) = W_pulleys - D_contact + W_friction - D_belt - D_mass - D_carrier
                                - D_carrier_friction - D_clutch + W_scaling,   D_contact = -W_normal - dU_contact

``W_pulleys`` is the work of motors, applied torques and viscous loads, ``W_normal`` and
``W_friction`` that of the contact impulses on belt and pulleys (the normal work fills the penalty
storage and feeds the normal law's dissipation ``D_contact``; friction: minus the slip dissipation),
``D_*`` the damping dissipations; ``D_carrier_friction`` that of tensioner pivot friction, stops and
unloading damping, ``D_clutch`` that of one-way clutches (engagement) and decoupler dampers
(``U_springs`` holds the decoupler springs), ``W_scaling`` that of the step's mass scaling
(``solver.implicit_stiffness``: ``-S (v+ - v)``, a numerical term of order h^2, reported so that it is
seen). ``D_entry``, a part of ``D_contact``, is the normal law's dissipation at the points in the entry
window of their contact arcs (``dynamics.step.entry_window``): the landing loss of the discretisation.
Works are accumulated inside the step with mid-step velocities; the stored energy is computed here
from the saved states, so the balance is an independent check of the integrator (explicit internal
damping is booked at the start-of-step velocity: O(h) of its own, small, share).
"""

from __future__ import annotations

import math

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
from ..pulleys.carriers.constraints import AbstractConstrainedCarrier

__all__ = ["stored_energy", "energy_audit", "power_balance", "entry_loss_warning", "unclosed_share", "energy_status"]


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
        if s.constraints is not None:  # decoupler springs
            for k, c in enumerate(model.carriers):
                if isinstance(c, AbstractConstrainedCarrier):
                    U_spr = U_spr + c.spring_energy(pp, k, s.constraints.deflection[k])
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


def _changes(states: DriveState, E):
    """Stored-energy changes ``(7,)``, work changes (``WorkTerms``) and pulley work ``(p,)`` between the first
    and the last of ``states`` (stored energy terms ``E``); numpy or traced alike."""
    return (
        E[-1] - E[0],
        jax.tree.map(lambda x: x[-1] - x[0], states.work),
        states.pulley_work[-1] - states.pulley_work[0],
    )


def _residual(dE, w, wp):
    """The kinetic-energy theorem's residual: the penalty storage is on both sides (in dE and, through the
    normal work, in the contact damping), so it drops out."""
    w_constraints = w.carrier_friction + w.clutch  # minus the dissipation of pivots, stops, clutches
    # w.mass_scaling: the mass scaling's work (implicit_stiffness; 0 without): O(h^2), no physics
    return (dE.sum() - dE[6]) - (
        wp.sum()
        + w.normal
        + w.friction
        + w_constraints
        + w.mass_scaling
        - w.belt_damping
        - w.mass_damping
        - w.carrier_damping
    )


def _turned_over(dE, w, wp):
    """Every term of the balance but the residual (the closure check's scale: the largest of them)."""
    supplied, absorbed = jnp.sum(jnp.where(wp > 0, wp, 0.0)), -jnp.sum(jnp.where(wp < 0, wp, 0.0))
    d_contact_normal = -w.normal - dE[6]
    singles = [w.belt_damping, w.mass_damping, w.carrier_damping, w.friction, w.carrier_friction, w.clutch]
    return jnp.stack([supplied, absorbed, *dE, *singles, d_contact_normal, w.contact_entry, w.mass_scaling])


def unclosed_share(model: DriveModel, params: DriveParams, ends: DriveState):
    """``|residual|`` over the largest term of the balance between the two states ``ends`` (traceable: a sweep
    point's check, against ``ENERGY_TOLERANCE``); NaN when the state is."""
    dE, w, wp = _changes(ends, _stored(model, params, ends))
    scale = jnp.max(jnp.abs(_turned_over(dE, w, wp)))
    return jnp.abs(_residual(dE, w, wp)) / jnp.maximum(scale, jnp.finfo(scale.dtype).tiny)


def _balance(drive: Drive, states: DriveState, E: np.ndarray) -> dict:
    """The balance's terms [J] between the first and the last of ``states`` (stored energy terms ``E``)."""
    dE, w, wp = _changes(states, np.asarray(E))
    w = jax.tree.map(lambda x: float(np.asarray(x)), w)
    wp = np.asarray(wp)
    d_contact_normal = -w.normal - float(dE[6])
    residual = float(_residual(dE, w, wp))
    return dict(
        pulley_work={n: float(x) for n, x in zip(drive.model.pulley_names, wp)},
        supplied=float(wp[wp > 0].sum()),
        absorbed=float(-wp[wp < 0].sum()),
        belt_damping=w.belt_damping,
        mass_damping=w.mass_damping,
        carrier_damping=w.carrier_damping,
        friction_slip=-w.friction,
        carrier_friction=-w.carrier_friction,
        clutch=-w.clutch,
        contact_damping=d_contact_normal,
        contact_entry=w.contact_entry,
        mass_scaling=w.mass_scaling,
        stored=dict(zip(STORED_TERMS, (float(x) for x in dE))),
        residual=residual,
    )


STORED_TERMS = (
    "belt_kinetic",
    "belt_elastic",
    "belt_gravity",
    "pulley_spin",
    "carrier_kinetic",
    "carrier_potential",
    "contact_penalty",
)


def energy_audit(drive: Drive, ts, states: DriveState, *, stored=None) -> dict:
    """Terms of the energy balance from t = 0 to the last saved state, and the residual.

    The residual is reported relative to the total work supplied by motors and applied torques.
    ``contact_damping_J`` is the normal law's whole dissipation, ``contact_entry_J`` the part of it booked
    at points in the entry window of their contact arc (``dynamics.step.entry_window``: the landing loss of
    the discretisation). ``stored``: ``stored_energy(drive, states)`` if already computed.
    """
    E = stored_energy(drive, states) if stored is None else np.asarray(stored)
    b = _balance(drive, states, E)
    return dict(
        interval_s=[float(np.asarray(ts)[0]), float(np.asarray(ts)[-1])],
        pulley_work_J=b["pulley_work"],
        work_supplied_J=b["supplied"],
        work_absorbed_by_loads_J=b["absorbed"],
        belt_damping_J=b["belt_damping"],
        mass_damping_J=b["mass_damping"],
        carrier_damping_J=b["carrier_damping"],
        friction_slip_J=b["friction_slip"],
        carrier_friction_J=b["carrier_friction"],
        clutch_J=b["clutch"],
        contact_damping_J=b["contact_damping"],
        contact_entry_J=b["contact_entry"],
        mass_scaling_J=b["mass_scaling"],
        stored_change_J=b["stored"],
        residual_J=b["residual"],
        residual_relative=b["residual"] / max(b["supplied"], 1e-300),
    )


# A run whose energy audit leaves more than this share of the energy it turned over (the largest of the work
# supplied, absorbed, lost and stored) unaccounted did not resolve its motion: its status says so. Healthy runs
# close to 1e-7 (explicit) ... 2e-3 (implicit); an implicit run-up that went unstable at 2,800 rpm left 60 %.
ENERGY_TOLERANCE = 0.05


def energy_status(share: float, detail: str = "") -> str:
    """The status line of a run whose energy balance leaves ``share`` of its largest term unaccounted."""
    return (
        f"energy balance not closed: {detail}{share:.2g} of the energy turned over unaccounted "
        f"(> {ENERGY_TOLERANCE:g}): the time step did not resolve the motion (unstable); give a shorter "
        "solver.dt or raise solver.max_frequency"
    )


def energy_not_closed(audit: dict) -> str | None:
    """The status of a run whose energy balance does not close (``ENERGY_TOLERANCE``), else None."""
    terms = [audit["work_supplied_J"], audit["work_absorbed_by_loads_J"], *audit["stored_change_J"].values()]
    terms += [v for k, v in audit.items() if k.endswith("_J") and isinstance(v, float) and k != "residual_J"]
    scale = max((abs(float(x)) for x in terms), default=0.0)
    residual = float(audit["residual_J"])
    if not (abs(residual) > ENERGY_TOLERANCE * scale):  # NaN: the run's own fault says what happened
        return None
    return energy_status(abs(residual) / max(scale, 1e-300), f"{residual:.4g} J against {scale:.4g} J, ")


# A run warns when the entry (landing) loss exceeds this fraction of the power the drive takes in (what its
# drivers supply less what it stores: a prescribed driver's inertia swinging with an engine order over a window
# of a fractional number of cycles moves the supplied power by its stored energy's change, measured -2.3 kW of a
# 2.2 kW drive at 2,750 rpm).
ENTRY_LOSS_LIMIT = 1e-3
# The entry loss falls like the element length to this power (Benchmark A's belt, v/c = 0.7, 40 / 80 / 160
# elements: 2.3-2.7, see docs/outputs.md); the warning's element length assumes it.
ENTRY_LOSS_EXPONENT = 2.5


def power_balance(drive: Drive, ts, states: DriveState, *, stored=None) -> dict:
    """Mean powers [W] between the first and the last of ``states`` (the summary window's ends): what the
    drivers put in, what the loads take out, each loss, the stored energy's rate of change and the residual,

        d(E_stored)/dt = in - out - losses + residual.

    ``contact_normal_W`` is the normal law's dissipation outside the arcs' entry windows, ``contact_entry_W``
    inside them (the numerical landing loss); ``mass_scaling_W`` is the implicit scheme's O(h^2) term (its
    work counted as a loss when it takes energy out); ``delivered_W``, what the drive takes in (supplied less the
    stored energy's rate of change: the loads plus the losses, to the residual), is what ``entry_share`` is a share
    of. ``stored``: ``stored_energy(drive, states)``."""
    t = np.asarray(ts)
    dt = float(t[-1] - t[0])
    if dt <= 0.0:
        raise ValueError("a power balance needs two saved states at different times")
    E = stored_energy(drive, states) if stored is None else np.asarray(stored)
    b = _balance(drive, states, E)
    losses = dict(
        belt_damping_W=b["belt_damping"] / dt,
        mass_damping_W=b["mass_damping"] / dt,
        friction_slip_W=b["friction_slip"] / dt,
        contact_normal_W=(b["contact_damping"] - b["contact_entry"]) / dt,
        contact_entry_W=b["contact_entry"] / dt,
        carrier_damping_W=b["carrier_damping"] / dt,
        carrier_friction_W=b["carrier_friction"] / dt,
        clutch_W=b["clutch"] / dt,
        mass_scaling_W=-b["mass_scaling"] / dt,
    )
    supplied, stored = b["supplied"] / dt, sum(b["stored"].values()) / dt
    delivered = supplied - stored
    return dict(
        interval_s=[float(t[0]), float(t[-1])],
        supplied_W=supplied,
        absorbed_by_loads_W=b["absorbed"] / dt,
        losses=losses,
        stored_change_W=stored,
        residual_W=b["residual"] / dt,
        delivered_W=delivered,
        entry_share=losses["contact_entry_W"] / delivered if delivered > 0.0 else float("nan"),
    )


def entry_loss_warning(drive: Drive, balance: dict) -> str | None:
    """A warning when the entry loss exceeds ``ENTRY_LOSS_LIMIT`` of the delivered power, naming the element
    length (and count) that brings it below, by the loss's measured ~L_e^2.5; None otherwise."""
    share = balance["entry_share"]
    if not share > ENTRY_LOSS_LIMIT:  # also NaN: nothing supplied
        return None
    n, entry, delivered = drive.model.n_elements, balance["losses"]["contact_entry_W"], balance["delivered_W"]
    rest = delivered - entry  # what the drive would take in without it (a no-load drive: little)
    target = ENTRY_LOSS_LIMIT * (rest if rest > ENTRY_LOSS_LIMIT * delivered else delivered)
    needed = math.ceil(n * (entry / target) ** (1.0 / ENTRY_LOSS_EXPONENT))
    length = float(drive.params.belt.stress_free_length)
    return (
        f"numerical contact entry loss {entry:.3g} W is {100 * share:.2g} % of the "
        f"{delivered:.3g} W the drive takes in (more than {100 * ENTRY_LOSS_LIMIT:g} %): the belt's "
        f"contact points land on the pulleys instead of rolling onto them, a loss of the discretisation that falls "
        f"like the element length to the power {ENTRY_LOSS_EXPONENT:g}; elements of about "
        f"{1e3 * length / needed:.3g} mm ({needed} instead of {n}: belt.n_elements) bring it below "
        f"{100 * ENTRY_LOSS_LIMIT:g} %"
    )
