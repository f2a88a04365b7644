"""What the figures share: colours, signal lookup, saving (atomic, headless), the time-history plot."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..outputs.signals import OMEGA, TENSION, TIME, TORQUE


_STICK_COLOR, _SLIP_COLOR = "#2ca02c", "#d62728"


_SWEPT = {q.prefix for q in (OMEGA, TORQUE, TENSION)}  # the sweep figures plotted by plot_sweep


def _signals(obj) -> dict:
    return obj.signals if hasattr(obj, "signals") else obj


def _save(fig: Figure, path) -> Figure:
    if path is not None:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        _save_atomic(fig, Path(path))
    return fig


def _save_atomic(fig: Figure, path: Path, **kw):
    from ..io import atomic_write

    fmt = path.suffix.lstrip(".") or "png"
    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, format=fmt, dpi=kw.pop("dpi", 120), **kw)


def _time_plot(sig: dict, quantity, path, figsize=(8, 4.5)) -> Figure:
    """Every signal of ``quantity`` (a ``Quantity`` of the signal registry) against time."""
    prefix = f"{quantity.prefix}:"
    fig = Figure(figsize=figsize, layout="constrained")
    ax = fig.add_subplot()
    t = np.asarray(sig["t"])
    for key, value in sig.items():
        if key.startswith(prefix):
            ax.plot(t, np.asarray(value), label=key[len(prefix) :], lw=1.2)
    ax.set_xlabel(TIME.axis_label)
    ax.set_ylabel(quantity.axis_label)
    ax.set_title(quantity.title)
    ax.grid(True, alpha=0.3)
    if ax.lines:
        ax.legend(loc="best", fontsize="small")
    return _save(fig, path)


def _runs(mask: np.ndarray):
    """(start, stop) index pairs of the True runs of a boolean array."""
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    d = np.diff(m.astype(int))
    return list(zip(np.nonzero(d == 1)[0], np.nonzero(d == -1)[0]))
