"""The spans tier against the ANCF tier on the shipped accessory drive, and its speed (issue 30's targets).

Prints JSON lines:
* ``cross_check``: examples/accessory_drive.toml as shipped (start-up from rest, idle at 800 rpm with the 2nd
  order, pivot friction, OAP), both tiers to ``--t-end``, figures over the window after ``--window``: per span
  and per pulley the mean, peak-to-peak and standard deviation of the tension / hub load / arm angle, and the
  spans tier's deviation from the ANCF tier; CPU seconds of each (compile included);
* ``timing``: compile and run of the spans tier's program; one steady duty point (running start at 800 rpm,
  0.3 s); a 1,000-variant sweep of the tensioner spring at idle (``sweep(model="spans")``, 0.3 s each, split
  over every core as ``jaxbelt sweep`` does: wall time with the points' checks, compile and run apart); a
  run-up 800 -> 6,000 rpm over 5 s; the load average beside each.
Usage: python benchmarks/bench_spans_tier.py [--t-end 1.2] [--window 0.4] [--variants 1000]
"""

from __future__ import annotations

import argparse
import json
import os
import time

# the sweep splits its batch over every core, as `jaxbelt sweep` does (set before jax is imported)
os.environ.setdefault("XLA_FLAGS", f"--xla_force_host_platform_device_count={os.cpu_count() or 1}")

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

import jaxbelt as jb  # noqa: E402
from jaxbelt.analysis.sweep import sweep  # noqa: E402
from jaxbelt.spans import simulate_spans, spans_signals  # noqa: E402

EXAMPLE = os.path.join(os.path.dirname(__file__), "..", "examples", "accessory_drive.toml")


def _figures(sig: dict, t0: float) -> dict:
    w = np.asarray(sig["t"]) > t0
    out = {}
    for k, v in sig.items():
        if k.startswith(("tension:", "hub_load:", "arm_angle:")):
            x = np.asarray(v)[w]
            out[k] = dict(mean=float(x.mean()), pp=float(np.ptp(x)), std=float(x.std()))
    return out


def cross_check(t_end: float, window: float) -> dict:
    spec = jb.load_config(EXAMPLE)
    spec.solver.t_end = t_end
    drive = jb.build_drive(spec)
    c0 = time.process_time()
    ancf = jb.run(spec)
    c1 = time.process_time()
    tr = simulate_spans(drive, t_end=t_end, save_dt=float(drive.options.save_dt))
    jax.block_until_ready(tr.ts)
    c2 = time.process_time()
    a = _figures(ancf.signals, window)
    s = _figures(spans_signals(drive, tr), window)
    rows = {}
    for k in s:
        if k in a:
            rows[k] = dict(
                spans=s[k],
                ancf=a[k],
                mean_pct=100 * (s[k]["mean"] / a[k]["mean"] - 1),
                pp_pct=100 * (s[k]["pp"] / a[k]["pp"] - 1),
                std_pct=100 * (s[k]["std"] / a[k]["std"] - 1),
            )
    return dict(
        case="cross_check",
        t_end=t_end,
        window_from=window,
        rows=rows,
        cpu_s_ancf=c1 - c0,
        cpu_s_spans=c2 - c1,
        load_average=os.getloadavg()[0],
    )


def _at(spec, rpm):
    spec.pulleys[0].speed_rpm = rpm
    spec.pulleys[0].speed = None
    return spec


def timing(variants: int) -> dict:
    out = dict(case="timing")
    drive = jb.build_drive(_at(jb.load_config(EXAMPLE), 800.0))
    t0 = time.perf_counter()
    tr = simulate_spans(drive, t_end=0.3, save_dt=0.01, running=True)
    jax.block_until_ready(tr.ts)
    out["duty_point_first_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    tr = simulate_spans(drive, t_end=0.3, save_dt=0.01, running=True)
    jax.block_until_ready(tr.ts)
    out["duty_point_s"] = time.perf_counter() - t0
    out["dt"] = tr.dt
    key = "pulleys.tensioner.tensioner.stiffness"
    k0 = float(jb.get_parameter(drive, drive.params, key))
    spec = _at(jb.load_config(EXAMPLE), 800.0)
    spec.solver.start, spec.solver.t_end = "running", 0.3
    idle = jb.build_drive(spec)
    ks = np.linspace(0.5 * k0, 1.5 * k0, variants)
    t0 = time.perf_counter()
    res = sweep(idle, points={key: ks}, model="spans")  # what `jaxbelt sweep --model spans` runs
    out["sweep_wall_s"] = time.perf_counter() - t0
    out["sweep_compile_s"], out["sweep_run_s"] = res.timing["compile_s"], res.timing["run_s"]
    out["sweep_checks_s"] = out["sweep_wall_s"] - res.timing["compile_s"] - res.timing["run_s"]
    out["variants"], out["devices"] = variants, res.timing["devices"]
    out["sweep_faults"] = int(np.sum(res.figures["fault"] != 0))
    arm = np.degrees(res.figures["arm_angle:tensioner:mean"])
    out["sweep_arm_mean_range_deg"] = [float(arm.min()), float(arm.max())]
    spec = jb.load_config(EXAMPLE)
    spec.pulleys[0].speed_rpm = {"ramp": [0.0, 5.0, 800.0, 6000.0]}
    run_up = jb.build_drive(spec)
    t0 = time.perf_counter()
    tr = simulate_spans(run_up, t_end=5.0, save_dt=1e-3, running=True)
    jax.block_until_ready(tr.ts)
    out["run_up_first_s"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    tr = simulate_spans(run_up, t_end=5.0, save_dt=1e-3, running=True)
    jax.block_until_ready(tr.ts)
    out["run_up_s"] = time.perf_counter() - t0
    out["run_up_steps"] = int(round(5.0 / tr.dt))
    out["run_up_finite"] = bool(np.all(np.isfinite(np.asarray(tr.states.tension))))
    out["load_average"] = os.getloadavg()[0]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--t-end", type=float, default=1.2)
    ap.add_argument("--window", type=float, default=0.4)
    ap.add_argument("--variants", type=int, default=1000)
    ap.add_argument("--skip-cross-check", action="store_true")
    args = ap.parse_args()
    if not args.skip_cross_check:
        print(json.dumps(cross_check(args.t_end, args.window)), flush=True)
    print(json.dumps(timing(args.variants)), flush=True)


if __name__ == "__main__":
    main()
