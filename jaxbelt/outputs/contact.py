"""Contact forces on the pulleys: the distribution over each wrap with its stick and slip zones,
and the stick/slip/contact arcs averaged over a window of saved states (numpy results, geometry
from compiled helpers)."""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ..contact.coefficients import pulley_mu
from ..contact.kinematics import contact_points
from .._drive import Drive
from .._types import ContactState, DriveState
from ..pulleys.carrier import carrier_centers
from ..dynamics.step import drive_operators

__all__ = ["FREE", "STICK", "SLIP", "SATURATION", "contact_distribution", "window_contact_arcs"]

# Aliases kept for existing code: the members themselves (IntEnum, equal to 0, 1, 2).
FREE, STICK, SLIP = ContactState.FREE, ContactState.STICK, ContactState.SLIP


@eqx.filter_jit
def _contact_geometry(model, params, q, psi):
    ops = drive_operators(model, params)
    r, stretch = contact_points(q, ops.contact)
    seg = jnp.tile(ops.contact.length, model.n_elements) * stretch
    centers, _ = carrier_centers(model, params.pulleys, psi)
    return r, seg, centers


# Friction at this fraction of mu*p counts as slip. At the leading edge of a slip arc the creep
# velocity is smaller than what one step can resolve (h * acceleration), so the LCP may stick
# a point there with friction just under the bound (measured: 99.2-99.9 % on Benchmark A).
SATURATION = 0.99


def contact_distribution(
    drive: Drive,
    state: DriveState,
    dt: float | None = None,
    saturation: float = SATURATION,
    *,
    geometry: tuple | None = None,
    mu=None,
    coefficients: dict | None = None,
) -> dict:
    """Normal and friction force per unit belt length on each pulley, by wrap angle, with states.

    Returns ``{pulley: {"angle_deg", "pressure", "friction", "state", "stick_arc_deg",
    "slip_arc_deg", "contact_arc_deg", "wrap_deg"}}``; angles are measured from the installed belt
    entry point in the direction of travel; ``pressure`` and ``friction`` in N/m; ``friction`` is
    the force on the belt along its travel direction; ``state`` is FREE / STICK / SLIP per contact
    point. The stick (slip) arc is the arc of the sticking (slipping) points within the installed
    wrap, wherever they lie in it; the contact arc counts all touching points (the belt touches a
    little before the entry and after the exit).

    ``geometry`` (``_contact_geometry`` of the state), ``mu`` (``pulley_mu``) and ``coefficients`` (the
    friction law's): as the run's post-processing program computed them (``outputs.derived``).
    """
    dt = drive.dt if dt is None else dt
    model, params = drive.model, drive.params
    if geometry is None:
        geometry = _contact_geometry(model, params, state.q, state.psi)
    r, seg, centers = (np.asarray(x) for x in geometry)
    pulley = np.asarray(state.contact_pulley).astype(int)
    lam_n, lam_t = np.asarray(state.lam_n), np.asarray(state.lam_t)
    path = drive.path
    turn, arrive = np.asarray(path.turn), np.asarray(path.arrive_angle)
    wraps, radii = np.asarray(path.wrap_angle), np.asarray(params.pulleys.radius)
    mu_eff = np.asarray(pulley_mu(model, params) if mu is None else mu)  # per pulley, wedge factor included
    out = {}
    for p, name in enumerate(model.pulley_names):
        sel = pulley == p
        lever = r[sel] - centers[p]
        polar = np.arctan2(lever[:, 1], lever[:, 0])
        phi = np.mod(turn[p] * (polar - float(arrive[p])), 2 * np.pi)
        pn = lam_n[sel] / (dt * seg[sel])
        # Friction on the belt along travel: tangent t = z x n is the CCW direction.
        ft = turn[p] * lam_t[sel] / (dt * seg[sel])
        bound = _slip_bound(model, params, mu_eff[p], lam_n[sel], coefficients)
        st = _contact_states(lam_n[sel], lam_t[sel], bound, saturation)
        radius = float(radii[p])
        arc = np.degrees(seg[sel] / radius)
        order = np.argsort(phi)
        ang, st, arc = np.degrees(phi[order]), st[order], arc[order]
        wrap = float(np.degrees(wraps[p]))
        within = ang <= wrap  # between the installed entry and exit (what creep theory's arcs count)
        out[name] = dict(
            angle_deg=ang,
            pressure=pn[order],
            friction=ft[order],
            state=st,
            stick_arc_deg=float(arc[within & (st == STICK)].sum()),
            slip_arc_deg=float(arc[within & (st == SLIP)].sum()),
            contact_arc_deg=float(arc[st != FREE].sum()),
            wrap_deg=wrap,
        )
    return out


@eqx.filter_jit
def _window_geometry(model, params, q, psi):
    """Belt length per contact point ``(T, nc)``, point positions ``(T, nc, 2)`` and pulley centres
    ``(T, p, 2)`` of stacked states."""
    ops = drive_operators(model, params)
    base = jnp.tile(ops.contact.length, model.n_elements)

    def one(q, psi):
        r, stretch = contact_points(q, ops.contact)
        return base * stretch, r, carrier_centers(model, params.pulleys, psi)[0]

    return jax.vmap(one)(q, psi)


def window_contact_arcs(
    drive: Drive,
    states: DriveState,
    select=None,
    saturation: float = SATURATION,
    *,
    geometry: tuple | None = None,
    mu=None,
    coefficients: dict | None = None,
) -> dict:
    """Stick, slip and contact arcs [deg] of each pulley, averaged over saved states.

    ``select`` picks the states (a boolean mask or indices; default all). In each state a pulley's
    stick (slip) arc is the arc covered by its sticking (slipping) contact points within the
    installed wrap (from the belt's entry point to its exit), as creep theory counts them; the mean
    over states does not hang on one state's contact pattern. ``contact_arc_deg`` is all of the
    contact, also where the belt touches a little before the entry or after the exit.
    Returns ``{pulley: {"stick_arc_deg", "slip_arc_deg", "contact_arc_deg"}}``. ``geometry``
    (``_window_geometry`` of the selected states), ``mu`` and ``coefficients``: as the run's
    post-processing program computed them (``outputs.derived``).
    """
    pick = (lambda x: x) if select is None else (lambda x: x[select])
    q = pick(states.q)
    out = {
        name: dict(stick_arc_deg=math.nan, slip_arc_deg=math.nan, contact_arc_deg=math.nan)
        for name in drive.model.pulley_names
    }
    if q.shape[0] == 0:
        return out
    if geometry is None:
        geometry = _window_geometry(drive.model, drive.params, q, pick(states.psi))
    seg, r, centers = (np.asarray(x) for x in geometry)
    pulley = np.asarray(pick(states.contact_pulley)).astype(int)
    pulley = np.clip(pulley, 0, None)  # -1 before the first step: no impulses there either
    lam_n, lam_t = np.asarray(pick(states.lam_n)), np.asarray(pick(states.lam_t))
    radius = np.asarray(drive.params.pulleys.radius)
    mu_p = np.asarray(pulley_mu(drive.model, drive.params) if mu is None else mu)
    bound = _slip_bound(drive.model, drive.params, mu_p[pulley], lam_n, coefficients)
    st = _contact_states(lam_n, lam_t, bound, saturation)
    arc = np.degrees(seg / radius[pulley])
    path = drive.path
    turn, arrive = np.asarray(path.turn)[pulley], np.asarray(path.arrive_angle)[pulley]
    wrap = np.degrees(np.asarray(path.wrap_angle))[pulley]
    lever = r - np.take_along_axis(centers, pulley[..., None], axis=1)
    phi = np.degrees(np.mod(turn * (np.arctan2(lever[..., 1], lever[..., 0]) - arrive), 2 * np.pi))
    within = phi <= wrap  # angles from the installed entry; beyond the exit or before the entry: outside
    for p, name in enumerate(drive.model.pulley_names):
        on = pulley == p
        out[name] = {
            key: float(np.mean(np.sum(np.where(on & mask, arc, 0.0), axis=1)))
            for key, mask in (
                ("stick_arc_deg", within & (st == STICK)),
                ("slip_arc_deg", within & (st == SLIP)),
                ("contact_arc_deg", st != FREE),
            )
        }
    return out


def _slip_bound(model, params, mu, lam_n, coefficients: dict | None = None):
    """Friction a sliding point carries at least, by the drive's law (numpy; ``mu`` per point;
    ``coefficients``: the law's, if already computed)."""
    coef = model.friction_law.coefficients(params) if coefficients is None else coefficients
    coef = {k: np.asarray(v) for k, v in coef.items()}
    return np.asarray(model.friction_law.slip_bound(lam_n, {"mu": mu, **coef}))


def _contact_states(lam_n, lam_t, bound, saturation: float = SATURATION):
    """FREE / STICK / SLIP of each contact point from its impulses and friction bound."""
    return np.where(lam_n <= 0, FREE, np.where(np.abs(lam_t) >= saturation * bound, SLIP, STICK))
