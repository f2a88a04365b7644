"""Start-up cost of the command line: ``jaxbelt run examples/two_pulley_benchmark.toml`` as a fresh
process with an empty compilation cache, then again with the cache it filled. Prints JSON: each run's
wall time (process start to exit) and the command's own split (build, compile, run, post-processing),
and, as the baseline, a fresh process with an empty cache compiling with XLA's default CPU code generator
(``JAXBELT_FAST_COMPILE=0``: without the faster-compiling code generator jaxbelt uses for the run's programs).

Usage: python benchmarks/bench_startup.py [--config FILE] [--t-end T]
Targets (issue 12): empty cache <= 8 s, warm cache <= 4 s, post-processing <= 0.3 s.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _one(config: str, out: Path, env: dict, extra: list[str]) -> dict:
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "jaxbelt", "run", config, "--out", str(out), "--no-plots", "-q", *extra],
        env=env,
        capture_output=True,
        text=True,
    )
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"jaxbelt run failed ({proc.returncode}): {proc.stderr}")
    timing = json.loads((out / "summary.json").read_text())["timing"]
    keys = ("build_s", "compile_s", "run_s", "postprocess_s", "num_steps")
    return {"process_wall_s": wall, **{k: timing[k] for k in keys}}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--config", default=str(ROOT / "examples" / "two_pulley_benchmark.toml"))
    ap.add_argument("--t-end", type=float, default=None)
    args = ap.parse_args()
    extra = [] if args.t_end is None else ["--t-end", str(args.t_end)]
    load_before = os.getloadavg()  # a shared machine: the load says how far the timings can be trusted
    with tempfile.TemporaryDirectory(prefix="jaxbelt-bench-startup-") as tmp:
        env = {**os.environ, "JAXBELT_CACHE_DIR": str(Path(tmp) / "cache")}
        cold = _one(args.config, Path(tmp) / "cold", env, extra)
        warm = _one(args.config, Path(tmp) / "warm", env, extra)
        entries = len(list((Path(tmp) / "cache").iterdir()))
        # baseline: XLA's default CPU code generator for the run's programs too (jaxbelt._xla.compile_forward)
        default_env = dict(env, JAXBELT_FAST_COMPILE="0", JAXBELT_CACHE_DIR=str(Path(tmp) / "cache-default"))
        default = _one(args.config, Path(tmp) / "default", default_env, extra)
    out = {
        "case": "startup",
        "config": args.config,
        "cpu_count": os.cpu_count(),
        "empty_cache": cold,
        "warm_cache": warm,
        "empty_cache_xla_default_codegen": default,
        "cache_entries": entries,
        "load_average_before_after": [[round(x, 2) for x in load_before], [round(x, 2) for x in os.getloadavg()]],
        "targets_s": {"empty_cache": 8.0, "warm_cache": 4.0, "postprocess": 0.3},
    }
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
