"""What a run costs before it runs: its step count, the bytes of its saved states and of its dense
operators, checked against fixed limits and against the memory this machine has free. Also the
drive's state at rest, whose shapes (evaluated abstractly) the estimate measures.
"""

from __future__ import annotations

import functools
import math
import os

import jax
import jax.numpy as jnp
import numpy as np

from .._errors import ConfigError
from .._types import DriveState, Fault, WorkTerms
from .checks import _require
from .spec import DriveSpec

__all__ = []

# Limits that catch typos (an extra zero or three) before they turn into an out-of-memory crash or a
# run that never ends. Real drives stay far below them.
MAX_STEPS = 10**9  # settle + run steps of one simulation
MAX_SAVED_BYTES = 4 * 1024**3  # saved states of one simulation (the trajectory kept in memory)
# Memory of a run, checked against what this machine has free (see _check_memory): a run may plan
# to use this fraction of it.
MEMORY_SAFETY = 0.8
# Peak copies of the saved trajectory (diffrax's buffer, the sliced states, the host copy and the
# post-processing vmapped over all states): measured 3.8 x at 240 elements, 8001 saves.
TRAJECTORY_COPIES = 4


def _initial_state(q0, psi0, npul: int, nc: int) -> DriveState:
    """The drive at rest on its installed path (also evaluated abstractly for the memory estimate).
    Host (numpy) values put on the device: no eager device operation, each compiled once per process."""
    f64 = lambda x: jax.device_put(np.asarray(x, dtype=float))  # noqa: E731 (in JAX's float width)
    z = f64(np.zeros(npul))
    return DriveState(
        q=q0,
        v=jax.device_put(np.zeros(q0.shape, q0.dtype)),
        theta=z,
        omega=z,
        psi=psi0,
        psi_dot=z,
        lam_n=f64(np.zeros(nc)),
        lam_t=f64(np.zeros(nc)),
        contact_pulley=f64(np.full(nc, -1.0)),
        belt_torque=z,
        lcp_residual=f64(0.0),
        work=WorkTerms.zeros(),
        pulley_work=z,
        angular_impulse=z,
        fault=f64(float(Fault.OK)),
        fault_time=f64(np.inf),
    )


def _state_bytes(n: int, npul: int, nc: int) -> int:
    """Bytes of one ``DriveState`` (traced abstractly with ``jax.eval_shape``: nothing runs or compiles; once per
    size and float width: a sweep checks every point, and tracing was half of each point's check)."""
    return _state_bytes_of(n, npul, nc, np.dtype(jnp.result_type(float)).name)


@functools.lru_cache(maxsize=64)
def _state_bytes_of(n: int, npul: int, nc: int, dtype: str) -> int:
    shapes = jax.eval_shape(
        functools.partial(_initial_state, npul=npul, nc=nc),
        jax.ShapeDtypeStruct((n, 2, 2), dtype),
        jax.ShapeDtypeStruct((npul,), dtype),
    )
    return int(sum(math.prod(x.shape) * np.dtype(x.dtype).itemsize for x in jax.tree.leaves(shapes)))


def _check_run_size(spec: DriveSpec, dt: float, n: int, npul: int, nc: int) -> None:
    """Refuse runs whose step count or saved trajectory is beyond reason (a typo in t_end, save_dt ...)."""
    s = spec.solver
    n_settle = int(round(s.settle_time / dt))
    n_run = int(math.ceil(s.t_end / dt - 1e-9))
    key, value = ("solver.settle_time", s.settle_time) if n_settle > n_run else ("solver.t_end", s.t_end)
    _require(
        n_settle + n_run <= MAX_STEPS,
        key,
        value,
        f"with the time step {dt:.3g} s, settling {s.settle_time:g} s and running {s.t_end:g} s take "
        f"{n_settle + n_run:.3g} steps, more than the {MAX_STEPS:.0e} allowed; shorten {key} "
        "(or coarsen the mesh, belt.n_elements, for a larger stable step)",
    )
    stride = max(1, int(round(s.save_dt / dt)))
    n_saves = n_run // stride + 2  # the saved times 0, save_dt, ... and the final state
    per_state = _state_bytes(n, npul, nc)
    need = n_saves * per_state
    gib = 1024**3
    if need > MAX_SAVED_BYTES:
        _require(
            2 * per_state <= MAX_SAVED_BYTES,
            "belt.n_elements",
            n,
            f"one saved state takes {per_state / gib:.3g} GiB; the limit for all saved states is "
            f"{MAX_SAVED_BYTES / gib:g} GiB",
        )
        min_save_dt = s.t_end / (MAX_SAVED_BYTES // per_state - 2)
        raise ConfigError(
            f"solver.save_dt = {s.save_dt!r}: saving {n_saves} states ({per_state / 1024:.4g} KiB each) until "
            f"t_end = {s.t_end:g} s needs {need / gib:.3g} GiB of memory, more than the {MAX_SAVED_BYTES / gib:g} GiB "
            f"allowed; raise solver.save_dt to at least {min_save_dt:.3g} s or shorten solver.t_end "
            f"(saves are at most one per time step, dt = {dt:.3g} s)"
        )
    _check_memory(spec, n, npul, nc, n_saves, per_state, dt=dt, n_run=n_run)


def _operator_bytes(n: int, points_per_element: int, itemsize: int) -> int:
    """Peak bytes of the dense operators one simulation builds (``drive_operators``).

    With ``N = 2 n`` scalar belt DOFs and ``nc`` contact points: the mass matrix, its inverse and
    one ``N x N`` work array of the inversion (3 N^2); S^T, [S; dS]^T (two) and S M^-1 (4 N nc); the
    Delassus matrix S M^-1 S^T (nc^2). Measured peak RSS growth of a short run (float64): 8.1 N^2 at
    1920 and 2880 elements with 2 points (this count: 8 N^2), 5.36 N^2 at 1920 with 1 point (5.25 N^2).
    """
    N, nc = 2 * n, n * points_per_element
    return itemsize * (3 * N * N + 4 * N * nc + nc * nc)


def _available_memory() -> tuple[int, str]:
    """Bytes this process can still allocate without swapping: MemAvailable of /proc/meminfo
    (else the free pages of os.sysconf), capped by a cgroup (container) memory limit."""
    avail = None
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    avail = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    if avail is None:
        try:
            avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            return 0, "memory"  # unknown: no check
    try:
        with open("/sys/fs/cgroup/memory.max") as fh:
            limit = fh.read().strip()
        with open("/sys/fs/cgroup/memory.current") as fh:
            used = int(fh.read().strip())
        if limit != "max":
            avail = min(avail, int(limit) - used)
    except (OSError, ValueError):
        pass
    return max(int(avail), 0), "memory"


def _device_memory() -> int | None:
    """Free memory of the first accelerator (None on a CPU-only JAX): the operators live there."""
    if jax.default_backend() == "cpu":
        return None
    try:
        stats = jax.devices()[0].memory_stats() or {}
        return int(stats["bytes_limit"]) - int(stats.get("bytes_in_use", 0))
    except (KeyError, TypeError, ValueError, RuntimeError):
        return None


def _check_memory(
    spec: DriveSpec,
    n: int,
    npul: int,
    nc: int,
    n_saves: int,
    per_state: int,
    *,
    dt: float | None = None,
    n_run: int | None = None,
) -> None:
    """Refuse a run whose operators and saved states need more memory than this machine has free."""
    m = nc // n
    itemsize = np.dtype(jnp.result_type(float)).itemsize
    ops = _operator_bytes(n, m, itemsize)
    traj = TRAJECTORY_COPIES * n_saves * per_state
    avail, where = _available_memory()
    if ops + traj > 2**30:  # only a large run asks JAX for its platform (initialising the backend)
        dev = _device_memory()  # operators and saved states live there, the host keeps copies of the states
        if dev is not None and (avail <= 0 or dev < avail):
            avail, where = dev, "accelerator memory"
    budget = MEMORY_SAFETY * avail
    if avail <= 0 or ops + traj <= budget:
        return
    gb = 1e9
    # per saved state bytes grow linearly with n (eval_shape of one more element gives the slope)
    slope = _state_bytes(n + 1, npul, nc + m) - per_state
    need = lambda k: _operator_bytes(k, m, itemsize) + TRAJECTORY_COPIES * n_saves * (per_state + (k - n) * slope)
    lo, hi = 0, n  # need(lo) fits (or lo = 0: none does), need(hi) does not
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if need(mid) <= budget else (lo, mid)
    what = (
        f"needs about {(ops + traj) / gb:.3g} GB of {where} (dense belt and contact operators "
        f"{ops / gb:.3g} GB, {n_saves} saved states {traj / gb:.3g} GB), more than {MEMORY_SAFETY:.0%} of the "
        f"{avail / gb:.3g} GB this machine has free"
    )
    if lo >= 8 and ops >= traj:
        raise ConfigError(f"belt.n_elements = {n}: the run {what}; at most {lo} elements fit")
    s = spec.solver
    max_saves = int((budget - ops) // (TRAJECTORY_COPIES * per_state))
    if dt is not None and n_run is not None and max_saves > 2:
        stride = math.ceil(n_run / (max_saves - 2))  # saves fall every stride steps (save_dt is rounded to that)
        raise ConfigError(
            f"solver.save_dt = {s.save_dt!r}: the run {what}; raise solver.save_dt to at least "
            f"{stride * dt:.6g} s, shorten solver.t_end or use fewer elements"
        )
    raise ConfigError(
        f"belt.n_elements = {n}: the run {what}; use fewer elements" + (f" (at most {lo})" if lo >= 8 else "")
    )
