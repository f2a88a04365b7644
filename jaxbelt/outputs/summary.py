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

from ..belt.element import shape_functions
from ..belt.ring import element_coordinates
from ..contact.kinematics import contact_points
from .._drive import Drive
from ..geometry.path import span_midpoints
from .._types import CARRIER_ARM, DriveState
from ..pulleys.carrier import carrier_centers
from ..dynamics.step import drive_operators
from .theory import CreepTheory, two_pulley_creep
from .._types import ContactState, Fault

__all__ = ["FREE", "STICK", "SLIP", "span_names", "span_tensions", "contact_distribution", "signals", "summary",
           "creep_theory_for", "belt_tension_profile", "belt_direction", "window_contact_arcs", "guarded"]

# Aliases kept for existing code: the members themselves (IntEnum, equal to 0, 1, 2).
FREE, STICK, SLIP = ContactState.FREE, ContactState.STICK, ContactState.SLIP


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
    roles = [p.role for p in drive.pulleys]
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
    "slip_arc_deg", "contact_arc_deg", "wrap_deg"}}``; angles are measured from the installed belt
    entry point in the direction of travel; ``pressure`` and ``friction`` in N/m; ``friction`` is
    the force on the belt along its travel direction; ``state`` is FREE / STICK / SLIP per contact
    point. The stick (slip) arc is the arc of the sticking (slipping) points within the installed
    wrap, wherever they lie in it; the contact arc counts all touching points (the belt touches a
    little before the entry and after the exit).
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
        bound = _slip_bound(model, params, mu * ffac[p], lam_n[sel])
        st = _contact_states(lam_n[sel], lam_t[sel], bound, saturation)
        radius = float(params.pulleys.radius[p])
        arc = np.degrees(seg[sel] / radius)
        order = np.argsort(phi)
        ang, st, arc = np.degrees(phi[order]), st[order], arc[order]
        wrap = float(np.degrees(path.wrap_angle[p]))
        within = ang <= wrap  # between the installed entry and exit (what creep theory's arcs count)
        out[name] = dict(angle_deg=ang, pressure=pn[order], friction=ft[order], state=st,
                         stick_arc_deg=float(arc[within & (st == STICK)].sum()),
                         slip_arc_deg=float(arc[within & (st == SLIP)].sum()),
                         contact_arc_deg=float(arc[st != FREE].sum()), wrap_deg=wrap)
    return out


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
    if len(drive.pulleys) != 2:
        return None
    roles = [p.role for p in drive.pulleys]
    if sorted(roles) != ["driven", "driver"]:
        return None
    i1, i2 = roles.index("driver"), roles.index("driven")
    # a speed-driven driver (kinematic) and no tensioner (fixed carriers)
    if not drive.model.kinematic[i1] or any(kind != 0 for kind in drive.model.carrier_kind):
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
    from ..analysis.parameters import get_parameter

    params = drive.params if params is None else params
    return dict(defined_by=drive.installed_by, pretension=float(get_parameter(drive, params, "belt.pretension")),
                stress_free_length=float(params.belt.stress_free_length))


def guarded(warnings_: list, what: str, fn, default=None):
    """``fn()``, or ``default`` with a warning when it fails: a derived output (creep theory, contact
    arcs, plots) must never cost the results of a finished simulation."""
    try:
        return fn()
    except Exception as err:  # noqa: BLE001 - reported, not hidden: the message goes into the summary
        warnings_.append(f"{what} not computed: {type(err).__name__}: {' '.join(str(err).split())}")
        return default


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


def window_contact_arcs(drive: Drive, states: DriveState, select=None, saturation: float = SATURATION) -> dict:
    """Stick, slip and contact arcs [deg] of each pulley, averaged over saved states.

    ``select`` picks the states (a boolean mask or indices; default all). In each state a pulley's
    stick (slip) arc is the arc covered by its sticking (slipping) contact points within the
    installed wrap (from the belt's entry point to its exit), as creep theory counts them; the mean
    over states does not hang on one state's contact pattern. ``contact_arc_deg`` is all of the
    contact, also where the belt touches a little before the entry or after the exit.
    Returns ``{pulley: {"stick_arc_deg", "slip_arc_deg", "contact_arc_deg"}}``.
    """
    pick = (lambda x: x) if select is None else (lambda x: x[select])
    q = pick(states.q)
    out = {name: dict(stick_arc_deg=math.nan, slip_arc_deg=math.nan, contact_arc_deg=math.nan)
           for name in drive.model.pulley_names}
    if q.shape[0] == 0:
        return out
    seg, r, centers = (np.asarray(x) for x in _window_geometry(drive.model, drive.params, q, pick(states.psi)))
    pulley = np.asarray(pick(states.contact_pulley)).astype(int)
    pulley = np.clip(pulley, 0, None)  # -1 before the first step: no impulses there either
    lam_n, lam_t = np.asarray(pick(states.lam_n)), np.asarray(pick(states.lam_t))
    ffac = np.asarray(drive.model.friction_factor)
    radius = np.asarray(drive.params.pulleys.radius)
    bound = _slip_bound(drive.model, drive.params, float(drive.params.mu) * ffac[pulley], lam_n)
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
        out[name] = {key: float(np.mean(np.sum(np.where(on & mask, arc, 0.0), axis=1)))
                     for key, mask in (("stick_arc_deg", within & (st == STICK)),
                                       ("slip_arc_deg", within & (st == SLIP)),
                                       ("contact_arc_deg", st != FREE))}
    return out


def _slip_bound(model, params, mu, lam_n):
    """Friction a sliding point carries at least, by the drive's law (numpy; ``mu`` per point)."""
    coef = {k: np.asarray(v) for k, v in model.friction_law.coefficients(params).items()}
    return np.asarray(model.friction_law.slip_bound(lam_n, {"mu": mu, **coef}))


def _contact_states(lam_n, lam_t, bound, saturation: float = SATURATION):
    """FREE / STICK / SLIP of each contact point from its impulses and friction bound."""
    return np.where(lam_n <= 0, FREE, np.where(np.abs(lam_t) >= saturation * bound, SLIP, STICK))


# Plausibility limits of a finished run (see _implausible).
SLACK_FRACTION = 0.25        # highest span tension below this fraction of the installed tension: belt slack
LOST_CONTACT_FRACTION = 0.1  # mean contact arc below this fraction of the installed wrap: contact lost
SPEED_DEVIATION = 0.5        # |omega R - v| above this fraction of the belt speed v: not rolling with the belt
MIN_WRAP_DEG = 5.0           # wraps smaller than this are not checked for contact


def _installed_tension(drive: Drive) -> float:
    bp = drive.params.belt
    return float(bp.EA) * (float(drive.path.length) / float(bp.stress_free_length) - 1.0)


def _implausible(drive: Drive, states: DriveState, sel, pulleys: dict, spans: list) -> str | None:
    """What is physically implausible about a run that finished without a fault, and the fix."""
    found, fixes = [], []
    names = drive.model.pulley_names
    radius = np.asarray(drive.params.pulleys.radius)
    bp = drive.params.belt
    T0 = _installed_tension(drive)
    L = float(drive.path.length)
    v = np.asarray(states.v)[sel]
    speed = float(np.mean(np.linalg.norm(v[:, :, 0, :], axis=-1))) if v.size else 0.0  # nodes are evenly spaced
    tension = np.array([sp["tension_mean"] for sp in spans])
    if T0 > 0 and tension.size and tension.max() < SLACK_FRACTION * T0:
        found.append(f"the belt went slack: the span tensions ({', '.join(f'{t:.3g}' for t in tension)} N) all fell "
                     f"below {SLACK_FRACTION:.0%} of the installed tension {T0:.4g} N")
        fixes.append("check the pulley positions and radii and the tensioner preload")
    centrifugal = float(bp.mass_per_length) * speed**2
    low = [(sp["name"], sp["tension_mean"]) for sp in spans if sp["tension_mean"] < centrifugal]
    if low:
        found.append("negative effective tension (below the centrifugal term m v^2 = "
                     f"{centrifugal:.3g} N: the belt lifts off) in span "
                     + ", ".join(f"{n} ({t:.3g} N)" for n, t in low))
        fixes.append("raise belt.pretension or lower the speed")
    wrap = np.degrees(np.asarray(drive.path.wrap_angle))
    lost = [i for i, n in enumerate(names) if wrap[i] >= MIN_WRAP_DEG
            and pulleys[n]["contact_arc_deg"] < LOST_CONTACT_FRACTION * wrap[i]]
    if lost:
        found.append("the belt lost contact with "
                     + ", ".join(f"{names[i]!r} (installed wrap {wrap[i]:.3g} deg)" for i in lost))
        fixes.append("check that pulley's position and radius and the belt tension")
    kin = np.asarray(drive.model.kinematic)
    off = [(n, pulleys[n]["omega_mean"], speed / radius[i]) for i, n in enumerate(names)
           if not kin[i] and i not in lost and speed > 1e-3
           and abs(abs(pulleys[n]["omega_mean"]) * radius[i] - speed) > SPEED_DEVIATION * speed]
    if off:
        found.append(f"pulley speed far from rolling with the belt ({speed:.3g} m/s): " + ", ".join(
            f"{n!r} turns at {abs(w):.3g} rad/s instead of {k:.3g} rad/s" for n, w, k in off))
        fixes.append("gross slip: lower the load or raise belt.pretension or contact.mu; or the run is not steady "
                     "yet: run longer")
    if not found:
        return None
    element = L / drive.model.n_elements
    small = [i for i in range(len(names)) if element > 2.0 * radius[i]]
    if small:  # the likely cause: contact is tested at points, a tiny pulley fits between them
        fixes = [f"the belt elements ({1e3 * element:.3g} mm) are longer than twice the radius of "
                 + ", ".join(f"{names[i]!r} ({1e3 * radius[i]:.3g} mm)" for i in small)
                 + f", so the belt's contact points can step over it: use a realistic radius or at least "
                 f"{math.ceil(2 * L / radius[small].min())} elements (belt.n_elements)"]
    return "; ".join(found) + " - " + "; ".join(fixes)


def summary(drive: Drive, ts, states: DriveState, final: DriveState, window: float = 0.2,
            signals_: dict | None = None) -> dict:
    """Means over the final ``window`` fraction of the run (speeds, torques, tensions, contact arcs),
    the status, warnings, and creep theory beside.

    Torques are the belt's angular impulse over the window divided by its length (every step
    counts, not only the saved ones); ``torque_std`` is the spread of the same average over each
    save interval. Stick and slip arcs are means over the saved states in the window
    (``window_contact_arcs``). A run that finished without a fault but whose result is physically
    implausible (slack belt, lost contact, a pulley not rolling with the belt) gets a status saying
    so. A derived output that fails (e.g. creep theory) becomes an entry of ``warnings``.
    """
    ts = np.asarray(ts)
    sel = ts >= ts[-1] - window * (ts[-1] - ts[0])
    warnings_ = []
    sig = signals(drive, ts, states) if signals_ is None else signals_
    names = drive.model.pulley_names
    arcs = guarded(warnings_, "stick/slip arcs", lambda: window_contact_arcs(drive, states, sel),
                   {n: dict(stick_arc_deg=math.nan, slip_arc_deg=math.nan, contact_arc_deg=math.nan) for n in names})
    t_w = ts[sel]
    J = np.asarray(states.angular_impulse)[sel]
    wrap = np.degrees(np.asarray(drive.path.wrap_angle))
    pulleys = {}
    for i, name in enumerate(names):
        if t_w.size >= 2 and t_w[-1] > t_w[0]:
            torque_mean = float((J[-1, i] - J[0, i]) / (t_w[-1] - t_w[0]))
            torque_std = float(np.std(np.diff(J[:, i]) / np.diff(t_w)))
        else:  # one saved state: its last step's torque
            torque_mean, torque_std = float(sig[f"torque:{name}"][sel].mean()), 0.0
        pulleys[name] = dict(omega_mean=float(sig[f"omega:{name}"][sel].mean()), torque_mean=torque_mean,
                             torque_std=torque_std, stick_arc_deg=arcs[name]["stick_arc_deg"],
                             slip_arc_deg=arcs[name]["slip_arc_deg"], contact_arc_deg=arcs[name]["contact_arc_deg"],
                             wrap_deg=float(wrap[i]), running_sense=int(drive.running_sense[i]))
        if f"arm_angle:{name}" in sig:
            pulleys[name]["arm_angle_mean"] = float(sig[f"arm_angle:{name}"][sel].mean())
    spans = [dict(name=f"{a}-{b}", **{"from": a, "to": b},
                  tension_mean=float(sig[f"tension:{a}-{b}"][sel].mean())) for a, b in span_names(drive)]
    fault = Fault(int(final.fault))
    status = fault.message if fault == Fault.OK else (
        f"diverged at t = {float(final.fault_time):.6g} s ({fault.message}): reduce solver.dt, "
        "raise solver.lcp_iterations, or soften contact.stiffness")
    if fault == Fault.OK and t_w.size:
        found = guarded(warnings_, "plausibility checks", lambda: _implausible(drive, states, sel, pulleys, spans))
        if found:
            status = "implausible result: " + found
    res = np.asarray(states.lcp_residual)[sel]
    res_all = np.asarray(states.lcp_residual)
    if res_all.size and float(np.median(res_all)) > LCP_TOLERANCE:
        warnings_.append(f"contact solver not converged: median relative residual {float(np.median(res_all)):.2g} "
                         f"> {LCP_TOLERANCE:g} (raise solver.lcp_iterations or lower solver.relaxation)")
    direction = belt_direction(drive)
    belt = {key: direction[key] for key in ("direction", "travel_order", "spans_in_travel_order",
                                                "tight_span", "slack_span")}
    out = dict(belt=belt, pulleys=pulleys, spans=spans, window_s=[float(ts[sel][0]), float(ts[-1])], status=status,
               lcp_residual_max=float(res.max()) if res.size else 0.0,
               lcp_residual_median=float(np.median(res_all)) if res_all.size else 0.0, warnings=warnings_)
    theory = guarded(warnings_, "creep theory", lambda: creep_theory_for(drive))
    if theory is not None:
        out["creep_theory"] = theory.as_dict()
    # which key fixed the installed belt: pretension, stress_free_length or a poly-V effective_length
    installed = out.setdefault("belt", {}).setdefault("installed_state", {})
    installed["defined_by"] = drive.installed_by
    installed.update(installed_state(drive))  # and, whatever defined it, the pretension and stress-free length
    if installed["defined_by"] == "effective_length":
        installed.update(effective_length=drive.effective_length, effective_offset=drive.effective_offset,
                         stress_free_length=float(drive.params.belt.stress_free_length))
    return out
