"""solver.implicit_damping off/on: time step, us per step and s per simulated second (Benchmark A, short run,
compile excluded), and span vibration frequencies (Benchmark A pulleys at rest, mid-span FFT).

Prints one JSON object per line. Usage:
    python benchmarks/bench_implicit_damping.py timing 60,120,240 0.02
    python benchmarks/bench_implicit_damping.py span 60
"""

import dataclasses
import json
import sys
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxbelt as jb  # noqa: E402
from jaxbelt.dynamics.simulate import simulate  # noqa: E402


def timing(ns, t_end):
    for n in ns:
        for imp in (False, True):
            spec = jb.benchmark_a(n_elements=n, t_end=t_end)
            spec.solver.implicit_damping = imp
            d = jb.build_drive(spec)
            run = simulate(d.model, d.params, d.state0, t_end=t_end, dt=d.dt, settle_time=0.0, _ahead_of_time=True)
            jax.block_until_ready(run(d.params, d.state0).final.q)
            best = np.inf
            for _ in range(3):
                t0 = time.perf_counter()
                tr = run(d.params, d.state0)
                jax.block_until_ready(tr.final.q)
                best = min(best, time.perf_counter() - t0)
            steps = int(tr.num_steps)
            row = dict(n=n, implicit=imp, dt=d.dt, steps=steps, us_per_step=1e6 * best / steps)
            print(json.dumps(dict(row, s_per_sim_s=best / (steps * d.dt))), flush=True)


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
    else:
        span(int(sys.argv[2]))
