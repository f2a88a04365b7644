"""The two tiers' forced response, order by order: steady running at fixed driver speeds with an engine order, both
tiers from a running start, and per signal the order's amplitude (a single-bin Fourier coefficient over whole
periods of the window), its peak-to-peak and its mean (the measurements behind docs/spans.md's "Re-measured and
narrowed down").

Prints one JSON line per speed and tier: the driver speed, the tier, CPU seconds, and per span tension, free
pulley speed and tensioner arm ``{"amplitude", "pp", "mean"}``; then one line with the spans tier's amplitudes
over the ANCF tier's. The configuration's own orders are kept; ``--add-order K:DEG`` gives the driver order K with
DEG degrees of crank angle (replacing the configuration's orders), for a drive that has none.

Usage:
    python benchmarks/bench_tier_harmonics.py [--config examples/accessory_drive.toml] [--rpm 800,1200,1700,2243]
        [--order 2] [--add-order 2:1.5] [--t-end 0.6] [--window 0.3] [--tier ancf --tier spans]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

import jaxbelt as jb  # noqa: E402
from jaxbelt.spans import simulate_spans, spans_signals  # noqa: E402

ROOT = Path(__file__).parents[1]
KINDS = ("tension:", "omega:", "arm_angle:", "travel:")


def order_amplitude(t: np.ndarray, x: np.ndarray, f: float) -> float:
    """Amplitude of the component at ``f`` [Hz] of ``x(t)`` over the whole periods of the samples."""
    periods = math.floor((t[-1] - t[0]) * f)
    if periods < 1:
        return math.nan
    keep = t <= t[0] + periods / f
    t, x = t[keep], x[keep]
    return float(2.0 * abs(np.mean((x - x.mean()) * np.exp(-2j * np.pi * f * t))))


def spec_at(config: Path, rpm: float, t_end: float, add_order: tuple[int, float] | None):
    """The configuration at a constant driver speed from a running start (its loads as configured)."""
    spec = jb.load_config(config)
    driver = next(p for p in spec.pulleys if p.role == "driver")
    driver.speed = None
    driver.speed_rpm = {"smooth_step": [0.0, 0.01, rpm, rpm]}
    if add_order is not None:
        driver.excitation = {add_order[0]: {"amplitude_deg": add_order[1]}}
    spec.solver.start, spec.solver.t_end, spec.solver.expect_steady = "running", t_end, False
    spec.solver.save_dt = min(float(spec.solver.save_dt), 2e-4)
    return spec


def figures(sig: dict, f: float, t0: float, fixed: set[str]) -> dict:
    t = np.asarray(sig["t"])
    w = t >= t0
    out = {}
    for k, v in sig.items():
        if k.startswith(KINDS) and k.split(":", 1)[1] not in fixed:
            x = np.asarray(v)
            out[k] = dict(amplitude=order_amplitude(t[w], x[w], f), pp=float(np.ptp(x[w])), mean=float(x[w].mean()))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", type=Path, default=ROOT / "examples" / "accessory_drive.toml")
    ap.add_argument("--rpm", default="800,1200,1700,2243")
    ap.add_argument("--order", type=float, default=2.0, help="the driver order whose amplitude is read")
    ap.add_argument("--add-order", help="K:DEG, the driver's order K of DEG degrees (replaces the file's orders)")
    ap.add_argument("--t-end", type=float, default=0.6)
    ap.add_argument("--window", type=float, default=0.3, help="the last WINDOW seconds are read")
    ap.add_argument("--tier", action="append", choices=("ancf", "spans"))
    args = ap.parse_args()
    add = None
    if args.add_order:
        k, deg = args.add_order.split(":")
        add = (int(k), float(deg))
    tiers = args.tier or ["ancf", "spans"]
    for rpm in (float(r) for r in args.rpm.split(",")):
        spec = spec_at(args.config, rpm, args.t_end, add)
        drive = jb.build_drive(spec)
        fixed = {p.name for p in drive.pulleys if p.role == "driver"}
        f = args.order * rpm / 60.0
        rows = {}
        for tier in tiers:
            cpu = time.process_time()
            if tier == "spans":
                tr = simulate_spans(drive, t_end=args.t_end, running=True, save_dt=float(spec.solver.save_dt))
                sig = {k: np.asarray(v) for k, v in spans_signals(drive, tr).items()}
            else:
                sig = {k: np.asarray(v) for k, v in jb.run(spec).signals.items()}
            rows[tier] = figures(sig, f, args.t_end - args.window, fixed)
            line = dict(rpm=rpm, tier=tier, order_hz=f, cpu_s=time.process_time() - cpu, load_average=os.getloadavg())
            print(json.dumps(dict(line, signals=rows[tier])), flush=True)
        if {"ancf", "spans"} <= rows.keys():
            a, s = rows["ancf"], rows["spans"]
            ratio = {k: s[k]["amplitude"] / a[k]["amplitude"] - 1.0 for k in a if k in s and a[k]["amplitude"] > 0}
            print(json.dumps(dict(rpm=rpm, spans_over_ancf_amplitude=ratio)), flush=True)


if __name__ == "__main__":
    main()
