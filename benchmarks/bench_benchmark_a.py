"""Benchmark A (2.45 s simulated): wall time with compile/run split, and accuracy against theory.

Prints one JSON object per mesh (machine-readable) and writes them to benchmarks/results/.
Usage:  python benchmarks/bench_benchmark_a.py [--elements 60 120] [--t-end 2.45]
"""

import argparse
import json
import os
import platform
import time

import jax

jax.config.update("jax_enable_x64", True)

import jaxbelt as jb  # noqa: E402

EXUDYN = {
    "reference": "Exudyn 1.13.6, 2-core CPU, as quoted in issue 3",
    "wall_s": {"120": 89.0, "240": 189.0},
    "omega_driven": {"120": 11.348, "240": 11.340},
}


def measure(n: int, t_end: float, lcp_iterations: int) -> dict:
    load_before = os.getloadavg()  # a shared machine: the load says how far the timings can be trusted
    t0 = time.perf_counter()
    r = jb.run(jb.benchmark_a(n_elements=n, t_end=t_end, lcp_iterations=lcp_iterations))
    wall = time.perf_counter() - t0
    th = r.summary["creep_theory"]
    p = r.summary["pulleys"]
    spans = {s["name"]: s["tension_mean"] for s in r.summary["spans"]}
    dw = 12.0 - p["driven"]["omega_mean"]
    return {
        "case": "benchmark_a",
        "elements": n,
        "t_end_s": t_end,
        "lcp_iterations": lcp_iterations,
        "wall_s_total": round(wall, 3),
        **{k: round(v, 6) if isinstance(v, float) else v for k, v in r.timing.items()},
        "omega_driven": p["driven"]["omega_mean"],
        "speed_loss": dw,
        "speed_loss_theory": th["speed_loss"],
        "speed_loss_error_pct": 100 * (dw / th["speed_loss"] - 1),
        "T_tight": spans["driven-driver"],
        "T_slack": spans["driver-driven"],
        "T_tight_error_pct": 100 * (spans["driven-driver"] / th["T_tight"] - 1),
        "T_slack_error_pct": 100 * (spans["driver-driven"] / th["T_slack"] - 1),
        "torque_driver": -p["driver"]["torque_mean"],
        "status": r.summary["status"],
        "lcp_residual_max": r.summary["lcp_residual_max"],
        "load_average_before_after": [[round(x, 2) for x in load_before], [round(x, 2) for x in os.getloadavg()]],
        "machine": {
            "cpus": os.cpu_count(),
            "platform": platform.platform(),
            "jax": jax.__version__,
            "backend": jax.default_backend(),
        },
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--elements", type=int, nargs="+", default=[60, 120])
    ap.add_argument("--t-end", type=float, default=2.45)
    ap.add_argument("--lcp-iterations", type=int, default=8)  # the library default
    args = ap.parse_args()
    out = []
    for n in args.elements:
        res = measure(n, args.t_end, args.lcp_iterations)
        res["exudyn_for_comparison"] = EXUDYN
        print(json.dumps(res), flush=True)
        out.append(res)
    os.makedirs(os.path.join(os.path.dirname(__file__), "results"), exist_ok=True)
    with open(os.path.join(os.path.dirname(__file__), "results", "benchmark_a.json"), "w") as f:
        json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
