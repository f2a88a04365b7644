"""``run``: from a DriveSpec to results, with compile and run time measured separately."""

from __future__ import annotations

import dataclasses
import time
from typing import Callable

import jax
import numpy as np

from .._drive import Drive
from ..config import DriveSpec, build_drive
from ..outputs.energy import energy_audit
from ..outputs.signals import signals_of
from ..outputs.summary import guarded, summary
from ..dynamics.chunked import ChunkedRun, RunProgress
from ..dynamics.simulate import Trajectory

__all__ = ["RunResult", "run"]


@dataclasses.dataclass
class RunResult:
    drive: Drive
    trajectory: Trajectory
    signals: dict
    summary: dict
    timing: dict

    @property
    def ts(self):
        return np.asarray(self.trajectory.ts)


def run(
    spec: DriveSpec | Drive,
    *,
    t_end: float | None = None,
    progress: bool = False,
    window: float = 0.2,
    on_chunk: Callable[[ChunkedRun, RunProgress, bool], None] | None = None,
    resume: dict | None = None,
) -> RunResult:
    """Build (validating first), simulate and post-process a drive.

    The simulation runs as compiled chunks (``jaxbelt.dynamics.chunked``): ``progress`` shows a bar
    between them, Ctrl-C stops after the chunk under way, ``on_chunk(chunked, progress, interrupted)``
    is called after every chunk (and once more, with ``interrupted=True``, on Ctrl-C) and ``resume``
    (``RunProgress.arrays`` of an earlier, interrupted run of the same drive) continues from there.
    """
    t0 = time.perf_counter()
    drive = spec if isinstance(spec, Drive) else build_drive(spec)
    t_build = time.perf_counter() - t0
    s = drive.options
    t_end = s.t_end if t_end is None else t_end
    t0 = time.perf_counter()
    chunked = ChunkedRun(
        drive.model, drive.params, drive.state0, t_end=t_end, dt=drive.dt, save_dt=s.save_dt, settle_time=s.settle_time
    )
    chunked.compile()
    t_compile = time.perf_counter() - t0
    t0 = time.perf_counter()
    at = chunked.start() if resume is None else chunked.restore(resume)
    traj = _advance(chunked, at, progress, on_chunk)
    t_run = time.perf_counter() - t0
    traj = traj.computed()
    num_steps = int(traj.num_steps)
    t0 = time.perf_counter()
    sig, summ = _postprocess(drive, traj, window)
    t_post = time.perf_counter() - t0
    timing = dict(
        build_s=t_build,
        compile_s=t_compile,
        run_s=t_run,
        num_steps=num_steps,
        dt=drive.dt,
        us_per_step=1e6 * t_run / max(num_steps, 1),
        wall_s=t_build + t_compile + t_run,
        postprocess_s=t_post,
    )
    summ.update(num_steps=num_steps, wall_time_s=timing["wall_s"], compile_time_s=t_compile, dt=drive.dt)
    return RunResult(drive=drive, trajectory=traj, signals=sig, summary=summ, timing=timing)


def _advance(chunked: ChunkedRun, at: RunProgress, progress: bool, on_chunk) -> Trajectory:
    """Chunks until the end, with the progress bar and the callback between them."""
    bar = None
    try:
        if progress:
            from tqdm import tqdm  # type: ignore[import-untyped]

            total = chunked.n_macro * chunked.schedule.substeps
            bar = tqdm(
                total=total, initial=at.k * chunked.schedule.substeps, unit="step", unit_scale=True, smoothing=0.1
            )
        while not chunked.done(at):
            k = at.k
            at = chunked.advance(at)
            if bar is not None:
                bar.update((at.k - k) * chunked.schedule.substeps)
            if on_chunk is not None:
                on_chunk(chunked, at, False)
    except KeyboardInterrupt:
        if on_chunk is not None:
            on_chunk(chunked, at, True)  # the last whole chunk, e.g. for a checkpoint
        raise
    finally:
        if bar is not None:
            bar.close()
    return chunked.trajectory(at)


def _postprocess(drive: Drive, traj: Trajectory, window: float):
    """Signals, summary and energy audit of a computed trajectory.

    Measured on Benchmark A in a fresh process: 1-1.4 s, nearly all of it tracing and compiling dozens
    of small programs, one per eager jax operation (indexing the saved states, the signals). Here the
    signals are one compiled program (in the persistent cache with the rest) and the summary indexes
    host (numpy) copies of the states.
    """
    host = jax.tree.map(np.asarray, traj.states)
    names: list[str] = []  # in signals.csv order: a dict returned from jit would come back sorted

    def values(params, states, path):
        out = signals_of(drive, params, states, path)
        names[:] = list(out)
        return [out[k] for k in names]

    computed = jax.jit(values)(drive.params, traj.states, drive.path)
    sig = {"t": np.asarray(traj.ts), **{k: np.asarray(v) for k, v in zip(names, computed, strict=True)}}
    summ = summary(drive, traj.ts, host, traj.final, window=window, signals_=sig)
    if traj.ts.shape[0] >= 2:
        # the audit compares the first and the last saved state: only those two are evaluated
        ends = np.asarray([0, traj.ts.shape[0] - 1])
        states = jax.tree.map(lambda x: x[ends], host)
        energy = guarded(
            summ["warnings"], "energy audit", lambda: energy_audit(drive, np.asarray(traj.ts)[ends], states)
        )
        if energy is not None:
            summ["energy"] = energy
    return sig, summ
