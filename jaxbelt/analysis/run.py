"""``run``: from a DriveSpec to results, with compile and run time measured separately."""

from __future__ import annotations

import dataclasses
import time

import jax
import numpy as np

from .._drive import Drive
from ..config import DriveSpec, build_drive
from ..outputs.energy import energy_audit
from ..outputs.summary import guarded, signals, summary
from ..dynamics.simulate import Trajectory, simulate

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
    spec: DriveSpec | Drive, *, t_end: float | None = None, progress: bool = False, window: float = 0.2
) -> RunResult:
    """Build (validating first), simulate and post-process a drive."""
    t0 = time.perf_counter()
    drive = spec if isinstance(spec, Drive) else build_drive(spec)
    t_build = time.perf_counter() - t0
    s = drive.options
    t_end = s.t_end if t_end is None else t_end
    t0 = time.perf_counter()
    compiled = simulate(
        drive.model,
        drive.params,
        drive.state0,
        t_end=t_end,
        dt=drive.dt,
        save_dt=s.save_dt,
        settle_time=s.settle_time,
        progress=progress,
        _ahead_of_time=True,
    )
    t_compile = time.perf_counter() - t0
    t0 = time.perf_counter()
    traj = compiled(drive.params, drive.state0)
    jax.block_until_ready(traj.final.q)
    t_run = time.perf_counter() - t0
    traj = traj.computed()
    num_steps = int(traj.num_steps)
    t0 = time.perf_counter()
    sig = signals(drive, traj.ts, traj.states)
    summ = summary(drive, traj.ts, traj.states, traj.final, window=window, signals_=sig)
    if traj.ts.shape[0] >= 2:
        energy = guarded(summ["warnings"], "energy audit", lambda: energy_audit(drive, traj.ts, traj.states))
        if energy is not None:
            summ["energy"] = energy
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
