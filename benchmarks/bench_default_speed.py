"""What a user gets by default: seconds per simulated second of `jaxbelt.run` with `solver.scheme = "auto"` and
the automatic step, on the fast-by-default issue's drives (the accessory example, 0.5 s; Benchmark A at 60 / 120 /
240 elements, 2.45 s), each beside a baseline run in the same process: the same drive and scheme at
``--baseline-dt`` (default 1e-4 s, the implicit scheme's default step until 2026-11-28), so that the ratio holds on
a noisy machine.

Per run: scheme, step and its reason, steps, microseconds per step, run / compile wall seconds, process CPU seconds
and the load average; ``s_per_sim_s`` is the run's wall time over the simulated time including the settle phase
(steps x dt). Prints one JSON object per drive. Usage:
    python benchmarks/bench_default_speed.py [--case accessory] [--case ba120] [--baseline-dt 1e-4]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import jaxbelt as jb  # noqa: E402

ROOT = Path(__file__).parents[1]
CASES = {
    "accessory": lambda: jb.load_config(ROOT / "examples" / "accessory_drive.toml"),
    "ba60": lambda: jb.benchmark_a(n_elements=60),
    "ba120": lambda: jb.benchmark_a(n_elements=120),
    "ba240": lambda: jb.benchmark_a(n_elements=240),
}


def timed(spec) -> dict:
    cpu = time.process_time()
    r = jb.run(spec)
    t, s = r.timing, r.summary
    return dict(
        scheme=s["scheme"],
        dt=t["dt"],
        dt_reason=s["dt_reason"],
        status=s["status"],
        steps=t["num_steps"],
        us_per_step=t["us_per_step"],
        run_s=t["run_s"],
        compile_s=t["compile_s"],
        s_per_sim_s=t["run_s"] / (t["num_steps"] * t["dt"]),
        cpu_s=time.process_time() - cpu,
        load_average=os.getloadavg(),
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", action="append", choices=sorted(CASES))
    ap.add_argument("--baseline-dt", type=float, default=1e-4)
    args = ap.parse_args()
    for case in args.case or list(CASES):
        default = timed(CASES[case]())
        spec = CASES[case]()
        spec.solver.scheme = default["scheme"]  # with a given dt "auto" would run explicit
        spec.solver.dt = args.baseline_dt if default["scheme"] == "implicit" else None
        baseline = timed(spec) if default["scheme"] == "implicit" else None
        out = dict(case=case, default=default, baseline=baseline)
        if baseline is not None:
            out["ratio_default_over_baseline"] = {
                k: default[k] / baseline[k] for k in ("s_per_sim_s", "us_per_step", "cpu_s")
            }
        print(json.dumps(out), flush=True)


if __name__ == "__main__":
    main()
