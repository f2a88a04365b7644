"""``run``: from a DriveSpec to results, with compile and run time measured separately."""

from __future__ import annotations

import dataclasses
import time
from typing import Callable

import jax
import numpy as np

from .._drive import Drive
from .._errors import ConfigError
from .._types import DriveState
from ..config import DriveSpec, build_drive
from ..config.validate import resolve_model
from ..outputs.derived import Derived, DerivedProgram, window_start
from ..outputs.energy import energy_audit, energy_not_closed, entry_loss_warning, power_balance
from ..outputs.signals import signals_of
from ..outputs.summary import guarded, summary
from ..dynamics.chunked import ChunkedRun, RunProgress
from ..dynamics.simulate import Trajectory

__all__ = ["RunResult", "run", "check_window"]


@dataclasses.dataclass
class RunResult:
    drive: Drive
    trajectory: Trajectory
    signals: dict
    summary: dict
    timing: dict
    # the post-processing program's arrays (contact geometry of the last saved state, ...), None if not computed
    derived: Derived | None = None

    @property
    def ts(self):
        return np.asarray(self.trajectory.ts)


def check_window(window) -> None:
    """The summary window, a fraction of the run: refused (ConfigError) outside (0, 1] before anything runs
    (a NaN or negative window selected no saved state: every mean was NaN)."""
    from ..config.checks import _require, _is_number

    _require(
        _is_number(window) and 0 < window <= 1,
        "window",
        window,
        "must be a fraction of the run in (0, 1], e.g. 0.2 (the final fifth)",
    )


def _checked_t_end(t_end, save_dt: float) -> float:
    """``run``'s ``t_end`` argument, refused as ``solver.t_end`` is (a built drive was checked with its own)."""
    from ..config.checks import _positive, _require

    _positive("t_end", t_end)
    _require(
        t_end >= save_dt,
        "t_end",
        t_end,
        f"is shorter than solver.save_dt = {save_dt:g} s: the run would save only its initial state; "
        "give a t_end of several save intervals",
    )
    return float(t_end)


def _settle_fault(drive: Drive, final) -> None:
    from .._errors import ConfigError
    from .._types import Fault
    from ..outputs.summary import step_remedy

    raise ConfigError(
        f"solver.dt = {drive.dt:.4g}: the run diverged in the settling phase, at t = {float(final.fault_time):.4g} s "
        f"({Fault(int(final.fault)).message}), before t = 0, so nothing was saved: {step_remedy(drive)}, raise "
        "solver.lcp_iterations, or soften contact.stiffness"
    )


def run(
    spec: DriveSpec | Drive,
    *,
    t_end: float | None = None,
    progress: bool = False,
    window: float = 0.2,
    on_chunk: Callable[[ChunkedRun, RunProgress, bool], None] | None = None,
    resume: dict | None = None,
    steady: bool | None = None,
    model: str | None = None,
) -> RunResult:
    """Build (validating first), simulate and post-process a drive.

    The simulation runs as compiled chunks (``jaxbelt.dynamics.chunked``): ``progress`` shows a bar
    between them, Ctrl-C stops after the chunk under way, ``on_chunk(chunked, progress, interrupted)``
    is called after every chunk (and once more, with ``interrupted=True``, on Ctrl-C) and ``resume``
    (``RunProgress.arrays`` of an earlier, interrupted run of the same drive) continues from there.
    ``steady``: the summary window is meant to be a steady state, and a window that is not gets a status
    saying so (``outputs.steadiness``); False for runs that change on purpose (a run-up); None: the
    spec's ``solver.expect_steady``. ``model``: "ancf" (the ANCF belt), or "spans": the spans tier's run
    (``jaxbelt.spans.run_spans``: its own ``SpansResult``, the same signal names and summary status; no
    ``progress``, ``on_chunk`` or ``resume``); None: the spec's ``solver.model``.
    """
    check_window(window)
    t0 = time.perf_counter()
    drive = spec if isinstance(spec, Drive) else build_drive(spec)
    t_build = time.perf_counter() - t0
    if resolve_model(drive, model, "run") == "spans":
        if progress or on_chunk is not None or resume is not None:
            raise ConfigError("run: model = 'spans' has no progress, on_chunk or resume (its runs take seconds)")
        from ..spans import run_spans

        return run_spans(drive, t_end=t_end, window=window, steady=steady)  # type: ignore[return-value]
    s = drive.options
    t_end = s.t_end if t_end is None else _checked_t_end(t_end, s.save_dt)
    t0 = time.perf_counter()
    chunked = ChunkedRun(
        drive.model, drive.params, drive.state0, t_end=t_end, dt=drive.dt, save_dt=s.save_dt, settle_time=s.settle_time
    )
    chunked.compile()
    t_compile = time.perf_counter() - t0
    t0 = time.perf_counter()
    program = _derived_program(drive, chunked, window)
    at = chunked.start() if resume is None else chunked.restore(resume)
    traj = _advance(chunked, at, progress, on_chunk)
    t_run = time.perf_counter() - t0
    traj = traj.computed()
    if len(traj.ts) == 0:  # diverged while settling, before t = 0: there is nothing to post-process
        _settle_fault(drive, traj.final)
    num_steps = int(traj.num_steps)
    t0 = time.perf_counter()
    if steady is None:
        steady = bool(getattr(drive.spec.solver, "expect_steady", True))
    sig, summ, derived = _postprocess(drive, traj, window, program, steady=steady)
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
    summ.update(
        num_steps=num_steps,
        wall_time_s=timing["wall_s"],
        compile_time_s=t_compile,
        dt=drive.dt,
        scheme=drive.scheme,
        scheme_reason=drive.scheme_reason,
        dt_reason=drive.dt_reason,
    )
    return RunResult(drive=drive, trajectory=traj, signals=sig, summary=summ, timing=timing, derived=derived)


def _derived_program(drive: Drive, chunked: ChunkedRun, window: float) -> DerivedProgram | None:
    """The post-processing program for the saves of a run that goes to the end, compiling on a
    background thread while the run computes (it needs the states' shapes only)."""
    w0 = window_start(chunked.save_times(), window)
    if w0 is None:
        return None
    n = chunked.schedule.n_saves
    like = jax.tree.map(lambda x: jax.ShapeDtypeStruct((n, *np.shape(x)), np.asarray(x).dtype), drive.state0)
    return DerivedProgram(drive, like, w0).start()


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


def _postprocess(
    drive: Drive, traj: Trajectory, window: float, program: DerivedProgram | None = None, *, steady: bool = True
):
    """Signals, summary and energy audit of a computed trajectory, and the ``Derived`` arrays they came from.

    The traced part is one compiled program (``outputs.derived``: in the persistent cache with the rest,
    and compiled while the run computes when ``program`` was started before it); everything else
    is numpy on host copies of the states. Should that program fail, each part is computed on its own
    as before (a derived output that fails then becomes a warning of the summary).
    """
    host = jax.tree.map(np.asarray, traj.states)
    ts = np.asarray(traj.ts)
    derived = None
    w0 = window_start(ts, window)
    if w0 is not None:
        try:
            derived = (program or DerivedProgram(drive, host, w0))(host, w0)
        except Exception:  # noqa: BLE001 - the parts one by one below, where their errors are reported
            derived = None
    if derived is not None:
        sig = {"t": ts, **derived.signals}
    else:
        sig = _signals(drive, traj)
    summ = summary(drive, ts, host, traj.final, window=window, signals_=sig, derived=derived, steady=steady)
    # the build's warnings first (a Python warning alone is shown once per process, never in summary.json)
    later = [w for w in summ.get("warnings", []) if w not in drive.build_warnings]
    summ["warnings"] = list(dict.fromkeys(drive.build_warnings)) + later
    if ts.shape[0] >= 2:
        # the audit compares the first and the last saved state: only those two are evaluated
        ends = np.asarray([0, ts.shape[0] - 1])
        states = jax.tree.map(lambda x: x[ends], host)
        stored = None if derived is None else derived.stored_ends
        energy = guarded(summ["warnings"], "energy audit", lambda: energy_audit(drive, ts[ends], states, stored=stored))
        if energy is not None:
            summ["energy"] = energy
            if (why := energy_not_closed(energy)) is not None:
                summ["warnings"].append(why)
                if summ["status"] == "ok":  # figures of a motion the step did not follow are not "ok"
                    summ["status"] = why
    if w0 is not None and w0 < ts.shape[0] - 1:
        # the summary's window: its start trimmed to whole periods of the engine orders (outputs.window)
        start = int(np.argmax(ts >= summ["window_s"][0])) if "window_s" in summ else w0
        _window_power_balance(drive, ts, host, max(start, w0), derived, summ)
    return sig, summ, derived


def _window_power_balance(drive: Drive, ts, host: DriveState, w0: int, derived: Derived | None, summ: dict) -> None:
    """The power balance from saved state ``w0`` to the last (``summary["power_balance"]``), and the warning when
    the numerical entry loss is too large a share of the delivered power."""
    ends = np.asarray([w0, ts.shape[0] - 1])
    states = jax.tree.map(lambda x: x[ends], host)
    stored = None
    if derived is not None:
        a, b = derived.stored_at(int(ends[0])), derived.stored_at(int(ends[1]))
        stored = None if a is None or b is None else np.stack([a, b])
    balance = guarded(summ["warnings"], "power balance", lambda: power_balance(drive, ts[ends], states, stored=stored))
    if balance is not None:
        summ["power_balance"] = balance
        if (why := entry_loss_warning(drive, balance)) is not None:
            summ["warnings"].append(why)


def _signals(drive: Drive, traj: Trajectory) -> dict:
    """The named signals as one compiled program of their own."""
    names: list[str] = []  # in signals.csv order: a dict returned from jit would come back sorted

    def values(params, states, path):
        out = signals_of(drive, params, states, path)
        names[:] = list(out)
        return [out[k] for k in names]

    computed = jax.jit(values)(drive.params, traj.states, drive.path)
    return {"t": np.asarray(traj.ts), **{k: np.asarray(v) for k, v in zip(names, computed, strict=True)}}
