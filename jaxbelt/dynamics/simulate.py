"""``simulate``: one jit-compiled diffrax solve of a drive, settle phase included.

The run starts at ``t = -settle_time`` with the pulleys locked, friction off and strong mass
damping, so the belt finds its static equilibrium on the pulleys (tension, sag, contact
penetration); at ``t = 0`` the physics switches on with no spurious shock. Settle and run are
the same compiled step.
"""

from __future__ import annotations

import dataclasses
import math
import typing

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._equinox_checks import callback_free_checks
from .._types import DriveModel, DriveParams, DriveState
from .solver import solve_fixed_steps
from .step import MoreauJean, drive_operators
from .._types import Fault

__all__ = ["simulate", "Trajectory", "Schedule", "schedule"]


@typing.final
class Trajectory(eqx.Module):
    # ts, states and valid are numpy arrays (host copies) in the trajectory of a chunked run (``run``)
    ts: jax.Array | np.ndarray  # saved times (s)
    states: DriveState  # stacked along the leading axis
    final: DriveState  # state at the end of the run (or the last good state)
    num_steps: jax.Array
    valid: jax.Array | np.ndarray  # per saved time: computed (False after a run stopped at a fault)

    def computed(self) -> "Trajectory":
        """The part of the history that was computed (host-side; drops saves after a fault)."""
        keep = np.asarray(self.valid)
        if keep.all():  # nothing to drop (and no eager device indexing of every leaf)
            return self
        return Trajectory(
            ts=self.ts[keep],
            states=jax.tree.map(lambda x: x[keep], self.states),
            final=self.final,
            num_steps=self.num_steps,
            valid=self.valid[keep],
        )


# Reverse mode keeps every step's state while that fits this budget. Recomputing the forward pass
# from sparse checkpoints is compiled differently, rounds differently, and can flip a stick/slip
# decision somewhere in thousands of steps: measured 1e-4 relative gradient error that way, 1e-12
# with every step stored.
REVERSE_MEMORY_BUDGET_BYTES = 2 * 1024**3


def _adjoint(kind: str, max_steps: int, state_bytes: int):
    if kind == "forward":
        return diffrax.ForwardMode()
    if kind == "reverse-recompute":
        return diffrax.RecursiveCheckpointAdjoint()
    return diffrax.RecursiveCheckpointAdjoint(
        checkpoints=int(max(2, min(max_steps, REVERSE_MEMORY_BUDGET_BYTES // max(state_bytes, 1))))
    )


# Contact steps per diffrax step: the largest divisor of the save stride up to this, so saves fall
# on diffrax step boundaries.
MAX_SUBSTEPS = 32


def _substeps(stride: int) -> int:
    return max(k for k in range(1, min(stride, MAX_SUBSTEPS) + 1) if stride % k == 0)


@dataclasses.dataclass(frozen=True)
class Schedule:
    """Step counts of a run: settle steps, run steps, contact steps per diffrax step, save stride."""

    dt: float
    n_settle: int  # steps before t = 0 (whole macro steps)
    n_run: int  # steps after t = 0 (whole macro steps, >= n_steps)
    n_steps: int  # steps to t_end
    stride: int  # steps per save
    substeps: int  # contact steps per diffrax (macro) step

    @property
    def n_macro(self) -> int:
        return (self.n_settle + self.n_run) // self.substeps

    @property
    def n_saves(self) -> int:
        return self.n_steps // self.stride + 1


def schedule(*, t_end: float, dt: float, save_dt: float | None, settle_time: float) -> Schedule:
    """The step counts ``simulate`` (and the chunked run) use for these times."""
    save_dt = dt if save_dt is None else save_dt
    stride = max(1, int(round(save_dt / dt)))
    substeps = _substeps(stride)
    # whole macro steps in the settle phase, so that t = 0 (physics on) falls on a step boundary
    n_settle = substeps * int(math.ceil(round(settle_time / dt) / substeps))
    n_steps = int(math.ceil(t_end / dt - 1e-9))
    # Whole macro steps to the end as well: the run stops at the first macro-step boundary at or after
    # t_end (at most substeps - 1 steps later; saves stay <= t_end). A shortened last macro step (its
    # substeps of h_last / substeps) made the outputs kinky: measured slope jumps of 1e-3 relative within
    # 1e-5 relative parameter changes, which finite-difference checks then trip over.
    n_run = substeps * int(math.ceil(n_steps / substeps))
    return Schedule(dt=dt, n_settle=n_settle, n_run=n_run, n_steps=n_steps, stride=stride, substeps=substeps)


@eqx.filter_jit
@callback_free_checks()  # traced without host callbacks: the program reaches the persistent cache
def _solve(
    model: DriveModel,
    params: DriveParams,
    state0: DriveState,
    dt,
    save_ts,
    *,
    n_settle: int,
    n_run: int,
    progress: bool,
    adjoint: str = "reverse",
    substeps: int = 1,
):
    """The run from ``state0`` as one diffrax solve (``simulate``'s program): the saved states, the final
    state and the number of steps taken.

    Parameters: ten, because under ``eqx.filter_jit`` each argument is traced or static by its own type: the
    parameters, the start state and the save times are traced, the model's fields, ``dt`` and the keyword
    options (``n_settle``, ``n_run``, ``progress``, ``adjoint``, ``substeps``) are static and part of the
    compilation key; a record grouping them would hold both kinds and change what the program (and the
    persistent cache's key) depends on."""
    ops = drive_operators(model, params)
    t0 = -n_settle * dt
    t1 = n_run * dt
    n_macro = (n_settle + n_run) // substeps  # both are whole numbers of macro steps (see simulate)
    # the save times are k * stride * dt <= t1 by construction; XLA's iota * dt can land one ulp past t1 where
    # Python's n_run * dt does not (measured: 5 of 400 steps between 5.0e-5 and 5.5e-5 s), and diffrax's check
    # of them, callback-free (``_equinox_checks``), then turns every save time into NaN: nothing was saved
    saveat = diffrax.SaveAt(ts=jnp.clip(save_ts, t0, t1), t1=True)
    meter = diffrax.TqdmProgressMeter(refresh_steps=200) if progress else diffrax.NoProgressMeter()
    sol = solve_fixed_steps(
        MoreauJean(substeps=substeps),
        state0,
        (model, params, ops),
        t0=t0,
        t1=t1,
        dt0=substeps * dt,
        saveat=saveat,
        max_steps=n_macro + 2,
        adjoint=_adjoint(adjoint, n_macro + 2, sum(x.size * x.dtype.itemsize for x in jax.tree.leaves(state0))),
        event=diffrax.Event(lambda t, y, args, **kw: y.fault != Fault.OK),
        throw=False,
        progress_meter=meter,
    )
    states = jax.tree.map(lambda x: x[:-1], sol.ys)
    final = jax.tree.map(lambda x: x[-1], sol.ys)
    # After a fault event diffrax fills later saves with inf; fall back to the last good save.
    valid = jnp.all(jnp.isfinite(states.q), axis=(1, 2, 3))
    last = jax.tree.map(lambda x: x[jnp.maximum(jnp.sum(valid) - 1, 0)], states)
    final_ok = jnp.all(jnp.isfinite(final.q))
    # a run that reached its end without a fault yet whose end save was never written: its history was lost, not
    # its physics (as the unclipped save times above did); say so in the fault code rather than hand on a history
    # of infinities marked "ok"
    # (a fault freezes the last good state, finite, with its code, and the end save holds it: an end save that is
    # not finite was never written)
    final = jax.tree.map(lambda a, b: jnp.where(final_ok, a, b), final, last)
    lost = ~final_ok & (final.fault == Fault.OK)
    final = eqx.tree_at(lambda s: s.fault, final, jnp.where(lost, float(Fault.SAVES_LOST), final.fault))
    return states, final, sol.stats["num_steps"] * substeps


def simulate(
    model: DriveModel,
    params: DriveParams,
    state0: DriveState,
    *,
    t_end: float,
    dt: float,
    save_dt: float | None = None,
    settle_time: float = 0.1,
    progress: bool = False,
    adjoint: str = "reverse",
    _ahead_of_time: bool = False,
):
    """Integrate the drive from rest to ``t_end`` with fixed step ``dt``; save every ``save_dt``.

    ``params`` is an ordinary argument: ``jax.grad``/``jax.jacfwd``/``vmap`` of a function of the
    returned trajectory differentiate or batch through the whole run (contact solve included).
    ``adjoint="reverse"`` (checkpointed, for ``jax.grad``) or ``"forward"`` (diffrax.ForwardMode,
    for ``jax.jacfwd``/``jax.jvp``: cheaper with a few parameters).

    Parameters: the three traced arguments (model, parameters, start state) and seven keyword options of one run
    (length, step, saves, settle time, progress meter, adjoint, ahead-of-time compilation), each passed by name;
    the step counts are derived from them as one ``Schedule`` record inside.
    """
    if adjoint not in ("reverse", "reverse-recompute", "forward"):
        raise ValueError(f"adjoint = {adjoint!r}: must be 'reverse', 'reverse-recompute' or 'forward'")
    sch = schedule(t_end=t_end, dt=dt, save_dt=save_dt, settle_time=settle_time)
    n_settle, n_run, substeps = sch.n_settle, sch.n_run, sch.substeps
    save_ts = jnp.arange(0, sch.n_steps + 1, sch.stride, dtype=jnp.result_type(dt)) * dt
    kwargs: dict[str, typing.Any] = dict(
        n_settle=n_settle, n_run=n_run, progress=progress, adjoint=adjoint, substeps=substeps
    )

    def trajectory(out):
        states, final, num_steps = out
        valid = jnp.all(jnp.isfinite(states.q), axis=(1, 2, 3))
        return Trajectory(ts=save_ts, states=states, final=final, num_steps=num_steps, valid=valid)

    if _ahead_of_time:  # compile now (timed apart from the run); returns run(params, state0), no retracing
        # equinox types filter_jit as returning the function itself; the jitted wrapper has .lower
        compiled = _solve.lower(model, params, state0, dt, save_ts, **kwargs).compile()  # type: ignore[attr-defined]
        return lambda params, state0: trajectory(compiled(model, params, state0, dt, save_ts, **kwargs))
    return trajectory(_solve(model, params, state0, dt, save_ts, **kwargs))
