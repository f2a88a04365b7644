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

``--coverage-drive N`` instead runs N full fits (N noise seeds) on a drive other than the benchmark, that of
tests/test_identify_convergence.py (the start-up and load-step example, 16 elements, 0.45 s; E and mu from
a record made with E +10 %, mu -10 %, starting at the file's values, default iteration cap): how many
converged, the fraction whose truth lies within 1.96 standard errors (expect about 95 %), the RMS of
(value - truth) / standard error, the iterations and runs per fit. ``--record-step own`` makes the record
at the drive's own time step (as ``jaxbelt run`` does) instead of the fit's, so that the time-step error
is in it too.

Usage:  python benchmarks/bench_identify.py [--seeds 20] [--iterations 8] [--noise 0.01] [--no-noise-free]
                                            [--processes 2]
        python benchmarks/bench_identify.py --coverage-drive 20 [--record-step fit|own]
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


def coverage_drive(n_seeds: int, record_step: str, noise: float) -> dict:
    """Full nonlinear fits of ``n_seeds`` noise seeds on the start-up example (see the module's docstring)."""
    import importlib
    import warnings

    ident = importlib.import_module("jaxbelt.analysis.identify")
    keys, names = ["belt.E", "contact.mu"], ["omega:fan", "tension:motor-fan", "tension:fan-motor"]
    spec = jb.load_config(
        os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples", "startup_load_step.toml")
    )
    spec.belt.n_elements, spec.solver.t_end, spec.solver.save_dt = 16, 0.45, 2e-3
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        drive = jb.build_drive(spec)
    start = {k: float(jb.get_parameter(drive, drive.params, k)) for k in keys}
    truth = {"belt.E": 1.1 * start["belt.E"], "contact.mu": 0.9 * start["contact.mu"]}
    lo, hi = [start[k] / 2 for k in keys], [start[k] * 2 for k in keys]
    # the record at the step identify runs the model at (only the noise differs), or at the drive's own
    rec = drive if record_step == "own" else ident._drive_stable_over_bounds(drive, keys, lo, hi)
    box = {k: (start[k], (lo[i], hi[i])) for i, k in enumerate(keys)}
    p = rec.params
    for k in keys:
        p = jb.set_parameter(rec, p, k, truth[k])
    ts, sig = jb.simulate_signals(rec, p)
    t = np.asarray(ts)
    z, converged, iters, runs, jacs, walls = {k: [] for k in keys}, 0, [], [], [], []
    for seed in range(n_seeds):
        rng = np.random.default_rng(seed)
        cols = {n: np.asarray(sig[n]) + noise * np.std(np.asarray(sig[n])) * rng.normal(size=t.size) for n in names}
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = jb.identify(drive, jb.Measurement(t, cols), box, time_step_check=record_step == "own")
        walls.append(time.perf_counter() - t0)
        converged += r.converged
        iters.append(r.iterations)
        runs.append(r.timing["forward_runs"])
        jacs.append(r.timing.get("jacobians", 0))
        for k in keys:
            z[k].append((r.values[k] - truth[k]) / r.std_errors[k] if r.converged else float("nan"))
    zs = {k: np.asarray(v) for k, v in z.items()}
    return dict(
        case="identify E, mu: start-up example, 16 elements, 0.45 s; record E +10 %, mu -10 %; start at the file's",
        record_step=record_step,
        noise=noise,
        seeds=n_seeds,
        converged=converged,
        coverage_1_96=({k: float(np.mean(np.abs(v) <= 1.96)) for k, v in zs.items()}),
        z_rms={k: float(np.sqrt(np.nanmean(v**2))) for k, v in zs.items()},
        z_mean={k: float(np.nanmean(v)) for k, v in zs.items()},
        iterations=dict(median=float(np.median(iters)), max=int(np.max(iters))),
        forward_runs=dict(median=float(np.median(runs)), max=int(np.max(runs))),
        jacobians=dict(median=float(np.median(jacs)), max=int(np.max(jacs))),
        fit_wall_s=dict(median=float(np.median(walls)), first=walls[0]),
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=0, help="noise seeds for the +-2 sigma coverage (0: skip)")
    ap.add_argument("--iterations", type=int, default=8)
    ap.add_argument("--noise", type=float, default=0.01, help="noise level, fraction of each column's std")
    ap.add_argument("--no-noise-free", action="store_true", help="skip the fit of the noise-free measurement")
    ap.add_argument("--processes", type=int, default=1, help="run on N processes (jax.distributed, this machine)")
    ap.add_argument("--coverage-drive", type=int, default=0, metavar="N", help="N fits on a drive other than this one")
    ap.add_argument(
        "--record-step", choices=["fit", "own"], default="fit", help="--coverage-drive's record's time step"
    )
    ap.add_argument("--coordinator", help=argparse.SUPPRESS)  # set by launch() for its workers
    ap.add_argument("--process-id", type=int, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.coverage_drive:
        print(json.dumps(coverage_drive(a.coverage_drive, a.record_step, a.noise), indent=1))
        return
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
        converged=res.converged,
        convergence=res.convergence["reason"],
        error_budget=res.error_budget,
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
        inside, fre, z, conv = {k: 0 for k in TRUTH}, [], {k: [] for k in TRUTH}, 0
        for seed in range(100, 100 + a.seeds):
            r, _ = fit(drive, measurement(sig, ts, seed, a.noise), a.iterations)
            fre.append(r.timing["forward_run_equivalents"])
            conv += r.converged  # a fit that has not converged has no standard errors (NaN): counted outside
            for k in TRUTH:
                inside[k] += abs(r.values[k] - TRUTH[k]) <= 1.96 * r.std_errors[k]
                z[k].append((r.values[k] - TRUTH[k]) / r.std_errors[k])
        out["coverage_1_96"] = {k: v / a.seeds for k, v in inside.items()}
        out["converged"] = conv
        out["seeds"] = a.seeds
        # calibration: (value - truth) / std error should have mean ~0 and RMS ~1 over the seeds
        out["z_mean"] = {k: float(np.nanmean(v)) for k, v in z.items()}
        out["z_rms"] = {k: float(np.sqrt(np.nanmean(np.square(v)))) for k, v in z.items()}
        out["coverage_1sigma"] = {k: float(np.mean(np.abs(v) < 1)) for k, v in z.items()}
        out["forward_run_equivalents_per_seed"] = dict(median=float(np.median(fre)), max=float(np.max(fre)))
    if jax.process_index() == 0:
        print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
