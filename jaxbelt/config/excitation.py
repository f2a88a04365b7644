"""Engine orders and per-pulley friction as written in a spec: their checks (numpy only), the stored
``Excitation`` and per-pulley ``mu``, and their ``set_parameter`` keys.

A pulley's ``excitation`` is a table keyed by order (TOML ``[pulleys.excitation.2]``, Python
``{2: {...}}``); each entry gives exactly one of ``amplitude`` (rad/s on a speed, N m on a torque)
or ``amplitude_deg`` (the crank's angular oscillation, speed drivers only), and ``phase_deg``.
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np

from .._errors import ConfigError, did_you_mean
from ..pulleys.excitation import Excitation
from .checks import _finite, _is_number, _pulley_label, _require
from .laws import _RPM, _law_values, angle_period, is_angle_law
from .spec import DriveSpec, PulleySpec

__all__ = ["order_entries", "check_excitation", "check_pulley_mu", "build_excitation", "build_mu"]

_ENTRY_KEYS = ("amplitude", "amplitude_deg", "phase_deg")
_LAWS = ("speed", "speed_rpm", "torque", "load", "power_kw")


def _order_of(f: str, key) -> float:
    """An order key (a number, or its text in TOML) as a float > 0."""
    try:
        k = float(key) if isinstance(key, str) or _is_number(key) else math.nan
    except ValueError:
        k = math.nan
    _require(
        math.isfinite(k) and k > 0,
        f"{f}.excitation.{key}",
        key,
        "an engine order must be a number > 0 (2 = firing order of a four-cylinder four-stroke engine)",
    )
    return k


def order_entries(f: str, p: PulleySpec) -> list[tuple[float, float, bool, float]]:
    """``(order, amplitude, in_degrees, phase [rad])`` per order of pulley ``p`` (labelled ``f``), checked."""
    exc = p.excitation
    if exc is None:
        return []
    _require(isinstance(exc, dict), f + ".excitation", exc, "must be a table {order: {amplitude, phase_deg}}")
    out = []
    for key, entry in exc.items():
        k, what = _order_of(f, key), f"{f}.excitation.{key}"
        _require(isinstance(entry, dict), what, entry, "must be a table {amplitude | amplitude_deg, phase_deg}")
        for name in entry:
            if name not in _ENTRY_KEYS:
                raise ConfigError(
                    f"unknown key '{what}.{name}'{did_you_mean(str(name), _ENTRY_KEYS)}: "
                    "valid keys: " + ", ".join(_ENTRY_KEYS)
                )
        given = [n for n in ("amplitude", "amplitude_deg") if n in entry]
        _require(len(given) == 1, what, entry, "give exactly one of 'amplitude' (rad/s or N m) or 'amplitude_deg'")
        (name,) = given
        _finite(f"{what}.{name}", entry[name])
        phase = entry.get("phase_deg", 0.0)
        _finite(f"{what}.phase_deg", phase)
        out.append((k, float(entry[name]), name == "amplitude_deg", math.radians(float(phase))))
    _require(len({e[0] for e in out}) == len(out), f + ".excitation", list(exc), "each order may appear once")
    return out


def _follows_speed(p: PulleySpec) -> bool:
    return p.role == "driver" and (p.speed is not None or p.speed_rpm is not None)


def check_excitation(f: str, p: PulleySpec) -> None:
    """Where orders and angle tables make sense, and that a speed with its orders never reverses."""
    entries = order_entries(f, p)
    angle_laws = [k for k in _LAWS if is_angle_law(getattr(p, k))]
    for key in angle_laws:
        _require(
            p.role in ("driver", "driven"),
            f"{f}.{key}",
            getattr(p, key),
            "a law over the crank angle (angle_table) belongs to a driver or a driven pulley",
        )
    if not entries:
        return
    _require(
        p.role in ("driver", "driven"),
        f + ".excitation",
        p.excitation,
        f"engine orders drive a driver's speed or torque or a driven pulley's load, not a pulley of role {p.role!r}",
    )
    if not _follows_speed(p):
        for k, a, deg, _ in entries:
            _require(
                not deg,
                f"{f}.excitation.{k:g}.amplitude_deg",
                a,
                "an angular oscillation [deg] needs a prescribed speed; on a torque give 'amplitude' in N m",
            )
        return
    key = "speed_rpm" if p.speed_rpm is not None else "speed"
    if is_angle_law(getattr(p, key)):
        return  # a measured speed over the cycle: the orders add to it as given
    _check_no_reversal(f, key, p, entries)


def _check_no_reversal(f: str, key: str, p: PulleySpec, entries) -> None:
    """mean (1 - sum k X pi/180) - sum |A| > 0 at every knot of the mean speed law (the speed never reverses)."""
    mean = np.abs(_law_values(getattr(p, key))) * (_RPM if key == "speed_rpm" else 1.0)
    values = _law_values(getattr(p, key))
    lowest = 0.0 if values.size and values.min() < 0 < values.max() else float(mean.min()) if mean.size else 0.0
    rel = sum(k * abs(a) * math.pi / 180.0 for k, a, deg, _ in entries if deg)
    absolute = sum(abs(a) for _, a, deg, _ in entries if not deg)
    # amplitude_deg scales with the mean speed (k omega X pi/180): it never reverses the crank while
    # k X pi/180 < 1, even through a standstill; absolute amplitudes need the mean speed above them
    if rel < 1.0 and (absolute == 0.0 or lowest * (1.0 - rel) - absolute > 0):
        return
    share = [e[0] * abs(e[1]) * math.pi / 180.0 * lowest if e[2] else abs(e[1]) for e in entries]
    k, a, deg, _ = entries[int(np.argmax(share))]  # name the largest contribution
    what = f"{f}.excitation.{k:g}.amplitude" + ("_deg" if deg else "")
    raise ConfigError(
        f"{what} = {a:g}: the orders' speed amplitudes sum to {absolute + rel * lowest:.4g} rad/s, not below the "
        f"lowest mean speed {lowest:.4g} rad/s of {f}.{key}: the crank would turn backwards; allowed: "
        "sum of |amplitude| + sum of k omega |amplitude_deg| pi/180 < mean speed (start a run-up above it, "
        "or give amplitude_deg, which scales with the mean speed)"
    )


def check_pulley_mu(f: str, p: PulleySpec) -> None:
    if p.mu is not None:
        _require(
            _is_number(p.mu) and math.isfinite(float(p.mu)) and p.mu > 0,
            f + ".mu",
            p.mu,
            "must be a finite number > 0 (the pulley's own friction coefficient; leave it out for contact.mu)",
        )
        _require(p.mu <= 10.0, f + ".mu", p.mu, "is beyond any belt's grip (as contact.mu): at most 10")


def _angle_law_of(p: PulleySpec):
    return next((getattr(p, k) for k in _LAWS if is_angle_law(getattr(p, k))), None)


def build_excitation(spec: DriveSpec, sense) -> Excitation | None:
    """The stored orders and angle tables of the pulleys (model order), or None when no pulley has any."""
    per = [order_entries(_pulley_label(i, p), p) for i, p in enumerate(spec.pulleys)]
    laws = [_angle_law_of(p) for p in spec.pulleys]
    if not any(per) and all(law is None for law in laws):
        return None
    n, m = len(spec.pulleys), max(len(e) for e in per)
    rows = np.zeros((5, n, m))  # order, amplitude, phase, absolute, relative
    rows[0] = 1.0
    for i, entries in enumerate(per):
        for j, (k, a, deg, ph) in enumerate(entries):
            rows[:, i, j] = (k, a, ph, 0.0 if deg else 1.0, k * math.pi / 180.0 if deg else 0.0)
    starts = [angle_period(law) if law is not None else (0.0, 1.0) for law in laws]
    f = lambda x: jnp.asarray(x, dtype=float)  # noqa: E731
    return Excitation(
        sense=f(np.asarray(sense, dtype=float)),
        over_angle=f([0.0 if law is None else 1.0 for law in laws]),
        angle_start=f([s[0] for s in starts]),
        period=f([s[1] for s in starts]),
        order=f(rows[0]),
        amplitude=f(rows[1]),
        phase=f(rows[2]),
        absolute=f(rows[3]),
        relative=f(rows[4]),
        any_angle=any(law is not None for law in laws),
    )


def build_mu(spec: DriveSpec) -> tuple[tuple[bool, ...], jnp.ndarray | None]:
    """Which pulleys have their own ``mu`` (static) and the per-pulley values (None when none has)."""
    own = tuple(p.mu is not None for p in spec.pulleys)
    if not any(own):
        return (), None
    return own, jnp.asarray([spec.contact.mu if p.mu is None else p.mu for p in spec.pulleys], dtype=float)


# --------------------------------------------------------------------------- parameter keys
def parameter_keys(drive) -> list[str]:
    """``pulleys.<name>.mu`` (pulleys with their own) and ``pulleys.<name>.excitation.<order>.<key>``."""
    keys = []
    for i, (name, p) in enumerate(zip(drive.model.pulley_names, drive.spec.pulleys)):
        if drive.model.own_mu and drive.model.own_mu[i]:
            keys.append(f"pulleys.{name}.mu")
        for key, entry in (p.excitation or {}).items():
            form = "amplitude_deg" if "amplitude_deg" in entry else "amplitude"
            keys += [f"pulleys.{name}.excitation.{key}.{form}", f"pulleys.{name}.excitation.{key}.phase_deg"]
    return keys


def parameter_slot(drive, i: int, rest: str):
    """Where key ``pulleys.<name>.<rest>`` of pulley ``i`` sits: ``(selector, index, factor)`` with
    ``value = selector(params)[index] * factor``; None if ``rest`` is not one of this module's keys."""
    if rest == "mu":
        own = drive.model.own_mu
        return (lambda q: q.pulleys.mu, i, 1.0) if own and own[i] else None
    parts = rest.split(".")
    if len(parts) < 3 or parts[0] != "excitation":
        return None
    text, name = ".".join(parts[1:-1]), parts[-1]  # an order may hold a dot (1.5)
    for j, (key, entry) in enumerate((drive.spec.pulleys[i].excitation or {}).items()):
        try:
            same = float(key) == float(text)
        except ValueError:
            same = False
        if not same:
            continue
        if name == "phase_deg":
            return (lambda q: q.pulleys.excitation.phase, (i, j), 180.0 / math.pi)
        if name in entry and name in ("amplitude", "amplitude_deg"):
            return (lambda q: q.pulleys.excitation.amplitude, (i, j), 1.0)
    return None
