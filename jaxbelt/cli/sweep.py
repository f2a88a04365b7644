"""``jaxbelt sweep``: a grid over configuration keys as one batched run; writes sweep.csv and sweep.png."""

from __future__ import annotations

import math
import os
from pathlib import Path

from .common import EXIT_FAILED, EXIT_OK, UsageError, load_spec, output_dir, with_config_context
from .interrupt import raise_if_interrupted

__all__ = ["command", "split_cpu_into_devices"]


def split_cpu_into_devices() -> None:
    """For ``sweep``: present every CPU core as a JAX device, so the batch is sharded over all cores.

    One CPU device runs a batched simulation mostly on one core (measured on 2 cores: 64 variants in
    32.9 s on one device, 16.1 s on two). Only the host platform is split (GPUs are unaffected), only
    when the user has not set the count, and before JAX creates its backend.
    """
    flags = os.environ.get("XLA_FLAGS", "")
    if "xla_force_host_platform_device_count" not in flags and (os.cpu_count() or 1) > 1:
        os.environ["XLA_FLAGS"] = f"{flags} --xla_force_host_platform_device_count={os.cpu_count()}".strip()


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
    return key.strip(), np.linspace(a, b, n)


@with_config_context
def command(args, cfg: Path) -> int:
    import numpy as np

    from ..config.build import build_drive
    from ..analysis.sweep import sweep
    from ..io import atomic_write

    if not args.vary:
        raise UsageError("give at least one --vary KEY=START:STOP:N")
    grid = dict(_parse_vary(v) for v in args.vary)
    spec = load_spec(cfg, args.t_end)
    out_dir = output_dir(args, cfg, "_sweep")
    drive = build_drive(spec)
    n = int(np.prod([len(v) for v in grid.values()]))
    if not args.quiet:
        print(
            f"{cfg.stem}: sweeping {n} points ({', '.join(grid)}) in one batched run; checking every point ...",
            flush=True,
        )
    say = None if args.quiet else (lambda msg: print(f"{cfg.stem}: {msg}", flush=True))
    from .._types import Fault

    res = sweep(drive, grid, window=args.window, progress=say)
    raise_if_interrupted()
    header, rows = res.table()
    with atomic_write(out_dir / "sweep.csv", "w", inputs=[cfg]) as fh:
        fh.write(",".join(header) + "\n")
        for row in rows:
            fh.write(",".join(repr(float(x)) for x in row) + "\n")
    from ..viz import plot_sweep

    plot_sweep(res, out_dir / "sweep.png")
    bad = int(np.sum(res.figures["fault"] != Fault.OK))
    print(
        f"{cfg.stem}: {n} points on {res.timing['devices']} device(s), dt = {res.timing['dt']:.4g} s: compile "
        f"{res.timing['compile_s']:.1f} s, run {res.timing['run_s']:.1f} s; {bad} diverged; results in {out_dir}"
    )
    return EXIT_OK if bad == 0 else EXIT_FAILED
