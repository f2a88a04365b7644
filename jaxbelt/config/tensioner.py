"""Tensioner carriers in a spec: their checks, the rest coordinate in model units, and the warning
for a spring whose installed load the belt cannot hold.
"""

from __future__ import annotations

import math

from .checks import _finite, _non_negative, _pair, _positive, _pulley_label, _require, _warn
from .spec import DriveSpec, TensionerSpec

__all__ = ["arm_geometry", "carrier_inertia"]

MAX_ARM_ANGLE = 2 * math.pi  # |tensioner.rest| of an arm [rad]; beyond a full turn it was meant in degrees
SPRING_LOAD_FACTOR = 3.0  # warn when a tensioner spring's installed load exceeds this many times
# the most the belt can hold on it (2 T L on an arm, 2 T on a slider)


def _check_tensioner(f: str, t: TensionerSpec, ctr: tuple[float, float]) -> None:
    """The carrier of pulley ``f`` (installed centre ``ctr``): kind, numbers, pivot or direction, inertia, rest."""
    _require(
        isinstance(t.kind, str) and t.kind in ("arm", "slider"),
        f + ".tensioner.kind",
        t.kind,
        "must be 'arm' or 'slider'",
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
    if t.kind == "arm":
        _require(t.pivot is not None, f + ".tensioner.pivot", t.pivot, "an arm tensioner needs its pivot (x, y)")
        L, _ = arm_geometry(ctr, pivot)
        _require(L > 0, f + ".tensioner.pivot", t.pivot, "must differ from the pulley centre")
    _positive(f + ".tensioner.inertia", carrier_inertia(t, ctr))
    _tensioner_rest(f, t)


def arm_geometry(center, pivot) -> tuple[float, float]:
    """An arm's length [m] and installed angle [rad] from its pivot to the pulley centre."""
    dx, dy = center[0] - pivot[0], center[1] - pivot[1]
    return math.hypot(dx, dy), math.atan2(dy, dx)


def carrier_inertia(t: TensionerSpec, ctr) -> float:
    """The carrier's inertia about its pivot [kg m^2] (arm) or its mass [kg] (slider), the default
    from the pulley mass where none is given (one formula for the check and the build)."""
    if t.kind == "arm":
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
            t.kind == "arm",
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
    if t.kind == "arm":
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
    if not tension > 0:  # a belt installed without tension: no scale to compare with
        return
    for i, p in enumerate(spec.pulleys):
        t = p.tensioner
        if t is None:
            continue
        f = _pulley_label(i, p)
        rest = _tensioner_rest(f, t)
        if t.kind == "arm":
            L, psi0 = arm_geometry(p.center, t.pivot)
            r = psi0 if rest is None else rest
            load, cap = t.preload + t.stiffness * (r - psi0), 2.0 * tension * L
            what = (
                f"the spring torque at installation, preload + stiffness·(rest − angle) = {t.preload:.4g} + "
                f"{t.stiffness:.4g}·({r:.4g} − {psi0:.4g}) = {load:.4g} N m, is {abs(load) / cap:.3g} times the "
                f"most the belt can hold on this arm (2·T·L = 2 × {tension:.4g} N × {L:.4g} m = {cap:.4g} N m, "
                "T the installed belt tension)"
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
