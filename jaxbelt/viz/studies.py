"""Figures of studies: duty points against engine speed, a run-up's order tracking, a parameter sweep."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from ._common import _SWEPT, _save


def plot_duty(result, path=None, min_safety: float = 1.0) -> Figure:
    """Duty-point study: slip safety factor (log axis; values below ``min_safety`` marked with a red cross,
    the region below shaded) and hub load of every pulley against the driver speed. Pulleys that transmit
    no torque (safety infinite) are left out of the left panel; factors above 100 are drawn at 100."""
    fig = Figure(figsize=(12, 4.2), layout="constrained")
    ax1, ax2 = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    rpm = np.asarray(result.rpm, dtype=float)
    top = 2.0 * max(min_safety, 1.0)
    for k, (name, d) in enumerate(result.pulleys.items()):
        color = f"C{k % 10}"
        sf = np.asarray(d["slip_safety"], dtype=float)
        if np.any(np.isfinite(sf)):
            y = np.minimum(np.where(np.isfinite(sf), sf, np.nan), 100.0)
            ax1.plot(rpm, y, "o-", ms=3, color=color, label=name)
            low = y < min_safety
            if np.any(low):
                ax1.plot(rpm[low], y[low], "x", ms=9, mew=2, color="#c00")
            top = max(top, float(np.nanmax(y)) * 1.3)
        ax2.plot(rpm, d["hub_load"], "o-", ms=3, color=color, label=name)
    from matplotlib.ticker import FixedLocator, FormatStrFormatter, NullFormatter

    ax1.set_yscale("log")
    bottom = min(0.5 * min_safety, 0.5)
    ax1.set_ylim(bottom, top)
    ax1.yaxis.set_major_locator(FixedLocator([0.2, 0.5, 1, 2, 5, 10, 20, 50, 100]))  # plain numbers, not 10^k
    ax1.yaxis.set_major_formatter(FormatStrFormatter("%g"))
    ax1.yaxis.set_minor_formatter(NullFormatter())
    ax1.axhspan(bottom, min_safety, color="#c00", alpha=0.1, lw=0)
    ax1.axhline(1.0, color="k", lw=0.8, ls="--")
    if min_safety != 1.0:
        ax1.axhline(min_safety, color="#c00", lw=0.8, ls=":")
    ax1.set(
        xlabel="driver speed [rpm]",
        ylabel="slip safety factor [-] (log)",
        title=f"slip safety (> 1: no gross slip; shaded: < {min_safety:g})",
    )
    ax2.set(xlabel="driver speed [rpm]", ylabel="hub load [N]", title="hub load (mean)")
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3, which="both")
    fig.legend(*ax2.get_legend_handles_labels(), loc="outside right upper", fontsize=8)  # one legend, off the data
    return _save(fig, path) if path is not None else fig


def plot_run_up(runup, names=None, path=None) -> Figure:
    """Order plot of a run-up (``analysis.runup.run_up``): per signal the amplitude of each tracked engine
    order and the half peak-to-peak against crank speed, with the resonance crossings (mode i crossed by
    order k at 60 f_i / k rpm) as vertical lines."""
    from ..outputs.signals import quantity_of

    names = list(runup.orders) if names is None else list(names)
    ncol = min(2, max(1, len(names)))
    nrow = max(1, math.ceil(len(names) / ncol))
    fig = Figure(figsize=(6 * ncol, 3.6 * nrow), layout="constrained")
    for i, name in enumerate(names):
        ax = fig.add_subplot(nrow, ncol, i + 1)
        ax.plot(runup.rpm, runup.amplitude[name], "k-", lw=1.0, label="half peak-to-peak")
        for k, amp in runup.orders[name].items():
            ax.plot(runup.rpm, amp, "o-", ms=2.5, label=f"order {k:g}")
        for c in runup.crossings:
            ax.axvline(c["rpm"], color="0.6", lw=0.8, ls="--")
            ax.text(c["rpm"], 1.0, f" {c['mode']}/{c['order']:g}", transform=ax.get_xaxis_transform(), fontsize=6,
                    va="top", rotation=90)  # fmt: skip
        ax.set(xlabel="crank speed [rpm]", ylabel=f"amplitude [{quantity_of(name).unit}]", title=name)
        ax.grid(alpha=0.3)
        if i == 0:
            ax.legend(fontsize=7)
    return _save(fig, path) if path is not None else fig


def plot_sweep(result, path=None) -> Figure:
    """Each steady figure (speeds, torques, tensions) against the first varied key, one line per
    value of the other keys."""
    keys, pts = result.keys, np.asarray(result.points)
    names = [n for n in result.figures if n.endswith(":mean") and n.split(":")[0] in _SWEPT]
    ncol = 3
    nrow = max(1, math.ceil(len(names) / ncol))
    fig = Figure(figsize=(4.2 * ncol, 3.2 * nrow), layout="constrained")
    x = pts[:, 0]
    others = [tuple(r) for r in pts[:, 1:]] if pts.shape[1] > 1 else [()] * len(x)
    groups = sorted(set(others))
    for i, name in enumerate(names):
        ax = fig.add_subplot(nrow, ncol, i + 1)
        y = np.asarray(result.figures[name])
        for g in groups:
            sel = np.array([o == g for o in others])
            label = ", ".join(f"{k}={v:.3g}" for k, v in zip(keys[1:], g)) or None
            ax.plot(x[sel], y[sel], "o-", ms=3, label=label)
        ax.set_xlabel(keys[0])
        ax.set_title(name.removesuffix(":mean"), fontsize=9)
        ax.grid(alpha=0.3)
        if i == 0 and len(groups) > 1:
            ax.legend(fontsize=7)
    return _save(fig, path) if path is not None else fig
