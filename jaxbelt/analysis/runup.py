"""Run-up: the crank speed ramped through a range with its engine-order excitation; amplitudes and order
content of chosen signals against crank speed, with the resonance crossings of the linearised modes.

The driver's speed law becomes: rest, a smooth start to ``rpm_start`` (``lead_time``), then a linear ramp
to ``rpm_end`` over ``duration``; the configuration's ``excitation`` orders stay (they are defined over
crank angle, so they remain orders through the ramp). The ramp is cut into windows of
``revolutions`` crank revolutions; per window and signal: the mean crank speed, the half peak-to-peak
amplitude and the amplitude of each engine order after removing the window's linear trend
(``outputs.spectra.order_spectrum`` over the window,
Hann window, on-bin for orders that are multiples of ``1 / revolutions``). A rotational mode of frequency
``f`` is crossed by order ``k`` at ``60 f / k`` rpm; a span's transverse mode is crossed where ``k n / 60``
meets its running frequency, which falls with the belt speed and follows the span's tension in the run-up
(``campbell``: at 2,900 rpm a span at v/c = 0.3 runs 10 % below its frequency at rest).
"""

from __future__ import annotations
from ..config.validate import resolve_model

import copy
import dataclasses
import math
from typing import Any

import numpy as np

from .._errors import ConfigError

__all__ = ["RunUp", "run_up", "track_orders", "resonance_crossings"]


@dataclasses.dataclass
class RunUp:
    rpm: np.ndarray  # (W,) mean crank speed per window
    amplitude: dict  # signal -> (W,) half peak-to-peak per window
    orders: dict  # signal -> {order: (W,) amplitude}
    crossings: list  # {"mode", "frequency_hz", "kind", "order", "rpm"} inside the ramp
    result: Any  # the RunResult of the run-up (None for a RunUp made by hand)


def track_orders(angle, signals: dict, orders, revolutions: int = 4):
    """Per window of ``revolutions`` revolutions of ``angle`` [rad, increasing]: mean speed [rpm] (from the
    angle and ``signals["t"]``), half peak-to-peak and order amplitudes of every other signal."""
    from ..outputs.spectra import order_spectrum

    angle = _increasing(angle)
    t = np.asarray(signals["t"], dtype=float)
    names = [n for n in signals if n != "t"]
    rpm: list[float] = []
    amp: dict[str, list[float]] = {n: [] for n in names}
    per_order: dict[str, dict] = {n: {k: [] for k in orders} for n in names}
    for sel in _windows(angle, revolutions):
        ts, angs = t[sel], angle[sel]
        rpm.append(_window_rpm(ts, angs))
        for n in names:
            x = np.asarray(signals[n], dtype=float)[sel]
            amp[n].append(0.5 * float(np.ptp(x)))
            # the ramp's own trend over the window would leak into the low orders: remove its straight line
            spec = order_spectrum(angs, x - np.polyval(np.polyfit(angs, x, 1), angs))
            for k in orders:
                i = int(np.argmin(np.abs(spec["order"] - k)))
                per_order[n][k].append(float(spec["amplitude"][i]))
    return (
        np.asarray(rpm),
        {n: np.asarray(v) for n, v in amp.items()},
        {n: {k: np.asarray(v) for k, v in d.items()} for n, d in per_order.items()},
    )


def _increasing(angle) -> np.ndarray:
    angle = np.asarray(angle, dtype=float)
    return -angle if angle[-1] < angle[0] else angle


def _windows(angle: np.ndarray, revolutions: int):
    """Boolean selections of the saves in each whole window of ``revolutions`` turns of the increasing
    ``angle`` (a window holding fewer than ``MIN_SAMPLES_PER_WINDOW`` saves is skipped)."""
    edges = np.arange(angle[0], angle[-1], 2 * math.pi * revolutions)
    for a, b in zip(edges[:-1], edges[1:]):
        sel = (angle >= a) & (angle < b)
        if np.count_nonzero(sel) >= MIN_SAMPLES_PER_WINDOW:
            yield sel


def _window_rpm(ts: np.ndarray, angs: np.ndarray) -> float:
    return float((angs[-1] - angs[0]) / (ts[-1] - ts[0]) * 60 / (2 * math.pi))


def window_means(angle, signals: dict, revolutions: int = 4):
    """Per window of ``track_orders``: the mean crank speed [rpm] and each signal's mean (``signals["t"]``
    the save times)."""
    angle = _increasing(angle)
    t = np.asarray(signals["t"], dtype=float)
    names = [n for n in signals if n != "t"]
    sels = list(_windows(angle, revolutions))
    rpm = np.array([_window_rpm(t[s], angle[s]) for s in sels])
    return rpm, {n: np.array([float(np.mean(np.asarray(signals[n])[s])) for s in sels]) for n in names}


def resonance_crossings(modes, orders, rpm_start: float, rpm_end: float) -> list:
    """The crank speeds inside the ramp at which order k meets a mode of fixed frequency (``60 f / k``);
    ``modes``: a ``Modes`` (or any record with ``frequencies`` and ``kinds``). A run-up's span modes follow the
    belt speed and span tension instead (``campbell``)."""
    from .campbell import CampbellLines, order_crossings

    rows = [dict(mode=j + 1, frequency_hz=float(f), kind=kind, span=span)
            for j, (f, kind, span) in enumerate(zip(modes.frequencies, modes.kinds, _spans(modes)))]  # fmt: skip
    f = np.array([r["frequency_hz"] for r in rows]).reshape(len(rows), 1)
    return order_crossings(CampbellLines(rpm=np.zeros(1), frequency=f, modes=rows, tension_from="installed"),
                           orders, rpm_start, rpm_end)  # fmt: skip


def _spans(modes) -> list:
    return list(getattr(modes, "span", None) or [None] * len(modes.frequencies))


def _run_up_crossings(drive, table: list[dict], orders, rpm_start, rpm_end, angle, sig, revolutions) -> list:
    """The crossings of ``table``'s modes (rows with ``frequency_hz``, ``kind``, ``span``) inside the ramp, the
    span modes at the run-up's own span tensions (window means; the first and last window's out to the ramp's
    ends) and belt speed (``campbell``)."""
    from .campbell import campbell_lines, order_crossings

    spans = sorted({r["span"] for r in table if r.get("kind") == "transverse" and r.get("span")})
    wanted = {"t": sig["t"], **{s: sig[f"tension:{s}"] for s in spans if f"tension:{s}" in sig}}
    rpm, means = window_means(angle, wanted, revolutions)
    lo, hi = sorted((rpm_start, rpm_end))
    if rpm.size:
        order = np.argsort(rpm)
        grid = np.concatenate([[min(lo, rpm[order[0]])], rpm[order], [max(hi, rpm[order[-1]])]])
        tension = {s: np.concatenate([[m[order[0]]], m[order], [m[order[-1]]]]) for s, m in means.items()}
    else:  # no whole window: the installed tensions
        grid, tension = np.linspace(lo, hi, 201), {}
    lines = campbell_lines(drive, table, grid, tension, tension_from="run-up window means")
    return order_crossings(lines, orders, rpm_start, rpm_end)


def _check_turns(rpm_start: float, rpm_end: float, duration: float, revolutions: int) -> None:
    """The ramp turns the crank through at least one window of ``revolutions`` (else it ran to track nothing)."""
    turns = 0.5 * (rpm_start + rpm_end) / 60.0 * duration
    if turns < revolutions:
        one = revolutions * 60.0 / (0.5 * (rpm_start + rpm_end))
        raise ConfigError(
            f"run-up: duration = {duration!r} s: {rpm_start:g} -> {rpm_end:g} rpm turns the crank {turns:.3g} times, "
            f"fewer than one window of revolutions = {revolutions}; give a duration of at least {one:.3g} s "
            f"(about {10 * one:.3g} s for ten windows), or fewer revolutions per window"
        )


# A window's order spectrum needs at least this many saved samples (``track_orders`` skips a thinner one).
MIN_SAMPLES_PER_WINDOW = 16


def _check_samples(save_dt: float, rpm_start: float, rpm_end: float, revolutions: int) -> None:
    """Every window of ``revolutions`` holds ``MIN_SAMPLES_PER_WINDOW`` saves at the highest speed (else the
    windows there are skipped: a run-up that tracked nothing, or only its slow part, said "ok")."""
    fastest = max(rpm_start, rpm_end)
    window = revolutions * 60.0 / fastest
    if window / save_dt < MIN_SAMPLES_PER_WINDOW:
        need = window / MIN_SAMPLES_PER_WINDOW
        raise ConfigError(
            f"run-up: solver.save_dt = {save_dt:g} s: a window of revolutions = {revolutions} lasts {window:.3g} s at "
            f"{fastest:g} rpm, {window / save_dt:.3g} saves where its order spectrum needs {MIN_SAMPLES_PER_WINDOW}; "
            f"save at least every {need:.3g} s, or more revolutions per window"
        )


def run_up(
    spec,
    rpm_start: float,
    rpm_end: float,
    duration: float,
    *,
    signals: list[str] | None = None,
    orders=(1, 2, 4),
    revolutions: int = 4,
    lead_time: float = 0.2,
    modes: bool = True,
    model: str | None = None,
) -> RunUp:
    """Run ``spec`` (a DriveSpec) through the ramp; ``signals``: names to track (default: every tensioner
    coordinate and span tension); ``model``: ``"ancf"`` (the ANCF belt) or ``"spans"`` (the spans tier, its
    own modes for the crossings: docs/spans.md); None: the spec's ``solver.model``.

    Parameters: the spec and the ramp (start and end speed, duration) with six keyword options of one study
    (signals, orders, revolutions per window, lead time, modes, tier), each with a default and passed by name;
    a record of them would only rename them."""
    from ..config import build_drive
    from .run import run

    model = resolve_model(spec, model, "run-up")
    for name, v in (("rpm_start", rpm_start), ("rpm_end", rpm_end), ("duration", duration), ("lead_time", lead_time)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise ConfigError(f"run-up: {name} = {v!r}: must be a finite number > 0")
    if not (isinstance(revolutions, int) and revolutions >= 1):
        raise ConfigError(f"run-up: revolutions = {revolutions!r}: must be a whole number >= 1")
    spec = copy.deepcopy(spec)
    drivers = [p for p in spec.pulleys if p.role == "driver" and (p.speed is not None or p.speed_rpm is not None)]
    if len(drivers) != 1:
        raise ConfigError("run-up: needs exactly one driver with a prescribed speed ('speed' or 'speed_rpm')")
    d = drivers[0]
    d.speed = None
    d.speed_rpm = {"table": [[0.0, 0.0], [lead_time, rpm_start], [lead_time + duration, rpm_end]]}
    spec.solver.t_end = lead_time + duration
    drive = build_drive(spec)
    from ..outputs.signals import signal_names

    if model == "spans":
        from ..spans import spans_signal_names

        known = ["t", *spans_signal_names(drive)]
    else:
        known = ["t", *signal_names(drive)]
    wanted = signals or [n for n in known if n.startswith(("arm_angle:", "travel:", "tension:"))]
    unknown = [n for n in wanted if n not in known]
    if unknown:  # before the run: a typo costs nothing
        from .._errors import did_you_mean

        hint = did_you_mean(unknown[0], known)
        raise ConfigError(f"run-up: signal {unknown[0]!r} is not a signal of this drive{hint}")
    _check_turns(rpm_start, rpm_end, duration, revolutions)
    _check_samples(float(drive.options.save_dt), rpm_start, rpm_end, revolutions)
    result: Any
    if model == "spans":
        from ..spans import run_spans

        result = run_spans(drive, steady=False)  # a run-up changes on purpose
    else:
        result = run(drive, steady=False, model="ancf")  # a ramp changes on purpose: gross slip is still flagged
    from ..outputs.spectra import crank_angle

    sig = result.signals
    keep = np.asarray(sig["t"]) >= lead_time
    angle = crank_angle(result)[keep]
    tracked = {"t": np.asarray(sig["t"])[keep], **{n: np.asarray(sig[n])[keep] for n in wanted}}
    rpm, amp, per_order = track_orders(angle, tracked, orders, revolutions)
    crossings = []
    if modes:
        if model == "spans":
            from ..spans import spans_campbell_modes

            table = spans_campbell_modes(drive, count=6)  # as the ANCF tier's: its lowest six, undamped
        else:
            from .modes import linear_modes

            table = linear_modes(drive, count=6).table()
        tensions = {n: np.asarray(v)[keep] for n, v in sig.items() if n == "t" or n.startswith("tension:")}
        crossings = _run_up_crossings(drive, table, orders, rpm_start, rpm_end, angle, tensions, revolutions)
    return RunUp(rpm=rpm, amplitude=amp, orders=per_order, crossings=crossings, result=result)
