"""Is the summary window a steady state, and does any pulley slip grossly? Post-processing (numpy).

A duty figure is a mean over the final window of a run; it means something only if the drive has
stopped changing there. Three checks, each with the fix it suggests:

* **laws**: no prescribed speed, torque or load law may still change inside the window (its last
  knot after the window's start); engine orders over the crank angle are periodic and do not count.
* **drift**: the trend over the window of every free pulley's speed (and clutch rotor's), every span
  tension and every tensioner coordinate. The trend is the slope of a least-squares fit
  ``a + b (t - t_mid) + sum_k (c_k cos k w t + s_k sin k w t)`` times the window length, ``w`` the
  fundamental of the engine orders at the excited pulley's mean speed: the harmonics take out the
  forced response, whose partial periods would otherwise read as drift (only harmonics with a whole
  period inside the window are fitted). Limits: surface speed ``DRIFT_SPEED`` of the belt speed,
  tension ``DRIFT_TENSION`` of the span's mean (at least of the installed tension), arm ``DRIFT_ARM_DEG``,
  slider ``DRIFT_TRAVEL``.
* **gross slip** (any pulley, drivers included): in creep the surface of a pulley runs at the speed of
  the belt where it sticks, between the speeds of its two spans (``v (1 + eps)`` with their strains);
  a window-mean surface speed outside that interval by more than ``GROSS_SLIP`` of the belt speed means
  the belt slides over the whole arc.
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np

from .._drive import Drive
from .._types import DriveModel, DriveParams, DriveState
from ..contact.coefficients import pulley_mu
from .contact import SATURATION
from .signals import span_names
from .window import fundamental_orders

__all__ = [
    "steadiness",
    "stick_shares",
    "GROSS_SLIP",
    "DRIFT_SPEED",
    "DRIFT_TENSION",
    "DRIFT_ARM_DEG",
    "DRIFT_TRAVEL",
    "laws_end",
]

GROSS_SLIP = 0.01  # surface speed outside the spans' speeds by more than 1 % of the belt speed (squeal: ~1-2 %)
DRIFT_SPEED = 0.005  # trend of a surface speed over the window, fraction of the belt speed
DRIFT_TENSION = 0.02  # trend of a span tension, fraction of max(its mean, the installed tension)
DRIFT_ARM_DEG = 0.2  # trend of an arm angle [deg]
DRIFT_TRAVEL = 2e-4  # trend of a slider's travel [m]
MAX_HARMONICS = 12
MIN_WRAP_DEG = 5.0  # smaller wraps: no slip check (a few contact points)
STICK_SHARE_MIN = 0.05  # at most this share of a pulley's contact sticking (window mean): the whole arc slides


def stick_shares(model: DriveModel, params: DriveParams, states: DriveState, weight) -> jnp.ndarray:
    """Each pulley's share of sticking contact points among its contact points, over the saved states
    weighted by ``weight`` (T,) (traceable: the sweep's figure ``stick_share:<pulley>``). A point sticks
    below ``SATURATION`` of its friction bound, as the run's stick arcs count it (``outputs.contact``)."""
    pulley = jnp.clip(states.contact_pulley, 0, None).astype(int)  # (T, nc); -1 before the first step
    mu = pulley_mu(model, params)[pulley]
    coef = model.friction_law.coefficients(params)
    bound = model.friction_law.slip_bound(states.lam_n, {"mu": mu, **coef})
    touching = states.lam_n > 0
    stick = touching & (jnp.abs(states.lam_t) < SATURATION * bound)
    owner = pulley[..., None] == jnp.arange(model.n_pulleys)  # (T, nc, p)
    w = weight[:, None, None]
    n_stick = jnp.sum(jnp.where(owner & stick[..., None], w, 0.0), axis=(0, 1))
    n_touch = jnp.sum(jnp.where(owner & touching[..., None], w, 0.0), axis=(0, 1))
    return jnp.where(n_touch > 0, n_stick / jnp.where(n_touch > 0, n_touch, 1.0), 0.0)


def laws_end(drive: Drive) -> float:
    """Time [s] after which every prescribed speed and torque law (loads included) holds its last value
    (0 for constant laws). Padded knots repeat the last value and do not count."""
    end = 0.0
    pp = drive.params.pulleys
    for law in (pp.speed, pp.torque):
        t, v = np.asarray(law.times), np.asarray(law.values)
        for i in range(t.shape[0]):
            changed = np.nonzero(v[i] != v[i, -1])[0]  # knots before the last value is reached
            if changed.size:
                end = max(end, float(t[i, changed[-1] + 1]))
    return end


def _trend(t: np.ndarray, x: np.ndarray, bases: list[float]) -> float:
    """Change of ``x`` over the window by its linear trend (see ``_fit``)."""
    return _fit(t, x, bases)[1]


def _level(t: np.ndarray, x: np.ndarray, bases: list[float]) -> float:
    """Mean of ``x`` over the window without the partial periods of the forced response (see ``_fit``)."""
    return _fit(t, x, bases)[0]


def _fit(t: np.ndarray, x: np.ndarray, bases: list[float]) -> tuple[float, float]:
    """Level at the window's middle and change over the window of ``x``'s linear trend, with the harmonics
    of each base frequency [rad/s] fitted beside (those with a whole period inside the window, well below
    the saves' Nyquist frequency; fewer if the fit would be ill-conditioned)."""
    if t.size < 3:
        return (float(np.mean(x)) if t.size else math.nan), 0.0
    if not np.all(np.isfinite(x)):
        return math.nan, math.nan
    span = float(t[-1] - t[0])
    tau = t - 0.5 * (t[0] + t[-1])
    base = [np.ones_like(t), tau]
    freqs: list[float] = []
    if span > 0:
        nyquist = math.pi * (t.size - 1) / span
        for w in bases:
            freqs += [
                k * w for k in range(1, MAX_HARMONICS + 1) if 2 * math.pi <= k * w * span and k * w <= 0.25 * nyquist
            ]
    freqs = sorted(set(round(f, 9) for f in freqs))[: max(0, (t.size - 3) // 4)]
    while True:
        cols = base + [f(w * t) for w in freqs for f in (np.cos, np.sin)]
        A = np.stack(cols, axis=1)
        scale = np.linalg.norm(A, axis=0)
        if not freqs or np.linalg.cond(A / scale) < 1e6:
            break
        freqs = freqs[:-1]  # the highest harmonic out until the fit is well posed
    coef, *_ = np.linalg.lstsq(A / scale, x, rcond=None)
    return float(coef[0] / scale[0]), float(coef[1] / scale[1] * span)


def _base_frequencies(drive: Drive, sig: dict, sel) -> list[float]:
    """The fundamental frequency [rad/s] of each excited pulley's engine orders at its mean speed: the
    greatest common divisor of its orders (in quarters) times its speed. None without excitation."""
    names = drive.model.pulley_names
    out = [g * abs(float(np.mean(sig[f"omega:{names[i]}"][sel]))) for i, g in fundamental_orders(drive).items()]
    return [w for w in out if w > 0]


def steadiness(drive: Drive, sig: dict, sel, *, check_drift: bool = True, stick_share: dict | None = None) -> dict:
    """The checks over the window ``sel`` (a mask of the saved states) of the signals ``sig``.

    Returns ``steady`` (laws and drift; True when ``check_drift`` is off), ``gross_slip`` (pulley names),
    ``findings`` (one sentence each), ``fixes``, ``intermittent_slip`` (a sentence, or None: pulleys
    that slip beyond creep on average but stick part of the time), ``laws_end_s`` and, per checked signal,
    ``drift`` (its trend over the window, in the signal's unit; arm angles in degrees). ``stick_share``:
    each pulley's mean share of sticking contact over the window (see ``_gross_slip``)."""
    names = list(drive.model.pulley_names)
    t = np.asarray(sig["t"])[sel]
    radius = np.asarray(drive.params.pulleys.radius)
    spans = [f"{a}-{b}" for a, b in span_names(drive)]
    v_belt = float(np.mean([abs(float(np.mean(sig[f"speed:{s}"][sel]))) for s in spans])) if t.size else 0.0
    bases = _base_frequencies(drive, sig, sel) if t.size else []
    found: list[str] = []
    fixes: list[str] = []
    drift: dict[str, float] = {}
    steady = True
    t_laws = laws_end(drive)
    if check_drift and t.size and t_laws > float(t[0]) + 1e-12:
        steady = False
        found.append(f"prescribed laws still change until t = {t_laws:.4g} s, inside the window from {t[0]:.4g} s")
        fixes.append(f"end the ramps earlier or run longer (solver.t_end >= {t_laws + (t[-1] - t[0]) * 1.5:.3g} s)")
    if check_drift and t.size >= 3:
        w = bases
        T0 = float(drive.params.belt.EA) * (float(drive.path.length) / float(drive.params.belt.stress_free_length) - 1)
        moving: list[str] = []
        speed_floor = max(v_belt, 1e-3)
        for i, n in enumerate(names):
            for key in (f"omega:{n}", f"rotor_omega:{n}"):
                if key in sig and not (key.startswith("omega:") and drive.model.kinematic[i]):
                    d = _trend(t, np.asarray(sig[key])[sel], w)
                    drift[key] = d
                    if not abs(d) * radius[i] <= DRIFT_SPEED * speed_floor:
                        moving.append(f"{key} {d:+.3g} rad/s")
        for s in spans:
            x = np.asarray(sig[f"tension:{s}"])[sel]
            d = drift[f"tension:{s}"] = _trend(t, x, w)
            if not abs(d) <= DRIFT_TENSION * max(abs(float(x.mean())), T0):
                moving.append(f"tension:{s} {d:+.3g} N")
        for n in names:
            if f"arm_angle:{n}" in sig:
                d = drift[f"arm_angle:{n}"] = math.degrees(_trend(t, np.asarray(sig[f"arm_angle:{n}"])[sel], w))
                if not abs(d) <= DRIFT_ARM_DEG:
                    moving.append(f"arm_angle:{n} {d:+.3g} deg")
            if f"travel:{n}" in sig:
                d = drift[f"travel:{n}"] = _trend(t, np.asarray(sig[f"travel:{n}"])[sel], w)
                if not abs(d) <= DRIFT_TRAVEL:
                    moving.append(f"travel:{n} {1e3 * d:+.3g} mm")
        if moving:
            steady = False
            found.append("still changing over the window (trend over the window): " + ", ".join(moving))
            fixes.append("run longer (solver.t_end or --t-end) or start nearer the operating point")
    slipping, partial = _gross_slip(drive, sig, sel, bases, stick_share) if t.size else ([], [])
    if slipping:  # first: the status then reads "gross slip: the belt slides ..."
        found.insert(
            0,
            "the belt slides over the whole arc of "
            + ", ".join(f"{n!r} (slip {100 * s:+.3g} % of the belt speed)" for n, s in slipping),
        )
        fixes.insert(
            0,
            "lower the load or its ramp rate (accessories accelerate through the belt), raise belt.pretension, "
            "the tensioner preload or contact.mu, or wrap more of the slipping pulley",
        )
    return dict(
        steady=steady,
        gross_slip=[n for n, _ in slipping],
        findings=found,
        fixes=fixes,
        # only in a steady window: while the drive accelerates, belt and pulley speeds part by their inertia too
        intermittent_slip=(
            "slip beyond creep on average (mean surface speed outside its spans' speeds by more than "
            f"{100 * GROSS_SLIP:g} % of the belt speed, while part of the contact grips: intermittent slip, or the "
            "regularised law's sliding; belt minus surface): "
            + ", ".join(f"{n!r} {100 * x:+.3g} %" for n, x in partial)
            if partial and steady and check_drift
            else None
        ),
        laws_end_s=t_laws,
        drift=drift,
    )


def _gross_slip(
    drive: Drive, sig: dict, sel, bases: list[float], stick_share: dict | None
) -> tuple[list[tuple[str, float]], list[tuple[str, float]]]:
    """Pulleys whose mean surface speed lies outside their two spans' speeds by more than ``GROSS_SLIP`` of
    the belt speed, as ``(name, slip)`` with slip = (belt - surface) / belt (the ``slip`` signal's sign): in
    gross slip where at most ``STICK_SHARE_MIN`` of their contact sticks (``stick_share``: pulley -> share;
    None: unknown, speeds alone decide), else slipping intermittently (part of each cycle). Means are the
    levels of ``_fit``."""
    t = np.asarray(sig["t"])[sel]
    names = list(drive.model.pulley_names)
    spans = [f"{a}-{b}" for a, b in span_names(drive)]
    v_span = np.array([_level(t, np.asarray(sig[f"speed:{s}"])[sel], bases) for s in spans])
    k = len(names)
    radius = np.asarray(drive.params.pulleys.radius)
    wrap = np.degrees(np.asarray(drive.path.wrap_angle))
    sense = np.asarray(drive.running_sense, dtype=float)
    omega = [_level(t, np.asarray(sig[f"omega:{n}"])[sel], bases) for n in names]
    surfaces = [sense[i] * omega[i] * radius[i] for i in range(k)]
    # the speed the slip is measured against: the belt's, or a pulley's surface where the belt hardly moves (a
    # driver spinning under a belt that friction does not take along: mu ~ 0 read "ok" with the belt's alone)
    v_belt = max([float(np.mean(np.abs(v_span))) if v_span.size else 0.0, *(abs(float(x)) for x in surfaces)])
    if not v_belt > 1e-3:
        return [], []
    direction = float(np.mean(v_span)) if v_span.size and abs(float(np.mean(v_span))) > 1e-3 * v_belt else 1.0
    gross: list[tuple[str, float]] = []
    partial: list[tuple[str, float]] = []
    for i, n in enumerate(names):
        if wrap[i] < MIN_WRAP_DEG:
            continue
        surface = surfaces[i]
        ref = math.copysign(1.0, direction) * surface
        lo, hi = sorted((abs(v_span[(i - 1) % k]), abs(v_span[i])))
        if max(lo - ref, ref - hi, 0.0) > GROSS_SLIP * v_belt:
            slip = ((lo if ref < lo else hi) - ref) / v_belt  # as the slip signal: > 0 the belt runs ahead
            share = None if stick_share is None else stick_share.get(n)
            (gross if share is None or not share > STICK_SHARE_MIN else partial).append((n, slip))
    return gross, partial
