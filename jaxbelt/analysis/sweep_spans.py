"""The spans tier in a sweep (``sweep(..., model="spans")``, and so ``duty_study``): one grid point's figures
and the one step all points share. The grid, its checks, chunks, sharding, files and resume are the sweep's own;
the figures carry the ANCF tier's names (``tension:A-B:mean``, ``stick_share:P``, ``fault``), so the duty table
and the points' status read either tier the same way."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from .._drive import Drive
from .._errors import ConfigError
from .._types import Fault
from ..spans import simulate_spans, spans_signals_of, spans_time_steps
from ..spans.simulate import running_start
from ..outputs.window import traced_window

__all__ = ["spans_point_program", "spans_shared_step"]


def spans_shared_step(drive: Drive, params) -> tuple[float, str]:
    """One step for the batch of point parameters ``params``: the smallest of the points' stable steps."""
    steps = spans_time_steps(drive, params)
    bad = np.flatnonzero(~(np.isfinite(steps) & (steps > 0)))
    if bad.size:  # the installed statics of these points found no equilibrium: no step, no run
        raise ConfigError(
            f"sweep (spans tier): point {int(bad[0]) + 1} of {steps.size} has no stable step ({bad.size} such points): "
            "its installed statics found no equilibrium (a belt too short or too long for its tensioner?)"
        )
    worst = int(np.argmin(steps))
    dt = float(steps[worst])
    return dt, f"time step {dt:.4g} s for every point, spans tier: the smallest of the points' stable steps"


def spans_point_program(
    drive: Drive, point_params, t_end, save_dt, window: float, dt: float, keep_signals: bool, batched: bool = False
):
    """The figures of one grid point ``x`` on the spans tier (``point_params(x)``: its ``DriveParams``): every
    signal's window mean (``sweep.steady_figures``), each wrap's share of the window in creep
    (``stick_share:P``: without gross slip it keeps its adhesion arc) and ``fault`` (non-finite state);
    ``batched``: the gross-slip projection taken batch-wide (``simulate_spans``)."""
    from .sweep import steady_figures

    t_end = float(drive.options.t_end if t_end is None else t_end)
    save_dt = float(drive.options.save_dt if save_dt is None else save_dt)
    running = running_start(drive)

    def one(x):
        p = point_params(x)
        traj = simulate_spans(drive, p, t_end=t_end, dt=dt, save_dt=save_dt, running=running, batched=batched)
        sig = spans_signals_of(drive, p, traj.ts, traj.states)
        ts = sig.pop("t")
        in_window = traced_window(drive, ts, traj.states.theta, window)
        figs = steady_figures(drive, ts, sig, mask=in_window)
        figs["window_start_s"] = ts[jnp.argmax(in_window > 0)]  # trimmed to whole engine periods (outputs.window)
        creep = jnp.sum(in_window[:, None] * (traj.states.slip == 0.0).astype(ts.dtype), axis=0) / jnp.sum(in_window)
        figs.update({f"stick_share:{n}": creep[i] for i, n in enumerate(drive.model.pulley_names)})
        finite = jnp.all(jnp.asarray([jnp.all(jnp.isfinite(a)) for a in jax.tree.leaves(traj.states)]))
        figs["fault"] = jnp.where(finite, Fault.OK, Fault.NONFINITE).astype(jnp.int32)
        if keep_signals:
            figs["signals"] = sig
            figs["t"] = ts
        return figs

    return one
