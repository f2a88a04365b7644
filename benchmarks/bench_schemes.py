"""The step schemes side by side on Benchmark A: explicit, ``solver.implicit_damping`` and
``solver.implicit_stiffness`` (at ``--dt``, default 2e-4 s).

* ``timing N,N,.. T``: time step, us per step and s per simulated second (short run of T s, compile excluded;
  the implicit-stiffness run is 10 x longer so that it takes as many steps);
* ``accuracy N,N,..``: the full Benchmark A (2.45 s) per scheme: speed loss and span tensions against creep
  theory, energy-audit residual, LCP residual, wall time;
* ``span N``: span vibration frequencies (pulleys at rest, mid-span FFT) against the explicit run.

Prints one JSON object per line. Usage:
    python benchmarks/bench_schemes.py timing 60,120,240 0.02
    python benchmarks/bench_schemes.py accuracy 60,120,240
    python benchmarks/bench_schemes.py span 60
"""

import dataclasses
import json
import os
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxbelt as jb  # noqa: E402
from jaxbelt.dynamics.simulate import simulate  # noqa: E402


SCHEMES = ("explicit", "implicit_damping", "implicit_stiffness")
STIFF_DT = float(os.environ.get("BENCH_STIFF_DT", "2e-4"))


def scheme_spec(scheme, **kw):
    spec = jb.benchmark_a(**kw)
    if scheme != "explicit":
        setattr(spec.solver, scheme, True)
    if scheme == "implicit_stiffness":
        spec.solver.dt = STIFF_DT
    return spec


def timing(ns, t_end):
    for n in ns:
        for scheme in SCHEMES:
            T = 10 * t_end if scheme == "implicit_stiffness" else t_end
            d = jb.build_drive(scheme_spec(scheme, n_elements=n, t_end=T))
            run = simulate(d.model, d.params, d.state0, t_end=T, dt=d.dt, settle_time=0.0, _ahead_of_time=True)
            jax.block_until_ready(run(d.params, d.state0).final.q)
            best = np.inf
            for _ in range(3):
                t0 = time.perf_counter()
                tr = run(d.params, d.state0)
                jax.block_until_ready(tr.final.q)
                best = min(best, time.perf_counter() - t0)
            steps = int(tr.num_steps)
            row = dict(n=n, scheme=scheme, dt=d.dt, steps=steps, us_per_step=1e6 * best / steps)
            print(json.dumps(dict(row, s_per_sim_s=best / (steps * d.dt))), flush=True)


def accuracy(ns):
    for n in ns:
        for scheme in SCHEMES:
            t0 = time.perf_counter()
            r = jb.run(scheme_spec(scheme, n_elements=n))
            wall = time.perf_counter() - t0
            s, th = r.summary, r.summary["creep_theory"]
            loss = th["omega_driver"] - s["pulleys"]["driven"]["omega_mean"]
            spans = {x["name"]: x["tension_mean"] for x in s["spans"]}
            row = dict(n=n, scheme=scheme, dt=r.drive.dt, status=s["status"], wall_s=round(wall, 1))
            row.update(
                speed_loss_vs_theory=loss / th["speed_loss"] - 1,
                tight_vs_theory=spans["driven-driver"] / th["T_tight"] - 1,
                slack_vs_theory=spans["driver-driven"] / th["T_slack"] - 1,
                energy_residual=s["energy"]["residual_relative"],
                lcp_residual_max=s["lcp_residual_max"],
            )
            print(json.dumps(row), flush=True)


def _peaks(ts, sig, bands=((15, 60), (60, 140), (140, 220))):
    sig = sig - sig.mean()
    N = 64 * len(sig)
    F = np.abs(np.fft.rfft(sig * np.hanning(len(sig)), N))
    f = np.fft.rfftfreq(N, ts[1] - ts[0])
    out = []
    for lo, hi in bands:
        k = np.where((f > lo) & (f < hi))[0]
        j = k[np.argmax(F[k])]
        a, b, c = np.log(F[j - 1 : j + 2])
        out.append(float(f[j] + 0.5 * (a - c) / (a - 2 * b + c) * (f[1] - f[0])))
    return out


def span(n, t_end=0.4, save=5e-5):
    spec = jb.benchmark_a(n_elements=n, t_end=0.01, load=0.0)
    spec.pulleys[0].speed = {"ramp": [0.05, 0.6, 0.0, 0.0]}
    d = jb.build_drive(spec)
    s0 = simulate(d.model, d.params, d.state0, t_end=0.01, dt=d.dt, save_dt=0.01, settle_time=0.1).final
    x, y = np.asarray(s0.q[:, 0, 0]), np.asarray(s0.q[:, 0, 1])
    Ls = np.pi * 0.1  # upper span between the pulley tops
    on = (y > 0.05) & (x > 0.0) & (x < Ls)
    xi = np.clip(x / Ls, 0, 1)
    v = np.asarray(s0.v).copy()
    v[:, 0, 1] += np.where(on, 0.05 * np.sin(np.pi * xi) + 0.03 * np.sin(3 * np.pi * xi), 0.0)  # modes 1, 3 (, 5)
    s1 = dataclasses.replace(s0, v=jnp.asarray(v))
    mid = int(np.argmin(np.where(on, np.abs(x - Ls / 2), 9.0)))

    def freqs(model, dt):
        tr = simulate(model, d.params, s1, t_end=t_end, dt=dt, save_dt=save, settle_time=0.0)
        return _peaks(np.asarray(tr.ts), np.asarray(tr.states.q[:, mid, 0, 1]))

    imp = dataclasses.replace(d.model, implicit_damping=True)
    dt_imp = 0.9 * jb.dynamics.stable_time_step(imp, d.params)
    ref, same, own = freqs(d.model, d.dt), freqs(imp, d.dt), freqs(imp, dt_imp)
    rel = lambda xs: [b / a - 1 for a, b in zip(ref, xs)]  # noqa: E731
    print(
        json.dumps(
            dict(n=n, dt_explicit=d.dt, dt_implicit=dt_imp, explicit_hz=ref, rel_same_dt=rel(same), rel_own_dt=rel(own))
        ),
        flush=True,
    )


if __name__ == "__main__":
    if sys.argv[1] == "timing":
        timing([int(x) for x in sys.argv[2].split(",")], float(sys.argv[3]))
    elif sys.argv[1] == "accuracy":
        accuracy([int(x) for x in sys.argv[2].split(",")])
    else:
        span(int(sys.argv[2]))
