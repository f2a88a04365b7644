"""Compile time of each command, first and second invocation on the same drive (issue 27: a second
invocation compiles nothing; target: <= 2 s of compiling). Each command runs twice as a fresh process on
one empty, temporary compilation cache (shared by the commands, run in the order given: a later command
may find programs an earlier one stored). Prints JSON: per process the wall time, the persistent-cache
lookups, hits and missed programs, XLA's time compiling or loading programs (``backend_compile_s``: every
``/jax/core/compile/backend_compile_duration``) and JAX's tracing and lowering time (``trace_lower_s``:
nested traces counted in each, an upper bound), and the load average before and after.

Usage: python benchmarks/bench_compile_cache.py [--config FILE] [--t-end T] [--commands run,sweep,...]
Default: a 12-element Benchmark A transient (0.02 s), every command.

``--preset benchmark_a``: the compile issue's first-compile targets on examples/two_pulley_benchmark.toml (60
elements, ``--t-end`` 0.6 unless given): a 9-point sweep (contact.mu x belt.E, 3 x 3), a 3-point duty (driver speed
and load), an E-eta-mu identification (one Levenberg-Marquardt iteration: every program it compiles), and a run;
the time spent compiling is ``backend_compile_s + trace_lower_s`` of each command's first process.
"""

import argparse
import collections
import json
import os
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

COUNTER = textwrap.dedent("""
    import collections, json, logging, os, sys
    from jax import monitoring

    counts = {"requests": 0, "hits": 0, "missed": [], "durations": collections.defaultdict(float)}

    def _event(name, **kw):
        if name == "/jax/compilation_cache/compile_requests_use_cache":
            counts["requests"] += 1
        elif name == "/jax/compilation_cache/cache_hits":
            counts["hits"] += 1

    def _duration(name, secs, **kw):
        counts["durations"][name] += secs

    class _Missed(logging.Handler):
        def emit(self, record):
            if record.getMessage().startswith("PERSISTENT COMPILATION CACHE MISS"):
                counts["missed"].append(str(record.args[0]))

    monitoring.register_event_listener(_event)
    monitoring.register_event_duration_secs_listener(_duration)
    log = logging.getLogger("jax._src.compiler")
    log.setLevel(logging.DEBUG)
    log.addHandler(_Missed())
    from jaxbelt.cli import main

    code = main(sys.argv[1:])
    with open(os.environ["BENCH_COUNTS"], "w") as f:
        json.dump(counts, f)
    sys.exit(code)
""")


def commands(cfg: str) -> dict:
    return {
        "run": ["run", cfg, "--no-plots"],
        "statics": ["statics", cfg],
        "modes": ["modes", cfg, "--count", "4"],
        "runup": [
            "runup",
            cfg,
            "--rpm",
            "1500:1800",
            "--duration",
            "0.05",
            "--lead-time",
            "0.01",
            "--revolutions",
            "1",
        ],
        "sweep": ["sweep", cfg, "--vary", "contact.mu=0.3:0.6:2"],
        "duty": ["duty", cfg, "--rpm", "100,200", "--torque", "driven=1,2"],
        "report": ["report", cfg],
        "identify": ["identify", cfg, "--measured", "measured.csv", "--fit", "belt.EA", "--iterations", "1"],
    }


def benchmark_a_commands(cfg: str) -> dict:
    """The compile issue's first-compile cases on Benchmark A (``--preset benchmark_a``)."""
    return {
        "sweep9": ["sweep", cfg, "--vary", "contact.mu=0.3:0.7:3", "--vary", "belt.E=8e6:1.2e7:3"],
        "duty3": ["duty", cfg, "--rpm", "95,115,135", "--torque", "driven=20,25,30"],
        "identify3": [
            "identify",
            cfg,
            "--measured",
            "measured.csv",
            "--fit",
            "belt.E,belt.eta,contact.mu",
            "--iterations",
            "1",
        ],
        "run": ["run", cfg, "--no-plots"],
    }


def one(work: Path, tag: str, argv: list[str], env: dict) -> dict:
    counts = work / f"{tag}.json"
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, str(work / "counter.py"), *argv, "--out", f"out_{tag}", "--quiet"],
        cwd=work,
        env=dict(env, BENCH_COUNTS=str(counts)),
        capture_output=True,
        text=True,
    )
    wall = time.perf_counter() - t0
    if proc.returncode not in (0, 1):
        raise SystemExit(f"{argv[0]} failed ({proc.returncode}): {proc.stderr[-2000:]}")
    c = json.loads(counts.read_text())
    d = collections.defaultdict(float, c["durations"])
    return {
        "process_wall_s": round(wall, 2),
        "lookups": c["requests"],
        "hits": c["hits"],
        "missed": c["missed"],
        "backend_compile_s": round(d["/jax/core/compile/backend_compile_duration"], 2),
        "trace_lower_s": round(
            d["/jax/core/compile/jaxpr_trace_duration"] + d["/jax/core/compile/jaxpr_to_mlir_module_duration"], 2
        ),
    }


def main():
    from helpers import two_pulley_toml

    ap = argparse.ArgumentParser()
    ap.add_argument("--config", help="drive (default: a 12-element Benchmark A transient, 0.02 s)")
    ap.add_argument("--t-end", type=float)
    ap.add_argument("--commands", help="comma-separated (default: every command of the preset)")
    ap.add_argument("--preset", choices=("transient", "benchmark_a"), default="transient")
    args = ap.parse_args()
    table = benchmark_a_commands if args.preset == "benchmark_a" else commands
    if args.preset == "benchmark_a":
        args.config = args.config or str(ROOT / "examples" / "two_pulley_benchmark.toml")
        args.t_end = args.t_end or 0.6
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        (work / "counter.py").write_text(COUNTER)
        cfg = work / "drive.toml"
        if args.config:
            cfg.write_text(Path(args.config).read_text())
        else:
            cfg.write_text(two_pulley_toml(n_elements=12, t_end=0.02, speed_ramp=(0.0, 0.01), load_ramp=(0.005, 0.015)))
        if args.preset == "benchmark_a":  # the driven pulley following the driver's ramp (0.05-0.6 s to 12 rad/s)
            rows = "".join(
                f"{0.01 * i:.6g},{min(12.0, max(0.0, (0.01 * i - 0.05) / 0.55 * 12.0)):.6g}\n" for i in range(61)
            )
        else:
            rows = "".join(f"{0.002 * i:.6g},{min(6.0, 600.0 * 0.002 * i):.6g}\n" for i in range(11))
        (work / "measured.csv").write_text("t,omega:driven\n" + rows)
        env = dict(os.environ, PYTHONUNBUFFERED="1", JAX_COMPILATION_CACHE_DIR=str(work / "cache"))
        env["JAXBELT_CACHE_DIR"] = env["JAX_COMPILATION_CACHE_DIR"]
        env.pop("EQX_ON_ERROR", None)
        results = {}
        for name in (args.commands or ",".join(table("x"))).split(","):
            argv = table("drive.toml")[name] + (["--t-end", str(args.t_end)] if args.t_end else [])
            results[name] = {"first": one(work, f"{name}1", argv, env), "second": one(work, f"{name}2", argv, env)}
            print(name, json.dumps(results[name]), file=sys.stderr, flush=True)
    print(
        json.dumps({"load_average_before": load0, "load_average_after": os.getloadavg(), "commands": results}, indent=1)
    )


if __name__ == "__main__":
    main()
