"""Steady-state summary of a run: means over a final window (speeds, torques, span tensions, contact
arcs), the belt's direction of travel, plausibility checks, the contact-solver residual and creep
theory beside. Post-processing of saved states; nothing here runs inside the time loop. The signals
come from the registry (``signals.py``), the contact arcs from ``contact.py``.
"""

from __future__ import annotations

import math
import typing
from typing import TYPE_CHECKING

import numpy as np

from .._drive import Drive
from ..contact.coefficients import pulley_mu
from .._types import DriveState
from .fead import fead_summary
from .contact import FREE, SATURATION, SLIP, STICK, contact_distribution, window_contact_arcs
from .window import summary_window
from .signals import signals, span_names, span_tensions
from .steadiness import steadiness
from .theory import CreepTheory, effective_tension, mass_per_current_length, two_pulley_creep
from .._types import Fault

if TYPE_CHECKING:
    from .derived import Derived

__all__ = [
    "FREE",
    "STICK",
    "SLIP",
    "SATURATION",
    "span_names",
    "span_tensions",
    "contact_distribution",
    "signals",
    "summary",
    "creep_theory_for",
    "belt_direction",
    "window_contact_arcs",
    "guarded",
    "installed_state",
]


def step_remedy(drive) -> str:
    """How to shorten the step of ``drive``: the implicit scheme's own choice goes through solver.max_frequency
    (its stability on light pulleys riding on a tensioner arm is limited: docs/config.md)."""
    if drive.model.implicit_stiffness and drive.spec.solver.dt is None:
        return f"raise solver.max_frequency (the step {drive.dt:.3g} s: {drive.dt_reason}) or give a shorter solver.dt"
    return "reduce solver.dt"


def belt_direction(drive: Drive) -> dict:
    """How the belt runs: ``direction`` ("clockwise"/"counter-clockwise", seen with z toward the
    viewer), ``travel_order`` (pulley names from the first listed one), ``spans_in_travel_order``
    (True: the belt runs along each span from its first pulley to its second), ``tight_span`` and
    ``slack_span`` (entering and leaving the first driver; None without one; a run's summary swaps them where
    the window's mean tensions say the driver is driven back) and each pulley's
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
    return dict(
        direction="counter-clockwise" if drive.travel > 0 else "clockwise",
        travel_order=[names[i] for i in seq],
        spans_in_travel_order=along,
        tight_span=tight,
        slack_span=slack,
        running_sense={n: int(s) for n, s in zip(names, drive.running_sense)},
    )


# A run whose contact-solver residual (last sweep's change / largest impulse) stays above this in
# the median step is flagged in the summary's status; one whose window has a step above it, in its warnings.
LCP_TOLERANCE = 1e-3


def creep_theory_for(
    drive: Drive, omega_driver: float | None = None, *, mu=None, compliant: bool = True
) -> CreepTheory | None:
    """Creep theory for a two-pulley drive whose driven pulley carries a torque/viscous load (``mu``: each
    pulley's ``pulley_mu``, if already computed). The driver's speed: ``omega_driver``, else the final
    value of its speed law; a torque-driven driver has none, and without ``omega_driver`` (e.g. the
    run's mean) there is no theory. ``creep_theory_absent`` says why a two-pulley drive has none.
    ``compliant``: with the contact's compliance, as the ANCF belt has it (False: rigid pulleys, as the spans
    tier's wraps)."""
    if creep_theory_absent(drive, omega_driver) is not None or len(drive.pulleys) != 2:
        return None
    roles = [p.role for p in drive.pulleys]
    if sorted(roles) != ["driven", "driver"]:
        return None
    i1, i2 = roles.index("driver"), roles.index("driven")
    pp = drive.params.pulleys
    # Final values of the laws (held after their last knot); numpy, no compiled evaluation needed.
    w1 = float(np.asarray(pp.speed.values)[i1, -1]) if omega_driver is None else omega_driver
    load = -drive.running_sense[i2] * float(np.asarray(pp.torque.values)[i2, -1])  # brake in its running sense
    R = np.asarray(pp.radius)
    center = np.asarray(pp.center)
    D = float(np.linalg.norm(center[i1] - center[i2]))
    bp = drive.params.belt
    mu_p = np.asarray(pulley_mu(drive.model, drive.params) if mu is None else mu)
    mu = float(mu_p[i1])  # the driver's, wedge factor included
    return two_pulley_creep(
        radius_driver=float(R[i1]),
        radius_driven=float(R[i2]),
        center_distance=D,
        EA=float(bp.EA),
        # per current length at installation: the belt's mass over its installed path (L0 m0 / L)
        mass_per_length=float(bp.mass_per_length) * float(bp.stress_free_length) / float(drive.path.length),
        mu=mu,
        omega_driver=abs(w1),
        load_torque=max(load, 0.0),
        load_viscous=float(np.asarray(pp.viscous)[i2]),
        stress_free_length=float(bp.stress_free_length),
        # the sunk path and rolling radii, as the ANCF belt has them
        contact_stiffness=float(drive.params.contact_stiffness) if compliant else None,
    )


def creep_theory_absent(drive: Drive, omega_driver: float | None = None) -> str | None:
    """Why a drive of one driver and one driven pulley has no creep theory (None: it has one, or the
    drive is not such a pair, for which the theory is not meant)."""
    roles = [p.role for p in drive.pulleys]
    if sorted(roles) != ["driven", "driver"]:
        return None
    i1 = roles.index("driver")
    if drive.model.any_movable:
        return "a pulley sits on a movable carrier (the theory is for fixed centres)"
    if not drive.model.kinematic[i1] and omega_driver is None:
        return f"the driver {drive.pulleys[i1].name!r} is torque-driven and no driver speed was given"
    return None


def installed_state(drive: Drive, params=None, *, pretension: float | None = None) -> dict:
    """What defined the belt's installed state (held when E, EA or a radius change) and both its values
    (``pretension``: the parameter ``belt.pretension`` of ``params``, if already computed)."""
    from ..geometry.installed import installed_pretension

    params = drive.params if params is None else params
    if pretension is None:
        pretension = float(installed_pretension(drive, params))
    return dict(
        defined_by=drive.installed_by,
        pretension=pretension,
        stress_free_length=float(params.belt.stress_free_length),
    )


def guarded(warnings_: list, what: str, fn, default=None):
    """``fn()``, or ``default`` with a warning when it fails: a derived output (creep theory, contact
    arcs, plots) must never cost the results of a finished simulation."""
    try:
        return fn()
    except Exception as err:  # noqa: BLE001 - reported, not hidden: the message goes into the summary
        warnings_.append(f"{what} not computed: {type(err).__name__}: {' '.join(str(err).split())}")
        return default


SLACK_FRACTION = 0.25  # highest span tension below this fraction of the installed tension: belt slack
LOST_CONTACT_FRACTION = 0.1  # mean contact arc below this fraction of the installed wrap: contact lost
SPEED_DEVIATION = 0.5  # |omega R - v| above this fraction of the belt speed v: not rolling with the belt
MIN_WRAP_DEG = 5.0  # wraps smaller than this are not checked for contact


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
        found.append(
            f"the belt went slack: the span tensions ({', '.join(f'{t:.3g}' for t in tension)} N) all fell "
            f"below {SLACK_FRACTION:.0%} of the installed tension {T0:.4g} N"
        )
        fixes.append("check the pulley positions and radii and the tensioner preload")
    m, EA = float(bp.mass_per_length), float(bp.EA)
    # m' v^2 with m' per current length at the span's own tension (theory.mass_per_current_length)
    low = [
        (sp["name"], sp["tension_mean"], mass_per_current_length(m, sp["tension_mean"], EA) * speed**2)
        for sp in spans
        if effective_tension(sp["tension_mean"], speed, m, EA) < 0
    ]
    if low:
        found.append(
            "negative effective tension (below the centrifugal term m' v^2: the belt lifts off) in span "
            + ", ".join(f"{n} ({t:.3g} N < {c:.3g} N)" for n, t, c in low)
        )
        fixes.append("raise belt.pretension or lower the speed")
    wrap = np.degrees(np.asarray(drive.path.wrap_angle))
    lost = [
        i
        for i, n in enumerate(names)
        if wrap[i] >= MIN_WRAP_DEG and pulleys[n]["contact_arc_deg"] < LOST_CONTACT_FRACTION * wrap[i]
    ]
    if lost:
        found.append(
            "the belt lost contact with " + ", ".join(f"{names[i]!r} (installed wrap {wrap[i]:.3g} deg)" for i in lost)
        )
        fixes.append("check that pulley's position and radius and the belt tension")
    kin = np.asarray(drive.model.kinematic)
    off = [
        (n, pulleys[n]["omega_mean"], speed / radius[i])
        for i, n in enumerate(names)
        if not kin[i]
        and i not in lost
        and speed > 1e-3
        and abs(abs(pulleys[n]["omega_mean"]) * radius[i] - speed) > SPEED_DEVIATION * speed
    ]
    if off:
        found.append(
            f"pulley speed far from rolling with the belt ({speed:.3g} m/s): "
            + ", ".join(f"{n!r} turns at {abs(w):.3g} rad/s instead of {k:.3g} rad/s" for n, w, k in off)
        )
        fixes.append(
            "gross slip: lower the load or raise belt.pretension or contact.mu; or the run is not steady "
            "yet: run longer"
        )
    if not found:
        return None
    element = L / drive.model.n_elements
    small = [i for i in range(len(names)) if element > 2.0 * radius[i]]
    if small:  # the likely cause: contact is tested at points, a tiny pulley fits between them
        fixes = [
            f"the belt elements ({1e3 * element:.3g} mm) are longer than twice the radius of "
            + ", ".join(f"{names[i]!r} ({1e3 * radius[i]:.3g} mm)" for i in small)
            + f", so the belt's contact points can step over it: use a realistic radius or at least "
            f"{math.ceil(2 * L / radius[small].min())} elements (belt.n_elements)"
        ]
    return "; ".join(found) + " - " + "; ".join(fixes)


def summary(
    drive: Drive,
    ts,
    states: DriveState,
    final: DriveState,
    window: float = 0.2,
    signals_: dict | None = None,
    derived: Derived | None = None,
    steady: bool = True,
) -> dict:
    """Means over the final ``window`` fraction of the run, trimmed to whole periods of the engine orders
    (``outputs.window``; ``window_s``, ``window_periods``: speeds, torques, tensions, contact arcs),
    the status, warnings, and creep theory beside.

    Torques are the belt's angular impulse over the window divided by its length (every step
    counts, not only the saved ones); ``torque_std`` is the spread of the same average over each
    save interval. Stick and slip arcs are means over the saved states in the window
    (``window_contact_arcs``). A run that finished without a fault but whose result is physically
    implausible (slack belt, lost contact, a pulley not rolling with the belt) gets a status saying
    so. A window that is not a steady state (prescribed laws still changing, speeds, tensions or arms
    still drifting) or a pulley in gross slip (``outputs.steadiness``) gets a status saying so and what
    to change; ``steady=False`` (a run-up: changing on purpose) keeps the gross-slip check only.
    A derived output that fails (e.g. creep theory) becomes an entry of ``warnings``.
    ``derived``: the run's post-processing program output for these states (``outputs.derived``), whose
    arrays are then read instead of computed here.
    """
    ts = np.asarray(ts)
    sel, periods = summary_window(drive, ts, states.theta, window)
    warnings_: list[str] = []
    if periods is not None and periods < 1:
        warnings_.append(
            f"the summary window holds {periods:.2f} of a period of the engine orders: its means and amplitudes "
            "carry a partial period of the forced response (run longer, or a larger --window)"
        )
    sig = signals(drive, ts, states) if signals_ is None else signals_
    arcs = guarded(
        warnings_,
        "stick/slip arcs",
        lambda: window_contact_arcs(drive, states, sel, **({} if derived is None else derived.window_inputs(sel))),
        {
            n: dict(stick_arc_deg=math.nan, slip_arc_deg=math.nan, contact_arc_deg=math.nan)
            for n in drive.model.pulley_names
        },
    )
    pulleys = _pulley_means(drive, ts[sel], np.asarray(states.angular_impulse)[sel], sig, sel, arcs)
    spans = [
        dict(name=f"{a}-{b}", **{"from": a, "to": b}, tension_mean=float(sig[f"tension:{a}-{b}"][sel].mean()))
        for a, b in span_names(drive)
    ]
    share = {
        n: a["stick_arc_deg"] / a["contact_arc_deg"] if a["contact_arc_deg"] > 0 else 0.0
        for n, a in arcs.items()
        if math.isfinite(a["stick_arc_deg"]) and math.isfinite(a["contact_arc_deg"])
    }
    steadiness_ = guarded(
        warnings_, "steadiness checks", lambda: steadiness(drive, sig, sel, check_drift=steady, stick_share=share)
    )
    if steadiness_ is not None and steadiness_["intermittent_slip"]:
        warnings_.append(steadiness_["intermittent_slip"])
    status = _status(drive, states, final, sel, pulleys, spans, warnings_, steadiness_)
    res = np.asarray(states.lcp_residual)[sel]
    res_all = np.asarray(states.lcp_residual)
    if res_all.size and float(np.median(res_all)) > LCP_TOLERANCE:
        unconverged = (
            f"contact solver not converged: median relative residual {float(np.median(res_all)):.2g} "
            f"> {LCP_TOLERANCE:g} (raise solver.lcp_iterations or lower solver.relaxation)"
        )
        warnings_.append(unconverged)
        if status == "ok":  # the figures rest on impulses that do not satisfy the laws: not an "ok" result
            status = unconverged
    elif res.size and float(res.max()) > LCP_TOLERANCE:
        # converged in the median but not at every step: the figures stand, those near these times less so
        worst = int(np.argmax(res))
        warnings_.append(
            f"contact solver not converged at some steps: {int(np.sum(res > LCP_TOLERANCE))} of {res.size} saved "
            f"intervals in the window above {LCP_TOLERANCE:g} (largest relative residual {float(res[worst]):.2g} "
            f"before t = {float(ts[sel][worst]):.4g} s): figures that peak there may be off"
        )
    direction = belt_direction(drive)
    belt = {
        key: direction[key]
        for key in ("direction", "travel_order", "spans_in_travel_order", "tight_span", "slack_span")
    }
    mean = {str(sp["name"]): typing.cast(float, sp["tension_mean"]) for sp in spans}
    if belt["tight_span"] is not None and mean[belt["tight_span"]] < mean[belt["slack_span"]]:
        # the driver is driven back (a motoring starter-generator, engine braking): its tight side leaves it
        belt["tight_span"], belt["slack_span"] = belt["slack_span"], belt["tight_span"]
    out = dict(
        belt=belt,
        pulleys=pulleys,
        spans=spans,
        window_s=[float(ts[sel][0]), float(ts[-1])],
        window_periods=periods,
        status=status,
        steadiness=_steadiness_summary(steadiness_, steady),
        lcp_residual_max=float(res.max()) if res.size else 0.0,
        lcp_residual_median=float(np.median(res_all)) if res_all.size else 0.0,
        warnings=warnings_,
    )
    mu = None if derived is None else derived.mu
    fead = guarded(warnings_, "accessory-drive outputs", lambda: fead_summary(drive, sig, sel, mu=mu))
    if fead is not None:  # per pulley and span, beside the means above
        for name, extra in fead["pulleys"].items():
            pulleys[name].update(extra)
        for sp in spans:
            sp.update(fead["spans"][sp["name"]])
    # a torque-driven driver: the theory at the run's mean driver speed (a speed law's final value otherwise)
    roles = [p.role for p in drive.pulleys]
    i1 = roles.index("driver") if "driver" in roles else None
    w1 = None if i1 is None or drive.model.kinematic[i1] else abs(pulleys[drive.pulleys[i1].name]["omega_mean"])
    theory = guarded(warnings_, "creep theory", lambda: creep_theory_for(drive, w1, mu=mu))
    if theory is not None:
        out["creep_theory"] = theory.as_dict()
        if w1 is not None:
            out["creep_theory_note"] = "torque-driven driver: the theory at the run's mean driver speed"
    elif (why := creep_theory_absent(drive, w1)) is not None:
        warnings_.append(f"creep theory not computed: {why}")
    belt["installed_state"] = _installed_summary(drive, None if derived is None else derived.pretension)
    belt["contact_stiffness"] = float(drive.params.contact_stiffness)
    belt["contact_path_shortening_mm"] = guarded(
        warnings_, "contact path shortening", lambda: 1e3 * contact_path_shortening(drive, states, sel), math.nan
    )
    return out


def contact_path_shortening(drive: Drive, states: DriveState, sel) -> float:
    """How much shorter [m] the belt's path is for its penetration into the pulleys, averaged over the
    saved states ``sel``: the sum over the wraps of the integral of the penetration over the wrap angle,
    ``sum_i int delta dphi`` (the path length changes by the wrap angle per unit of radius).

    A contact point's normal force ``f = lam_n / h`` presses it ``delta = f / (k s)`` into the pulley (k the
    contact stiffness per unit length, s the belt length the point stands for) and it covers ``s / R`` of
    the wrap (R the radius at the belt axis), so each point adds ``f / (k R)``: no geometry needed, and in
    steady running the compliant law's damper adds nothing on average. The tensioner (or, with fixed
    centres, the belt's strain) takes this length up; the installation statics does the same with
    ``delta = T / (R k)`` (``analysis.statics``)."""
    lam = np.asarray(states.lam_n)[sel]
    owner = np.rint(np.asarray(states.contact_pulley)[sel]).astype(int)  # -1 before the first step
    radius = np.asarray(drive.params.pulleys.radius)[np.clip(owner, 0, None)]
    k = float(drive.params.contact_stiffness)
    per_point = np.where((owner >= 0) & (lam > 0), lam / (drive.dt * k * radius), 0.0)
    return float(per_point.sum(axis=-1).mean()) if per_point.size else math.nan


def _pulley_means(drive: Drive, t_w, J, sig: dict, sel, arcs: dict) -> dict:
    """Each pulley's means over the window ``t_w`` (``J``: angular impulses at those times)."""
    wrap = np.degrees(np.asarray(drive.path.wrap_angle))
    pulleys = {}
    for i, name in enumerate(drive.model.pulley_names):
        if t_w.size >= 2 and t_w[-1] > t_w[0]:
            torque_mean = float((J[-1, i] - J[0, i]) / (t_w[-1] - t_w[0]))
            torque_std = float(np.std(np.diff(J[:, i]) / np.diff(t_w)))
        else:  # one saved state: its last step's torque
            torque_mean, torque_std = float(sig[f"torque:{name}"][sel].mean()), 0.0
        pulleys[name] = dict(
            omega_mean=float(sig[f"omega:{name}"][sel].mean()),
            torque_mean=torque_mean,
            torque_std=torque_std,
            stick_arc_deg=arcs[name]["stick_arc_deg"],
            slip_arc_deg=arcs[name]["slip_arc_deg"],
            contact_arc_deg=arcs[name]["contact_arc_deg"],
            wrap_deg=float(wrap[i]),
            running_sense=int(drive.running_sense[i]),
        )
        if f"arm_angle:{name}" in sig:
            pulleys[name]["arm_angle_mean"] = float(sig[f"arm_angle:{name}"][sel].mean())
        if f"travel:{name}" in sig:  # a slider tensioner [m]
            pulleys[name]["travel_mean"] = float(sig[f"travel:{name}"][sel].mean())
    return pulleys


def _steadiness_summary(found: dict | None, checked: bool) -> dict:
    """The ``steadiness`` entry of the summary: ``steady`` (None: not checked), ``gross_slip``, ``findings``
    and each checked signal's ``drift`` over the window."""
    if found is None:
        return dict(steady=None, gross_slip=[], findings=[], drift={})
    return dict(
        steady=found["steady"] if checked else None,
        gross_slip=found["gross_slip"],
        findings=found["findings"],
        laws_end_s=found["laws_end_s"],
        drift=found["drift"],
    )


def _status(
    drive: Drive,
    states: DriveState,
    final: DriveState,
    sel,
    pulleys: dict,
    spans: list,
    warnings_: list,
    steady: dict | None = None,
) -> str:
    """ "ok", the fault and its remedies, what is implausible about a run that finished, a pulley in gross
    slip, or a window that is not steady (``steady``: ``outputs.steadiness``), in that order."""
    fault = Fault(int(final.fault))
    status = (
        fault.message
        if fault == Fault.OK
        else (
            f"diverged at t = {float(final.fault_time):.6g} s ({fault.message}): {step_remedy(drive)}, "
            "raise solver.lcp_iterations, or soften contact.stiffness"
        )
    )
    if fault == Fault.OK and np.any(sel):
        found = guarded(warnings_, "plausibility checks", lambda: _implausible(drive, states, sel, pulleys, spans))
        if found:
            status = "implausible result: " + found
        elif steady is not None and steady["gross_slip"]:
            status = "gross slip: " + "; ".join(steady["findings"]) + " - " + "; ".join(steady["fixes"])
        elif steady is not None and steady["steady"] is False:
            status = "not steady: " + "; ".join(steady["findings"]) + " - " + "; ".join(steady["fixes"])
    return status


def _installed_summary(drive: Drive, pretension: float | None = None) -> dict:
    """Which key fixed the installed belt (pretension, stress_free_length or a poly-V effective_length or
    installed_effective_length), and, whatever defined it, the pretension and stress-free length."""
    installed: dict[str, object] = dict(defined_by=drive.installed_by)
    installed.update(installed_state(drive, pretension=pretension))
    if installed["defined_by"] == "effective_length":
        installed.update(
            effective_length=drive.effective_length,
            effective_offset=drive.effective_offset,
            stress_free_length=float(drive.params.belt.stress_free_length),
        )
    if installed["defined_by"] == "installed_effective_length":
        # and the catalogue (unstretched) effective length of that belt
        L0, e = float(drive.params.belt.stress_free_length), float(drive.effective_offset or 0.0)
        installed.update(
            installed_effective_length=float(drive.spec.belt.installed_effective_length or math.nan),
            effective_offset=e,
            effective_length=L0 - 2.0 * math.pi * e,
            stress_free_length=L0,
        )
    return installed
