"""Belt tension from a measured span frequency, and the span's frequencies from a tension.

Sonic tension meters pluck a span and read its first transverse frequency; ``T = 4 m' L^2 f^2`` (a string
of length L between fixed points) is what they print. A belt span is not that string: it has bending
stiffness, its ends are the tangent points on pulleys whose compliant contact lets the belt move at the
ends, its mass per current length is ``m' = m0 / (1 + T / EA)``, and it may run. This module solves the
span's frequency equation with all of these and inverts it.

The span (length L between the tangent points) is a tensioned Euler-Bernoulli beam,
``EI w'''' - T w'' - m' w^2 w = 0``; beyond each tangent point the belt lies on the pulley, a beam on the
contact's elastic foundation (stiffness ``k`` per unit length, the model's ``contact.stiffness``):
``EI w'''' - T w'' + (k - m' w^2) w = 0``, its solutions decaying into the wrap. ``w`` and its first
three derivatives are continuous at the tangent points. The decaying pair of roots ``r1, r2`` enters only
through ``r1 + r2 = -sqrt(T/EI + 2Q)`` and ``r1 r2 = Q = sqrt((k - m' w^2) / EI)``, both real whether the
roots are real or complex, so each end gives two real conditions

    w'' = p w' + q w,   w''' = (p^2 + q) w' + p q w,    p = r1 + r2, q = -r1 r2,

and the symmetric (n odd) and antisymmetric (n even) modes each a 2 x 2 determinant. Limits: EI -> 0 gives
a string whose ends sit ``l = sqrt(T / (k - m' w^2))`` inside the wraps (the span acts ``2 l`` longer: a few mm on
a poly-V belt), k -> inf a tensioned beam clamped at the tangent points (``f_n ~ f_string (1 + 2 / lam +
...)``, ``lam = L sqrt(T / EI)``). The pinned-pinned formula ``f_n sqrt(1 + pi^2 n^2 EI / (T L^2))`` is
neither. Running belts: the static frequency times the moving string's factor ``1 - v^2 / c^2``,
``c^2 = T / m'`` (exact for the string, an approximation with bending and compliant ends).

Plain numpy in float64: a scan for sign changes and bisection for the frequency, bisection in log T for
the inverse; the uncertainty from the derivatives of the solved frequency (central differences).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._errors import ConfigError

__all__ = ["Span", "span_frequency", "span_tension", "SpanTension", "span_of"]

SCAN_POINTS = 600  # sign-change scan of the frequency function per mode
BISECTIONS = 80  # to float64 round-off from the scan's bracket


@dataclasses.dataclass(frozen=True)
class Span:
    """One span's numbers: tangent-to-tangent ``length`` [m], the belt's ``mass_per_length`` per stress-free
    length [kg/m], ``EA`` [N], ``EI`` [N m^2], the contact ``foundation`` stiffness per unit length [N/m^2]
    (``math.inf``: rigid pulleys) and the belt ``speed`` [m/s]."""

    length: float
    mass_per_length: float
    EA: float
    EI: float
    foundation: float
    speed: float = 0.0
    name: str = "span"

    def __post_init__(self):
        for key in ("length", "mass_per_length", "EA", "foundation"):
            x = getattr(self, key)
            if not (isinstance(x, (int, float)) and x > 0 and not math.isnan(x)):
                raise ConfigError(f"span {self.name}: {key} = {x!r} must be a positive number")
        for key in ("EI", "speed"):
            x = getattr(self, key)
            if not (isinstance(x, (int, float)) and math.isfinite(x) and x >= 0):
                raise ConfigError(f"span {self.name}: {key} = {x!r} must be a finite number >= 0")

    def mass_at(self, T: float) -> float:
        """Mass per current length at tension T: the stress-free mass spread over the stretched length."""
        return self.mass_per_length / (1.0 + T / self.EA)


def _end_coefficients(span: Span, T, m, w):
    """p, q of the decaying solutions on the wrap (see the module docstring), scaled by 1/|p|."""
    EI, k = span.EI, span.foundation
    if math.isinf(k):
        return None
    Q = np.sqrt(np.maximum(k - m * w * w, 0.0) / EI)
    p = -np.sqrt(T / EI + 2.0 * Q)
    return p, -Q


def _mode_function(span: Span, T: float, w: np.ndarray, symmetric: bool) -> np.ndarray:
    """A function of the angular frequency ``w`` whose zeros are the static span's frequencies of one
    symmetry class (continuous in w, rows scaled so that it stays finite for any EI)."""
    h = 0.5 * span.length
    m = span.mass_at(T)
    w = np.asarray(w, dtype=float)
    if span.EI == 0.0:  # string: w' = -w / l at the right end, l = sqrt(T / (k - m w^2))
        a = w * np.sqrt(m / T)
        ell = 0.0 if math.isinf(span.foundation) else np.sqrt(T / np.maximum(span.foundation - m * w * w, 1e-300))
        if symmetric:
            return np.cos(a * h) - a * ell * np.sin(a * h)
        return np.sin(a * h) / np.maximum(a * h, 1e-300) + ell / h * np.cos(a * h)  # a = 0 root removed
    EI = span.EI
    root = np.sqrt(T * T + 4.0 * EI * m * w * w)
    alpha = np.sqrt(2.0 * m * w * w / (root + T))  # no cancellation for small EI
    beta = np.sqrt((T + root) / (2.0 * EI))
    c, s = np.cos(alpha * h), np.sin(alpha * h)
    if symmetric:  # cos(alpha x), cosh(beta x) / cosh(beta h)
        t = np.tanh(beta * h)
        f1 = (c, -alpha * s, -(alpha**2) * c, alpha**3 * s)
    else:  # sin(alpha x) / (alpha h), sinh(beta x) / sinh(beta h)
        t = 1.0 / np.tanh(beta * h)
        ah = np.maximum(alpha * h, 1e-300)
        f1 = (s / ah, alpha * c / ah, -(alpha**2) * s / ah, -(alpha**3) * c / ah)
    f2 = (np.ones_like(w), beta * t, beta**2, beta**3 * t)
    pq = _end_coefficients(span, T, m, w)
    if pq is None:  # rigid pulleys: clamped at the tangent points (w = w' = 0)
        rows = lambda f: (f[0], f[1] / beta)  # noqa: E731
    else:
        p, q = pq
        scale = -p

        def rows(f):
            return ((f[2] - p * f[1] - q * f[0]) / scale, (f[3] - (p * p + q) * f[1] - p * q * f[0]) / scale**3)

    a1, a2 = rows(f1)
    b1, b2 = rows(f2)
    return a1 * b2 - a2 * b1


def _string_estimate(span: Span, T: float, n: int) -> float:
    """The pinned string's n-th static frequency with the bending factor [Hz] (a scan's scale)."""
    m = span.mass_at(T)
    B = math.pi**2 * span.EI / (T * span.length**2)
    return n / (2.0 * span.length) * math.sqrt(T / m) * math.sqrt(1.0 + B * n * n)


def _static_frequency(span: Span, T: float, n: int) -> float:
    """The n-th transverse frequency of the span at rest [Hz]."""
    symmetric = n % 2 == 1
    order = (n + 1) // 2 if symmetric else n // 2  # the order-th root of its symmetry class
    f_est = _string_estimate(span, T, n)
    hi = 1.6 * f_est + 2.0 * _string_estimate(span, T, 1)
    while True:
        f = np.linspace(0.02 * f_est / n, hi, SCAN_POINTS * max(1, n // 2 + 1))
        g = _mode_function(span, T, 2 * math.pi * f, symmetric)
        change = np.flatnonzero(np.sign(g[:-1]) * np.sign(g[1:]) <= 0)
        if change.size >= order:
            break
        if hi > 1e3 * f_est:  # pragma: no cover - the function always has its roots below this
            raise RuntimeError(f"span {span.name}: mode {n} not found below {hi:.4g} Hz")
        hi *= 2.0
    lo, up = f[change[order - 1]], f[change[order - 1] + 1]
    g_lo = _mode_function(span, T, 2 * math.pi * lo, symmetric)
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + up)
        g_mid = _mode_function(span, T, 2 * math.pi * mid, symmetric)
        if np.sign(g_mid) == np.sign(g_lo):
            lo, g_lo = mid, g_mid
        else:
            up = mid
        if up - lo <= 1e-15 * up:
            break
    return 0.5 * (lo + up)


def _check_speed(span: Span, T: float) -> float:
    c2 = T / span.mass_at(T)
    if span.speed**2 >= c2:
        raise ConfigError(
            f"span {span.name}: belt speed {span.speed:.4g} m/s is at or above the span's transverse wave speed "
            f"{math.sqrt(c2):.4g} m/s at {T:.4g} N (critical speed): no transverse frequency"
        )
    return 1.0 - span.speed**2 / c2


def span_frequency(span: Span, tension: float, mode: int = 1) -> float:
    """The span's ``mode``-th transverse frequency [Hz] at ``tension`` [N] (module docstring)."""
    _check_mode(mode)
    T = float(tension)
    if not (math.isfinite(T) and T > 0):
        raise ConfigError(f"span {span.name}: tension = {tension!r} must be a positive number [N]")
    return _static_frequency(span, T, mode) * _check_speed(span, T)


@dataclasses.dataclass(frozen=True)
class SpanTension:
    """Result of :func:`span_tension`: ``tension`` [N] and its parts (what each correction changes), the
    derivatives used for the uncertainty, and the uncertainty for the given ``frequency_uncertainty`` [Hz]
    and ``length_uncertainty`` [m] (root sum of squares)."""

    span: str
    mode: int
    frequency: float
    tension: float
    uncertainty: float
    string_tension: float  # 4 m0 L^2 f^2 / n^2: what a plain sonic meter prints with the catalogue mass
    current_mass_tension: float  # the string with the mass per current length
    static_tension: float  # + bending and compliant ends, belt at rest
    dT_df: float  # [N/Hz]
    dT_dL: float  # [N/m]
    length: float
    speed: float
    frequency_uncertainty: float
    length_uncertainty: float

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


def _check_mode(mode) -> None:
    if isinstance(mode, bool) or not isinstance(mode, (int, np.integer)) or mode < 1:
        raise ConfigError(f"mode = {mode!r}: must be an integer >= 1 (1: the span's first transverse mode)")


def _invert(span: Span, f: float, mode: int) -> float:
    """The tension at which the span's ``mode``-th frequency is ``f``: bisection in log T (f rises with T)."""
    T0 = 4.0 * span.mass_per_length * span.length**2 * f * f / mode**2
    lo, hi = T0 / 4.0, T0 * 4.0
    freq = lambda T: span_frequency(span, T, mode) if span.speed**2 < T / span.mass_at(T) else -math.inf  # noqa: E731
    for _ in range(60):
        if freq(lo) < f:
            break
        lo /= 4.0
    for _ in range(60):
        if freq(hi) > f:
            break
        hi *= 4.0
    if not (freq(lo) < f < freq(hi)):
        raise ConfigError(f"span {span.name}: no tension gives {f:.6g} Hz in mode {mode}")
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        if freq(mid) < f:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-13 * hi:
            break
    return math.sqrt(lo * hi)


def span_tension(
    span: Span,
    frequency: float,
    mode: int = 1,
    *,
    frequency_uncertainty: float = 0.0,
    length_uncertainty: float = 0.0,
) -> SpanTension:
    """The span's tension [N] from its measured ``mode``-th transverse ``frequency`` [Hz], with every
    correction of the module docstring, and its uncertainty from the frequency's and the span length's."""
    _check_mode(mode)
    f = float(frequency)
    if not (math.isfinite(f) and f > 0):
        raise ConfigError(f"span {span.name}: frequency = {frequency!r} must be a positive number [Hz]")
    for key, x in (("frequency_uncertainty", frequency_uncertainty), ("length_uncertainty", length_uncertainty)):
        if not (math.isfinite(x) and x >= 0):
            raise ConfigError(f"{key} = {x!r} must be a finite number >= 0")
    T = _invert(span, f, mode)
    df = 1e-6 * f
    dT_df = (_invert(span, f + df, mode) - _invert(span, f - df, mode)) / (2 * df)
    dL = 1e-6 * span.length
    longer = dataclasses.replace(span, length=span.length + dL)
    shorter = dataclasses.replace(span, length=span.length - dL)
    dT_dL = (_invert(longer, f, mode) - _invert(shorter, f, mode)) / (2 * dL)
    string = 4.0 * span.mass_per_length * span.length**2 * f * f / mode**2
    # string with m' = m0 / (1 + T / EA): T (1 + T / EA) = string, the positive root
    current = 2.0 * string / (1.0 + math.sqrt(1.0 + 4.0 * string / span.EA))
    static = _invert(dataclasses.replace(span, speed=0.0), f, mode)
    return SpanTension(
        span=span.name,
        mode=int(mode),
        frequency=f,
        tension=T,
        uncertainty=math.hypot(dT_df * frequency_uncertainty, dT_dL * length_uncertainty),
        string_tension=string,
        current_mass_tension=current,
        static_tension=static,
        dT_df=dT_df,
        dT_dL=dT_dL,
        length=span.length,
        speed=span.speed,
        frequency_uncertainty=float(frequency_uncertainty),
        length_uncertainty=float(length_uncertainty),
    )


def span_of(drive, name: str, *, length: float | None = None, speed: float = 0.0) -> Span:
    """The :class:`Span` called ``name`` (``"A-B"`` or ``"B-A"``, A and B neighbouring pulleys) of ``drive``:
    its tangent-to-tangent length from the installation statics (tensioners at their installed
    equilibrium) unless ``length`` [m] is given, the belt's numbers, the contact stiffness as the
    foundation, and the belt ``speed`` [m/s]."""
    from .statics import statics

    names = list(drive.model.pulley_names)
    k = len(names)
    spans = {f"{names[j]}-{names[(j + 1) % k]}": j for j in range(k)}
    for j in range(k):  # B-A names the same span unless it is another span's own name (two pulleys)
        spans.setdefault(f"{names[(j + 1) % k]}-{names[j]}", j)
    if name not in spans:
        listed = ", ".join(f"{names[j]}-{names[(j + 1) % k]}" for j in range(k))
        raise ConfigError(f"span {name!r}: no such span; the drive's spans are {listed}")
    j = spans[name]
    if length is None:
        length = statics(drive).spans[j]["length"]
    b = drive.params.belt
    return Span(
        length=float(length),
        mass_per_length=float(b.mass_per_length),
        EA=float(b.EA),
        EI=float(b.EI),
        foundation=float(drive.params.contact_stiffness),
        speed=float(speed),
        name=f"{names[j]}-{names[(j + 1) % k]}",
    )
