"""Tension from a rung span of the ANCF belt: ring the upper span of Benchmark A at rest (no gravity, no load),
read its spectrum, invert the first transverse frequency with ``span_tension`` and compare with the span's
mean axial force. The ANCF tier's own test of the span-tension command (issue 30), at several meshes.

The span gets a transverse velocity bump at 0.3 L after the installed state settled; the y-displacements of
the span's nodes between 0.1 L and 0.9 L are recorded for ``--record`` seconds; the Hanning-windowed power
spectrum's peak near the first mode (parabolic interpolation of the log power) is the measured f1. Prints
one JSON object per element count. Usage:
    python benchmarks/bench_span_tension.py --elements 40 --elements 160 --scheme implicit
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxbelt as jb  # noqa: E402
from jaxbelt.analysis.span_tension import span_frequency, span_of, span_tension  # noqa: E402
from jaxbelt.belt.tension import axial_force_profile  # noqa: E402
from jaxbelt.dynamics.simulate import simulate  # noqa: E402

R, SPAN = 0.1, 0.1 * math.pi


def ring(n: int, scheme: str, record: float, dt: float | None) -> dict:
    spec = jb.benchmark_a(n_elements=n, t_end=record, save_dt=2e-4)
    spec.gravity = (0.0, 0.0)
    spec.pulleys[0].speed = 0.0
    spec.pulleys[1].inertia, spec.pulleys[1].load, spec.pulleys[1].viscous = 0.005, None, 0.0
    spec.solver.scheme = scheme
    if dt is not None:
        spec.solver.dt = dt
    d = jb.build_drive(spec)
    t0 = time.process_time()
    settle = simulate(d.model, d.params, d.state0, t_end=0.02, dt=d.dt, save_dt=0.02)
    st = settle.final
    q, v = np.asarray(st.q), np.array(st.v)
    x, y = q[:, 0, 0], q[:, 0, 1]
    upper = (y > 0.5 * R) & (x > 0.1 * SPAN) & (x < 0.9 * SPAN)
    v[:, 0, 1] += 0.02 * np.exp(-0.5 * ((x - 0.3 * SPAN) / (0.04 * SPAN)) ** 2) * (y > 0.5 * R)
    st = jax.tree.map(lambda a: a, st)
    import dataclasses

    tr = simulate(
        d.model,
        d.params,
        dataclasses.replace(st, v=jnp.asarray(v)),
        t_end=record,
        dt=d.dt,
        save_dt=2e-4,
        settle_time=0.0,
    )
    cpu = time.process_time() - t0
    ts, Y = np.asarray(tr.ts), np.asarray(tr.states.q)[:, upper, 0, 1]
    force, mid = jax.vmap(lambda q, v: axial_force_profile(n, d.params.belt, q, v))(tr.states.q, tr.states.v)
    force, mid = np.asarray(force), np.asarray(mid)
    sel = (mid[..., 1] > 0.5 * R) & (mid[..., 0] > 0.2 * SPAN) & (mid[..., 0] < 0.8 * SPAN)
    T = float(force[sel].mean())
    span = span_of(d, "driver-driven")
    f_theory = span_frequency(span, T, 1)
    sig = (Y - Y.mean(0)) * np.hanning(len(ts))[:, None]
    nfft = 1 << 20
    p = (np.abs(np.fft.rfft(sig, n=nfft, axis=0)) ** 2).sum(1)
    f = np.fft.rfftfreq(nfft, ts[1] - ts[0])
    band = np.flatnonzero((f > 0.8 * f_theory) & (f < 1.2 * f_theory))
    i = band[np.argmax(p[band])]
    a, b, c = np.log(p[i - 1 : i + 2])
    f1 = f[i] + 0.5 * (a - c) / (a - 2 * b + c) * (f[1] - f[0])
    r = span_tension(span, f1)
    return dict(
        elements=n,
        scheme=d.scheme,
        dt=d.dt,
        record_s=record,
        fault=int(tr.final.fault),
        axial_force=T,
        f1_measured=f1,
        f1_theory=f_theory,
        frequency_error_pct=100 * (f1 / f_theory - 1),
        tension_from_f1=r.tension,
        tension_error_pct=100 * (r.tension / T - 1),
        string_formula_error_pct=100 * (r.string_tension / T - 1),
        cpu_s=cpu,
        load_average=os.getloadavg()[0],
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--elements", type=int, action="append", help="element counts (default 40, 160)")
    ap.add_argument("--scheme", default="implicit", choices=("explicit", "implicit"))
    ap.add_argument("--record", type=float, default=1.0, help="recorded time after the bump [s]")
    ap.add_argument("--dt", type=float, default=None, help="time step (default: the scheme's own)")
    args = ap.parse_args()
    for n in args.elements or [40, 160]:
        print(json.dumps(ring(n, args.scheme, args.record, args.dt)), flush=True)


if __name__ == "__main__":
    main()
