"""The accessory-drive figure: layout with hub loads, slip safety factors and tensioner motion."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from ..outputs.signals import TENSION
from ._common import _SLIP_COLOR, _save
from .belt import _draw_pulleys, _limits, _pulley_geometry


def _fead_layout(ax, result, pulleys: dict) -> None:
    """Pulleys at their last position with each mean hub-load vector (force of the belt on it)."""
    import jax

    drive = result.drive
    state = jax.tree.map(lambda x: x[-1], result.trajectory.states)
    _draw_pulleys(ax, drive, state)
    centers = _pulley_geometry(drive, state)[0]
    loads = np.array([pulleys[p.name]["hub_load_mean"] for p in drive.pulleys])
    size = float(np.ptp(centers, axis=0).max())
    scale = 0.25 * size / max(float(loads.max()), 1e-12)
    for c, p, load in zip(centers, drive.pulleys, loads):
        a = math.radians(pulleys[p.name]["hub_load_direction_deg"])
        tip = c + scale * load * np.array([math.cos(a), math.sin(a)])
        ax.annotate("", xy=tip, xytext=c, arrowprops=dict(arrowstyle="-|>", color=_SLIP_COLOR, lw=1.8), zorder=5)
        ax.annotate(f"{load:.0f} N", tip, fontsize="x-small", color=_SLIP_COLOR, zorder=5)
    pts = np.concatenate([centers, centers + scale * loads.max()])
    _limits(ax, drive, pts)
    ax.set_title("Mean hub loads (force of the belt on the pulley)")


def plot_fead(result, path=None) -> Figure:
    """The accessory-drive outputs of a run: hub-load vectors on the layout, slip safety factors
    (mean and worst, threshold 1), slip, and span tensions (total and effective, dynamic amplitude)."""
    s = result.summary
    pulleys, spans = s["pulleys"], s["spans"]
    names = list(pulleys)
    x = np.arange(len(names))
    fig = Figure(figsize=(12, 8.5), layout="constrained")
    _fead_layout(fig.add_subplot(2, 2, 1), result, pulleys)
    ax = fig.add_subplot(2, 2, 2)
    cap = 100.0  # idlers transmit nothing: their safety factor is huge (or inf); bars stop at the cap
    for off, key, label in ((-0.2, "slip_safety_factor", "mean tensions"), (0.2, "slip_safety_factor_min", "worst")):
        vals = [min(cap, pulleys[n][key]) if pulleys[n][key] is not None else cap for n in names]
        ax.bar(x + off, vals, 0.4, label=label)
    ax.axhline(1.0, color="k", lw=1.0, ls="--")
    ax.set_yscale("log")
    ax.set_xticks(x, names, rotation=30, fontsize="small")
    ax.set_ylabel(f"slip safety factor (capped at {cap:g})")
    ax.set_title("Slip safety factor mu_eff phi / ln(T1e/T2e) (> 1: no gross slip)")
    ax.legend(fontsize="small")
    ax = fig.add_subplot(2, 2, 3)
    ax.bar(x - 0.2, [pulleys[n]["slip_mean_pct"] for n in names], 0.4, label="mean")
    ax.bar(x + 0.2, [pulleys[n]["slip_peak_pct"] for n in names], 0.4, label="peak |slip|")
    ax.set_xticks(x, names, rotation=30, fontsize="small")
    ax.set_ylabel("slip [%]")
    ax.set_title("Slip: arriving belt speed against surface speed")
    ax.legend(fontsize="small")
    ax = fig.add_subplot(2, 2, 4)
    xs = np.arange(len(spans))
    ax.bar(
        xs - 0.2,
        [sp["tension_mean"] for sp in spans],
        0.4,
        yerr=[sp["tension_amplitude"] for sp in spans],
        label="total T (bar: amplitude p-p/2)",
    )
    ax.bar(xs + 0.2, [sp["tension_eff_mean"] for sp in spans], 0.4, label="effective T - m'v^2")
    ax.set_xticks(xs, [sp["name"] for sp in spans], rotation=30, fontsize="small")
    ax.set_ylabel(f"span tension [{TENSION.unit}]")
    ax.set_title("Span tensions (mean over the window)")
    ax.legend(fontsize="small")
    return _save(fig, path)
