"""The summary window: which saved states a run's steady figures (means, amplitudes, minima, arcs, power
balance) are taken over. One rule for every command and both tiers, for numpy and traced arrays.

The window is the final ``window`` fraction of the run, trimmed at its start to a **whole number of periods
of the engine orders** where one pulley is excited: a mean over a fractional number of periods carries part
of a period of the forced response. Measured on the accessory example at idle (window 0.4-0.5 s, 2.68 periods of
the 2nd order, tensions rippling +-83 ... +-132 N): the slack spans' means read 182 / 184 N where whole periods give
194 / 195 N (-6 %), the crank's mean friction use 0.724 for 0.674 (+7 %). The period is the fundamental of the
pulley's orders (the greatest common divisor of its orders, in quarters) in its own rotation angle, so it holds
while the speed varies within the window. A window shorter than one period is kept as it is (and said:
``periods``).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np

from .._drive import Drive

__all__ = ["excitation_period", "window_mask", "summary_window", "traced_window", "window_from_start"]


def fundamental_orders(drive: Drive) -> dict[int, float]:
    """Each excited pulley's fundamental engine order (per revolution of its own angle): the greatest common
    divisor of its orders (in quarters) with a non-zero amplitude, and of a law tabulated over its angle."""
    exc = drive.params.pulleys.excitation
    if exc is None:
        return {}
    out = {}
    orders, amp = np.asarray(exc.order), np.asarray(exc.amplitude)
    over, period = np.asarray(exc.over_angle), np.asarray(exc.period)
    for i in range(len(drive.model.pulley_names)):
        ks = [int(round(4 * k)) for k, a in zip(orders[i], amp[i]) if a != 0 and k > 0]
        if over[i] > 0.5:  # a table over the angle repeats with its period: its order 2 pi / period
            ks.append(max(1, int(round(4 * 2 * math.pi / period[i]))))
        ks = [k for k in ks if k > 0]
        if ks:
            out[i] = math.gcd(*ks) / 4
    return out


def excitation_period(drive: Drive) -> tuple[int, float] | None:
    """(pulley index, period [rad] of its rotation angle) of the forced response when exactly one pulley is
    excited; None without excitation, or with several excited pulleys (no common period in general)."""
    orders = fundamental_orders(drive)
    if len(orders) != 1:
        return None
    ((i, g),) = orders.items()
    return i, 2.0 * math.pi / g


def window_mask(ts, window: float, angle=None, period: float | None = None):
    """Mask of the saved states in the summary window: the final ``window`` fraction of ``ts``, trimmed at its
    start to the largest whole number of ``period`` of ``angle`` (a pulley's rotation at each saved state) that
    fits, counted back from the last state; the first kept state lies less than one save after the start of the
    periods, so the kept states sample whole periods. Traceable (``jax.numpy`` arrays) and numpy alike; without
    ``angle`` (or with less than one period in the window) the fraction alone."""
    xp = jnp if isinstance(ts, jax.Array) else np
    sel = ts >= ts[-1] - window * (ts[-1] - ts[0])
    if angle is None or period is None:
        return sel
    back = xp.abs(angle - angle[-1])  # rotation back from the window's end
    # the largest rotation back from here to the end: a contiguous tail even if the pulley stood or turned back
    flipped = back[::-1]
    reach = (jax.lax.cummax(flipped) if xp is jnp else np.maximum.accumulate(flipped))[::-1]
    first = xp.argmax(sel)
    periods = xp.floor(reach[first] / period + 1e-9)
    keep = reach < periods * period - 1e-9 * period
    return xp.where(periods >= 1, sel & keep, sel)


def summary_window(drive: Drive, ts, theta, window: float) -> tuple[np.ndarray, float | None]:
    """The summary window's mask over the saved times ``ts`` (numpy) with every pulley's angle ``theta``
    (saves x pulleys), and the number of periods of the forced response it holds (the fractional count of the
    untrimmed window where it holds less than one; None without a single excited pulley)."""
    ts = np.asarray(ts)
    found = excitation_period(drive)
    if found is None or ts.size < 2:
        return window_mask(ts, window), None
    i, period = found
    angle = np.asarray(theta)[:, i]
    sel = window_mask(ts, window, angle, period)
    span = abs(float(angle[sel][-1] - angle[sel][0]))
    untrimmed = window_mask(ts, window)
    count = abs(float(angle[-1] - angle[untrimmed][0])) / period
    return sel, (float(math.floor(count + 1e-9)) if count >= 1 - 1e-9 else count) if span > 0 else 0.0


def traced_window(drive: Drive, ts, theta, window: float):
    """``summary_window``'s mask for traced saves (a sweep's point, the spans tier): ``ts`` (saves,), ``theta``
    (saves x pulleys), as a float array (1 in the window)."""
    found = excitation_period(drive)
    if found is None:
        return window_mask(ts, window).astype(ts.dtype)
    i, period = found
    return window_mask(ts, window, theta[:, i], period).astype(ts.dtype)


def window_from_start(t, start, window: float) -> np.ndarray:
    """The window's mask over saved times ``t`` (numpy) from a start a traced window gave (a sweep's figure
    ``window_start_s``); the final ``window`` fraction where there is none (None or not finite)."""
    t = np.asarray(t)
    if start is None or not math.isfinite(float(start)):
        return window_mask(t, window)
    return t >= float(start)
