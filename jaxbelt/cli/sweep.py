"""``jaxbelt sweep``: a grid over configuration keys as one batched run; writes sweep.csv and sweep.png."""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

from .._xla import add_xla_flags
from .common import EXIT_FAILED, EXIT_OK, UsageError, load_spec, output_dir, start_processes, with_config_context
from .interrupt import raise_if_interrupted

__all__ = ["command", "split_cpu_into_devices"]

# The most points one sweep takes: every point is checked in Python before anything is compiled (about 1 ms
# each) and simulated; far more is a typo (an extra zero or three) that would only run out of memory.
MAX_POINTS = 1_000_000


def split_cpu_into_devices() -> None:
    """For ``sweep``: present every CPU core as a JAX device, so the batch is sharded over all cores.

    One CPU device runs a batched simulation mostly on one core (measured on 2 cores: 64 variants in
    32.9 s on one device, 16.1 s on two). Only the host platform is split (GPUs are unaffected), only
    when the user has not set the count, and before JAX creates its backend.
    """
    if (os.cpu_count() or 1) > 1:
        add_xla_flags(f"--xla_force_host_platform_device_count={os.cpu_count()}")


def _parse_vary(text: str):
    import numpy as np

    key, sep, grid = text.partition("=")
    parts = grid.split(":")
    if not sep or len(parts) != 3:
        raise UsageError(f"--vary {text}: expected KEY=START:STOP:N, e.g. contact.mu=0.2:0.6:5")
    try:
        a, b, n = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise UsageError(f"--vary {text}: START and STOP must be numbers and N an integer") from None
    if n < 1 or not (math.isfinite(a) and math.isfinite(b)):
        raise UsageError(f"--vary {text}: N must be >= 1 and START, STOP finite")
    if n > MAX_POINTS:
        raise UsageError(f"--vary {text}: N = {n}: at most {MAX_POINTS:,} points per sweep")
    return key.strip(), np.linspace(a, b, n)


def _grid(texts: list[str]) -> dict:
    """The ``--vary`` options as key -> values; a key given twice, or a grid beyond ``MAX_POINTS``, is refused."""
    grid: dict = {}
    for text in texts:
        key, values = _parse_vary(text)
        if key in grid:
            raise UsageError(f"--vary {text}: '{key}' is varied twice; give each key once (one START:STOP:N)")
        grid[key] = values
    n = math.prod(len(v) for v in grid.values())
    if n > MAX_POINTS:
        sizes = " x ".join(str(len(v)) for v in grid.values())
        raise UsageError(
            f"--vary: the grid has {sizes} = {n:,} points, more than {MAX_POINTS:,}; use fewer values per key "
            "(or --points FILE.csv for a sample of the space)"
        )
    return grid


def _read_points(path: str) -> dict:
    """``--points FILE.csv``: header of keys, one row of numbers per point."""
    import csv

    import numpy as np

    from .common import check_input_file

    file = check_input_file(path, "points file")
    try:  # utf-8-sig: a spreadsheet's byte-order mark is not part of the first key
        with open(file, newline="", encoding="utf-8-sig") as fh:
            rows = [r for r in csv.reader(fh) if r and not r[0].lstrip().startswith("#")]
    except UnicodeDecodeError as error:
        raise UsageError(f"--points {path}: not a UTF-8 text file ({error.reason} at byte {error.start})") from None
    if len(rows) < 2:
        raise UsageError(f"--points {path}: need a header of keys and at least one row of values")
    header = [h.strip() for h in rows[0]]
    if len(header) == 1 and ";" in header[0]:
        raise UsageError(
            f"--points {path}: the header {header[0]!r} is separated by ';': separate keys and values by ','"
        )
    if len(set(header)) != len(header) or not all(header):
        raise UsageError(f"--points {path}: the header must name each key once (got {','.join(header)})")
    values = [_point_row(path, i, row, header) for i, row in enumerate(rows[1:], start=2)]
    if len(values) > MAX_POINTS:
        raise UsageError(f"--points {path}: {len(values):,} points, more than {MAX_POINTS:,} per sweep")
    table = np.asarray(values)
    return {k: table[:, j] for j, k in enumerate(header)}


def _point_row(path: str, i: int, row: list[str], header: list[str]) -> list[float]:
    """Line ``i`` of a points file: one finite number per key."""
    if len(row) != len(header):
        raise UsageError(f"--points {path}: line {i} has {len(row)} values, the header {len(header)} keys")
    try:
        values = [float(x) for x in row]
    except ValueError:
        raise UsageError(f"--points {path}: line {i}: every value must be a number (got {','.join(row)})") from None
    for key, x, text in zip(header, values, row):
        if not math.isfinite(x):
            raise UsageError(f"--points {path}: line {i}: {key} = {text.strip()}: must be a finite number")
    return values


@with_config_context
def command(args, cfg: Path) -> int:
    import numpy as np

    from ..config.build import build_drive
    from ..analysis.sweep import sweep

    group = start_processes(args)
    if bool(args.vary) == bool(args.points):
        raise UsageError("give a grid (--vary KEY=START:STOP:N, repeatable) or a list of points (--points FILE.csv)")
    grid = _grid(args.vary) if args.vary else None
    listed = _read_points(args.points) if args.points else None
    spec = load_spec(cfg, args.t_end, args.scheme)
    out_dir = output_dir(args, cfg, "_sweep", results=("sweep.png",), check=group.writes)  # the files are process 0's
    drive = build_drive(spec)
    table = grid if grid is not None else listed
    assert table is not None
    n = int(np.prod([len(v) for v in table.values()])) if grid is not None else len(next(iter(table.values())))
    quiet = args.quiet or not group.writes
    if not quiet:
        what = "grid points" if grid is not None else f"points from {args.points}"
        print(
            f"{cfg.stem}: sweeping {n} {what} ({', '.join(table)}) as batched runs; checking every point ...",
            flush=True,
        )
    say = None if quiet else (lambda msg: print(f"{cfg.stem}: {msg}", flush=True))
    from .._types import Fault
    from ..outputs.energy import ENERGY_TOLERANCE

    res = sweep(
        drive,
        grid,
        points=listed,
        window=args.window,
        progress=say,
        chunk_size=args.chunk_size,
        out_dir=out_dir,  # every process: the programs (signals kept or not) must match; process 0 writes
        resume=args.resume,
        inputs=[cfg] + ([Path(args.points)] if args.points else []),
        model=args.model,
    )
    raise_if_interrupted()
    if not group.writes:
        return EXIT_OK
    from ..viz import plot_sweep

    plot_sweep(res, out_dir / "sweep.png")
    bad = int(np.sum(res.figures["fault"] != Fault.OK))
    # finite but not a motion the step followed (energy balance open): as wrong as a diverged point
    unclosed = res.figures.get("energy_unclosed", np.zeros(n))
    runaway = int(np.sum((res.figures["fault"] == Fault.OK) & (unclosed > ENERGY_TOLERANCE)))
    opened = (
        f"{runaway} ran away (energy balance not closed: column energy_unclosed > {ENERGY_TOLERANCE:g}; give a "
        "shorter solver.dt); "
        if runaway
        else ""
    )
    t = res.timing
    resumed = f"{t['resumed_from']} of them done before, " if t["resumed_from"] else ""
    tier = "spans tier, " if t["model"] == "spans" else ""
    # each finished point's window through the run's checks (as duty's): a point whose belt slides over a whole
    # wrap, or whose window still drifts, has figures that are not a steady state of that drive
    flagged = _checked_points(drive, res, out_dir, args.window, bool(getattr(spec.solver, "expect_steady", True)))
    print(
        f"{cfg.stem}: {n} points ({tier}{resumed}{t['chunks']} chunk(s)) on {t['devices']} device(s) x "
        f"{t['processes']} process(es), dt = {t['dt']:.4g} s: compile {t['compile_s']:.1f} s, run {t['run_s']:.1f} s; "
        f"{bad} diverged; {opened}{flagged} not steady or in gross slip (sweep_status.csv); results in {out_dir}"
    )
    return EXIT_OK if bad + runaway + flagged == 0 else EXIT_FAILED


def _checked_points(drive, res, out_dir: Path, window: float, steady: bool) -> int:
    """Writes ``sweep_status.csv`` (each point's keys and its status: "ok", "gross slip: ...", "not steady: ...",
    "diverged ...") and returns how many finite, closed points are not "ok" (the others are counted apart)."""
    import csv
    import io

    from ..analysis.sweep import point_status
    from ..analysis.sweep_store import SIGNALS
    from ..io import atomic_write, csv_number

    if not (out_dir / SIGNALS).exists():
        return 0
    said: list = []
    ok, status = point_status(drive, res, out_dir / SIGNALS, window, check_drift=steady, warnings=said)
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow([*res.keys, "status", "warnings"])
    for x, st, w in zip(res.points, status, said):
        writer.writerow([*(csv_number(v) for v in x), st, "; ".join(w)])
    with atomic_write(out_dir / "sweep_status.csv", "w") as fh:
        fh.write(text.getvalue())
    warned = sum(1 for w in said if w)
    if warned:  # as each point's run would warn: its mean figures alone do not show it
        print(
            f"jaxbelt sweep: warning: {warned} of {len(said)} points slip intermittently (a wrap sliding in part of "
            "the window; sweep_status.csv, column warnings)",
            file=sys.stderr,
        )
    return sum(1 for st in status if st != "ok" and not st.startswith(("diverged", "energy balance not closed")))
