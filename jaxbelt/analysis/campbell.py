"""Campbell lines: the linearised modes' frequencies against crank speed, and the crank speeds at which engine
orders cross them (a run-up's crossings, the report's resonance map).

The modes are computed with the drive at rest. A rotational mode keeps that frequency (its change with belt
speed is a few 0.1 %: the audit's two-pulley drive, 139.33 Hz at rest and 138.55 Hz running at 2,000 rpm). A
span's transverse mode does not: a moving string's frequency falls as ``1 - v^2 / c^2`` (``c^2 = T / m``, m
per current length), 10 % at v/c = 0.32, and follows the span's tension. A transverse mode of span S,
computed at the span's installed tension T0, therefore runs at crank speed n at

    f(n) = f0 * f_S(T(n)) / f_S(T0) * (1 - v(n)^2 m(T(n)) / T(n)),   v(n) = 2 pi n / 60 * R_driver,

with ``f_S`` the span model's static frequency of the mode's harmonic (``analysis.span_tension``: bending and
the contact's end compliance) and T(n) the span's tension at that speed (a run-up's own window means, or a
load case's static tensions); 0 at and beyond the critical speed. Order k crosses a line where
``k n / 60 = f(n)``, found between the speeds at which the line is evaluated (linear interpolation)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

__all__ = ["CampbellLines", "campbell_lines", "order_crossings"]


@dataclasses.dataclass(frozen=True)
class CampbellLines:
    rpm: np.ndarray  # (N,) crank speeds, ascending [rpm]
    frequency: np.ndarray  # (modes, N) each mode's frequency at those speeds [Hz]
    modes: list  # per mode {"mode", "frequency_hz" (at rest), "kind", "span"}
    tension_from: str  # what T(n) is: "installed", "static load case", "run-up window means"


def _driver_radius(drive) -> float:
    drivers = [i for i, p in enumerate(drive.pulleys) if p.role == "driver"]
    if len(drivers) != 1:
        return 0.0  # no single crank: no belt speed to tie to the crank's (the lines stay flat)
    return float(np.asarray(drive.params.pulleys.radius)[drivers[0]])


def campbell_lines(
    drive,
    modes: list[dict],
    rpm,
    tension: dict | None = None,
    tension_from: str = "installed",
) -> CampbellLines:
    """Each mode of ``modes`` (rows of ``Modes.table()`` or the spans tier's list: ``frequency_hz``, ``kind``,
    ``span``) evaluated at the crank speeds ``rpm``: the module docstring's rule. ``tension``: span name ->
    its tension [N] at each speed (an array like ``rpm``) or one value; None: the installed tension (no change
    with speed but the moving string's)."""
    from .span_tension import _static_frequency, span_of
    from .statics import statics

    from .._errors import ConfigError

    rpm = np.asarray(rpm, dtype=float)
    try:
        rest = {s["name"]: (float(s["tension"]), float(s["length"])) for s in statics(drive).spans}
    except ConfigError as e:  # no installation statics: every line flat, at its frequency at rest - and said
        import warnings

        warnings.warn(f"resonance crossings of span modes at their frequencies at rest (no installation statics: {e})")
        rest, tension_from = {}, "none (frequencies at rest)"
    R = _driver_radius(drive)
    v = 2 * math.pi / 60 * np.abs(rpm) * R
    rows = []
    for m in modes:
        f0 = float(m["frequency_hz"])
        name = m.get("span")
        if m.get("kind") != "transverse" or not isinstance(name, str) or name not in rest:
            rows.append(np.full(rpm.shape, f0))
            continue
        T0, length = rest[name]
        span = span_of(drive, name, length=length)
        harmonic = max(1, round(f0 / _static_frequency(span, T0, 1)))
        static0 = _static_frequency(span, T0, harmonic)
        T = np.broadcast_to(np.asarray(T0 if tension is None else tension.get(name, T0), dtype=float), rpm.shape)
        # the static frequency at each distinct tension (a run-up's windows: one solve each)
        distinct, where = np.unique(T, return_inverse=True)
        static = np.array([_static_frequency(span, float(t), harmonic) if t > 0 else 0.0 for t in distinct])[where]
        with np.errstate(divide="ignore", invalid="ignore"):
            moving = np.where(T > 0, 1.0 - v**2 * span.mass_per_length / (1.0 + T / span.EA) / T, 0.0)  # mass_at
        rows.append(f0 * static / static0 * np.maximum(moving, 0.0))
    table = [dict(mode=m.get("mode", i + 1), frequency_hz=float(m["frequency_hz"]), kind=m.get("kind"),
                  span=m.get("span")) for i, m in enumerate(modes)]  # fmt: skip
    return CampbellLines(rpm=rpm, frequency=np.asarray(rows).reshape(len(modes), rpm.size), modes=table,
                         tension_from=tension_from)  # fmt: skip


def order_crossings(lines: CampbellLines, orders, rpm_lo: float, rpm_hi: float) -> list[dict]:
    """Where order k's ray ``k n / 60`` meets each line inside ``[rpm_lo, rpm_hi]``, ascending in rpm: mode,
    its frequency there, kind, span, order, rpm (a line crossed more than once is listed each time)."""
    lo, hi = sorted((rpm_lo, rpm_hi))
    n = lines.rpm
    out = []
    for m, f in zip(lines.modes, lines.frequency):
        for k in orders:
            g = f - k * n / 60.0
            if n.size == 1 or np.all(f == f[0]):  # a flat line: the exact crossing
                at = 60.0 * float(f[0]) / k
                hits = [(at, float(f[0]))] if lo <= at <= hi else []
            else:
                hits = []
                for i in np.flatnonzero(np.sign(g[:-1]) * np.sign(g[1:]) <= 0):
                    if g[i] == g[i + 1]:
                        continue
                    s = g[i] / (g[i] - g[i + 1])
                    at = float(n[i] + s * (n[i + 1] - n[i]))
                    if lo <= at <= hi and not any(abs(at - h) < 1e-9 for h, _ in hits):
                        hits.append((at, float(f[i] + s * (f[i + 1] - f[i]))))
            for at, fr in hits:
                out.append(dict(mode=m["mode"], frequency_hz=fr, kind=m["kind"], span=m["span"], order=k, rpm=at))
    return sorted(out, key=lambda c: c["rpm"])
