"""Benchmark A simulated for 20 s: stability, steadiness and the energy balance. Prints JSON.

Usage: python benchmarks/bench_long_run.py [--t-end 20] [--elements 60]
"""

import argparse
import json

import jax

jax.config.update("jax_enable_x64", True)
import numpy as np  # noqa: E402

import jaxbelt as jb  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--t-end", type=float, default=20.0)
    ap.add_argument("--elements", type=int, default=60)
    args = ap.parse_args()
    r = jb.run(jb.benchmark_a(n_elements=args.elements, t_end=args.t_end, save_dt=1e-2))
    s, ts = r.signals, r.signals["t"]
    w2 = s["omega:driven"]
    late = ts > args.t_end - 2.0
    mid = (ts > 2.0) & (ts < 4.0)
    th = r.summary["creep_theory"]
    out = {
        "case": "benchmark_a_long",
        "elements": args.elements,
        "t_end_s": args.t_end,
        "status": r.summary["status"],
        "timing": r.timing,
        "omega_driven_2_4s": float(w2[mid].mean()),
        "omega_driven_last_2s": float(w2[late].mean()),
        "omega_driven_std_last_2s": float(w2[late].std()),
        "omega_driven_theory": th["omega_driven"],
        "speed_loss_error_pct": 100 * ((12 - w2[late].mean()) / th["speed_loss"] - 1),
        "energy": r.summary["energy"],
        "all_finite": bool(np.all(np.isfinite(w2))),
    }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
