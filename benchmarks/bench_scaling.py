"""Cost per simulated second against the element count: dense against structured ring operators.

Benchmark A at 30/60/120/240 elements (short settle and run: the cost per step does not depend on the
phase), each mesh compiled with both operator forms in the same process and run alternately, compile
excluded (best of ``--repeats``). Also the largest difference of the final belt coordinates and pulley
speeds between the two forms (they agree to round-off). Prints one JSON object.
Usage:  python benchmarks/bench_scaling.py [--elements 30 60 120 240] [--t-end 0.01] [--repeats 3]
"""

import argparse
import dataclasses
import json
import os
import platform
import time

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

import jaxbelt as jb  # noqa: E402
from jaxbelt.dynamics.simulate import simulate  # noqa: E402


def _with_operators(drive, kind: str):
    return dataclasses.replace(drive, model=dataclasses.replace(drive.model, ring_operators=kind))


def _compiled(drive, t_end: float, settle_time: float):
    return simulate(
        drive.model, drive.params, drive.state0, t_end=t_end, dt=drive.dt, save_dt=t_end,
        settle_time=settle_time, _ahead_of_time=True,
    )  # fmt: skip


def measure(n: int, t_end: float, settle_time: float, repeats: int) -> dict:
    """Both forms compiled first, then run alternately ``repeats`` times: the minimum time of each is
    the least disturbed by other processes on a shared machine."""
    base = jb.build_drive(jb.benchmark_a(n_elements=n, t_end=t_end))
    kinds = ("dense", "structured")
    runs, best, finals, steps = {}, {k: float("inf") for k in kinds}, {}, {}
    for kind in kinds:
        t0 = time.perf_counter()
        runs[kind] = _compiled(_with_operators(base, kind), t_end, settle_time)
        best[kind + "_compile"] = time.perf_counter() - t0
    for _ in range(repeats):
        for kind in kinds:
            t0 = time.perf_counter()
            traj = runs[kind](base.params, base.state0)
            jax.block_until_ready(traj.final.q)
            best[kind] = min(best[kind], time.perf_counter() - t0)
            finals[kind], steps[kind] = traj.final, int(traj.num_steps)
    out: dict = {"elements": n, "dt": base.dt}
    for kind in kinds:
        us = 1e6 * best[kind] / steps[kind]
        out[kind] = {
            "us_per_step": round(us, 2),
            "steps_per_sim_s": round(1.0 / base.dt),
            "s_per_sim_s": round(us * 1e-6 / base.dt, 3),
            "num_steps": steps[kind],
            "compile_s": round(best[kind + "_compile"], 2),
        }
    out["speedup"] = round(out["dense"]["us_per_step"] / out["structured"]["us_per_step"], 2)
    fd, fs = finals["dense"], finals["structured"]
    out["max_abs_diff_final_q_m"] = float(np.max(np.abs(np.asarray(fd.q) - np.asarray(fs.q))))
    out["max_abs_diff_final_omega_rad_s"] = float(np.max(np.abs(np.asarray(fd.omega) - np.asarray(fs.omega))))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--elements", type=int, nargs="+", default=[30, 60, 120, 240])
    ap.add_argument("--t-end", type=float, default=0.01)
    ap.add_argument("--settle-time", type=float, default=0.02)
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    res = {
        "case": "benchmark_a scaling, dense vs structured ring operators",
        "t_end_s": a.t_end,
        "settle_time_s": a.settle_time,
        "default_switch_elements": jb.belt.ring.STRUCTURED_FROM,
        "meshes": [measure(n, a.t_end, a.settle_time, a.repeats) for n in a.elements],
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform(), "jax": jax.__version__},
    }
    print(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
