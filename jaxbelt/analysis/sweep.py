"""Parameter sweeps: many variants of one drive in one vmapped, jit-compiled run, sharded over devices.

The grid (cartesian product of the varied keys) is laid along a batch axis that is split over every
device JAX sees (``jax.devices()``: the CPU, one or several GPUs, or all hosts' devices after
``jax.distributed.initialize()``). The same code runs everywhere; XLA partitions the vmapped
simulation along the batch axis, so devices never exchange data until the figures are gathered.

On a CPU, JAX sees one device and runs the batch mostly on one core. Start Python with
``XLA_FLAGS=--xla_force_host_platform_device_count=<cores>`` (``jaxbelt sweep`` does this itself) and
the batch is split over every core: measured 32.9 s -> 16.1 s for 64 variants on 2 cores.

Every point is checked before anything is compiled: by ``build_drive``'s own checks (``check_spec`` on
the configuration with the point's values written in), and the one time step all points share
against each point's stability limit.
"""

from __future__ import annotations

import copy
import dataclasses
import itertools
import math
import time
from dataclasses import dataclass

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from .._drive import Drive
from .._errors import ConfigError
from ..config import DriveSpec
from ..config.validate import check_spec
from .parameters import check_together, get_parameter, parameter_keys, set_parameters
from ..outputs.signals import simulate_signals
from ..dynamics.stability import stable_time_step

__all__ = ["SweepResult", "sweep", "steady_figures"]


@dataclass
class SweepResult:
    keys: list[str]
    points: np.ndarray  # (N, K) parameter values
    figures: dict[str, np.ndarray]  # name -> (N,) steady-state figure
    timing: dict

    def table(self) -> tuple[list[str], np.ndarray]:
        """Header and rows (varied keys, then figures) for ``sweep.csv``."""
        names = list(self.figures)
        return self.keys + names, np.column_stack([self.points] + [self.figures[n] for n in names])


def steady_figures(drive: Drive, ts, sig: dict, window: float = 0.2) -> dict:
    """Means of every signal over the final ``window`` fraction of the run (traceable)."""
    t_end = ts[-1]
    w = (ts >= t_end - window * (t_end - ts[0])).astype(ts.dtype)
    out = {}
    for name, x in sig.items():
        out[f"{name}:mean"] = jnp.sum(w * x) / jnp.sum(w)
    return out


def _grid(values: dict[str, np.ndarray | list[float]]) -> np.ndarray:
    return np.array(list(itertools.product(*[np.asarray(v, dtype=float).ravel() for v in values.values()])))


def _point_label(keys: list[str], x) -> str:
    return ", ".join(f"{k} = {float(v):.6g}" for k, v in zip(keys, x))


def _spec_at(drive: Drive, key: str, value: float, spec: DriveSpec) -> None:
    """Write one swept value into ``spec`` (a copy), the way a user would edit the configuration.

    Only the validation reads the result, so a key whose configuration entry has no limit beyond being
    finite (the final level of a load, torque or speed law) is left alone.
    """
    parts = key.split(".")
    if parts[0] == "belt":
        b, k = spec.belt, parts[1]
        if k == "E":  # as set_parameter: a spec with E keeps its explicit EA/EI; one without scales both
            if b.E is not None or not value > 0:  # (a value out of range: refused by the check under its name)
                b.E = value
            else:
                assert b.EA is not None and b.EI is not None  # a valid spec without E gives both
                scale = value / float(get_parameter(drive, drive.params, key))
                b.EA, b.EI = b.EA * scale, b.EI * scale
        elif k == "eta":
            b.eta, b.axial_damping = value, None
        elif k == "pretension":
            b.pretension, b.stress_free_length, b.effective_length, b.effective_offset = value, None, None, None
        elif k == "stress_free_length":
            b.stress_free_length, b.pretension, b.effective_length, b.effective_offset = value, None, None, None
        else:  # EA, EI, mass_per_length, axial_damping, bending_damping: fields of the same name
            setattr(b, k, value)
    elif parts[0] == "contact":
        setattr(spec.contact, parts[1], value)
    elif parts[0] == "pulleys":
        p = next(p for p in spec.pulleys if p.name == parts[1])
        rest = parts[2:]
        if rest == ["radius"]:  # the key is the radius at the belt axis, the spec the surface's
            p.radius = p.radius + (value - float(get_parameter(drive, drive.params, key)))
        elif rest in (["inertia"], ["viscous"]):
            setattr(p, rest[0], value)
        elif rest[0] == "tensioner":
            setattr(p.tensioner, rest[1], value)


def _check_points(drive: Drive, keys: list[str], points: np.ndarray, t_end, save_dt) -> None:
    """Every grid point through ``build_drive``'s own checks, ``check_spec`` (ranges, geometry, strain, run size)."""
    base = copy.deepcopy(drive.spec)
    base.solver.dt = None  # the shared time step is checked against every point's limit apart (below)
    if t_end is not None:
        base.solver.t_end = t_end
    if save_dt is not None:
        base.solver.save_dt = save_dt
    bad: list[tuple[int, ConfigError]] = []
    for i, x in enumerate(points):
        spec = copy.deepcopy(base)
        for k, v in zip(keys, x):
            _spec_at(drive, k, float(v), spec)
        try:
            check_spec(spec)
        except ConfigError as err:
            bad.append((i, err))
    if bad:
        i, first = bad[0]
        more = f" ({len(bad)} of {len(points)} points are refused)" if len(bad) > 1 else ""
        raise ConfigError(f"sweep point {i + 1} of {len(points)} ({_point_label(keys, points[i])}): {first}{more}")


def _point_params(drive: Drive, keys: list[str], x):
    return set_parameters(drive, drive.params, [(k, x[i]) for i, k in enumerate(keys)])


def _point_program(drive: Drive, keys: list[str], t_end, save_dt, window: float):
    """The figures of one grid point ``x`` (K values), to be vmapped over the batch and sharded."""

    def one(x):
        p = _point_params(drive, keys, x)
        ts, sig, traj = simulate_signals(drive, p, t_end=t_end, save_dt=save_dt, return_trajectory=True)
        figs = steady_figures(drive, ts, sig, window)
        figs["fault"] = traj.final.fault
        figs["lcp_residual_max"] = jnp.max(traj.states.lcp_residual)
        return figs

    return one


def _shared_time_step(drive: Drive, keys: list[str], points: np.ndarray) -> tuple[float, str]:
    """One step for all points: every point's stability limit, from the parameters it is simulated with.

    Without ``solver.dt`` the step is 0.9 x the smallest limit (what ``run`` would choose for the most
    demanding point); a given ``solver.dt`` above any point's limit is refused, naming that point.
    """
    belts = jax.tree.map(np.asarray, jax.vmap(lambda x: _point_params(drive, keys, x).belt)(jnp.asarray(points)))
    limits = np.array(
        [
            stable_time_step(
                drive.model, eqx.tree_at(lambda p: p.belt, drive.params, jax.tree.map(lambda a: a[i], belts))
            )
            for i in range(len(points))
        ]
    )
    worst = int(np.argmin(limits))
    given = drive.spec.solver.dt
    if given is None:
        dt = 0.9 * float(limits[worst])
        note = (
            f"time step {dt:.4g} s for every point: 0.9 x the smallest stability limit over the grid "
            f"(point {worst + 1}: {_point_label(keys, points[worst])})"
        )
        return dt, note
    over = np.flatnonzero(given > limits)
    if over.size:
        i = int(over[0])
        raise ConfigError(
            f"solver.dt = {given!r}: exceeds the stability limit {limits[i]:.4g} s of sweep point {i + 1} of "
            f"{len(points)} ({_point_label(keys, points[i])}; {over.size} of {len(points)} points are over their "
            f"limit); a sweep runs every point with one step: use solver.dt <= {0.9 * limits[worst]:.4g} s "
            f"(0.9 x the smallest limit, point {worst + 1}), or leave solver.dt out and the sweep chooses it"
        )
    return float(given), f"time step {given:.4g} s (solver.dt) for every point"


def sweep(
    drive: Drive,
    values: dict[str, "np.ndarray | list[float]"],
    *,
    t_end: float | None = None,
    save_dt: float | None = None,
    window: float = 0.2,
    devices=None,
    progress=False,
) -> SweepResult:
    """Simulate every point of the grid ``values`` (key -> 1-D values) in one batched computation.

    Every point is checked first (the limits ``build_drive`` applies, and the shared time step against
    its stability limit), before anything is compiled. ``progress``: True prints a line before each
    long phase (compiling, running); a callable receives those lines instead.
    """
    log = print if progress is True else (progress or (lambda msg: None))
    keys = list(values)
    known = set(parameter_keys(drive))
    for k in keys:
        if k not in known:
            get_parameter(drive, drive.params, k)  # raises ConfigError with a suggestion
    check_together(drive, keys)  # keys that set the same thing (E with EA, ...), before anything is built
    points = _grid(values)
    if points.size == 0:
        raise ConfigError("sweep: the grid is empty (give at least one value per key)")
    if not np.all(np.isfinite(points)):
        raise ConfigError("sweep: every value must be a finite number")
    _check_points(drive, keys, points, t_end, save_dt)
    dt, dt_note = _shared_time_step(drive, keys, points)
    drive = dataclasses.replace(drive, dt=dt)

    devices = jax.devices() if devices is None else list(devices)
    n_dev = len(devices)
    n = points.shape[0]
    pad = (-n) % n_dev  # the batch must split evenly over the devices; repeat the last point
    padded = np.concatenate([points, np.repeat(points[-1:], pad, axis=0)]) if pad else points

    s = drive.options
    steps = round(s.settle_time / dt) + math.ceil((s.t_end if t_end is None else t_end) / dt - 1e-9)
    log(dt_note)
    log(
        f"compiling one program for {n} points ({n + pad} slots on {n_dev} device(s)"
        + (f", {pad} of them repeat the last point" if pad else "")
        + ") ..."
    )
    mesh = Mesh(np.asarray(devices), ("batch",))
    batch = NamedSharding(mesh, PartitionSpec("batch", None))
    x = jax.make_array_from_callback(padded.shape, batch, lambda idx: padded[idx])
    fn = jax.jit(
        jax.vmap(_point_program(drive, keys, t_end, save_dt, window)),
        out_shardings=NamedSharding(mesh, PartitionSpec("batch")),
    )
    t0 = time.perf_counter()
    compiled = fn.lower(x).compile()
    t1 = time.perf_counter()
    log(f"compiled in {t1 - t0:.1f} s; running {n} points, {steps} steps each (settling included) ...")
    out = compiled(x)
    jax.block_until_ready(out)
    t2 = time.perf_counter()
    if jax.process_count() > 1:
        from jax.experimental import multihost_utils

        out = multihost_utils.process_allgather(out, tiled=True)
    figures = {k: np.asarray(v)[:n] for k, v in out.items()}
    timing = dict(
        points=n, devices=n_dev, dt=dt, steps=steps, compile_s=t1 - t0, run_s=t2 - t1, s_per_point=(t2 - t1) / n
    )
    return SweepResult(keys=keys, points=points, figures=figures, timing=timing)
