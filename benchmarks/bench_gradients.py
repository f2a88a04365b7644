"""Cost of derivatives relative to one forward run, and peak memory of a reverse-mode gradient.

Benchmark A (60 elements by default). Prints JSON. Times exclude compilation (each function is
compiled and run once before timing). Memory is the process's peak resident set (ru_maxrss), which
includes compilation: ``peak_rss_mb`` follows the one process through forward, forward-mode Jacobian and
reverse-mode gradient (so each figure is a peak over everything before it); ``alone_peak_rss_mb`` runs
each of the three in a fresh process of its own (``--only``), the peak memory of that computation alone,
three times: compiling it (empty compilation cache: XLA's compiler is most of the peak), loading it from a
warm persistent cache (a temporary one), and compiling
it with XLA's faster-compiling CPU code generator (``jaxbelt.use_fast_cpu_compile``; the default otherwise).
Usage: python benchmarks/bench_gradients.py [--elements 60] [--t-end 2.45] [--only forward|jacfwd|reverse]
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

import jax

jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp  # noqa: E402

import jaxbelt as jb  # noqa: E402

KEYS = ["belt.E", "belt.eta", "contact.mu"]


def rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def timed(fn, x, repeats=1):
    out = fn(x)
    jax.block_until_ready(out)
    t0 = time.perf_counter()
    for _ in range(repeats):
        out = fn(x)
        jax.block_until_ready(out)
    return (time.perf_counter() - t0) / repeats


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--elements", type=int, default=60)
    ap.add_argument("--implicit-stiffness", type=float, metavar="DT", help="solver.implicit_stiffness with step DT")
    ap.add_argument("--t-end", type=float, default=2.45)
    ap.add_argument("--only", choices=["forward", "jacfwd", "reverse"], help="run this one alone, print its peak RSS")
    ap.add_argument("--no-alone", action="store_true", help="skip the fresh-process peaks")
    args = ap.parse_args()
    spec = jb.benchmark_a(n_elements=args.elements, t_end=args.t_end, save_dt=1e-2)
    if args.implicit_stiffness:  # solver.implicit_stiffness at this step
        spec.solver.implicit_stiffness, spec.solver.dt = True, args.implicit_stiffness
    drive = jb.build_drive(spec)
    x0 = jnp.asarray([float(jb.get_parameter(drive, drive.params, k)) for k in KEYS])

    def outputs(x, adjoint):
        p = drive.params
        for i, k in enumerate(KEYS):
            p = jb.set_parameter(drive, p, k, x[i])
        ts, s = jb.simulate_signals(drive, p, adjoint=adjoint)
        sel = ts >= ts[-1] - 0.2 * (ts[-1] - ts[0])
        return jnp.stack(
            [
                jnp.sum(jnp.where(sel, s["omega:driven"], 0)) / jnp.sum(sel),
                jnp.sum(jnp.where(sel, s["tension:driven-driver"], 0)) / jnp.sum(sel),
            ]
        )

    rss0 = rss_mb()
    if args.only:
        fn = dict(
            forward=lambda: jax.jit(lambda x: outputs(x, "reverse")),
            jacfwd=lambda: jax.jit(jax.jacfwd(lambda x: outputs(x, "forward"))),
            reverse=lambda: jax.jit(jax.grad(lambda x: outputs(x, "reverse")[0])),
        )[args.only]()
        seconds = timed(fn, x0)
        print(json.dumps({"only": args.only, "seconds": seconds, "start_rss_mb": rss0, "peak_rss_mb": rss_mb()}))
        return
    # first, while this process is still small: a child's peak RSS counts what it shares with its parent at fork
    alone: dict = {}
    if not args.no_alone:
        with tempfile.TemporaryDirectory() as cache:
            env = dict(os.environ, JAX_COMPILATION_CACHE_DIR=cache)
            env["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"] = "0"
            for kind in ("forward", "jacfwd", "reverse"):
                cmd = [sys.executable, __file__, "--elements", str(args.elements), "--t-end", str(args.t_end)]
                if args.implicit_stiffness:
                    cmd += ["--implicit-stiffness", str(args.implicit_stiffness)]
                # the third: compiling with the faster-compiling CPU code generator (jaxbelt.use_fast_cpu_compile)
                fast = dict(env, XLA_FLAGS=" ".join([env.get("XLA_FLAGS", ""), *jb._xla.CPU_COMPILE_FLAGS]).strip())
                for label, e in (("compiling", env), ("cached", env), ("compiling_fast_cpu_compile", fast)):
                    out = subprocess.run([*cmd, "--only", kind], capture_output=True, text=True, check=True, env=e)
                    alone.setdefault(label, {})[kind] = json.loads(out.stdout.strip().splitlines()[-1])["peak_rss_mb"]
    fwd = jax.jit(lambda x: outputs(x, "reverse"))
    t_forward = timed(fwd, x0)
    rss_forward = rss_mb()
    jf = jax.jit(jax.jacfwd(lambda x: outputs(x, "forward")))
    t_jacfwd = timed(jf, x0)
    rss_jacfwd = rss_mb()
    gr = jax.jit(jax.grad(lambda x: outputs(x, "reverse")[0]))
    t_grad = timed(gr, x0)
    rss_grad = rss_mb()
    print(
        json.dumps(
            {
                "case": "benchmark_a",
                "elements": args.elements,
                "implicit_stiffness_dt": args.implicit_stiffness,
                "t_end_s": args.t_end,
                "parameters": KEYS,
                "num_steps": int(round((args.t_end + drive.spec.solver.settle_time) / drive.dt)),
                "forward_s": t_forward,
                "jacfwd_3_params_s": t_jacfwd,
                "grad_reverse_s": t_grad,
                "jacfwd_over_forward": t_jacfwd / t_forward,
                "grad_reverse_over_forward": t_grad / t_forward,
                "peak_rss_mb": {
                    "start": rss0,
                    "after_forward": rss_forward,
                    "after_jacfwd": rss_jacfwd,
                    "after_reverse_grad": rss_grad,
                },
                "alone_peak_rss_mb": alone,
                "devices": [str(d) for d in jax.devices()],
            }
        )
    )


if __name__ == "__main__":
    main()
