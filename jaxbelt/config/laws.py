"""Time laws as written in a spec (a number, a TimeLaw or a ramp/smooth_step/table dict): their
checks (numpy only), their values, and their translation into the stored ``TimeLaw`` (SI,
counter-clockwise positive).
"""

from __future__ import annotations

import math

import numpy as np

from .._errors import ConfigError
from ..pulleys import timelaw as tl
from .checks import _finite, _is_number, _pulley_label, _require
from .spec import DriveSpec, PulleySpec

__all__ = ["law_from_spec"]

_RPM = 2.0 * math.pi / 60.0


_LAW_FORMS = ("constant", "ramp", "smooth_step", "table", "angle_table")
_LAW_OPTIONS = ("base", "smooth", "period_deg")  # keys a law dict may hold besides its form


def _law_kind(value: dict) -> str:
    """The form of a checked law dict (``ramp``, ``table``, ``angle_table``, ...)."""
    (kind,) = set(value) - set(_LAW_OPTIONS)
    return kind


def is_angle_law(value) -> bool:
    """A law over the pulley's rotation angle (``{angle_table = [[deg, value], ...]}``)."""
    return isinstance(value, dict) and "angle_table" in value


def angle_period(value) -> tuple[float, float]:
    """First angle and period [rad] of a checked angle table (period: ``period_deg``, default its span)."""
    pts = np.asarray(value["angle_table"], dtype=float)
    span = float(pts[-1, 0] - pts[0, 0])
    return math.radians(float(pts[0, 0])), math.radians(float(value.get("period_deg", span)))


def _law_points(t: np.ndarray, v: np.ndarray, what: str):
    _require(
        t.ndim == 1 and t.shape == v.shape and t.size > 0,
        what,
        (t.tolist(), v.tolist()),
        "needs as many times as values, at least one",
    )
    _require(bool(np.all(np.isfinite(t))), what, t.tolist(), "times must be finite numbers")
    _require(bool(np.all(np.isfinite(v))), what, v.tolist(), "values must be finite numbers")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        k = int(bad[0])
        raise ConfigError(
            f"{what}: times must increase strictly: t = {t[k + 1]:g} at point {k + 1} follows "
            f"t = {t[k]:g} at point {k} (times {t.tolist()})"
        )


def _check_law(value, what: str) -> None:
    """Validate a time law (numbers, shapes, strictly increasing times) with numpy only: no JAX
    array is made, nothing is traced or compiled. Raises ``ConfigError`` naming ``what``."""
    if value is None:
        return
    if isinstance(value, tl.TimeLaw):
        try:
            t, v = np.asarray(value.times, dtype=float), np.asarray(value.values, dtype=float)
        except Exception:  # noqa: BLE001 - traced values: whoever traced them checks them
            return
        _law_points(t, v, what)
        return
    if _is_number(value):
        _require(math.isfinite(float(value)), what, value, "must be finite")
        return
    if not isinstance(value, dict):
        raise ConfigError(f"{what} = {value!r}: must be a number, a TimeLaw or a table/ramp/smooth_step dict")
    keys = set(value) - set(_LAW_OPTIONS)
    _require(
        len(keys) == 1 and keys <= set(_LAW_FORMS),
        what,
        value,
        "must have exactly one of 'constant', 'ramp', 'smooth_step', 'table', 'angle_table'",
    )
    (kind,) = keys
    base = value.get("base", 0.0)
    _finite(f"{what}.base", base)
    if "smooth" in value:
        _require(
            isinstance(value["smooth"], (bool, np.bool_)), f"{what}.smooth", value["smooth"], "must be true or false"
        )
    arg = value[kind]
    _require(
        "period_deg" not in value or kind == "angle_table",
        f"{what}.period_deg",
        value.get("period_deg"),
        "belongs to an angle_table (a law over the crank angle)",
    )
    if kind == "constant":
        _finite(f"{what}.constant", arg)
        _require(math.isfinite(float(arg) + float(base)), f"{what}.constant", arg, "plus base must be finite")
        return
    if kind in ("ramp", "smooth_step"):
        ok = (
            isinstance(arg, (list, tuple, np.ndarray))
            and len(arg) == 4
            and all(_is_number(x) and math.isfinite(float(x)) for x in arg)
        )
        _require(ok, f"{what}.{kind}", arg, "must be [t0, t1, v0, v1], four finite numbers")
        t0, t1, v0, v1 = map(float, arg)
        _require(t1 > t0, f"{what}.{kind}", arg, "needs t1 > t0")
        _law_points(np.array([t0, t1]), np.array([v0, v1]) + float(base), f"{what}.{kind}")
        return
    ok = (
        isinstance(arg, (list, tuple, np.ndarray))
        and len(arg) >= 1
        and all(isinstance(r, (list, tuple, np.ndarray)) and len(r) == 2 and all(_is_number(x) for x in r) for r in arg)
    )
    pair = "[angle_deg, value]" if kind == "angle_table" else "[t, value]"
    _require(ok, f"{what}.{kind}", arg, f"must be a non-empty list of {pair} pairs of numbers")
    pts = np.asarray(arg, dtype=float)
    _law_points(pts[:, 0], pts[:, 1] + float(base), f"{what}.{kind}")
    if kind == "angle_table":
        _check_angle_table(value, pts, what)


def _check_angle_table(value: dict, pts: np.ndarray, what: str) -> None:
    """At least two angles; the period (``period_deg``, default the table's span) covers the table."""
    _require(len(pts) >= 2, f"{what}.angle_table", value["angle_table"], "needs at least two [angle_deg, value] points")
    span = float(pts[-1, 0] - pts[0, 0])
    if "period_deg" in value:
        period = value["period_deg"]
        _finite(f"{what}.period_deg", period)
        _require(
            float(period) >= span and float(period) > 0,
            f"{what}.period_deg",
            period,
            f"must be > 0 and >= the table's span {span:g} deg (e.g. 720 for a four-stroke cycle)",
        )


def _law_minimum(value) -> float:
    """The smallest value a validated law takes, as written (numpy only: validation compiles nothing);
    +inf for no law or a traced one."""
    try:
        if value is None:
            return math.inf
        if isinstance(value, tl.TimeLaw):
            return float(np.min(np.asarray(value.values, dtype=float)))
        if _is_number(value):
            return float(value)
        kind = _law_kind(value)
        arg = value[kind]
        values = [arg] if kind == "constant" else arg[2:] if kind in ("ramp", "smooth_step") else [r[1] for r in arg]
        return float(min(float(v) for v in values)) + float(value.get("base", 0.0))
    except Exception:  # noqa: BLE001 - traced laws: nothing to say before tracing
        return math.inf


def law_from_spec(value, what: str, sign: float = 1.0) -> tl.TimeLaw:
    """A number (constant), a TimeLaw, or a dict:
    ``{ramp = [t0, t1, v0, v1]}``, ``{smooth_step = [t0, t1, v0, v1]}``,
    ``{table = [[t, v], ...], smooth = false}``, optional ``base`` added to steps/ramps."""
    _check_law(value, what)
    if value is None:
        return tl.constant(0.0)
    if isinstance(value, tl.TimeLaw):
        return tl.TimeLaw(value.times, sign * value.values, value.smooth)
    try:
        if _is_number(value):
            return tl.constant(sign * float(value))
        kind = _law_kind(value)
        base = float(value.get("base", 0.0))
        arg = value[kind]
        if kind == "constant":
            return tl.constant(sign * (float(arg) + base))
        if kind == "angle_table":
            return _angle_law(value, sign, base)
        if kind in ("ramp", "smooth_step"):
            t0, t1, v0, v1 = map(float, arg)
            return (tl.ramp if kind == "ramp" else tl.smooth_step)(t0, t1, sign * (v0 + base), sign * (v1 + base))
        pts = np.asarray(arg, dtype=float)
        return tl.table(pts[:, 0], sign * (pts[:, 1] + base), smooth=bool(value.get("smooth", False)))
    except (TypeError, ValueError) as err:  # not expected after _check_law; still never an obscure error
        raise ConfigError(f"{what}: {err}") from None


def _angle_law(value: dict, sign: float, base: float) -> tl.TimeLaw:
    """An angle table as a stored law whose knots are angles [rad]; a period longer than the table's
    span adds the first point one period on (the cycle closes linearly)."""
    pts = np.asarray(value["angle_table"], dtype=float)
    start, period = angle_period(value)
    angles, values = np.radians(pts[:, 0]), pts[:, 1]
    if period > angles[-1] - start:
        angles, values = np.append(angles, start + period), np.append(values, values[0])
    return tl.table(angles, sign * (values + base), smooth=bool(value.get("smooth", False)))


def _law_values(value) -> np.ndarray:
    """Values of a checked time law (base included), numpy only; empty for traced values."""
    if isinstance(value, tl.TimeLaw):
        try:
            return np.asarray(value.values, dtype=float).ravel()
        except Exception:  # noqa: BLE001 - traced: no value to read
            return np.zeros(0)
    if _is_number(value):
        return np.array([float(value)])
    kind = _law_kind(value)
    base, arg = float(value.get("base", 0.0)), value[kind]
    if kind == "constant":
        return np.array([float(arg) + base])
    if kind in ("ramp", "smooth_step"):
        return np.array([float(arg[2]), float(arg[3])]) + base
    return np.asarray(arg, dtype=float)[:, 1] + base


def _law_sign(p: PulleySpec, key: str, sense: int, spec: DriveSpec) -> float:
    """Factor from a law as written (``key`` of pulley ``p``, running sense ``sense``) to the stored
    law (SI, counter-clockwise positive). ``load``/``power_kw`` brake: they oppose the running sense;
    ``torque`` and a driver's speed count in the running sense, except a driver's without
    ``belt.direction``: counter-clockwise positive (as before the key existed; its sign sets the sense)."""
    if key in ("load", "power_kw"):
        return -float(sense)
    unit = _RPM if key == "speed_rpm" else 1.0
    if p.role == "driver" and spec.belt.direction is None:
        return unit
    return unit * float(sense)


def _driver_law(p: PulleySpec) -> tuple[str, np.ndarray]:
    key = next(k for k in ("speed", "speed_rpm", "torque") if getattr(p, k) is not None)
    return key, _law_values(getattr(p, key))


def _nominal_speeds(spec: DriveSpec, radii: np.ndarray) -> np.ndarray:
    """Each pulley's nominal speed [rad/s]: the speed driver's final speed times its radius over the
    pulley's (both at the belt axis); needed (and checked) only where ``power_kw`` is given."""
    users = [i for i, p in enumerate(spec.pulleys) if p.power_kw is not None]
    out = np.full(len(spec.pulleys), np.nan)
    if not users:
        return out
    first = _pulley_label(users[0], spec.pulleys[users[0]]) + ".power_kw"
    drivers = [
        i for i, p in enumerate(spec.pulleys) if p.role == "driver" and (p.speed is not None or p.speed_rpm is not None)
    ]
    _require(
        len(drivers) == 1,
        first,
        spec.pulleys[users[0]].power_kw,
        "needs exactly one driver with a prescribed speed ('speed' or 'speed_rpm') to set the nominal "
        f"speed; found {len(drivers)}: give 'load' (N m) instead",
    )
    d = spec.pulleys[drivers[0]]
    key, v = _driver_law(d)
    w = abs(float(v[-1])) * (_RPM if key == "speed_rpm" else 1.0) if v.size else 0.0
    _require(
        w > 0,
        first,
        spec.pulleys[users[0]].power_kw,
        f"needs a non-zero final speed of the driver ({_pulley_label(drivers[0], d)}.{key}) to convert the "
        "power into a torque; give 'load' (N m) instead",
    )
    return w * radii[drivers[0]] / radii
