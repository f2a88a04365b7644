"""Identification of E, eta, mu from the noisy synthetic two-pulley measurement (tests/test_identify.py):
cost in forward-run equivalents, wall time and accuracy, against one forward run in the same process.

The forward-run equivalents count every forward run and every Jacobian at its measured cost ratio
(``IdentifyResult.timing``); ``to_1pct`` is the count at the first iteration where all three values are
within 1 % of the truth (issue 15 asks for <= 30), ``total`` includes what follows (the convergence
check and the Jacobian for the standard errors). With 1 % noise the fit's optimum itself may lie more
than 1 % from the truth (eta's standard error is ~2.3 %, mu's ~0.7 %): ``to_1pct`` is then null, and
``to_1pct_of_final`` counts to within 1 % of the values the fit ends at. The ``noise_free`` block fits
the same measurement without noise, where "within 1 % of the truth" is the issue's criterion proper
(``--no-noise-free`` skips it). ``--seeds N`` also fits N noise seeds and reports the fraction of true
values inside +-2 standard errors (expect about 95 %), inside +-1 (about 68 %), and the mean and RMS of
(value - truth) / standard error (about 0 and 1 when the standard errors are calibrated; slow: N fits).

``--processes N`` runs the same on N processes of this machine joined by ``jax.distributed`` (127.0.0.1,
one CPU device each; the script starts N copies of itself): every Jacobian's tangents are split over
them, the forward runs are repeated in each (docs/distributed.md). Process 0 prints; ``jacobian_s`` is
the median wall time of one Jacobian, the gathering of the columns included.

Usage:  python benchmarks/bench_identify.py [--seeds 20] [--iterations 8] [--noise 0.01] [--no-noise-free]
                                            [--processes 2]
"""

import argparse
import json
import os
import platform
import socket
import subprocess
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

import jaxbelt as jb  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))
from helpers import START, TRUTH  # noqa: E402
from helpers import identification_spec as _spec  # noqa: E402

NAMES = ["omega:driven", "tension:driven-driver", "tension:driver-driven"]
WINDOWS = [(0.3, 0.8), (0.0, 0.8)]


def measurement(sig, ts, seed: int, noise: float = 0.01) -> jb.Measurement:
    rng = np.random.default_rng(seed)
    t = np.asarray(ts)[::8]
    cols = {}
    for n in NAMES:
        x = np.asarray(sig[n])[::8]
        cols[n] = x + noise * np.std(x) * rng.normal(size=x.shape)  # 1 % noise by default
    return jb.Measurement(t, cols)


def fit(drive, meas, iterations):
    box = {k: (v * START[k], (v / 1.6, v * 1.6)) for k, v in TRUTH.items()}
    t0 = time.perf_counter()
    res = jb.identify(drive, meas, box, iterations=iterations, windows=WINDOWS)
    return res, time.perf_counter() - t0


def first_within(path, target, rel=0.01):
    """Forward-run equivalents at the first iteration whose values are all within ``rel`` of ``target``."""
    hit = next((p for p in path if all(abs(p["values"][k] / target[k] - 1) < rel for k in target)), None)
    return None if hit is None else hit["forward_run_equivalents"]


def launch(argv: list[str], n: int) -> int:
    """Start this script as processes 0 .. n-1 of a jax.distributed group on 127.0.0.1; process 0's output."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        addr = f"127.0.0.1:{s.getsockname()[1]}"
    env = dict(os.environ, XLA_FLAGS="--xla_force_host_platform_device_count=1")
    cmd = [sys.executable, os.path.abspath(__file__), *argv, "--coordinator", addr]
    procs = [subprocess.Popen([*cmd, "--process-id", str(i)], env=env) for i in range(n)]
    return max(abs(p.wait()) for p in procs)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=0, help="noise seeds for the +-2 sigma coverage (0: skip)")
    ap.add_argument("--iterations", type=int, default=8)
    ap.add_argument("--noise", type=float, default=0.01, help="noise level, fraction of each column's std")
    ap.add_argument("--no-noise-free", action="store_true", help="skip the fit of the noise-free measurement")
    ap.add_argument("--processes", type=int, default=1, help="run on N processes (jax.distributed, this machine)")
    ap.add_argument("--coordinator", help=argparse.SUPPRESS)  # set by launch() for its workers
    ap.add_argument("--process-id", type=int, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.processes > 1 and a.process_id is None:
        sys.exit(launch(sys.argv[1:], a.processes))
    if a.process_id is not None:
        from jaxbelt.analysis.distributed import initialize

        initialize(a.coordinator, a.processes, a.process_id)
    drive = jb.build_drive(_spec())
    ts, sig = jb.simulate_signals(drive)  # compile and run: the measurement
    t0 = time.perf_counter()
    ts, sig = jb.simulate_signals(drive)
    jax.block_until_ready(sig)
    forward_s = time.perf_counter() - t0  # one forward run (the drive's own step), compiled
    res, wall = fit(drive, measurement(sig, ts, 1, a.noise), a.iterations)
    tm = res.timing
    err = {k: res.values[k] / TRUTH[k] - 1 for k in TRUTH}
    out = dict(
        case="identify E, eta, mu: two-pulley start-up (tests/test_identify.py), 30 % off",
        noise=a.noise,
        machine=platform.processor() or platform.machine(),
        cpus=os.cpu_count(),
        forward_run_s=forward_s,
        identify_wall_s=wall,
        compile_s=tm["compile_s"],
        forward_run_in_fit_s=tm["forward_s"],
        processes=jax.process_count(),
        jacobian_s=tm.get("jacobian_s"),
        jacobian_ratio=tm.get("jacobian_ratio"),
        forward_runs=tm["forward_runs"],
        jacobians=tm.get("jacobians", 0),
        forward_run_equivalents=dict(
            to_1pct=first_within(tm["path"], TRUTH),
            to_1pct_of_final=first_within(tm["path"], res.values),
            total=tm["forward_run_equivalents"],
        ),
        iterations=res.iterations,
        relative_error=err,
        std_error_rel={k: res.std_errors[k] / TRUTH[k] for k in TRUTH},
        wall_over_forward=(wall - tm["compile_s"]) / forward_s,
    )
    if not a.no_noise_free:
        clean, clean_wall = fit(drive, measurement(sig, ts, 1, 0.0), a.iterations)
        ct = clean.timing
        out["noise_free"] = dict(
            forward_run_equivalents=dict(to_1pct=first_within(ct["path"], TRUTH), total=ct["forward_run_equivalents"]),
            forward_runs=ct["forward_runs"],
            jacobians=ct.get("jacobians", 0),
            jacobian_ratio=ct.get("jacobian_ratio"),
            jacobian_s=ct.get("jacobian_s"),
            identify_wall_s=clean_wall,
            relative_error={k: clean.values[k] / TRUTH[k] - 1 for k in TRUTH},
        )
    if a.seeds:
        inside, fre, z = {k: 0 for k in TRUTH}, [], {k: [] for k in TRUTH}
        for seed in range(100, 100 + a.seeds):
            r, _ = fit(drive, measurement(sig, ts, seed, a.noise), a.iterations)
            fre.append(r.timing["forward_run_equivalents"])
            for k in TRUTH:
                inside[k] += abs(r.values[k] - TRUTH[k]) < 2 * r.std_errors[k]
                z[k].append((r.values[k] - TRUTH[k]) / r.std_errors[k])
        out["coverage_2sigma"] = {k: v / a.seeds for k, v in inside.items()}
        out["seeds"] = a.seeds
        # calibration: (value - truth) / std error should have mean ~0 and RMS ~1 over the seeds
        out["z_mean"] = {k: float(np.mean(v)) for k, v in z.items()}
        out["z_rms"] = {k: float(np.sqrt(np.mean(np.square(v)))) for k, v in z.items()}
        out["coverage_1sigma"] = {k: float(np.mean(np.abs(v) < 1)) for k, v in z.items()}
        out["forward_run_equivalents_per_seed"] = dict(median=float(np.median(fre)), max=float(np.max(fre)))
    if jax.process_index() == 0:
        print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
