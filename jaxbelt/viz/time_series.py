"""Time histories of a run (speeds, span tensions, torques) and the amplitude or order spectrum of one signal."""

from __future__ import annotations


import numpy as np
from matplotlib.figure import Figure

from ..outputs.signals import OMEGA, TENSION, TORQUE
from ._common import _save, _signals, _time_plot


def plot_speeds(result, path=None) -> Figure:
    """Angular velocity of every pulley against time (``result``: a RunResult or a signals dict)."""
    return _time_plot(_signals(result), OMEGA, path)


def plot_tensions(result, path=None) -> Figure:
    """Tension at the middle of every span against time."""
    return _time_plot(_signals(result), TENSION, path)


def plot_torques(result, path=None) -> Figure:
    """Torque the belt exerts on every pulley against time."""
    return _time_plot(_signals(result), TORQUE, path)


def plot_spectrum(result, name: str, path=None, order: bool = False, window: str = "hann", t_start=None) -> Figure:
    """Amplitude spectrum of the signal ``name`` (over time, or with ``order`` over the driver's
    angle) from ``t_start`` (default: the whole record) on; see ``jaxbelt.outputs.spectra``."""
    from ..outputs.signals import quantity_of
    from ..outputs.spectra import amplitude_spectrum, crank_angle, order_spectrum

    sig = _signals(result)
    t = np.asarray(sig["t"])
    sel = t >= (t[0] if t_start is None else t_start)
    unit = quantity_of(name).unit
    if order:
        sp = order_spectrum(crank_angle(result)[sel], sig[name][sel], window=window, unit=unit)
        axis, label = sp["order"], "engine order [1/rev]"
    else:
        sp = amplitude_spectrum(t[sel], sig[name][sel], window=window, unit=unit)
        axis, label = sp["frequency"], "frequency [Hz]"
    fig = Figure(figsize=(8, 4.5), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(axis, sp["amplitude"], lw=1.2)
    ax.set_xlabel(label)
    ax.set_ylabel(f"amplitude [{unit}]")
    ax.set_title(
        f"{'Order' if order else 'Amplitude'} spectrum of {name} ({window} window, resolution {sp['resolution']:.3g})"
    )
    ax.grid(True, alpha=0.3)
    return _save(fig, path)
