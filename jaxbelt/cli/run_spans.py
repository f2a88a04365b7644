"""``jaxbelt run --model spans``: the drive on the spans tier (docs/spans.md); writes signals.csv and
summary.json (per signal the window's mean, minimum, maximum and peak-to-peak), prints the spans' tensions, hub
loads, tensioner positions and minimum slip safety factors (1 / the peak friction use)."""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from .common import EXIT_FAILED, EXIT_OK, fmt, load_spec, output_dir, print_warning

__all__ = ["command"]

RESULTS = ("summary.json", "signals.csv")


def command(args, cfg: Path) -> int:
    from ..config.build import build_drive
    from ..io import write_signals_csv, write_summary
    from ..spans import run_spans

    spec = load_spec(cfg, args.t_end, args.scheme)
    out_dir = output_dir(args, cfg, results=RESULTS)
    drive = build_drive(spec)
    t0 = time.perf_counter()
    result = run_spans(drive, window=args.window)
    wall = time.perf_counter() - t0
    sig, status = result.signals, result.summary["status"]
    t = sig["t"]
    window = t >= result.summary["window_s"][0]  # trimmed to whole engine periods (outputs.window)
    figures = {}
    for k, v in sig.items():
        if k == "t":
            continue
        x = np.asarray(v)[window]
        figures[k] = dict(mean=float(np.mean(x)), min=float(np.min(x)), max=float(np.max(x)), pp=float(np.ptp(x)))
    summary = dict(
        result.summary,
        t_end=float(t[-1]),
        dt=result.trajectory.dt,
        window=[float(t[window][0]), float(t[-1])],
        figures=figures,
        timing=dict(wall_s=wall, steps=int(round(float(t[-1]) / result.trajectory.dt))),
    )
    out_dir.mkdir(parents=True, exist_ok=True)
    write_signals_csv(out_dir / "signals.csv", sig, inputs=[cfg])
    write_summary(out_dir / "summary.json", summary, inputs=[cfg])  # an unbounded safety factor: null
    if not args.quiet:
        _print(cfg.stem, drive, figures, summary)
    for w in summary["warnings"]:
        print_warning(w)
    print(f"{cfg.stem}: {status}; spans tier, results in {out_dir}")
    return EXIT_OK if status == "ok" else EXIT_FAILED


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
        if k.startswith("friction_use:") and f["max"] > 0:  # the minimum slip safety factor: 1 / the peak use
            name = "slip_safety:" + k.partition(":")[2]
            print(f"  {name:<40} min  {fmt(1.0 / f['max'], '.4g'):>9}")
