"""The run as compiled chunks: one program advances the drive by a block of steps from a state, and a
Python loop calls it until the end.

Between chunks the caller can show progress, stop on Ctrl-C or write a checkpoint; the program itself
holds no host callback, so JAX's persistent compilation cache can store it (``jaxbelt._cache``), and
it does not depend on ``t_end``: one compiled program serves every run length of a drive.

The chunks take exactly the steps of ``simulate``'s loop (``solver.solve_fixed_steps``, shared with the free
belt): the same step times (diffrax's
``ConstantStepSize`` computes step ``k`` as ``t0 + (t1 - t0) k / N``, not by adding steps up), the same
``MoreauJean.advance`` per diffrax step, saves interpolated between the two step ends as diffrax does,
and the run stops after the first faulty step as diffrax's event does. ``simulate`` stays the one
program for ``jax.grad``, ``jit`` and ``vmap``.
"""

from __future__ import annotations

import dataclasses
import os
import typing

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._export import lowered_flat
from .._xla import compile_forward
from .._types import DriveModel, DriveParams, DriveState, Fault
from .simulate import Schedule, Trajectory, schedule
from .step import MoreauJean, drive_operators

__all__ = ["Clock", "ChunkedRun", "RunProgress", "STEPS_PER_CHUNK"]

# Contact steps per chunk (rounded to whole save intervals): about 0.1-0.5 s of computing on Benchmark A,
# short enough for a responsive Ctrl-C and progress bar, long enough that the call overhead (~1 ms) is lost.
# JAXBELT_STEPS_PER_CHUNK overrides it (tests kill a run between short chunks).
STEPS_PER_CHUNK = 4096


@typing.final
class Clock(eqx.Module):
    """Times of diffrax's constant step size controller, as arrays (dynamic: one program for all runs)."""

    t0: jax.Array  # start of the run (-settle time)
    t1: jax.Array  # end of the last macro step
    dt0: jax.Array  # macro step
    n: jax.Array  # number of macro steps (int32)
    t1_floor: jax.Array  # t1 less 100 ulp: a step ending above it ends at t1
    dt: jax.Array  # contact step (save times are multiples of stride * dt)
    stride: jax.Array  # contact steps per save (float)
    n_saves: jax.Array  # int32

    def time(self, k):
        """End of macro step ``k`` (0: t0), as ``diffrax.ConstantStepSize`` and ``_clip_to_end`` give it."""
        kf = k.astype(self.t0.dtype)
        t = self.t0 + (self.t1 - self.t0) * (kf / self.n.astype(self.t0.dtype))
        t = jnp.where(k == 1, jnp.minimum(self.t0 + self.dt0, self.t1), t)
        t = jnp.where(k >= self.n, self.t1, t)
        t = jnp.where(t > self.t1_floor, self.t1, t)
        return jnp.where(k == 0, self.t0, t)

    def save_time(self, j):
        # as jnp.arange(0, n_steps + 1, stride) * dt: whole numbers, exact, times dt
        return (j.astype(self.t0.dtype) * self.stride) * self.dt


def _clock(sch: Schedule) -> Clock:
    dt = sch.dt
    t0, t1, dt0 = np.float64(-sch.n_settle * dt), np.float64(sch.n_run * dt), np.float64(sch.substeps * dt)
    n = int(np.ceil((t1 - t0) / np.nextafter(dt0, np.inf)))  # as ConstantStepSize.init
    floor = t1
    for _ in range(100):
        floor = np.nextafter(floor, -np.inf)
    # host values put on the device (no eager device conversion to compile)
    f = lambda x: jax.device_put(np.asarray(x, dtype=jnp.result_type(float)))  # noqa: E731  (float32 without x64)
    i = lambda x: jax.device_put(np.asarray(x, dtype=np.int32))  # noqa: E731
    return Clock(
        t0=f(t0),
        t1=f(t1),
        dt0=f(dt0),
        n=i(n),
        t1_floor=f(floor),
        dt=f(dt),
        stride=f(sch.stride),
        n_saves=i(sch.n_saves),
    )


def _interpolate(tprev, t, tnext, y0, y1):
    """diffrax's LocalLinearInterpolation at ``t`` (``linear_rescale`` included)."""
    same = tprev == tnext
    coeff = jnp.where(same, 0.0, t - tprev) / jnp.where(same, 1.0, tnext - tprev)
    return jax.tree.map(lambda a, b: a + coeff * (b - a), y0, y1)


@eqx.filter_jit
def _chunk(model: DriveModel, params: DriveParams, state: DriveState, k0, k_stop, j0, clock: Clock, *, substeps, n_buf):
    """Macro steps ``k0 .. k_stop - 1`` (fewer after a fault) from ``state``; saves ``j0 ..`` into a buffer.

    Parameters: nine, because the seven positional ones are the chunk program's arguments, traced (the times
    already one record, ``Clock``; ``ChunkedRun.compile`` stores the program through ``lowered_flat``, its
    output shaped from these arguments by position), and ``substeps`` and ``n_buf`` its static options, part
    of the compilation key under ``eqx.filter_jit``; a record grouping them would mix the two kinds."""
    ops = drive_operators(model, params)
    solver = MoreauJean(substeps=substeps)
    buf = jax.tree.map(lambda x: jnp.full((n_buf,) + x.shape, jnp.inf, x.dtype), state)

    def save(tprev, tnext, y0, y1):
        def cond(c):
            j, _ = c
            return (j < clock.n_saves) & (clock.save_time(j) <= tnext) & (j - j0 < n_buf)

        def body(c):
            j, b = c
            ys = _interpolate(tprev, clock.save_time(j), tnext, y0, y1)
            return j + 1, jax.tree.map(lambda bb, x: bb.at[j - j0].set(x), b, ys)

        return cond, body

    def step_cond(c):
        k, y, _, _ = c
        return (k < k_stop) & (y.fault == Fault.OK)

    def step_body(c):
        k, y, j, b = c
        tprev, tnext = clock.time(k), clock.time(k + 1)
        y1 = solver.advance((model, params, ops), tprev, tnext - tprev, y)
        save_cond, save_body = save(tprev, tnext, y, y1)
        j, b = jax.lax.while_loop(save_cond, save_body, (j, b))
        return k + 1, y1, j, b

    k, y, j, buf = jax.lax.while_loop(step_cond, step_body, (k0, state, j0, buf))
    return k, y, j, buf


@dataclasses.dataclass
class RunProgress:
    """Where a chunked run stands: host copies, so that it can be checkpointed and resumed."""

    k: int  # macro steps done
    state: DriveState  # state after them
    saved: DriveState  # every save, stacked (numpy; inf where not reached yet)
    n_saved: int
    fault: bool = False

    @property
    def arrays(self) -> dict[str, np.ndarray]:
        """Flat ``{name: array}`` form (for a checkpoint file)."""
        out = {"k": np.asarray(self.k), "n_saved": np.asarray(self.n_saved), "fault": np.asarray(self.fault)}
        for prefix, tree in (("state", self.state), ("saved", self.saved)):
            for i, leaf in enumerate(jax.tree.leaves(tree)):
                out[f"{prefix}/{i}"] = np.asarray(leaf)
        return out


@typing.final
class ChunkedRun:
    """A drive's run as chunks: ``compile()``, then ``start()`` (or ``restore``) and ``advance`` until ``done``."""

    def __init__(self, model: DriveModel, params: DriveParams, state0: DriveState, *, t_end, dt, save_dt, settle_time):
        self.model, self.params, self.state0 = model, params, state0
        self.schedule = sch = schedule(t_end=t_end, dt=dt, save_dt=save_dt, settle_time=settle_time)
        self.clock = _clock(sch)
        per_save = sch.stride // sch.substeps  # macro steps per save interval
        steps = int(os.environ.get("JAXBELT_STEPS_PER_CHUNK", "") or STEPS_PER_CHUNK)
        saves_per_chunk = max(1, round(steps / sch.stride))
        self.chunk = saves_per_chunk * per_save  # macro steps per chunk
        # a save that rounding puts one step later can add one to a chunk's saves
        self._kw = dict(substeps=sch.substeps, n_buf=saves_per_chunk + 1)
        self._compiled = None

    @property
    def n_macro(self) -> int:
        return int(self.clock.n)

    def _args(self, progress: RunProgress, k_stop: int):
        i32 = lambda x: jax.device_put(np.asarray(x, dtype=np.int32))  # noqa: E731
        return (
            self.model,
            self.params,
            progress.state,
            i32(progress.k),
            i32(k_stop),
            i32(progress.n_saved),
            self.clock,
        )

    def compile(self) -> None:
        """Compile the chunk program now (so that its time is measured apart from the run)."""
        if self._compiled is None:
            args = self._args(self.start(), 0)
            # stored traced (jax.export) beside the compilation cache: a warm start skips tracing too
            lowered, self._unflatten = lowered_flat(
                "chunk", _chunk, args, self._kw, (args[3], args[2], args[5], args[2])
            )
            self._compiled = compile_forward(lowered, implicit=self.model.implicit_stiffness)

    def start(self) -> RunProgress:
        sch = self.schedule
        saved = jax.tree.map(lambda x: np.full((sch.n_saves,) + x.shape, np.inf, x.dtype), self.state0)
        return RunProgress(k=0, state=self.state0, saved=saved, n_saved=0)

    def restore(self, arrays: dict) -> RunProgress:
        """The progress stored by ``RunProgress.arrays`` (shapes checked against this run)."""
        start = self.start()

        def tree(prefix, like):
            leaves, treedef = jax.tree.flatten(like)
            new = [np.asarray(arrays[f"{prefix}/{i}"]) for i in range(len(leaves))]
            if any(a.shape != np.shape(b) or a.dtype != np.asarray(b).dtype for a, b in zip(new, leaves)):
                raise ValueError("the checkpoint's arrays do not fit this drive")
            return jax.tree.unflatten(treedef, new)

        state = jax.tree.map(jnp.asarray, tree("state", start.state))
        return RunProgress(
            k=int(arrays["k"]),
            state=state,
            saved=tree("saved", start.saved),
            n_saved=int(arrays["n_saved"]),
            fault=bool(arrays["fault"]),
        )

    def done(self, progress: RunProgress) -> bool:
        return progress.fault or progress.k >= self.n_macro

    def advance(self, progress: RunProgress) -> RunProgress:
        """One chunk further (host copies of the new saves)."""
        self.compile()
        k_stop = min(progress.k + self.chunk, self.n_macro)
        assert self._compiled is not None
        leaves = jax.tree.leaves(eqx.filter(self._args(progress, k_stop), eqx.is_array))
        k, y, j, buf = self._unflatten(self._compiled(*leaves))
        k, j = int(k), int(j)
        if j - progress.n_saved > self._kw["n_buf"]:  # cannot happen (see __init__); never drop saves silently
            raise RuntimeError("chunk save buffer overflow")
        new = jax.tree.map(np.asarray, buf)
        for dst, src in zip(jax.tree.leaves(progress.saved), jax.tree.leaves(new)):
            dst[progress.n_saved : j] = src[: j - progress.n_saved]
        fault = bool(np.asarray(y.fault) != Fault.OK)
        return RunProgress(k=k, state=y, saved=progress.saved, n_saved=j, fault=fault)

    def fraction(self, progress: RunProgress) -> float:
        return progress.k / max(self.n_macro, 1)

    def save_times(self) -> np.ndarray:
        """The save times of the run, as ``simulate`` gives them (numpy; whole numbers times ``dt``)."""
        sch = self.schedule
        dtype = jnp.result_type(sch.dt)  # float32 without x64, as simulate
        counts = np.arange(0, sch.n_steps + 1, sch.stride, dtype=dtype)
        return np.multiply(counts, np.asarray(sch.dt, dtype), dtype=dtype)

    def trajectory(self, progress: RunProgress) -> Trajectory:
        """The run's ``Trajectory``, as ``simulate`` returns it, but with host (numpy) copies of the saved
        states: post-processing reads them on the host, and eager device operations on them (indexing,
        masking) would each be compiled in a fresh process."""
        sch = self.schedule
        states = jax.tree.map(np.array, progress.saved)  # a copy: advance() writes into progress.saved
        valid = np.all(np.isfinite(states.q), axis=(1, 2, 3))
        num_steps = jax.device_put(np.asarray(progress.k * sch.substeps, dtype=np.int32))
        return Trajectory(ts=self.save_times(), states=states, final=progress.state, num_steps=num_steps, valid=valid)
