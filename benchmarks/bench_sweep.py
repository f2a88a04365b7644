"""64 variants of Benchmark A (reduced end time): one batched sweep against 64 separate runs and one run.

Target (issue 5): the 64-variant sweep in at most 8x the time of one run. Prints JSON. Times exclude
compilation. On a machine with a GPU also try --points 1024.
Usage: python benchmarks/bench_sweep.py [--points 64] [--t-end 0.3] [--elements 60] [--skip-separate]
"""

import argparse
import json
import os
import time

# Every core a JAX device (as `jaxbelt sweep` does), so the sweep is sharded over all of them; the
# single-run baseline uses one device either way. Set XLA_FLAGS yourself to compare other splits.
if "xla_force_host_platform_device_count" not in os.environ.get("XLA_FLAGS", ""):
    os.environ["XLA_FLAGS"] = (
        os.environ.get("XLA_FLAGS", "") + f" --xla_force_host_platform_device_count={os.cpu_count()}"
    ).strip()

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)
import numpy as np  # noqa: E402

import jaxbelt as jb  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", type=int, default=64)
    ap.add_argument("--t-end", type=float, default=0.3)
    ap.add_argument("--elements", type=int, default=60)
    ap.add_argument("--implicit-stiffness", type=float, metavar="DT", help="solver.implicit_stiffness with step DT")
    ap.add_argument("--skip-separate", action="store_true")
    args = ap.parse_args()
    spec = jb.benchmark_a(n_elements=args.elements, t_end=args.t_end, save_dt=1e-2)
    if args.implicit_stiffness:  # solver.implicit_stiffness at this step
        spec.solver.implicit_stiffness, spec.solver.dt = True, args.implicit_stiffness
    drive = jb.build_drive(spec)
    mus = np.linspace(0.3, 0.7, args.points)

    def one(mu):
        p = jb.set_parameter(drive, drive.params, "contact.mu", mu)
        ts, s = jb.simulate_signals(drive, p)
        return s["omega:driven"][-1]

    single = jax.jit(one)
    jax.block_until_ready(single(mus[0]))
    t0 = time.perf_counter()
    jax.block_until_ready(single(mus[0]))
    t_one = time.perf_counter() - t0

    t_sep = None
    if not args.skip_separate:
        t0 = time.perf_counter()
        for m in mus:
            jax.block_until_ready(single(m))
        t_sep = time.perf_counter() - t0

    res = jb.sweep(drive, {"contact.mu": mus})
    out = {
        "case": "benchmark_a",
        "elements": args.elements,
        "implicit_stiffness_dt": args.implicit_stiffness,
        "t_end_s": args.t_end,
        "points": args.points,
        "devices": res.timing["devices"],
        "backend": jax.default_backend(),
        "cpus": os.cpu_count(),
        "xla_flags": os.environ.get("XLA_FLAGS", ""),
        "one_run_s": t_one,
        "separate_runs_s": t_sep,
        "sweep_run_s": res.timing["run_s"],
        "sweep_compile_s": res.timing["compile_s"],
        "sweep_over_one_run": res.timing["run_s"] / t_one,
        "separate_over_sweep": (t_sep / res.timing["run_s"]) if t_sep else None,
        "target_sweep_over_one_run": 8.0,
    }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
