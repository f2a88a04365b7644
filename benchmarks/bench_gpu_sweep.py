"""Benchmark A sweeps on an accelerator: ms per variant-step against batch size (issue 25).

Each batch size B runs B variants (contact.mu spread over 0.3-0.7) as one chunk of ``jb.sweep``, one
compiled program per (scheme, B); the time excludes compilation. ms per variant-step = run time /
(B x steps). Prints one JSON line per measurement and, with --out, appends it to that file as it goes
(a killed run keeps what it measured). --budget-s skips what would start after that many seconds.
Usage: python benchmarks/bench_gpu_sweep.py [--elements 60] [--t-end 0.1] [--batches 1,64,4096]
       [--schemes explicit,implicit] [--implicit-dt 1e-4] [--out FILE] [--budget-s 420]
"""

import argparse
import json
import os
import time

import jax

jax.config.update("jax_enable_x64", True)
import numpy as np  # noqa: E402

import jaxbelt as jb  # noqa: E402


def measure(spec, batch: int) -> dict:
    drive = jb.build_drive(spec)
    mus = np.linspace(0.3, 0.7, batch)
    t0 = time.perf_counter()
    res = jb.sweep(drive, {"contact.mu": mus}, chunk_size=batch)
    wall = time.perf_counter() - t0
    t = res.timing
    omega = np.asarray(res.figures.get("omega:driven:mean", [np.nan]))
    return {
        "batch": batch,
        "steps": t["steps"],
        "dt": t["dt"],
        "compile_s": t["compile_s"],
        "run_s": t["run_s"],
        "wall_s": wall,
        "ms_per_variant_step": 1e3 * t["run_s"] / (batch * t["steps"]),
        "us_per_step_of_batch": 1e6 * t["run_s"] / t["steps"],
        "finite_share": float(np.mean(np.isfinite(omega))) if omega.size else None,
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--elements", type=int, default=60)
    ap.add_argument("--t-end", type=float, default=0.1)
    ap.add_argument("--batches", default="1,64,4096")
    ap.add_argument("--schemes", default="explicit,implicit")
    ap.add_argument("--implicit-dt", type=float, default=1e-4)
    ap.add_argument("--out")
    ap.add_argument("--budget-s", type=float, default=1e9)
    args = ap.parse_args()
    start = time.perf_counter()
    head = {
        "backend": jax.default_backend(),
        "devices": [str(d) for d in jax.devices()],
        "jax": jax.__version__,
        "cpus": os.cpu_count(),
        "load_average": os.getloadavg(),
    }
    print(json.dumps(head), flush=True)
    for scheme in args.schemes.split(","):
        for batch in [int(b) for b in args.batches.split(",")]:
            if time.perf_counter() - start > args.budget_s:
                print(json.dumps({"skipped": [scheme, batch], "reason": "budget"}), flush=True)
                continue
            spec = jb.benchmark_a(n_elements=args.elements, t_end=args.t_end, save_dt=1e-2)
            spec.solver.scheme = scheme
            if scheme == "implicit":
                spec.solver.dt = args.implicit_dt
            row = {"case": "benchmark_a", "elements": args.elements, "t_end_s": args.t_end, "scheme": scheme}
            try:
                row |= measure(spec, batch)
            except Exception as e:  # one failed size must not cost the others' device time
                row["error"] = f"{type(e).__name__}: {e}"[:500]
            row |= {"backend": head["backend"], "elapsed_s": time.perf_counter() - start}
            line = json.dumps(row)
            print(line, flush=True)
            if args.out:
                with open(args.out, "a") as f:
                    f.write(line + "\n")


if __name__ == "__main__":
    main()
