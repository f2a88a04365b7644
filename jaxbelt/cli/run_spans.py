"""``jaxbelt run --model spans``: the drive on the spans tier (docs/spans.md); writes signals.csv and
summary.json (per signal the window's mean, minimum, maximum and peak-to-peak), prints the spans' tensions, hub
loads, tensioner positions and minimum slip safety factors."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from .common import EXIT_FAILED, EXIT_OK, fmt, load_spec, output_dir

__all__ = ["command"]

RESULTS = ("summary.json", "signals.csv")


def command(args, cfg: Path) -> int:
    import jax

    from ..config.build import build_drive
    from ..io import write_signals_csv, write_summary
    from ..spans import simulate_spans, spans_signals

    spec = load_spec(cfg, args.t_end, args.scheme)
    out_dir = output_dir(args, cfg, results=RESULTS)
    drive = build_drive(spec)
    t_end = float(spec.solver.t_end)
    t0 = time.perf_counter()
    traj = simulate_spans(drive, t_end=t_end, save_dt=float(drive.options.save_dt))
    jax.block_until_ready(traj.ts)
    wall = time.perf_counter() - t0
    sig = spans_signals(drive, traj)
    t = sig["t"]
    window = t >= t[-1] * (1.0 - args.window) - 1e-12
    finite = all(np.all(np.isfinite(v)) for k, v in sig.items() if not k.startswith("slip_safety:"))
    figures = {}
    for k, v in sig.items():
        if k == "t":
            continue
        x = np.asarray(v)[window]
        figures[k] = dict(mean=float(np.mean(x)), min=float(np.min(x)), max=float(np.max(x)), pp=float(np.ptp(x)))
    status = "ok" if finite else "the spans tier's state became non-finite (a step too long for this drive?)"
    summary = dict(
        model="spans",
        status=status,
        t_end=t_end,
        dt=traj.dt,
        window=[float(t[window][0]), float(t[-1])],
        figures=figures,
        timing=dict(wall_s=wall, steps=int(round(t_end / traj.dt))),
    )
    out_dir.mkdir(parents=True, exist_ok=True)
    write_signals_csv(out_dir / "signals.csv", sig, inputs=[cfg])
    write_summary(out_dir / "summary.json", _finite(summary), inputs=[cfg])
    if not args.quiet:
        _print(cfg.stem, drive, figures, summary)
    print(f"{cfg.stem}: {status}; spans tier, results in {out_dir}")
    return EXIT_OK if finite else EXIT_FAILED


def _finite(obj):
    """JSON has no infinity: an unbounded slip safety factor (no torque) is written as null."""
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def _print(stem: str, drive, figures: dict, summary: dict) -> None:
    w0, w1 = summary["window"]
    print(
        f"{stem}: spans tier, {summary['timing']['steps']} steps of {summary['dt']:.3g} s in "
        f"{summary['timing']['wall_s']:.2f} s (compile included); window {w0:.3g}-{w1:.3g} s"
    )
    for prefix, unit in (("tension:", "N"), ("hub_load:", "N")):
        for k, f in figures.items():
            if k.startswith(prefix):
                print(f"  {k:<40} mean {fmt(f['mean'], '.5g'):>9} {unit}  p-p {fmt(f['pp'], '.4g'):>8} {unit}")
    for k, f in figures.items():
        if k.startswith(("arm_angle:", "travel:")):
            deg = k.startswith("arm_angle:")
            scale, unit = (180 / math.pi, "deg") if deg else (1000.0, "mm")
            print(f"  {k:<40} mean {f['mean'] * scale:9.3f} {unit}  p-p {f['pp'] * scale:8.3f} {unit}")
        if k.startswith("slip_safety:") and math.isfinite(f["min"]):
            print(f"  {k:<40} min  {fmt(f['min'], '.4g'):>9}")
