"""Tensioner carriers in a spec: their checks, the rest coordinate in model units, and the warning
for a spring whose installed load the belt cannot hold; the constrained carriers (pivot friction,
stops, unloading damping; one-way clutch pulleys) and their ``ConstraintParams``.
"""

from __future__ import annotations

import math

import numpy as np

from ..pulleys.carriers import AbstractCarrier, AbstractMovableCarrier, tensioner_kinds
from ..pulleys.carriers.clutch import Decoupler, OverrunningClutch
from ..pulleys.carriers.lossy import LossyCarrier
from .checks import _finite, _non_negative, _pair, _positive, _pulley_label, _require, _warn
from .spec import DriveSpec, PulleySpec, TensionerSpec

__all__ = [
    "arm_geometry",
    "carrier_inertia",
    "constrained_carrier",
    "check_pendulums",
    "pendulum_partners",
    "pivoted",
]

PIVOTED = ("arm", "pendulum")  # the tensioner kinds on an arm about a pivot (the coordinate an angle)
MAX_ARM_ANGLE = 2 * math.pi  # |tensioner.rest| of an arm [rad]; beyond a full turn it was meant in degrees
SPRING_LOAD_FACTOR = 3.0  # warn when a tensioner spring's installed load exceeds this many times
# the most the belt can hold on it (2 T L on an arm, 2 T on a slider)


def pivoted(t: TensionerSpec) -> bool:
    """The carrier swings on an arm about ``pivot`` (its coordinate an angle [rad])."""
    return t.kind in PIVOTED


def _check_tensioner(f: str, t: TensionerSpec, ctr: tuple[float, float]) -> None:
    """The carrier of pulley ``f`` (installed centre ``ctr``): kind, numbers, pivot or direction, inertia, rest."""
    kinds = tensioner_kinds()  # the movable carriers of the carriers room
    _require(
        isinstance(t.kind, str) and t.kind in kinds,
        f + ".tensioner.kind",
        t.kind,
        "must be " + " or ".join(repr(k) for k in kinds),
    )
    _non_negative(f + ".tensioner.stiffness", t.stiffness)
    _non_negative(f + ".tensioner.damping", t.damping)
    _non_negative(f + ".tensioner.mass", t.mass)
    _finite(f + ".tensioner.preload", t.preload, "must be finite")
    if t.inertia is not None:
        _positive(f + ".tensioner.inertia", t.inertia)
    if t.pivot is not None:
        pivot = _pair(f + ".tensioner.pivot", t.pivot)
    if t.direction is not None:
        d = _pair(f + ".tensioner.direction", t.direction, "(x, y)")
        _require(math.hypot(*d) > 0, f + ".tensioner.direction", t.direction, "must be a non-zero vector (x, y)")
    if pivoted(t):
        _require(
            t.pivot is not None,
            f + ".tensioner.pivot",
            t.pivot,
            "an arm tensioner needs its pivot (x, y)"
            if t.kind == "arm"
            else "a pendulum tensioner needs its pivot (x, y), usually the starter-generator's axis",
        )
        L, _ = arm_geometry(ctr, pivot)
        _require(L > 0, f + ".tensioner.pivot", t.pivot, "must differ from the pulley centre")
    _require(
        t.kind != "pendulum" or t.inertia is not None,
        f + ".tensioner.inertia",
        t.inertia,
        "a pendulum tensioner needs the inertia of its whole rocker (arm and both idlers) about the pivot [kg m^2]",
    )
    _positive(f + ".tensioner.inertia", carrier_inertia(t, ctr))
    _tensioner_rest(f, t)
    _check_pivot(f, t, ctr)


def pendulum_partners(spec: DriveSpec) -> dict[str, int]:
    """The second idler of each pendulum tensioner (its name) -> the index of the pendulum's pulley."""
    return {
        p.tensioner.partner: i
        for i, p in enumerate(spec.pulleys)
        if p.tensioner is not None and p.tensioner.kind == "pendulum" and p.tensioner.partner is not None
    }


def check_pendulums(spec: DriveSpec) -> None:
    """Each pendulum names its second idler: another pulley, of role "idler", without a carrier or clutch of its
    own, not another pendulum's, away from the pivot; no other kind names a partner."""
    names = [p.name for p in spec.pulleys]
    claimed: dict[str, str] = {}
    for i, p in enumerate(spec.pulleys):
        t = p.tensioner
        if t is None:
            continue
        f = _pulley_label(i, p) + ".tensioner.partner"
        if t.kind != "pendulum":
            _require(t.partner is None, f, t.partner, "names a pendulum's second idler: only kind = 'pendulum' has one")
            continue
        others = [n for n in names if n != p.name]
        _require(
            isinstance(t.partner, str) and t.partner in others,
            f,
            t.partner,
            f"a pendulum tensioner needs its second idler, the name of another pulley of this drive (one of {others})",
        )
        assert isinstance(t.partner, str)
        _require(
            t.partner not in claimed,
            f,
            t.partner,
            f"is already the second idler of {claimed.get(t.partner)!r}'s pendulum: each idler rides one arm",
        )
        claimed[t.partner] = p.name
        q = spec.pulleys[names.index(t.partner)]
        _require(
            q.role == "idler" and q.tensioner is None and q.clutch is None,
            f,
            t.partner,
            f"the second idler rides the pendulum's arm: it must be a pulley of role 'idler' without a tensioner or "
            f"clutch of its own ({q.name!r} has role {q.role!r}"
            + (", a tensioner table" if q.tensioner is not None else "")
            + (", a clutch" if q.clutch is not None else "")
            + ")",
        )
        _require(
            arm_geometry(q.center, t.pivot)[0] > 0, f, t.partner, "its centre must differ from the pendulum's pivot"
        )


def _installed(t: TensionerSpec, ctr) -> float:
    """The carrier's installed coordinate: the arm angle [rad] or travel 0."""
    return arm_geometry(ctr, t.pivot)[1] if pivoted(t) else 0.0


def _check_pivot(f: str, t: TensionerSpec, ctr) -> None:
    """Pivot friction, unloading damping and stops; the stops must contain the installed coordinate."""
    if t.friction_torque is not None:
        _non_negative(f + ".tensioner.friction_torque", t.friction_torque)
    if t.damping_unload is not None:
        _non_negative(f + ".tensioner.damping_unload", t.damping_unload)
    if t.stops is None:
        return
    lo, hi = _pair(f + ".tensioner.stops", t.stops, "(min, max)")
    unit = "rad" if pivoted(t) else "m"
    _require(lo < hi, f + ".tensioner.stops", t.stops, f"must be (min, max) with min < max [{unit}]")
    if pivoted(t):  # radians are easily given in degrees: stops = [72, 92] are 11 and 15 turns
        _require(
            max(abs(lo), abs(hi)) <= MAX_ARM_ANGLE,
            f + ".tensioner.stops",
            t.stops,
            f"an arm's stops are arm angles in radians and must be within [-2π, 2π] ([{lo:g}, {hi:g}] rad are "
            f"[{math.degrees(lo):.4g}, {math.degrees(hi):.4g}] deg); {_in_degrees(lo, hi)}",
        )


def _in_degrees(lo: float, hi: float) -> str:
    """The hint for arm stops given in degrees."""
    return f"these look like degrees: write stops = [{math.radians(lo):.6g}, {math.radians(hi):.6g}] (radians)"


def check_stops_contain_installed(f: str, t: TensionerSpec, ctr) -> None:
    """The stops contain the installed coordinate; checked after the layout, which moves no pulley but
    must first be possible (an overlapping layout is the problem to report, not the stops)."""
    if t.stops is None:
        return
    lo, hi = (float(x) for x in t.stops)
    psi0 = _installed(t, ctr)
    what = (
        f"the installed arm angle {psi0:.6g} rad ({math.degrees(psi0):.4g} deg, pivot to pulley centre)"
        if pivoted(t)
        else "the installed travel 0 m"
    )
    degrees = pivoted(t) and math.radians(lo) <= psi0 <= math.radians(hi)  # they would contain it in degrees
    _require(
        lo <= psi0 <= hi,
        f + ".tensioner.stops",
        t.stops,
        f"must contain {what} (allowed: min <= it <= max)" + (f"; {_in_degrees(lo, hi)}" if degrees else ""),
    )


def _check_clutch(f: str, p: PulleySpec) -> None:
    """A one-way clutch pulley: not on a driver or a tensioner, a rotor inertia, a decoupler spring."""
    if p.clutch is None:
        return
    _require(p.clutch in ("oap", "decoupler"), f + ".clutch", p.clutch, "must be 'oap' or 'decoupler' (or absent)")
    _require(
        p.role in ("driven", "idler"),
        f + ".clutch",
        p.clutch,
        f"a one-way clutch belongs on a driven pulley (an alternator); this pulley's role is {p.role!r}",
    )
    _require(p.tensioner is None, f + ".clutch", p.clutch, "a clutch pulley cannot ride on a tensioner carrier")
    _positive(f + ".rotor_inertia", p.rotor_inertia)
    if p.clutch_damping is not None:
        _non_negative(f + ".clutch_damping", p.clutch_damping)
    if p.clutch == "decoupler":
        _positive(f + ".clutch_stiffness", p.clutch_stiffness)


def _lossy(t: TensionerSpec | None) -> bool:
    return t is not None and not (t.friction_torque is t.damping_unload is t.stops is None)


def _spring_torque(t: TensionerSpec, ctr) -> float:
    """The spring's torque (force) on the carrier at installation."""
    rest, psi0 = _tensioner_rest("tensioner", t), _installed(t, ctr)
    return t.preload + t.stiffness * ((psi0 if rest is None else rest) - psi0)


def constrained_carrier(
    p: PulleySpec, base: AbstractCarrier, origin, row: dict, psi0: float, sense: int
) -> tuple[AbstractCarrier, tuple, dict, float]:
    """The carrier of pulley ``p`` (kind, anchor, numbers, installed coordinate): ``base`` with its numbers
    ``row`` unless it has pivot friction, stops or unloading damping (a lossy carrier: their numbers added) or a
    clutch (the rotor and, of a decoupler, its spring and damper; ``sense`` the running sense)."""
    if p.clutch is not None:
        numbers = dict(rotor_inertia=float(p.rotor_inertia or 0.0))
        if p.clutch == "oap":
            return OverrunningClutch(sense=1 if sense >= 0 else -1), origin, numbers, psi0
        numbers.update(clutch_stiffness=p.clutch_stiffness or 0.0, clutch_damping=p.clutch_damping or 0.0)
        return Decoupler(sense=1 if sense >= 0 else -1), origin, numbers, psi0
    t = p.tensioner
    if t is None or not _lossy(t):
        return base, origin, row, psi0
    load_sense = 1 if _spring_torque(t, p.center) < 0 else -1  # winding the spring up moves against its torque
    assert isinstance(base, AbstractMovableCarrier)  # a tensioner's carrier moves
    low, high = t.stops if t.stops is not None else (-np.inf, np.inf)
    losses = {
        "friction_torque": t.friction_torque or 0.0,
        "damping_unload": t.damping if t.damping_unload is None else t.damping_unload,
        "stops.min": float(low),
        "stops.max": float(high),
    }
    return LossyCarrier(inner=base, load_sense=load_sense), origin, {**row, **losses}, psi0


def _check_pivot_friction(spec: DriveSpec) -> None:
    """Warn when a carrier's friction is at least its spring's installed torque: the spring can
    never move the arm against its pivot friction (it moves only when the belt pushes it)."""
    for i, p in enumerate(spec.pulleys):
        t = p.tensioner
        if t is None or t.friction_torque is None or not t.friction_torque > 0:
            continue
        load = _spring_torque(t, p.center)
        if t.friction_torque >= abs(load):
            unit = "N m" if pivoted(t) else "N"
            _warn(
                f"{_pulley_label(i, p)}.tensioner.friction_torque = {t.friction_torque:.6g}: at least the spring's "
                f"installed load |preload + stiffness·(rest − installed)| = {abs(load):.4g} {unit} (allowed: below "
                "it): the spring can never move the carrier against its pivot friction"
            )


def arm_geometry(center, pivot) -> tuple[float, float]:
    """An arm's length [m] and installed angle [rad] from its pivot to the pulley centre."""
    dx, dy = center[0] - pivot[0], center[1] - pivot[1]
    return math.hypot(dx, dy), math.atan2(dy, dx)


def carrier_inertia(t: TensionerSpec, ctr) -> float:
    """The carrier's inertia about its pivot [kg m^2] (arm) or its mass [kg] (slider), the default
    from the pulley mass where none is given (one formula for the check and the build)."""
    if pivoted(t):
        L, _ = arm_geometry(ctr, t.pivot)
        return t.inertia if t.inertia is not None else max(t.mass, 1e-3) * L * L
    return t.inertia if t.inertia is not None else max(t.mass, 1e-2)


def _tensioner_rest(f: str, t: TensionerSpec) -> float | None:
    """The carrier's rest coordinate in model units (rad for an arm, m for a slider), None for the
    default. Refuses ``rest`` with ``rest_deg``, ``rest_deg`` on a slider and an arm angle beyond a
    full turn (radians are easily given in degrees: ``rest = 12`` is 688 deg)."""
    if t.rest_deg is not None:
        _finite(f + ".tensioner.rest_deg", t.rest_deg)
        _require(
            t.rest is None,
            f + ".tensioner.rest/rest_deg",
            (t.rest, t.rest_deg),
            "give the rest angle once: rest in rad or rest_deg in degrees",
        )
        _require(
            pivoted(t),
            f + ".tensioner.rest_deg",
            t.rest_deg,
            "is an arm's rest angle in degrees; a slider's rest is a travel: give rest in m",
        )
        _require(
            abs(t.rest_deg) <= 360.0,
            f + ".tensioner.rest_deg",
            t.rest_deg,
            "must be within [-360, 360] deg (an arm angle; a wound-up spring is given by preload)",
        )
        return math.radians(t.rest_deg)
    if t.rest is None:
        return None
    _finite(f + ".tensioner.rest", t.rest, "must be a finite number (rad for an arm, m for a slider)")
    if pivoted(t):
        _require(
            abs(t.rest) <= MAX_ARM_ANGLE,
            f + ".tensioner.rest",
            t.rest,
            f"an arm's rest angle is in radians and must be within [-2π, 2π] ({t.rest:g} rad is "
            f"{math.degrees(t.rest):.4g} deg); for degrees write rest_deg = {t.rest:g} "
            f"({math.radians(t.rest):.4g} rad)",
        )
    return float(t.rest)


def _check_spring_loads(spec: DriveSpec, tension: float) -> None:
    """Warn when a tensioner spring's installed torque (force) is far beyond what the belt can hold
    on that carrier: at most 2 T L on an arm of length L (both spans pulling along the hub load,
    perpendicular to the arm), 2 T on a slider, T the installed tension."""
    _check_pivot_friction(spec)
    if not tension > 0:  # a belt installed without tension: no scale to compare with
        return
    for i, p in enumerate(spec.pulleys):
        t = p.tensioner
        if t is None:
            continue
        f = _pulley_label(i, p)
        rest = _tensioner_rest(f, t)
        if pivoted(t):
            L, psi0 = arm_geometry(p.center, t.pivot)
            if t.kind == "pendulum":  # the second idler's hub load turns the same arm
                L += sum(arm_geometry(q.center, t.pivot)[0] for q in spec.pulleys if q.name == t.partner)
            r = psi0 if rest is None else rest
            load, cap = t.preload + t.stiffness * (r - psi0), 2.0 * tension * L
            what = (
                f"the spring torque at installation, preload + stiffness·(rest − angle) = {t.preload:.4g} + "
                f"{t.stiffness:.4g}·({r:.4g} − {psi0:.4g}) = {load:.4g} N m, is {abs(load) / cap:.3g} times the "
                f"most the belt can hold on this arm (2·T·L = 2 × {tension:.4g} N × {L:.4g} m = {cap:.4g} N m, "
                "T the installed belt tension" + (", L both idlers' arms" if t.kind == "pendulum" else "") + ")"
            )
            hints = []
            if t.rest is not None:
                hints.append(
                    f"tensioner.rest is in radians ({t.rest:g} rad = {math.degrees(t.rest):.4g} deg); "
                    f"if you meant degrees write rest_deg = {t.rest:g}"
                )
            if abs(r - psi0) > math.pi:
                hints.append(
                    f"the rest angle is {r - psi0:.4g} rad from the installed arm angle {psi0:.4g} rad "
                    "(angles are not wrapped: 2π more is a full turn of spring wind-up)"
                )
        else:
            r = 0.0 if rest is None else rest
            load, cap = t.preload + t.stiffness * r, 2.0 * tension
            what = (
                f"the spring force at installation, preload + stiffness·rest = {load:.4g} N, is "
                f"{abs(load) / cap:.3g} times the most the belt can hold on this slider (2·T = {cap:.4g} N, T the "
                "installed belt tension)"
            )
            hints = []
        if abs(load) <= SPRING_LOAD_FACTOR * cap:
            continue
        hints.append("check tensioner.preload, stiffness and rest (counter-clockwise or along direction positive)")
        _warn(f"{f}.tensioner: {what}: the carrier will swing far from its drawn position; " + "; ".join(hints))


def installation_tension(spec: DriveSpec, centers: np.ndarray, radii: np.ndarray, sides, gravity) -> float:
    """The uniform belt tension [N] that holds the drive's one tensioner in equilibrium at its drawn
    position (at rest, no load): its spring, preload and weight against the hub load ``T (d_i - d_(i-1))``
    (d the unit directions of the spans leaving and reaching it), the equation ``analysis.statics`` solves.
    For ``belt.installed_effective_length``: a drive report's installed length is the belt stretched by
    this tension over the drawn layout. ``ConfigError`` without exactly one tensioner or when that
    tensioner holds no positive tension there. Numpy, listed pulley order."""
    from ..geometry.path import _choose, _static_wrap_side

    key, value = "belt.installed_effective_length", spec.belt.installed_effective_length
    movable = [i for i, p in enumerate(spec.pulleys) if p.tensioner is not None]
    _require(
        len(movable) == 1,
        key,
        value,
        f"fixes the belt by the tension its tensioner holds at the drawn position, so the drive needs exactly one "
        f"tensioner (it has {len(movable)}); give effective_length (the catalogue length), stress_free_length or "
        "pretension instead",
    )
    i = movable[0]
    p, t = spec.pulleys[i], spec.pulleys[i].tensioner
    assert t is not None
    _, g = _choose(np.asarray(centers, float), np.asarray(radii, float), _static_wrap_side(sides), None)
    d = np.asarray(g["span_dir"])
    hub = d[i] - d[i - 1]  # force of the belt on the pulley per unit tension
    rest = _tensioner_rest(_pulley_label(i, p), t)
    if pivoted(t):
        L, psi0 = arm_geometry(p.center, t.pivot)
        dcenter = L * np.array([-math.sin(psi0), math.cos(psi0)])
    else:
        psi0 = 0.0
        u = np.asarray(t.direction if t.direction is not None else (0.0, 1.0), dtype=float)
        dcenter = u / np.linalg.norm(u)
    spring = t.preload + t.stiffness * ((psi0 if rest is None else rest) - psi0) + t.mass * float(dcenter @ gravity)
    lever = float(hub @ dcenter)
    names = [q.name for q in spec.pulleys]
    if t.kind == "pendulum" and t.partner in names:  # the second idler's hub load turns the same arm
        j = names.index(t.partner)
        arm = np.asarray(spec.pulleys[j].center, float) - np.asarray(t.pivot, float)
        lever += float((d[j] - d[j - 1]) @ np.array([-arm[1], arm[0]]))
    with np.errstate(all="ignore"):
        T = -spring / lever if lever != 0 else math.nan
    unit = "N m" if pivoted(t) else "N"
    _require(
        math.isfinite(T) and T > 0,
        key,
        value,
        f"needs the tension the tensioner {p.name!r} holds at its drawn position, but there its spring, preload and "
        f"weight ({spring:.4g} {unit}) do not pull the belt taut (the belt's generalised force per newton of "
        f"tension is {lever:.4g} {unit}/N): check the tensioner's preload (its sign and size) and rest"
        + (
            "; a pendulum whose two idlers' hub loads balance about its pivot holds any tension there: give "
            "pretension, stress_free_length or effective_length"
            if t.kind == "pendulum"
            else ""
        ),
    )
    return float(T)
