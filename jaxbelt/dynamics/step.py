"""One time step of a belt drive (Moreau–Jean style, velocity level), as a chain of named stages.

    smooth forces -> free velocities -> contact frames -> impulses (the contact solve: Newton, or Jacobi
    sweeps on the Delassus diagonal) -> update -> carrier constraints -> work terms -> fault check

Each stage is a function returning a small record, testable alone. Sticking is exact (zero relative
tangential velocity at the end of the step) and the compliant normal law is implicit, so neither
friction nor contact stiffness limits the step; the belt's own axial waves (and explicit damping)
do, see ``stable_time_step``. The belt-only stages (shared with the free belt) are in ``stages``.

About 610 lines, over the usual 400: the stages of one step and their records read top to bottom in
the order they run, which is how the step is checked against the scheme; split over files, every
stage would need the records of the others.
"""

from __future__ import annotations

import typing

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._linalg import xy_components
from .._types import DriveModel, DriveParams, DriveState, Fault, WorkTerms
from ..belt.ring import BeltOperators, belt_operators, gravity_forces
from ..contact.kinematics import ContactFrame, ContactOperators, contact_operators, nearest_pulley, point_kinematics
from ..contact.coefficients import point_mu
from ..contact.sweeps import BodyCoupling, Delassus, PointProblem, SolveSettings, solve_contact, solve_contact_coupled
from .contact_newton import CarrierLaws, PulleyUnknowns, newton_contact
from ..pulleys.carrier import carried_by, carrier_centers, free_pulley_velocities, pulley_inverse_mass
from ..pulleys.carrier import carrier_damping, sum_onto_carriers, take_carriers
from ..pulleys.carriers.constraints import AbstractClutchCarrier, ConstraintState
from ..pulleys.timelaw import evaluate
from .constraint_stage import _cs, constraint_local, constraint_response, constraint_state, constraint_work
from .solver import FixedStepSolver
from ..belt.implicit import apply_blocks, from_node_vectors, node_vectors
from .stages import (
    MASS_SCALING_DISSIPATION,
    ImplicitBelt,
    SmoothForces,
    advance_belt,
    belt_free_velocity,
    belt_implicit_free_velocity,
    belt_smooth_forces,
)

__all__ = [
    "DriveOperators",
    "drive_operators",
    "drive_step",
    "MoreauJean",
    "MAX_PENETRATION_FRACTION",
    "Phase",
    "running_motion",
    "FreeVelocities",
    "ContactFrames",
    "DelassusDiagonal",
    "Impulses",
    "Update",
    "Work",
    "step_phase",
    "smooth_forces",
    "free_velocities",
    "contact_frames",
    "delassus_diagonal",
    "contact_impulses",
    "update",
    "work_terms",
    "StepStages",
    "entry_window",
    "ENTRY_WINDOW_ELEMENTS",
    "check_fault",
    "constraint_state",
]

# A point deeper than this fraction of its pulley's radius means the contact has failed.
MAX_PENETRATION_FRACTION = 0.05

Points = Float[Array, " nc"]
PerPulley = Float[Array, " p"]


@typing.final
class DriveOperators(eqx.Module):
    belt: BeltOperators
    contact: ContactOperators
    gravity: jax.Array  # nodal weight forces (n, 2, 2)


def drive_operators(model: DriveModel, params: DriveParams) -> DriveOperators:
    """Everything derived once per simulation from the model and parameters (traceable)."""
    n = model.n_elements
    quad = (model.axial_quadrature, model.bending_quadrature, model.damping_quadrature)
    bops = belt_operators(n, params.belt, *quad, kind=model.ring_operators)
    cops = contact_operators(n, model.contact_points_per_element, bops)
    return DriveOperators(belt=bops, contact=cops, gravity=gravity_forces(n, params.belt, bops, params.gravity))


@typing.final
class Phase(eqx.Module):
    """Settle phase (t < 0): pulleys locked, friction off, strong mass damping -> static equilibrium."""

    settling: jax.Array  # bool
    recording: jax.Array  # 0 while settling, else 1: works count from t = 0
    mass_damping: jax.Array  # belt mass damping [1/s] of this step


def step_phase(params: DriveParams, t, h) -> Phase:
    # Steps start on multiples of h and t = 0 falls on a step boundary (see simulate); the half-step margin
    # keeps rounding in the accumulated step times (which differs between compiled programs, e.g. batched
    # ones) from settling one more step: measured 0.3 % changes of the early transient that way.
    settling = t < -0.5 * h
    return Phase(
        settling=settling,
        recording=jnp.where(settling, 0.0, 1.0),
        mass_damping=jnp.where(settling, params.settle_damping, params.mass_damping),
    )


def running_motion(model: DriveModel, params: DriveParams, q):
    """A running start's target while settling (``DriveParams.start``): each pulley's spin and the belt's
    transport velocity along its current shape, at the belt speed the driver's law prescribes at t = 0.

    The belt's material runs at one stress-free rate ``s' = v / mean|r'|`` (steady running carries the same
    mass flux through every section): a node moves with ``s' r'``, its slope with ``s' dr'/ds`` (central
    differences of the nodal slopes over the stress-free element length)."""
    start = params.start
    assert start is not None
    pp = params.pulleys
    law = jax.tree.map(lambda x: x[start.driver], pp.speed)
    v = jnp.abs(evaluate(law, 0.0)) * pp.radius[start.driver]  # belt speed at the driver
    omega = start.sense * v / pp.radius
    slope = q[:, 1, :]
    rate = start.along * v / jnp.mean(jnp.sqrt(jnp.sum(slope * slope, axis=-1)))
    length = params.belt.stress_free_length / model.n_elements
    curl = (jnp.roll(slope, -1, axis=0) - jnp.roll(slope, 1, axis=0)) / (2.0 * length)
    return omega, xy_components(rate * jnp.stack([slope, curl], axis=1))


def smooth_forces(
    params: DriveParams, ops: DriveOperators, state: DriveState, implicit_damping: bool = False
) -> SmoothForces:
    return belt_smooth_forces(params.belt, ops.belt, ops.gravity, state.q, state.v, implicit_damping)


@typing.final
class FreeVelocities(eqx.Module):
    """Velocities at the end of the step before contact impulses, and the bodies' inverse inertias."""

    vx: jax.Array  # start-of-step belt velocity components
    vy: jax.Array
    belt_x: jax.Array  # free belt velocity components
    belt_y: jax.Array
    omega: PerPulley  # free pulley spins
    psi_dot: PerPulley  # free carrier velocities
    applied: PerPulley  # applied torques at the end of the step
    inv_spin: PerPulley  # inverse spin inertia seen by impulses (0: speed prescribed or settling)
    inv_carrier: PerPulley  # inverse carrier inertia within the step (0: fixed)
    damping_x: jax.Array | None = None  # implicit Kelvin-Voigt force C(q) v_free (DriveModel.implicit_damping)
    damping_y: jax.Array | None = None
    # DriveModel.implicit_stiffness: the factored belt operator W; contact impulses act through it
    implicit: ImplicitBelt | None = None


def free_velocities(
    model: DriveModel,
    params: DriveParams,
    ops: DriveOperators,
    state: DriveState,
    forces: SmoothForces,
    phase: Phase,
    t,
    h,
) -> FreeVelocities:
    vx, vy = xy_components(state.v)
    damping_x = damping_y = implicit = None
    if model.implicit_damping:
        shape = ops.contact.shape if model.implicit_stiffness else None
        imp = belt_implicit_free_velocity(params.belt, ops.belt, state.q, forces, vx, vy, h, phase.mass_damping, shape)
        vfx, vfy, damping_x, damping_y, implicit = imp.vx, imp.vy, imp.damping_x, imp.damping_y, imp.operator
    else:
        vfx, vfy = belt_free_velocity(ops.belt.mass_inv, forces, vx, vy, h, phase.mass_damping)
    omega_free, psi_dot_free, applied, _ = free_pulley_velocities(model, params.pulleys, state, t, h, params.gravity)
    inv_spin, inv_carrier = pulley_inverse_mass(model, params.pulleys, h)
    omega_settle = 0.0
    if params.start is not None:  # a running start: settle towards the transport motion, pulleys spinning
        omega_settle, (tx, ty) = running_motion(model, params, state.q)
        pull = jnp.where(phase.settling, h * phase.mass_damping / (1.0 + h * phase.mass_damping), 0.0)
        vfx, vfy = vfx + pull * tx, vfy + pull * ty  # the mass damping acts on v - transport
        rotor = np.array([isinstance(c, AbstractClutchCarrier) for c in model.carriers])
        if rotor.any():  # a clutch's rotor spins with its sheave
            psi_dot_free = jnp.where(phase.settling & rotor, omega_settle, psi_dot_free)
    return FreeVelocities(
        vx=vx,
        vy=vy,
        belt_x=vfx,
        belt_y=vfy,
        omega=jnp.where(phase.settling, omega_settle, omega_free),
        psi_dot=psi_dot_free,
        applied=applied,
        inv_spin=jnp.where(phase.settling, 0.0, inv_spin),
        inv_carrier=inv_carrier,
        damping_x=damping_x,
        damping_y=damping_y,
        implicit=implicit,
    )


def _at_points(pulley, values, n_pulleys):
    """Per-pulley values (p,) at the contact points (nc,): a select chain over the few pulleys."""
    out = jnp.broadcast_to(values[0], pulley.shape)
    for k in range(1, n_pulleys):
        out = jnp.where(pulley == k, values[k], out)
    return out


@typing.final
class ContactFrames(eqx.Module):
    """Each contact point's nearest pulley and geometry at the start-of-step positions."""

    frame: ContactFrame
    stretch: Points  # local belt stretch |r'|
    rx: Points  # point positions
    ry: Points
    dcx: Points  # d(centre)/d(psi) of the point's pulley
    dcy: Points
    n_pulleys: int = eqx.field(static=True)
    movable: bool = eqx.field(static=True)  # static: skip carrier terms when every carrier is fixed
    # per pulley, the pulley whose carrier coordinate moves it (DriveModel.carrier_of); None: its own
    carrier_of: tuple[int, ...] | None = eqx.field(static=True, default=None)

    def at_points(self, values):
        return _at_points(self.frame.pulley, values, self.n_pulleys)

    def to_pulleys(self, x):
        """Sum of per-point values (nc,) over each pulley's points (p,)."""
        owner = self.frame.pulley[:, None] == jnp.arange(self.n_pulleys, dtype=self.frame.pulley.dtype)  # (nc, p)
        return jnp.sum(jnp.where(owner, x[:, None], 0.0), axis=0)

    def carrier_at_points(self, values):
        """Per-coordinate values (p,) at each point: those of the coordinate that carries the point's pulley."""
        return self.at_points(take_carriers(self.carrier_of, values))

    def to_carriers(self, x):
        """Sum of per-point values (nc,) onto the carrier coordinates that move the points' pulleys (p,)."""
        return sum_onto_carriers(self.carrier_of, self.to_pulleys(x))

    def pulley_velocity(self, omega, psi_dot):
        """Velocity (x, y) of the pulley surface material at each contact point."""
        w = self.at_points(omega)
        ux, uy = -w * self.frame.ly, w * self.frame.lx
        if self.movable:
            pd = self.carrier_at_points(psi_dot)
            ux, uy = ux + self.dcx * pd, uy + self.dcy * pd
        return ux, uy

    def pulley_response(self, free: FreeVelocities, Px, Py):
        """Pulley spin / carrier velocity changes from belt impulses P (reaction -P on the pulley),
        and the torque impulse on each pulley."""
        lx, ly = self.frame.lx, self.frame.ly
        torque = -self.to_pulleys(lx * Py - ly * Px)
        if self.movable:
            d_psi_dot = free.inv_carrier * -self.to_carriers(self.dcx * Px + self.dcy * Py)
        else:
            d_psi_dot = jnp.zeros_like(free.inv_carrier)
        return free.inv_spin * torque, d_psi_dot, torque

    def relative_velocity(self, cops: ContactOperators, vx, vy, omega, psi_dot):
        """Belt minus pulley velocity at the points, in the normal and tangential directions."""
        px, py = self.pulley_velocity(omega, psi_dot)
        ux = cops.positions.apply(vx) - px
        uy = cops.positions.apply(vy) - py
        fr = self.frame
        return ux * fr.nx + uy * fr.ny, ux * fr.tx + uy * fr.ty


def contact_frames(model: DriveModel, params: DriveParams, ops: DriveOperators, state: DriveState) -> ContactFrames:
    centers, dcenter = carrier_centers(model, params.pulleys, state.psi)
    rx, ry, stretch = point_kinematics(state.q, ops.contact)
    fr = nearest_pulley(rx, ry, centers, params.pulleys.radius)
    n_p = model.n_pulleys
    return ContactFrames(
        frame=fr,
        stretch=stretch,
        rx=rx,
        ry=ry,
        dcx=_at_points(fr.pulley, dcenter[:, 0], n_p),
        dcy=_at_points(fr.pulley, dcenter[:, 1], n_p),
        n_pulleys=n_p,
        movable=model.any_movable,
        carrier_of=carried_by(model),
    )


@typing.final
class DelassusDiagonal(eqx.Module):
    """Diagonal of the contact operator G = W^T M^-1 W (normal and tangential), with mass splitting."""

    n: Points
    t: Points


def delassus_diagonal(
    ops: DriveOperators, state: DriveState, frames: ContactFrames, free: FreeVelocities
) -> DelassusDiagonal:
    # Mass splitting: a pulley shared by N active points counts N times, which keeps the Jacobi sweep
    # convergent even for idlers lighter than the belt they carry.
    fr = frames.frame
    active = (fr.gap < 0.0) | (state.lam_n > 0.0)
    split = frames.at_points(jnp.maximum(frames.to_pulleys(active.astype(fr.lx.dtype)), 1.0))
    lever_n = fr.lx * fr.ny - fr.ly * fr.nx
    lever_t = fr.lx * fr.ty - fr.ly * fr.tx
    spin_inv = frames.at_points(free.inv_spin)
    diag_n = ops.contact.coupling_diag + split * spin_inv * lever_n**2
    diag_t = ops.contact.coupling_diag + split * spin_inv * lever_t**2
    if frames.movable:
        carr_inv = frames.carrier_at_points(free.inv_carrier)
        if frames.carrier_of is not None:  # a carrier shared by two pulleys: split over both's points
            split = frames.carrier_at_points(jnp.maximum(frames.to_carriers(active.astype(fr.lx.dtype)), 1.0))
        diag_n = diag_n + split * carr_inv * (frames.dcx * fr.nx + frames.dcy * fr.ny) ** 2
        diag_t = diag_t + split * carr_inv * (frames.dcx * fr.tx + frames.dcy * fr.ty) ** 2
    return DelassusDiagonal(n=diag_n, t=diag_t)


@typing.final
class Impulses(eqx.Module):
    """Contact impulses of the step [N s] and the solver's last relative change."""

    n: Points
    t: Points
    residual: jax.Array
    # carrier constraints (pivot friction, stops, clutches; None when the drive has none): the impulse
    # per pulley and the spin / carrier velocity changes it causes
    carrier: PerPulley | None = None
    d_omega: PerPulley | None = None
    d_psi_dot: PerPulley | None = None

    def components(self, frames: ContactFrames):
        """The impulses on the belt in x and y."""
        return _xy(frames.frame, self.n, self.t)


def _xy(fr: ContactFrame, lam_n, lam_t):
    return lam_n * fr.nx + lam_t * fr.tx, lam_n * fr.ny + lam_t * fr.ty


def _point_law(model: DriveModel, params: DriveParams, ops: DriveOperators, frames: ContactFrames):
    """Each point's normal stiffness and damper [N/m, N s/m]: per unit length times the current belt
    length the point stands for."""
    seg = jnp.tile(ops.contact.length, model.n_elements) * frames.stretch
    return params.contact_stiffness * seg, params.contact_damping * seg


def _warm_start(state: DriveState, frames: ContactFrames):
    """The last step's impulses at the points still on the same pulley."""
    same = state.contact_pulley == frames.frame.pulley.astype(frames.frame.lx.dtype)
    return jnp.where(same, state.lam_n, 0.0), jnp.where(same, state.lam_t, 0.0)


def contact_impulses(
    model: DriveModel,
    params: DriveParams,
    ops: DriveOperators,
    state: DriveState,
    frames: ContactFrames,
    free: FreeVelocities,
    phase: Phase,
    h,
) -> Impulses:
    """The complementarity problem on the free velocities (warm-started from the last step's impulses): the
    implicit scheme's Newton solve, else Jacobi sweeps on the Delassus diagonal (``delassus_diagonal``)."""
    cops, fr = ops.contact, frames.frame
    u_free_n, u_free_t = frames.relative_velocity(cops, free.belt_x, free.belt_y, free.omega, free.psi_dot)

    def apply_G(lam_n, lam_t):
        Px, Py = _xy(fr, lam_n, lam_t)
        d_omega, d_psi_dot, _ = frames.pulley_response(free, Px, Py)
        wx, wy = frames.pulley_velocity(d_omega, d_psi_dot)
        if free.implicit is None:
            cx, cy = cops.coupling.apply_pair(Px, Py)
        else:  # the belt's response through the step's W (implicit_stiffness)
            cx, cy = free.implicit.at_points(free.implicit.response(Px, Py))
        dux, duy = cx - wx, cy - wy
        return dux * fr.nx + duy * fr.ny, dux * fr.tx + duy * fr.ty

    k_pt, d_pt = _point_law(model, params, ops, frames)
    problem = PointProblem(
        u_free_n=u_free_n,
        u_free_t=u_free_t,
        bias_n=k_pt * fr.gap / (h * k_pt + d_pt),
        compliance_n=1.0 / (h * h * k_pt + h * d_pt),
        mu=point_mu(model, params, frames.at_points, phase.settling),  # contact.mu or the pulley's own
        point_mass=1.0 / cops.coupling_diag,
        step=h,
    )
    settings = SolveSettings(
        iterations=model.lcp_iterations,
        relaxation=model.lcp_relaxation,
        friction_law=model.friction_law,
        friction_params=model.friction_law.coefficients(params),
        batched=model.batched,
    )
    if free.implicit is not None:  # the implicit scheme: Newton on belt and pulleys together
        return _newton_impulses(model, params, state, frames, free, problem, settings, h)
    warm = _warm_start(state, frames)
    diag = delassus_diagonal(ops, state, frames, free)
    G = Delassus(apply_G, diag.n, diag.t)
    if not model.constrained:
        lam_n, lam_t, residual = solve_contact(G, problem, warm, settings)
        return Impulses(n=lam_n, t=lam_t, residual=residual)

    def shift(lam_c):  # relative velocity change at the points from the carrier impulses
        wx, wy = frames.pulley_velocity(*constraint_response(model, params, lam_c, free))
        return -(wx * fr.nx + wy * fr.ny), -(wx * fr.tx + wy * fr.ty)

    def local(lam_n, lam_t):  # the carriers' exact impulses with the contacts frozen
        d_omega, d_psi_dot, _ = frames.pulley_response(free, *_xy(fr, lam_n, lam_t))
        return constraint_local(model, params, state, free, free.omega + d_omega, free.psi_dot + d_psi_dot, h)

    bodies = BodyCoupling(warm=_cs(state).impulse, shift=shift, local=local)
    lam_n, lam_t, lam_c, residual = solve_contact_coupled(G, problem, warm, settings, bodies)
    d_omega, d_psi_dot = constraint_response(model, params, lam_c, free)
    return Impulses(n=lam_n, t=lam_t, residual=residual, carrier=lam_c, d_omega=d_omega, d_psi_dot=d_psi_dot)


def _newton_impulses(
    model, params, state, frames: ContactFrames, free: FreeVelocities, problem: PointProblem, settings, h
):
    """``contact_impulses`` of the implicit scheme (``contact_newton``): same laws, same record."""
    laws = None
    if model.constrained:

        def local(env, omega, psi_dot):  # each carrier's exact impulse given the velocities without it
            p, s, f, h = env  # parameters, state, free velocities, step (derivatives stopped in the iteration)
            return constraint_local(model, p, s, f, omega, psi_dot, h)

        unit = constraint_response(model, params, jnp.ones_like(free.omega), free)
        laws = CarrierLaws(local=local, env=(params, state, free, h), direction=unit, warm=_cs(state).impulse)
    unknowns = PulleyUnknowns(
        spins=tuple(k for k in range(model.n_pulleys) if not model.kinematic[k]),
        carriers=tuple(k for k, c in enumerate(model.carriers) if c.movable or c.constrained),
    )
    warm = _warm_start(state, frames)
    lam_n, lam_t, lam_c, residual = newton_contact(frames, free, problem, warm, settings, unknowns, laws)
    if lam_c is None:
        return Impulses(n=lam_n, t=lam_t, residual=residual)
    d_omega, d_psi_dot = constraint_response(model, params, lam_c, free)
    return Impulses(n=lam_n, t=lam_t, residual=residual, carrier=lam_c, d_omega=d_omega, d_psi_dot=d_psi_dot)


@typing.final
class Update(eqx.Module):
    """End-of-step velocities and positions."""

    vx: jax.Array  # belt velocity components
    vy: jax.Array
    v: jax.Array  # (n, 2, 2)
    q: jax.Array
    omega: PerPulley
    psi_dot: PerPulley
    torque_impulse: PerPulley  # angular impulse of the belt on each pulley over the step


def update(
    ops: DriveOperators, state: DriveState, frames: ContactFrames, free: FreeVelocities, imp: Impulses, h
) -> Update:
    Px, Py = imp.components(frames)
    if free.implicit is None:
        bx, by = ops.contact.impulse_response.apply_pair(Px, Py)
    else:
        bx, by = from_node_vectors(free.implicit.response(Px, Py))
    vnx, vny = free.belt_x + bx, free.belt_y + by
    v_new, q_new = advance_belt(state.q, vnx, vny, h)
    d_omega, d_psi_dot, torque_impulse = frames.pulley_response(free, Px, Py)
    if imp.carrier is not None:
        d_omega, d_psi_dot = d_omega + imp.d_omega, d_psi_dot + imp.d_psi_dot
    return Update(
        vx=vnx,
        vy=vny,
        v=v_new,
        q=q_new,
        omega=free.omega + d_omega,
        psi_dot=free.psi_dot + d_psi_dot,
        torque_impulse=torque_impulse,
    )


# The entry window of a contact arc, in elements: its first ENTRY_WINDOW_ELEMENTS x points_per_element
# points, counted from the arc's upstream end (where the belt runs onto the pulley).
ENTRY_WINDOW_ELEMENTS = 1


def entry_window(model: DriveModel, frames: ContactFrames, lam_n: Points, omega: PerPulley) -> Points:
    """Which points lie in the entry window of their contact arc (bool): in contact this step (``lam_n > 0``)
    with one of the window's points upstream of them (towards where the belt comes from) free or on
    another pulley. Upstream is where the pulley's surface comes from: the ring's next point ``i + 1`` lies
    along the surface's motion, then the belt arrives from ``i - 1``. Stateless: the points are material, so
    the first J points of an arc are those that landed within the last J point spacings of travel."""
    fr = frames.frame
    on, p = lam_n > 0.0, fr.pulley
    dx, dy = jnp.roll(frames.rx, -1) - frames.rx, jnp.roll(frames.ry, -1) - frames.ry
    forward = frames.at_points(omega) * (fr.tx * dx + fr.ty * dy) >= 0.0
    held = on
    for k in range(1, ENTRY_WINDOW_ELEMENTS * model.contact_points_per_element + 1):
        before = jnp.roll(on, k) & (jnp.roll(p, k) == p)  # point i - k on the same pulley
        after = jnp.roll(on, -k) & (jnp.roll(p, -k) == p)
        held = held & jnp.where(forward, before, after)
    return on & ~held


@typing.final
class Work(eqx.Module):
    """Work terms accumulated to the end of the step."""

    work: WorkTerms
    pulley_work: PerPulley


class StepStages(typing.NamedTuple):
    """What a step's stages computed, read by the energy audit's terms."""

    forces: SmoothForces
    frames: ContactFrames
    free: FreeVelocities
    imp: Impulses
    new: Update
    constraints: ConstraintState | None = None


def work_terms(
    model: DriveModel, params: DriveParams, ops: DriveOperators, state: DriveState, stages: StepStages, phase: Phase, h
) -> Work:
    """Energy audit terms, with mid-step velocities: the ones the scheme's kinetic energy change uses
    (T+ - T = h v_mid . F). Contact impulses act at the start-of-step geometry on the relative velocity
    u = v_belt - v_pulley (linear in the velocities), so their work on belt and pulleys together is lam . u_mid.

    The entry term: the normal law's dissipation ``-lam u_mid - dU`` of the points in the entry window of their
    contact arc (``entry_window``), ``dU`` the change of a point's penalty energy ``k min(g, 0)^2 / 2`` over its
    stay in the window (booked when it enters and leaves; the same energy the audit's stored contact term
    sums, so with every contact point in the window the term is the audit's whole contact damping)."""
    forces, frames, free, imp, new, constraints = stages
    pp, rec = params.pulleys, phase.recording
    kin = jnp.asarray(np.asarray(model.kinematic))
    omega_mid = 0.5 * (state.omega + new.omega)
    psi_dot_mid = 0.5 * (state.psi_dot + new.psi_dot)
    motor = jnp.where(
        kin, pp.inertia * (new.omega - state.omega) / h - new.torque_impulse / h, free.applied - pp.viscous * new.omega
    )
    power = motor * omega_mid
    if any(c.load_on_carrier for c in model.carriers):  # static: a clutch pulley's load acts on its rotor
        on_rotor = jnp.asarray([c.load_on_carrier for c in model.carriers])
        power = jnp.where(on_rotor, (free.applied - pp.viscous * new.psi_dot) * psi_dot_mid, power)
    pulley_work = state.pulley_work + rec * h * power
    vmx, vmy = 0.5 * (free.vx + new.vx), 0.5 * (free.vy + new.vy)
    um_n, um_t = frames.relative_velocity(ops.contact, vmx, vmy, omega_mid, psi_dot_mid)
    M = ops.belt.mass
    w = state.work
    dissipation = forces.dissipation
    if free.damping_x is not None and free.damping_y is not None:  # implicit Kelvin-Voigt force at v_free
        dissipation = dissipation + jnp.dot(vmx, free.damping_x) + jnp.dot(vmy, free.damping_y)
    work = WorkTerms(
        belt_damping=w.belt_damping + rec * (dissipation * h),
        mass_damping=w.mass_damping
        + rec * (phase.mass_damping * (jnp.dot(M.apply(vmx), new.vx) + jnp.dot(M.apply(vmy), new.vy)) * h),
        carrier_damping=w.carrier_damping + rec * (jnp.sum(carrier_damping(model, pp) * new.psi_dot * psi_dot_mid) * h),
        normal=w.normal + rec * jnp.sum(imp.n * um_n),
        friction=w.friction + rec * jnp.sum(imp.t * um_t),
        carrier_friction=w.carrier_friction,
        clutch=w.clutch,
        mass_scaling=w.mass_scaling,
        contact_entry=w.contact_entry + rec * _entry_loss(model, params, ops, state, frames, imp, um_n),
    )
    if free.implicit is not None:  # Kelvin-Voigt force C v+ and the mass scaling's -S (v+ - (1 - eps) v), end of step
        vm, v_new = node_vectors(vmx, vmy), node_vectors(new.vx, new.vy)
        damped = h * jnp.sum(vm * apply_blocks(free.implicit.damping, v_new))
        v_old = (1.0 - MASS_SCALING_DISSIPATION) * node_vectors(free.vx, free.vy)  # its damping too
        scaled = -jnp.sum(vm * apply_blocks(free.implicit.scaling, v_new - v_old))
        work = eqx.tree_at(
            lambda x: (x.belt_damping, x.mass_scaling),
            work,
            (work.belt_damping + rec * damped, w.mass_scaling + rec * scaled),
        )
    if model.constrained:
        pivot, clutch = constraint_work(model, params, state, imp, constraints, omega_mid, psi_dot_mid)
        work = eqx.tree_at(
            lambda x: (x.carrier_friction, x.clutch), work, (w.carrier_friction + rec * pivot, w.clutch + rec * clutch)
        )
    return Work(work=work, pulley_work=pulley_work)


def _entry_loss(model, params, ops, state: DriveState, frames: ContactFrames, imp: Impulses, um_n):
    """The normal law's dissipation over the step at the points in their arc's entry window [J]: their normal
    work, and the penalty energy of the points that enter the window (+) and leave it (-) at this step's
    start, which sums each point's energy change over its stay in the window (start-of-step values only)."""
    k_pt, _ = _point_law(model, params, ops, frames)
    energy = 0.5 * k_pt * jnp.minimum(frames.frame.gap, 0.0) ** 2
    now = entry_window(model, frames, imp.n, state.omega)
    before = entry_window(model, frames, state.lam_n, state.omega)  # last step's window
    booked = jnp.where(now, -imp.n * um_n, 0.0) + jnp.where(now & ~before, energy, 0.0)
    return jnp.sum(booked - jnp.where(before & ~now, energy, 0.0))


def check_fault(state: DriveState, new: DriveState, frames: ContactFrames, radius, t) -> DriveState:
    """Fault detection: keep the last good state (so the history stays usable) and flag the time."""
    finite = jnp.all(jnp.isfinite(new.q)) & jnp.all(jnp.isfinite(new.v)) & jnp.all(jnp.isfinite(new.omega))
    too_deep = jnp.any(frames.frame.gap < -MAX_PENETRATION_FRACTION * frames.at_points(radius))
    # float() keeps the state's float code (a weak-typed Python float, as before).
    code = jnp.where(~finite, float(Fault.NONFINITE), jnp.where(too_deep, float(Fault.PENETRATION), float(Fault.OK)))
    first = (state.fault == Fault.OK) & (code != Fault.OK)
    frozen = eqx.tree_at(
        lambda s: (s.fault, s.fault_time),
        state,
        (jnp.where(state.fault != Fault.OK, state.fault, code), jnp.where(first, t, state.fault_time)),
    )
    # A conditional, not a select per leaf: one branch op instead of one op per state array.
    return jax.lax.cond((code != Fault.OK) | (state.fault != Fault.OK), lambda: frozen, lambda: new)


def drive_step(model: DriveModel, params: DriveParams, ops: DriveOperators, state: DriveState, t, h) -> DriveState:
    phase = step_phase(params, t, h)
    forces = smooth_forces(params, ops, state, model.implicit_damping)
    free = free_velocities(model, params, ops, state, forces, phase, t, h)
    frames = contact_frames(model, params, ops, state)
    imp = contact_impulses(model, params, ops, state, frames, free, phase, h)
    new = update(ops, state, frames, free, imp, h)
    constraints = constraint_state(model, params, state, free, imp, h)
    work = work_terms(model, params, ops, state, StepStages(forces, frames, free, imp, new, constraints), phase, h)
    stepped = DriveState(
        q=new.q,
        v=new.v,
        theta=state.theta + h * jnp.where(phase.settling, 0.0, new.omega),  # crank angle 0 at t = 0
        omega=new.omega,
        psi=state.psi + h * new.psi_dot,
        psi_dot=new.psi_dot,
        lam_n=imp.n,
        lam_t=imp.t,
        contact_pulley=frames.frame.pulley.astype(new.q.dtype),
        belt_torque=new.torque_impulse / h,
        lcp_residual=imp.residual,
        work=work.work,
        pulley_work=work.pulley_work,
        angular_impulse=state.angular_impulse + phase.recording * new.torque_impulse,
        fault=state.fault,
        fault_time=state.fault_time,
        constraints=constraints,
    )
    return check_fault(state, stepped, frames, params.pulleys.radius, t)


@typing.final
class MoreauJean(FixedStepSolver):
    """diffrax solver wrapping ``drive_step``; ``args = (model, params, ops)``.

    Fixed steps only (use ``diffrax.ConstantStepSize``): the stick/slip switch lives inside the
    step, which is what makes true sticking possible and what adaptive error control cannot see.
    One diffrax step is ``substeps`` Moreau–Jean steps of ``h / substeps`` (a ``lax`` loop): diffrax's
    per-step bookkeeping (saving, events, progress) then runs once per save interval instead of once
    per contact step - measured 20 us of a 90 us step on Benchmark A.
    """

    substeps: int = eqx.field(static=True, default=1)

    def advance(self, args, t0, h, y0):
        model, params, ops = args
        if self.substeps == 1:
            return drive_step(model, params, ops, y0, t0, h)
        hs = h / self.substeps

        def one(i, y):
            # the state's contact residual is the largest of this macro step's contact steps: a save ends a macro
            # step, which is its whole save interval up to MAX_SUBSTEPS steps (simulate._substeps)
            y1 = drive_step(model, params, ops, y, t0 + i * hs, hs)
            return eqx.tree_at(
                lambda s: s.lcp_residual, y1, jnp.maximum(y1.lcp_residual, jnp.where(i == 0, 0.0, y.lcp_residual))
            )

        return jax.lax.fori_loop(0, self.substeps, one, y0)
