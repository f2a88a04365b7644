"""Derived outputs: span tensions, contact force distributions with stick/slip zones, signals,
steady-state summaries and the creep-theory comparison. Post-processing of saved states,
vmapped over time; nothing here runs inside the time loop.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from ._ancf import shape_functions
from ._belt import element_coordinates
from ._contact import contact_points
from ._drive import Drive, _effective_offset, installed_state_definition
from ._layout import span_midpoints
from ._model import CARRIER_ARM, DriveState
from ._pulley import carrier_centers
from ._stepper import drive_operators
from ._theory import CreepTheory, two_pulley_creep

__all__ = ["FREE", "STICK", "SLIP", "span_names", "span_tensions", "contact_distribution", "signals", "summary",
           "creep_theory_for", "belt_tension_profile", "belt_direction"]

FREE, STICK, SLIP = 0, 1, 2


def span_names(drive: Drive) -> list[tuple[str, str]]:
    names = drive.model.pulley_names
    return [(names[i], names[(i + 1) % len(names)]) for i in range(len(names))]


def belt_direction(drive: Drive) -> dict:
    """How the belt runs: ``direction`` ("clockwise"/"counter-clockwise", seen with z toward the
    viewer), ``travel_order`` (pulley names from the first listed one), ``spans_in_travel_order``
    (True: the belt runs along each span from its first pulley to its second), ``tight_span`` and
    ``slack_span`` (entering and leaving the first driver; None without one) and each pulley's
    ``running_sense`` (+1 counter-clockwise, -1 clockwise)."""
    names = list(drive.model.pulley_names)
    k = len(names)
    along = int(round(float(drive.path.orientation))) == drive.travel
    seq = list(range(k)) if along else [0, *range(k - 1, 0, -1)]
    spans = [f"{a}-{b}" for a, b in span_names(drive)]
    roles = [p.role for p in drive.spec.pulleys]
    tight = slack = None
    if "driver" in roles:
        i = roles.index("driver")
        # span j runs between pulleys j and j+1: along the path it enters pulley j+1, against it pulley j
        tight, slack = (spans[(i - 1) % k], spans[i]) if along else (spans[i], spans[(i - 1) % k])
    return dict(direction="counter-clockwise" if drive.travel > 0 else "clockwise",
                travel_order=[names[i] for i in seq], spans_in_travel_order=along, tight_span=tight, slack_span=slack,
                running_sense={n: int(s) for n, s in zip(names, drive.running_sense)})


def belt_tension_profile(drive: Drive, q, v, params=None):
    """Axial force ``EA eps + eta A d(eps)/dt`` at every element midpoint, and those midpoints."""
    return _tension_profile(drive.model.n_elements, (drive.params if params is None else params).belt, q, v)


def _tension_profile(n_elements: int, bp, q, v):
    L = bp.stress_free_length / n_elements
    s, ds, _ = shape_functions(jnp.asarray([0.5]), L)
    e, ed = element_coordinates(q), element_coordinates(v)
    r = jnp.einsum("k,jkd->jd", s[0], e)
    rp = jnp.einsum("k,jkd->jd", ds[0], e)
    rpd = jnp.einsum("k,jkd->jd", ds[0], ed)
    stretch = jnp.sqrt(jnp.sum(rp * rp, -1))  # never 0 for a belt that exists
    rate = jnp.sum(rp * rpd, -1) / stretch
    return bp.EA * (stretch - 1.0) + bp.axial_damping * rate, r


@eqx.filter_jit
def _span_tensions(n_elements: int, bp, mid, q, v):
    def one(q, v):
        N, r = _tension_profile(n_elements, bp, q, v)
        d = jnp.sum((r[:, None, :] - mid[None]) ** 2, -1)  # (n, k)
        return N[jnp.argmin(d, axis=0)]

    return jax.vmap(one)(q, v)


def span_tensions(drive: Drive, states: DriveState) -> np.ndarray:
    """Tension ``(T, k)`` at the middle of each span (the element whose midpoint lies nearest)."""
    mid, _ = span_midpoints(drive.path)
    return np.asarray(_span_tensions(drive.model.n_elements, drive.params.belt, mid, states.q, states.v))


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

# A run whose contact-solver residual (last sweep's change / largest impulse) stays above this in
# the median step is flagged in the summary.
LCP_TOLERANCE = 1e-3


def contact_distribution(drive: Drive, state: DriveState, dt: float | None = None,
                         saturation: float = SATURATION) -> dict:
    """Normal and friction force per unit belt length on each pulley, by wrap angle, with states.

    Returns ``{pulley: {"angle_deg", "pressure", "friction", "state", "stick_arc_deg",
    "slip_arc_deg", "contact_arc_deg"}}``; angles are measured from the installed belt entry point
    in the direction of travel; ``pressure`` and ``friction`` in N/m; ``friction`` is the force on
    the belt along its travel direction; ``state`` is FREE / STICK / SLIP per contact point.
    """
    dt = drive.dt if dt is None else dt
    model, params = drive.model, drive.params
    r, seg, centers = (np.asarray(x) for x in _contact_geometry(model, params, state.q, state.psi))
    pulley = np.asarray(state.contact_pulley).astype(int)
    lam_n, lam_t = np.asarray(state.lam_n), np.asarray(state.lam_t)
    path = drive.path
    turn = np.asarray(path.turn)
    ffac = np.asarray(model.friction_factor)
    mu = float(params.mu)
    out = {}
    for p, name in enumerate(model.pulley_names):
        sel = pulley == p
        lever = r[sel] - centers[p]
        polar = np.arctan2(lever[:, 1], lever[:, 0])
        phi = np.mod(turn[p] * (polar - float(path.arrive_angle[p])), 2 * np.pi)
        pn = lam_n[sel] / (dt * seg[sel])
        # Friction on the belt along travel: tangent t = z x n is the CCW direction.
        ft = turn[p] * lam_t[sel] / (dt * seg[sel])
        bound = mu * ffac[p] * lam_n[sel]
        st = np.where(lam_n[sel] <= 0, FREE, np.where(np.abs(lam_t[sel]) >= saturation * bound, SLIP, STICK))
        radius = float(params.pulleys.radius[p])
        arc = np.degrees(seg[sel] / radius)
        order = np.argsort(phi)
        ang, st, arc = np.degrees(phi[order]), st[order], arc[order]
        out[name] = dict(angle_deg=ang, pressure=pn[order], friction=ft[order], state=st,
                         stick_arc_deg=_entry_stick_arc(ang, st), slip_arc_deg=float(arc[st == SLIP].sum()),
                         contact_arc_deg=float(arc[st != FREE].sum()),
                         wrap_deg=float(np.degrees(path.wrap_angle[p])))
    return out


def _entry_stick_arc(angle_deg: np.ndarray, state: np.ndarray) -> float:
    """Adhesion arc at the belt entry (points sorted by wrap angle; contact near 360 deg is the
    belt arriving early, counted as negative angle)."""
    ang = np.where(angle_deg > 270.0, angle_deg - 360.0, angle_deg)
    order = np.argsort(ang)
    ang, state = ang[order], state[order]
    touching = np.nonzero(state != FREE)[0]
    if touching.size == 0:
        return 0.0
    first = touching[0]
    slipping = np.nonzero(state[first:] == SLIP)[0]
    if slipping.size == 0:  # all sticking: the whole contact arc adheres
        return float(max(ang[touching[-1]], 0.0))
    k = first + slipping[0]
    if k == first:
        return 0.0
    return float(max(0.5 * (ang[k - 1] + ang[k]), 0.0))


def signals(drive: Drive, ts, states: DriveState) -> dict[str, np.ndarray]:
    """Time histories, named as in ``signals.csv``: ``t``, ``omega:<p>``, ``torque:<p>``,
    ``tension:<from>-<to>``, ``arm_angle:<tensioner>`` (and ``travel:<slider>``)."""
    out = {"t": np.asarray(ts)}
    omega, torque = np.asarray(states.omega), np.asarray(states.belt_torque)
    for i, name in enumerate(drive.model.pulley_names):
        out[f"omega:{name}"] = omega[:, i]
    for i, name in enumerate(drive.model.pulley_names):
        out[f"torque:{name}"] = torque[:, i]
    tens = span_tensions(drive, states)
    for k, (a, b) in enumerate(span_names(drive)):
        out[f"tension:{a}-{b}"] = tens[:, k]
    psi = np.asarray(states.psi)
    for i, (name, kind) in enumerate(zip(drive.model.pulley_names, drive.model.carrier_kind)):
        if kind == CARRIER_ARM:
            out[f"arm_angle:{name}"] = psi[:, i]
        elif kind != 0:
            out[f"travel:{name}"] = psi[:, i]
    return out


def creep_theory_for(drive: Drive, omega_driver: float | None = None) -> CreepTheory | None:
    """Creep theory for a two-pulley drive with one speed-driven driver and a torque/viscous load."""
    spec = drive.spec
    if len(spec.pulleys) != 2:
        return None
    roles = [p.role for p in spec.pulleys]
    if sorted(roles) != ["driven", "driver"]:
        return None
    i1, i2 = roles.index("driver"), roles.index("driven")
    d1, d2 = spec.pulleys[i1], spec.pulleys[i2]
    if (d1.speed is None and d1.speed_rpm is None) or any(p.tensioner is not None for p in spec.pulleys):
        return None
    pp = drive.params.pulleys
    # Final values of the laws (held after their last knot); numpy, no compiled evaluation needed.
    w1 = float(np.asarray(pp.speed.values)[i1, -1]) if omega_driver is None else omega_driver
    load = -drive.running_sense[i2] * float(np.asarray(pp.torque.values)[i2, -1])  # brake in its running sense
    R = np.asarray(pp.radius)
    D = float(np.linalg.norm(np.asarray(pp.center[i1]) - np.asarray(pp.center[i2])))
    bp = drive.params.belt
    mu = float(drive.params.mu) * drive.model.friction_factor[i1]
    return two_pulley_creep(radius_driver=float(R[i1]), radius_driven=float(R[i2]), center_distance=D,
                            EA=float(bp.EA), mass_per_length=float(bp.mass_per_length), mu=mu,
                            omega_driver=abs(w1), load_torque=max(load, 0.0), load_viscous=float(pp.viscous[i2]),
                            stress_free_length=float(bp.stress_free_length))


def installed_state(drive: Drive, params=None) -> dict:
    """What defined the belt's installed state (held when E, EA or a radius change) and both its values."""
    from ._parameters import get_parameter

    params = drive.params if params is None else params
    return dict(defined_by=drive.installed_by, pretension=float(get_parameter(drive, params, "belt.pretension")),
                stress_free_length=float(params.belt.stress_free_length))


def summary(drive: Drive, ts, states: DriveState, final: DriveState, window: float = 0.2,
            signals_: dict | None = None) -> dict:
    """Means over the final ``window`` fraction of the run, contact arcs at the end, theory beside."""
    ts = np.asarray(ts)
    sel = ts >= ts[-1] - window * (ts[-1] - ts[0])
    sig = signals(drive, ts, states) if signals_ is None else signals_
    names = drive.model.pulley_names
    pulleys = {}
    dist = contact_distribution(drive, jax.tree.map(lambda x: x[-1], states))
    for name, sense in zip(names, drive.running_sense):
        pulleys[name] = dict(omega_mean=float(sig[f"omega:{name}"][sel].mean()),
                             torque_mean=float(sig[f"torque:{name}"][sel].mean()),
                             stick_arc_deg=dist[name]["stick_arc_deg"], slip_arc_deg=dist[name]["slip_arc_deg"],
                             wrap_deg=dist[name]["wrap_deg"], running_sense=int(sense))
        if f"arm_angle:{name}" in sig:
            pulleys[name]["arm_angle_mean"] = float(sig[f"arm_angle:{name}"][sel].mean())
    spans = [dict(name=f"{a}-{b}", **{"from": a, "to": b},
                  tension_mean=float(sig[f"tension:{a}-{b}"][sel].mean())) for a, b in span_names(drive)]
    fault = int(final.fault)
    status = "ok" if fault == 0 else (
        f"diverged at t = {float(final.fault_time):.6g} s ("
        + ("non-finite state" if fault == 1 else "belt penetrated a pulley") + "): reduce solver.dt, "
        "raise solver.lcp_iterations, or soften contact.stiffness")
    res = np.asarray(states.lcp_residual)[sel]
    res_all = np.asarray(states.lcp_residual)
    warnings_ = []
    if res_all.size and float(np.median(res_all)) > LCP_TOLERANCE:
        warnings_.append(f"contact solver not converged: median relative residual {float(np.median(res_all)):.2g} "
                         f"> {LCP_TOLERANCE:g} (raise solver.lcp_iterations or lower solver.relaxation)")
    direction = belt_direction(drive)
    belt = {key: direction[key] for key in ("direction", "travel_order", "spans_in_travel_order",
                                                "tight_span", "slack_span")}
    out = dict(belt=belt, pulleys=pulleys, spans=spans, window_s=[float(ts[sel][0]), float(ts[-1])], status=status,
               lcp_residual_max=float(res.max()) if res.size else 0.0,
               lcp_residual_median=float(np.median(res_all)) if res_all.size else 0.0, warnings=warnings_)
    theory = creep_theory_for(drive)
    if theory is not None:
        out["creep_theory"] = theory.as_dict()
    # which key fixed the installed belt: pretension, stress_free_length or a poly-V effective_length
    installed = out.setdefault("belt", {}).setdefault("installed_state", {})
    installed["defined_by"] = installed_state_definition(drive.spec)
    installed.update(installed_state(drive))  # and, whatever defined it, the pretension and stress-free length
    if installed["defined_by"] == "effective_length":
        installed.update(effective_length=float(drive.spec.belt.effective_length),
                         effective_offset=_effective_offset(drive.spec.belt),
                         stress_free_length=float(drive.params.belt.stress_free_length))
    return out
