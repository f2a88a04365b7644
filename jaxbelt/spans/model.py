"""The spans tier's static model (travel order, running senses) and state, and its installed start."""

from __future__ import annotations

import typing

import equinox as eqx
import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

from .._drive import Drive
from .._types import DriveModel, DriveParams
from ..geometry.installed import arc_stress_free, travel_chain
from ..pulleys.carrier import carrier_centers
from ..geometry.path import belt_path

__all__ = ["SpansModel", "SpansState", "entry_direction", "initial_spans_state", "sliding_mu", "span_path", "turned"]


@typing.final
class SpansModel(eqx.Module):
    """Static part of the spans tier: the drive's model and the belt's travel order. Span ``j`` runs from
    pulley ``j`` to ``j + 1`` (model order); ``leave[i]`` / ``arrive[i]`` are the spans the belt leaves
    pulley ``i`` by and arrives on it from; ``source[j]`` / ``target[j]`` the pulleys span ``j`` comes from
    and goes to in the direction of travel."""

    model: DriveModel = eqx.field(static=True)
    leave: tuple[int, ...] = eqx.field(static=True)
    arrive: tuple[int, ...] = eqx.field(static=True)
    source: tuple[int, ...] = eqx.field(static=True)
    target: tuple[int, ...] = eqx.field(static=True)
    sense: tuple[float, ...] = eqx.field(static=True)  # running sense of each pulley (+1 counter-clockwise)
    orientation: int = eqx.field(static=True)  # the path's reading (as the build chose)
    driver: int = eqx.field(static=True)  # the first driver (its law at t = 0 sets a running start's speed)
    # the run is vmapped, not reverse-differentiated: rare branches taken by the whole batch (capstan_projection)
    batched: bool = eqx.field(static=True, default=False)

    @classmethod
    def of(cls, drive: Drive) -> SpansModel:
        leave, arrive, _, start = travel_chain(drive)
        k = drive.model.n_pulleys
        return cls(
            model=drive.model,
            leave=tuple(leave),
            arrive=tuple(arrive),
            source=tuple(leave.index(j) for j in range(k)),
            target=tuple(arrive.index(j) for j in range(k)),
            sense=tuple(float(s) for s in drive.running_sense),
            orientation=1 if float(drive.path.orientation) > 0 else -1,
            driver=start,
        )


@typing.final
class SpansState(eqx.Module):
    """What a step of the spans tier advances (per pulley ``p``, per span ``k``)."""

    theta: Float[Array, " p"]
    omega: Float[Array, " p"]
    psi: Float[Array, " p"]  # carrier coordinate (arm angle, travel; a clutch's rotor angle)
    psi_dot: Float[Array, " p"]
    free: Float[Array, " k"]  # stress-free length of each span [m]
    strain: Float[Array, " k"]
    tension: Float[Array, " k"]  # axial force (elastic + Kelvin-Voigt) [N]
    wrap: Float[Array, " p"]  # stress-free belt on each wrap, as booked by the last step [m]
    entry: Float[Array, " p"]  # tension of each wrap's adhesion arc (the arriving span's, lagged) [N]
    deflection: Float[Array, " p"]  # decoupler spring deflection [rad]
    slip: Float[Array, " p"]  # gross-slip flux through each wrap over the last step [m/s] (0: creep)
    belt_torque: Float[Array, " p"]  # belt's torque on each pulley at the step's start [N m], + counter-clockwise
    hub: Float[Array, "p 2"]  # belt's force on each pulley at the step's start [N]
    carrier_torque: Float[Array, " p"]  # constraint impulse / h of each carrier (pivot friction, stops, clutch)


def sliding_mu(model: DriveModel, params: DriveParams):
    """Per pulley the coefficient of its sliding arcs: its own or contact.mu, times its wedge factor, times
    mu_kinetic / mu under the static-kinetic law."""
    from ..contact.coefficients import pulley_mu

    ratio = params.friction["mu_kinetic"] / params.mu if "mu_kinetic" in params.friction else 1.0
    return pulley_mu(model, params) * ratio


def wrap_contents(sm: SpansModel, params: DriveParams, leaving, wrap_angle, *, entry):
    """Stress-free belt on each wrap by creep theory (adhesion at the ``entry`` tension, the change to the
    ``leaving`` tension over the slip arc at the exit; the contact's compliance taken off the radius), and the
    slip arcs [rad]; per pulley."""
    pp, belt = params.pulleys, params.belt
    mu = sliding_mu(sm.model, params)
    # one kernel for one wrap, vmapped over the pulleys (a Python loop was seven times the operations)
    arc = jax.vmap(arc_stress_free, in_axes=(0, 0, 0, 0, 0, None, None))
    content, slip_arc, _ = arc(pp.radius, wrap_angle, entry, leaving, mu, belt.EA, params.contact_stiffness)
    return content, slip_arc


def span_path(sm: SpansModel, params: DriveParams, psi):
    """The belt path and d(centre)/d(psi) at carrier coordinates ``psi``."""
    centers, dcenter = carrier_centers(sm.model, params.pulleys, psi)
    return belt_path(centers, params.pulleys.radius, sm.model.wrap_side, orientation=sm.orientation), dcenter


def span_geometry(sm: SpansModel, params: DriveParams, psi):
    """Span lengths, directions, wrap angles and d(centre)/d(psi) at carrier coordinates ``psi``."""
    path, dcenter = span_path(sm, params, psi)
    return path.span_length, path.span_dir, path.wrap_angle, dcenter


def entry_direction(sm: SpansModel, path):
    """Per pulley the unit vector from its centre to the point where the belt runs onto it (the tangent point
    of its arriving span): span ``j`` starts on pulley ``j`` and ends on ``j + 1``."""
    k = sm.model.n_pulleys
    on = [path.span_start[i] if sm.arrive[i] == i else path.span_end[(i - 1) % k] for i in range(k)]
    return (jnp.stack(on) - path.centers) / path.radii[:, None]


def turned(e0, e1):
    """The angle [rad] from unit vectors ``e0`` to ``e1`` (counter-clockwise positive), per row."""
    cross = e0[..., 0] * e1[..., 1] - e0[..., 1] * e1[..., 0]
    return jnp.arctan2(cross, jnp.sum(e0 * e1, axis=-1))


def initial_spans_state(drive: Drive, params: DriveParams | None = None, *, running: bool = False) -> SpansState:
    """The installed state (the statics' tensions and carrier positions), at rest or, ``running``, with every
    pulley at the surface speed the driver's law gives at t = 0 (creep left to the first steps)."""
    from ..analysis.statics import solve_statics

    params = drive.params if params is None else params
    sm = SpansModel.of(drive)
    p = drive.model.n_pulleys
    st = solve_statics(drive, params, jnp.zeros(p))
    T, psi = st["T"], st["psi"]
    L, _, phi, _ = span_geometry(sm, params, psi)
    free = L / (1.0 + T / params.belt.EA)
    wrap, _ = wrap_contents(sm, params, T[jnp.asarray(sm.leave)], phi, entry=T[jnp.asarray(sm.arrive)])
    zeros = jnp.zeros(p)
    omega = zeros
    if running:
        from ..pulleys.timelaw import evaluate

        R = params.pulleys.radius
        v = sm.sense[sm.driver] * evaluate(jax_index(params.pulleys.speed, sm.driver), 0.0) * R[sm.driver]
        omega = jnp.asarray(sm.sense) * v / R
    psi_dot = jnp.where(jnp.asarray([c.load_on_carrier for c in drive.model.carriers]), omega, 0.0)
    return SpansState(
        theta=zeros,
        omega=omega,
        psi=psi,
        psi_dot=psi_dot,
        free=free,
        strain=T / params.belt.EA,
        tension=T,
        wrap=wrap,
        entry=T[jnp.asarray(sm.arrive)],
        deflection=zeros,
        slip=zeros,
        belt_torque=zeros,
        hub=jnp.zeros((p, 2)),
        carrier_torque=zeros,
    )


def jax_index(law, i: int):
    """One pulley's law out of the stacked laws."""
    import jax

    return jax.tree.map(lambda x: x[i], law)
