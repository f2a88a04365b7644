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

About 440 lines, over the usual 400: the checks, the chunk plan and the chunked, resumable run share the
points' layout and the manifest, and read best together.
"""

from __future__ import annotations

import copy
import dataclasses
import itertools
import math
import time
from dataclasses import dataclass
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from .._drive import Drive
from .._errors import ConfigError
from .._export import lowered as lowered_program
from .._xla import compile_forward
from ..config import DriveSpec
from ..config.validate import check_spec, resolve_model
from .distributed import broadcast, gather, process_group
from .sweep_store import SweepStore
from .parameters import check_together, get_parameter, parameter_keys, set_parameters
from .run import check_window
from ..outputs.fead import circular_mean
from ..outputs.signals import quantity_of, simulate_signals
from .._types import Fault
from ..outputs.energy import ENERGY_TOLERANCE, energy_status, unclosed_share
from ..outputs.steadiness import steadiness, stick_shares
from ..outputs.window import traced_window, window_from_start
from ..dynamics.stability import stable_time_step

__all__ = ["SweepResult", "sweep", "steady_figures", "point_status"]


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


def steady_figures(drive: Drive, ts, sig: dict, window: float = 0.2, *, mask=None) -> dict:
    """Means of every signal over the final ``window`` fraction of the run (traceable), or over ``mask`` (1 in
    the window: ``outputs.window.traced_window``, trimmed to whole periods of the engine orders as the run
    summary's). An angle that wraps (``Quantity.period``: ``hub_direction``) gets a circular mean, weighted by
    its magnitude where it has one (the direction of the mean hub-load vector, as the run summary's)."""
    w = (ts >= ts[-1] - window * (ts[-1] - ts[0])).astype(ts.dtype) if mask is None else mask
    out = {}
    for name, x in sig.items():
        q = quantity_of(name)
        if q.period is None:
            out[f"{name}:mean"] = jnp.sum(w * x) / jnp.sum(w)
        else:
            size = f"{q.magnitude}:{name.partition(':')[2]}"
            weight = w * sig[size] if q.magnitude is not None and size in sig else w
            out[f"{name}:mean"] = circular_mean(x, q.period, weight)
            if q.magnitude is not None and size in sig:  # the mean vector's magnitude (the run summary's mean)
                a = (2.0 * math.pi / q.period) * x
                c, s = jnp.sum(weight * jnp.cos(a)), jnp.sum(weight * jnp.sin(a))
                n2 = c * c + s * s  # guarded at zero (no direction): finite derivatives
                out[f"{size}:vector_mean"] = jnp.where(n2 > 0, jnp.sqrt(jnp.where(n2 > 0, n2, 1.0)), 0.0) / jnp.sum(w)
    return out


def point_status(
    drive: Drive, res, signals_file, window: float, check_drift: bool = True, warnings: list | None = None
) -> tuple[np.ndarray, list]:
    """Each point's window through the run's checks (``outputs.steadiness``), from its saved signals
    (``signals_file``: the sweep's ``sweep_signals.npz``) and the sweep's stick shares: (steady and not in gross
    slip, the status line). ``check_drift`` False (a transient on purpose): faults and gross slip only.
    ``warnings``: a list that receives per point the warnings a run of the point's tier would print about it
    (intermittent gross slip: a wrap sliding in part of the window, e.g. once per engine cycle)."""
    from ..spans.simulate import slip_warnings

    names = list(drive.model.pulley_names)
    with np.load(signals_file) as z:
        data = {k: z[k] for k in z.files}
    t = np.asarray(data.pop("t"))
    data.pop("point", None)
    starts = res.figures.get("window_start_s")
    steady, status = [], []
    for j in range(len(res.points)):
        sel = window_from_start(t, None if starts is None else starts[j], window)
        fault = int(res.figures["fault"][j])
        said: list[str] = []
        if warnings is not None:
            warnings.append(said)
        if fault != Fault.OK:
            steady.append(False)
            status.append(f"diverged ({Fault(fault).message})")
            continue
        unclosed = float(res.figures["energy_unclosed"][j]) if "energy_unclosed" in res.figures else 0.0
        if unclosed > ENERGY_TOLERANCE:  # a run-away that stayed finite: its figures are not the drive's
            steady.append(False)
            status.append(energy_status(unclosed))
            continue
        sig = {"t": t, **{k: v[j] for k, v in data.items()}}
        share = {n: float(res.figures[f"stick_share:{n}"][j]) for n in names}
        found = steadiness(drive, sig, sel, check_drift=check_drift, stick_share=share)
        ok = found["steady"] and not found["gross_slip"]
        steady.append(ok)
        head = "gross slip" if found["gross_slip"] else "not steady"
        status.append("ok" if ok else f"{head}: " + "; ".join(found["findings"]))
        if ok and getattr(res, "timing", {}).get("model", "ancf") == "spans":  # as run_spans: its wraps' slide counts
            said.extend(slip_warnings(share, found))
        elif ok and found.get("intermittent_slip"):  # as the ANCF run's summary
            said.append(found["intermittent_slip"])
    return np.asarray(steady, dtype=bool), status


def _column(key: str, v) -> np.ndarray:
    """One key's values as a flat float array; a value that is not a finite number is refused, named."""
    raw = np.ravel(np.asarray(v, dtype=object))
    for i, x in enumerate(raw):
        ok = isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, (bool, np.bool_))
        if not (ok and math.isfinite(float(x))):
            raise ConfigError(f"sweep: {key}: value {i + 1} of {raw.size} = {x!r}: every value must be a finite number")
    return raw.astype(float)


def _grid(values: dict[str, np.ndarray | list[float]]) -> np.ndarray:
    return np.array(list(itertools.product(*[_column(k, v) for k, v in values.items()])))


def _point_label(keys: list[str], x) -> str:
    return ", ".join(f"{k} = {float(v):.6g}" for k, v in zip(keys, x))


def _spec_at(drive: Drive, key: str, value: float, spec: DriveSpec) -> None:
    """Write one swept value into ``spec`` (a copy), the way a user would edit the configuration.

    Only the validation reads the result, so a key whose configuration entry has no limit beyond being
    finite (the final level of a load, torque or speed law) is left alone; a constant driver speed is written
    (the belt-speed check and the implicit scheme's step depend on it).
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
        elif k in ("pretension", "stress_free_length"):  # the other installed-state keys give way
            b.pretension = b.stress_free_length = b.effective_length = b.installed_effective_length = None
            b.effective_offset = None
            setattr(b, k, value)
        else:  # EA, EI, mass_per_length, axial_damping, bending_damping: fields of the same name
            setattr(b, k, value)
    elif parts[0] == "contact":
        setattr(spec.contact, parts[1], value)
    elif parts[0] == "pulleys":
        p = next(p for p in spec.pulleys if p.name == parts[1])
        rest = parts[2:]
        if rest == ["radius"]:  # the key is the radius at the belt axis, the spec the surface's
            p.radius = p.radius + (value - float(get_parameter(drive, drive.params, key)))
        elif rest in (["inertia"], ["viscous"], ["mu"], ["rotor_inertia"], ["clutch_stiffness"], ["clutch_damping"]):
            setattr(p, rest[0], value)
        elif rest[:2] == ["tensioner", "stops"]:  # one end of the (min, max) pair (the key exists: stops given)
            assert p.tensioner is not None and p.tensioner.stops is not None
            lo, hi = p.tensioner.stops
            p.tensioner.stops = (value, hi) if rest[2] == "min" else (lo, value)
        elif rest[0] == "tensioner":
            setattr(p.tensioner, rest[1], value)
        elif rest == ["speed"] and isinstance(p.speed, (int, float)):  # a constant driver speed (a duty point):
            p.speed = value  # its belt speed and the implicit step follow it
        elif rest == ["speed"] and isinstance(p.speed_rpm, (int, float)):
            p.speed_rpm = value * 60.0 / (2.0 * math.pi)
        elif rest[0] == "excitation":  # excitation.<order>.<entry>, the order as the spec writes it
            exc = p.excitation
            assert exc is not None  # the key exists: the pulley has this order
            text = ".".join(rest[1:-1])
            order = next(k for k in exc if float(k) == float(text))
            p.excitation = {**exc, order: {**exc[order], rest[-1]: value}}


def _editable_copy(spec: DriveSpec) -> DriveSpec:
    """A copy of ``spec`` that ``_spec_at`` may write into: new belt, contact, solver, pulley and tensioner records
    (it sets their fields; laws and tables it replaces whole, never edits). A deep copy cost a sweep's check of
    1,000 points 0.7 s."""
    pulleys = [
        dataclasses.replace(p, tensioner=None if p.tensioner is None else dataclasses.replace(p.tensioner))
        for p in spec.pulleys
    ]
    return dataclasses.replace(
        spec,
        belt=dataclasses.replace(spec.belt),
        contact=dataclasses.replace(spec.contact),
        solver=dataclasses.replace(spec.solver),
        pulleys=pulleys,
    )


class _LoopProgress:
    """``tick(i)`` in a loop over the points: once the loop has taken ``after_s``, a line with the points
    done and an estimate of the time left, then one every ``every_s`` (large sweeps check for minutes)."""

    def __init__(self, log, what: str, n: int, clock=None, after_s: float = 5.0, every_s: float = 30.0):
        self.log, self.what, self.n, self.clock = log, what, n, clock or time.perf_counter
        self.after_s, self.every_s = after_s, every_s
        self.t0 = self.clock()
        self.next_s = after_s

    def tick(self, done: int) -> None:
        elapsed = self.clock() - self.t0
        if elapsed < self.next_s or done >= self.n or done == 0:
            return
        self.next_s = elapsed + self.every_s
        left = elapsed * (self.n - done) / done
        self.log(f"{self.what}: {done} of {self.n} points in {elapsed:.0f} s; about {left:.0f} s left")


def _check_points(drive: Drive, keys: list[str], points: np.ndarray, t_end, save_dt, log=None) -> list:
    """Every grid point through ``build_drive``'s own checks, ``check_spec`` (ranges, geometry, strain, run
    size); ``log``: lines of progress for a long check. Returns each point's ``(step, reason)`` as its own run
    would take it under the implicit scheme (the accuracy step follows the point's speeds), else ``[]``."""
    base = copy.deepcopy(drive.spec)
    base.solver.scheme = drive.scheme  # every point runs the base drive's scheme ("auto" resolved once)
    if drive.scheme == "explicit":
        base.solver.dt = None  # the shared time step is checked against every point's limit apart (below)
    if t_end is not None:
        base.solver.t_end = t_end
    if save_dt is not None:
        base.solver.save_dt = save_dt
    bad: list[tuple[int, ConfigError]] = []
    steps: list[tuple[float | None, str]] = []
    meter = _LoopProgress(log or (lambda msg: None), "checking the points", len(points))
    for i, x in enumerate(points):
        meter.tick(i)
        spec = _editable_copy(base)
        for k, v in zip(keys, x):
            _spec_at(drive, k, float(v), spec)
        try:
            checked = check_spec(spec)
            steps.append((checked.dt, checked.dt_reason))
        except ConfigError as err:
            bad.append((i, err))
    if bad:
        i, first = bad[0]
        more = f" ({len(bad)} of {len(points)} points are refused)" if len(bad) > 1 else ""
        raise ConfigError(f"sweep point {i + 1} of {len(points)} ({_point_label(keys, points[i])}): {first}{more}")
    return steps if drive.scheme == "implicit" else []


def _point_params(drive: Drive, keys: list[str], x):
    return set_parameters(drive, drive.params, [(k, x[i]) for i, k in enumerate(keys)])


def _point_program(
    drive: Drive, keys: list[str], t_end, save_dt, window: float, keep_signals: bool = False, batched: bool = False
):
    """The figures of one grid point ``x`` (K values), to be vmapped over the batch and sharded; with
    ``keep_signals`` also its signal histories (``"signals"``) and saved times (``"t"``); ``batched``: rare
    branches taken batch-wide (``DriveModel.batched``: the points are vmapped and never differentiated)."""

    run_drive = dataclasses.replace(drive, model=dataclasses.replace(drive.model, batched=batched))

    def one(x):
        p = _point_params(drive, keys, x)
        ts, sig, traj = simulate_signals(run_drive, p, t_end=t_end, save_dt=save_dt, return_trajectory=True)
        in_window = traced_window(drive, ts, traj.states.theta, window)
        figs = steady_figures(drive, ts, sig, mask=in_window)
        shares = stick_shares(drive.model, p, traj.states, in_window)  # gross slip: no stick zone left
        figs.update({f"stick_share:{n}": shares[i] for i, n in enumerate(drive.model.pulley_names)})
        # mean torques as the run summary's: the belt's angular impulse over the window (every step counts,
        # not only the saved ones, whose one-step torques alias the contact's fast content)
        first = jnp.argmax(in_window > 0)
        figs["window_start_s"] = ts[first]  # the window's start, trimmed to whole engine periods (outputs.window)
        J = traj.states.angular_impulse
        torque = (J[-1] - J[first]) / jnp.maximum(ts[-1] - ts[first], 1e-300)
        figs.update(
            {
                f"torque:{n}:mean": jnp.where(ts[-1] > ts[first], torque[i], figs[f"torque:{n}:mean"])
                for i, n in enumerate(drive.model.pulley_names)
            }
        )
        figs["fault"] = traj.final.fault
        # a point that ran away without a non-finite state still leaves its energy balance open
        ends = jax.tree.map(lambda a: a[jnp.asarray([0, -1])], traj.states)
        figs["energy_unclosed"] = unclosed_share(drive.model, p, ends)
        figs["lcp_residual_max"] = jnp.max(traj.states.lcp_residual)
        if keep_signals:
            figs["signals"] = sig
            figs["t"] = ts
        return figs

    return one


def _shared_time_step(drive: Drive, keys: list[str], points: np.ndarray, log=None, steps=()) -> tuple[float, str]:
    """One step for all points: every point's stability limit, from the parameters it is simulated with
    (``log``: lines of progress for a long loop).

    Without ``solver.dt`` the step is 0.9 x the smallest limit (what ``run`` would choose for the most
    demanding point); a given ``solver.dt`` above any point's limit is refused, naming that point. The implicit
    scheme has no such limit: its points run at the smallest of their accuracy steps (``steps``, from
    ``_check_points``: a faster point's engine orders and belt travel need a shorter step), or ``solver.dt``.
    """
    if drive.model.implicit_stiffness:  # the belt bounds no step: the smallest of the points' accuracy steps
        dts = [dt for dt, _ in steps if dt is not None]
        if drive.spec.solver.dt is not None or not dts or min(dts) >= drive.dt:
            return drive.dt, f"time step {drive.dt:.4g} s for every point, implicit scheme: {drive.dt_reason}"
        worst = int(np.argmin([np.inf if dt is None else dt for dt, _ in steps]))
        dt, why = steps[worst]
        label = _point_label(keys, points[worst])
        return dt, f"time step {dt:.4g} s for every point, implicit scheme: at point {worst + 1} ({label}) {why}"
    belts = jax.tree.map(np.asarray, jax.vmap(lambda x: _point_params(drive, keys, x).belt)(jnp.asarray(points)))
    meter = _LoopProgress(log or (lambda msg: None), "stability limits", len(points))

    def limit(i: int) -> float:
        meter.tick(i)
        return stable_time_step(
            drive.model, eqx.tree_at(lambda p: p.belt, drive.params, jax.tree.map(lambda a: a[i], belts))
        )

    limits = np.array([limit(i) for i in range(len(points))])
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


def _sweep_points(drive: Drive, values, points) -> tuple[list[str], np.ndarray]:
    """Keys and the (N, K) point array of a grid (``values``) or a point list (``points``), checked."""
    if (values is None) == (points is None):
        raise ConfigError("sweep: give either a grid (values) or a list of points (points), not both or neither")
    table = values if values is not None else points
    keys = list(table)
    if not keys:
        raise ConfigError("sweep: no key to vary")
    known = set(parameter_keys(drive))
    for k in keys:
        if k not in known:
            get_parameter(drive, drive.params, k)  # raises ConfigError with a suggestion
    check_together(drive, keys)  # keys that set the same thing (E with EA, ...), before anything is built
    if values is not None:
        pts = _grid(values)
    else:
        cols = [_column(k, points[k]) for k in keys]
        if len({c.size for c in cols}) != 1:
            sizes = ", ".join(f"{k}: {c.size}" for k, c in zip(keys, cols))
            raise ConfigError(f"sweep: every key of a point list needs one value per point (got {sizes})")
        pts = np.column_stack(cols)
    if pts.size == 0:
        raise ConfigError("sweep: the grid is empty (give at least one value per key)")
    if not np.all(np.isfinite(pts)):
        raise ConfigError("sweep: every value must be a finite number")
    return keys, pts


# Points per device and chunk at most: more buys no speed (the batch already fills the vector units)
# and costs memory and lost work when a run dies.
MAX_POINTS_PER_DEVICE = 64
# From this many points per device a chunk's runs take their rare branches batch-wide (DriveModel.batched,
# _branch.batch_cond: the Newton solve's skip after convergence, the spans tier's gross-slip projection): measured,
# the implicit scheme's batch of 64 ran 1.76 x faster for 8 s more compiling (Benchmark A, 60 el.), the spans
# tier's 1,000 points 1.5 x; a small chunk's run costs less than the compiling it would add.
BATCHED_BRANCHES_FROM = 8
MAX_SPANS_POINTS_PER_DEVICE = 1024  # the spans tier's states are small: a larger batch fills the vector units
CHUNK_MEMORY_FRACTION = 0.5  # of the free memory, for one chunk's operators and saved states


def _chunk_plan(drive: Drive, n: int, n_dev: int, n_proc: int, chunk_size, t_end, save_dt, model="ancf") -> dict:
    """Chunk sizes: ``per_device`` points per device, ``local`` per process, ``global`` per chunk."""
    s = drive.options
    t_end = s.t_end if t_end is None else t_end
    save_dt = s.save_dt if save_dt is None else save_dt
    settle = round(s.settle_time / drive.dt) if model == "ancf" else 0  # the spans tier starts installed
    steps = settle + math.ceil(t_end / drive.dt - 1e-9)
    if chunk_size is not None:
        if not (isinstance(chunk_size, (int, np.integer)) and chunk_size >= 1):
            raise ConfigError(f"sweep: chunk_size = {chunk_size!r}: must be a whole number >= 1 (points per device)")
        per_device = int(chunk_size)
    else:
        from ..config.resources import _available_memory, _operator_bytes

        n_saves = int(t_end / max(save_dt or drive.dt, drive.dt)) + 2
        if model == "ancf":
            state = sum(np.asarray(x).nbytes for x in jax.tree.leaves(drive.state0))
            m = drive.model.contact_points_per_element
            per_point = _operator_bytes(drive.model.n_elements, m, 8) + 3 * n_saves * state
        else:  # a spans state: some twenty numbers per pulley
            per_point = 3 * n_saves * 8 * 24 * drive.model.n_pulleys
        avail, _ = _available_memory()
        cap = MAX_POINTS_PER_DEVICE if model == "ancf" else MAX_SPANS_POINTS_PER_DEVICE
        fit = int(CHUNK_MEMORY_FRACTION * avail // (per_point * n_dev)) if avail > 0 else cap
        per_device = max(1, min(fit, cap, math.ceil(n / (n_dev * n_proc))))
    local = per_device * n_dev
    chunks = math.ceil(n / (local * n_proc))
    return {
        "n": n,
        "per_device": per_device,
        "local": local,
        "global": local * n_proc,
        "chunks": chunks,
        "pad": chunks * local * n_proc - n,
        "steps": steps,
    }


def _manifest(drive: Drive, keys, pts, dt, plan, t_end, save_dt, window) -> dict:
    """What a resumed sweep must share with the one it continues."""
    import hashlib

    from ..config.toml import dump_toml

    config = hashlib.sha256(dump_toml(drive.spec).encode()).hexdigest()[:16] if drive.spec is not None else None
    return dict(
        format=1,
        keys=keys,
        points=pts.tolist(),
        config_sha256=config,
        dt=dt,
        t_end=t_end,
        save_dt=save_dt,
        window=window,
        points_per_chunk=plan["global"],
    )


class _ChunkProgram:
    """One compiled program for ``local`` points (split over the local devices), and its compile time."""

    def __init__(self, fn, devices, local: int, n_keys: int, options: str = "plain", static=None):
        mesh = Mesh(np.asarray(devices), ("batch",))
        self.batch = NamedSharding(mesh, PartitionSpec("batch", None))
        shape = jax.ShapeDtypeStruct((local, n_keys), jnp.result_type(float), sharding=self.batch)
        t0 = time.perf_counter()
        # stored traced beside the compilation cache (jax.export), keyed by ``static``: all that ``fn`` closes over
        out_sharding = NamedSharding(mesh, PartitionSpec("batch"))
        if static is not None:
            lowered = lowered_program("sweep", fn, (static, options), (shape,), {"out_shardings": out_sharding})
        else:
            lowered = jax.jit(fn, out_shardings=out_sharding).lower(shape)
        # the ANCF tier's options as its runs take them (compile_forward); the spans tier's program ran 35 % slower
        # with XLA:CPU's faster-compiling code generator (1,000 variants 15.7 against 11.7 s) and takes XLA's default
        self.compiled = lowered.compile() if options == "plain" else compile_forward(lowered, options == "implicit")
        self.compile_s = time.perf_counter() - t0

    def __call__(self, x: np.ndarray) -> dict:
        xs = jax.make_array_from_callback(x.shape, self.batch, lambda idx: x[idx])
        return jax.tree.map(np.asarray, self.compiled(xs))


class _PointRun(NamedTuple):
    """What every point of a sweep computes: its run to ``t_end`` saved every ``save_dt`` (None: the drive's),
    the summary ``window`` (a fraction of the run), whether its signals are kept, and the tier (``model``)."""

    t_end: float | None
    save_dt: float | None
    window: float
    keep_signals: bool
    model: str


def _compiled_chunk(drive, keys, n_keys, devices, plan, point_run: _PointRun, log) -> _ChunkProgram:
    """The chunk program of ``point_run.model``'s point program."""
    n_dev = len(devices)
    t_end, save_dt, window, keep_signals, model = point_run
    batched = plan["per_device"] >= BATCHED_BRANCHES_FROM
    log(
        f"compiling one program for {plan['n']} points ({plan['global']} slots per chunk, {plan['chunks']} "
        f"chunk(s), on {n_dev} device(s)"
        + (f" x {plan['global'] // plan['local']} processes" if plan["global"] > plan["local"] else "")
        + (f", {plan['pad']} slots repeat the last point" if plan["pad"] else "")
        + ") ..."
    )
    if model == "spans":
        from .sweep_spans import spans_point_program

        one = spans_point_program(
            drive, lambda x: _point_params(drive, keys, x), t_end, save_dt, window, drive.dt, keep_signals, batched
        )
    else:
        one = _point_program(drive, keys, t_end, save_dt, window, keep_signals, batched)
    options = "plain" if model == "spans" else ("implicit" if drive.model.implicit_stiffness else "explicit")
    static = (drive, tuple(keys), point_run, batched)  # all that ``one`` depends on besides its point
    program = _ChunkProgram(jax.vmap(one), devices, plan["local"], n_keys, options, static)
    log(
        f"compiled in {program.compile_s:.1f} s; running {plan['n']} points, {plan['steps']} steps each "
        "(settling included) ..."
    )
    return program


def _run_chunks(program: _ChunkProgram, pts, done: int, plan, group, store, keys, log):
    """Run the chunks from point ``done`` on, each recorded in ``store``; returns the figures of the points run."""
    n, g, local = len(pts), plan["global"], plan["local"]
    figures: dict[str, list] = {}
    for first in range(done, n, g):
        last = min(first + g, n)
        block = pts[first:last]
        if len(block) < g:  # a short last chunk: repeat its last point (same program shape)
            block = np.concatenate([block, np.repeat(block[-1:], g - len(block), axis=0)])
        mine = block[group.index * local : (group.index + 1) * local]
        out = gather(program(mine), group)
        out = jax.tree.map(lambda a: a[: last - first], out)
        signals = out.pop("signals", None)
        ts = out.pop("t", None)
        ts = None if ts is None else ts[0]
        for k, v in out.items():
            figures.setdefault(k, []).append(v)
        if store is not None:
            names = list(out)
            store.append(first, keys + names, np.column_stack([pts[first:last]] + [out[k] for k in names]), signals, ts)
        if plan["chunks"] > 1:
            log(f"chunk {first // g + 1} of {plan['chunks']}: points {first + 1}-{last} done")
    return {k: np.concatenate(v) for k, v in figures.items()}


def sweep(
    drive: Drive,
    values: "dict[str, np.ndarray | list[float]] | None" = None,
    *,
    points: "dict[str, np.ndarray | list[float]] | None" = None,
    t_end: float | None = None,
    save_dt: float | None = None,
    window: float = 0.2,
    devices=None,
    progress=False,
    chunk_size: int | None = None,
    out_dir=None,
    resume: bool = False,
    inputs=(),
    model: str | None = None,
) -> SweepResult:
    """Simulate every point of the grid ``values`` (key -> 1-D values, all combinations) or of the list
    ``points`` (key -> N values, point i takes the i-th of each: Monte Carlo spreads, CSV files).

    Every point is checked first (the limits ``build_drive`` applies, and the shared time step against
    its stability limit), before anything is compiled. Points run in chunks of ``chunk_size`` points per
    device (default: as many as fit in memory, at most 64, and no more than the sweep needs), all chunks
    one compiled program. With ``out_dir`` each finished chunk is added to ``sweep.csv`` and its signals
    to ``sweep_signals/`` there (see ``sweep_store``), atomically; ``resume=True`` continues a sweep
    killed before it finished, skipping the points already done. Under ``jax.distributed`` the points
    of each chunk are split over the processes (see ``distributed``) and process 0 writes the files.
    ``progress``: True prints a line before each long phase (compiling, running); a callable receives
    those lines instead. ``model``: "ancf" (the ANCF belt) or "spans" (the spans tier, docs/spans.md: every
    point at the smallest of the points' stable steps; the same figures' names); None: the drive's
    ``solver.model``.

    Parameters: besides the drive and the grid, its eleven keyword options are the user's choices for one sweep
    (points, run length, window, devices, progress, chunking, files, resumption, tier), each with a default and
    passed by name (``jaxbelt sweep`` passes most of them from its options); a record of them would only rename them.
    """
    log = print if progress is True else (progress or (lambda msg: None))
    check_window(window)
    model = resolve_model(drive, model, "sweep")
    keys, pts = _sweep_points(drive, values, points)
    steps = _check_points(drive, keys, pts, t_end, save_dt, log)
    if model == "spans":
        from .sweep_spans import spans_shared_step

        dt, dt_note = spans_shared_step(drive, jax.vmap(lambda x: _point_params(drive, keys, x))(jnp.asarray(pts)))
    else:
        dt, dt_note = _shared_time_step(drive, keys, pts, log, steps)
    drive = dataclasses.replace(drive, dt=dt)
    group = process_group()
    devices = jax.local_devices() if devices is None else list(devices)
    plan = _chunk_plan(drive, len(pts), len(devices), group.count, chunk_size, t_end, save_dt, model)
    store = None
    if out_dir is not None and group.writes:
        manifest = _manifest(drive, keys, pts, dt, plan, t_end, save_dt, window)
        if model != "ancf":  # (an ANCF sweep's manifest as before: its older sweeps still resume)
            manifest["model"] = model
        store = SweepStore(out_dir, manifest, resume=resume, inputs=inputs)
    done = int(broadcast(np.asarray(store.done if store is not None else 0), group))
    log(dt_note)
    keep_signals = out_dir is not None
    program = None
    if done < len(pts):
        point_run = _PointRun(t_end, save_dt, window, keep_signals, model)
        program = _compiled_chunk(drive, keys, pts.shape[1], devices, plan, point_run, log)
    else:
        log(f"all {len(pts)} points are done already")
    t1 = time.perf_counter()
    figures = _run_chunks(program, pts, done, plan, group, store, keys, log) if program is not None else {}
    t2 = time.perf_counter()
    if store is not None:
        store.finish()
        if done:  # the rows finished before the resume come from the file, bit-identical (repr floats)
            table, header = store.table(), store.header or []
            figures = {name: table[:, len(keys) + j] for j, name in enumerate(header[len(keys) :])}
    n = len(pts)
    timing = dict(
        points=n,
        devices=len(devices),
        processes=group.count,
        chunks=plan["chunks"],
        points_per_chunk=plan["global"],
        resumed_from=done,
        dt=dt,
        steps=plan["steps"],
        compile_s=program.compile_s if program is not None else 0.0,
        run_s=t2 - t1,
        s_per_point=(t2 - t1) / max(n - done, 1),
        model=model,
    )
    return SweepResult(keys=keys, points=pts, figures=figures, timing=timing)
