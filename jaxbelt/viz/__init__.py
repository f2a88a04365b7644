"""Plots of a run: speeds, span tensions, contact forces over the wrap with stick/slip zones, the
belt shape, and an animation of the belt running; the figures of studies (duty, run-up, sweep) and of an
accessory drive. One module per figure kind: ``time_series`` (time histories, spectra), ``contact``,
``belt`` (shape, animation), ``studies``, ``fead``; ``_common`` holds the saving and drawing helpers.

Every function returns a ``matplotlib.figure.Figure`` and, given ``path``, saves it there. The
figures are created without pyplot (no global figure registry, no GUI backend needed, nothing
to close), so the functions work the same on a headless machine, in a script and in a notebook
(where a returned figure is displayed as usual). Signal plots take their labels from the signal
registry (``outputs/signals.py``). ``plot_run`` calls the plot functions through this package's names
(tests replace one to check that a failing plot becomes a warning).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .belt import animate_belt as animate_belt, belt_polyline as belt_polyline, plot_belt as plot_belt
from .contact import plot_contact as plot_contact
from .fead import plot_fead as plot_fead
from .studies import plot_duty as plot_duty, plot_run_up as plot_run_up, plot_sweep as plot_sweep
from .time_series import plot_spectrum as plot_spectrum, plot_speeds as plot_speeds
from .time_series import plot_tensions as plot_tensions, plot_torques as plot_torques

__all__ = [
    "plot_speeds",
    "plot_tensions",
    "plot_torques",
    "plot_contact",
    "plot_belt",
    "animate_belt",
    "plot_run",
    "belt_polyline",
    "plot_sweep",
    "plot_duty",
    "plot_run_up",
    "plot_fead",
    "plot_spectrum",
]


def plot_run(
    result,
    out_dir,
    *,
    contact: dict | None = None,
    animate: bool = False,
    exaggeration: float = 1.0,
    fmt: str = "png",
    warnings_: list | None = None,
) -> dict[str, Path]:
    """All standard plots of a run into ``out_dir``; returns ``{plot name: path}``.

    With a ``warnings_`` list, a plot that fails is skipped and the reason appended there (the other
    plots are still written); without one the error propagates.
    """
    import jax

    from ..outputs.contact import contact_distribution
    from ..outputs.summary import guarded

    def attempt(what, fn, default=None):
        return fn() if warnings_ is None else guarded(warnings_, what, fn, default)

    out = Path(out_dir)
    if contact is None:
        contact = attempt(
            "contact plot",
            lambda: contact_distribution(result.drive, jax.tree.map(lambda x: x[-1], result.trajectory.states)),
        )
    t_end = float(np.asarray(result.trajectory.ts)[-1])
    plots = {
        "speeds": lambda path: plot_speeds(result, path),
        "tensions": lambda path: plot_tensions(result, path),
        "torques": lambda path: plot_torques(result, path),
        "contact": None
        if contact is None
        else (lambda path: plot_contact(contact, path, title=f"Contact forces at t = {t_end:.4g} s")),
        "belt": lambda path: plot_belt(result, path=path),
    }
    if "slip_safety_factor" in next(iter(result.summary.get("pulleys", {}).values()), {}):
        plots["fead"] = lambda path: plot_fead(result, path)
    if animate:
        plots["animation"] = lambda path: animate_belt(result, path, exaggeration=exaggeration)
    files = {}
    for name, fn in plots.items():
        path = out / ("belt.gif" if name == "animation" else f"{name}.{fmt}")
        if fn is not None and attempt(f"{path.name}", lambda: fn(path) or True, False):
            files[name] = path
    return files
