"""Which derivative of a steady-state figure is right: exact AD through the run or central differences?

Benchmark A (``--elements``, default 30), the driven pulley's speed averaged over the summary window (the
final ``window`` fraction of the run), differentiated with respect to E:

* forward-mode AD through the whole run (``jax.jacfwd``), for several window fractions;
* central differences ``(f(E (1 + h)) - f(E (1 - h))) / (2 h E)`` for relative steps h = 1e-1 ... 1e-5, and
  Richardson's extrapolation of the pair (h, h/2);
* creep theory's derivative (Grashof/Firbank with belt-length compatibility, ``outputs.theory``) by a
  central difference of the closed form, which is smooth: the steady state the window mean estimates.

Prints one JSON object. Usage: ``python benchmarks/bench_gradient_convergence.py [--elements 30]``.
"""

from __future__ import annotations

import argparse
import json
import os
import time

os.environ.setdefault("EQX_ON_ERROR", "nan")

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

import jaxbelt as jb  # noqa: E402
from jaxbelt.outputs.summary import creep_theory_for  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--elements", type=int, default=30)
    ap.add_argument("--t-end", type=float, default=2.45)
    ap.add_argument("--save-dt", type=float, default=1e-3)
    ap.add_argument("--law", default="coulomb", help="friction law (coulomb or regularized)")
    ap.add_argument("--nu-s", type=float, default=50.0, help="the regularised law's steepness [s/m]")
    ap.add_argument("--steps", default="1e-1,5e-2,3e-2,2e-2,1.5e-2,1e-2,6e-3,3e-3,1e-3,1e-4,1e-5")
    args = ap.parse_args()

    def spec():
        return jb.benchmark_a(
            n_elements=args.elements, t_end=args.t_end, save_dt=args.save_dt, friction_law=args.law, nu_s=args.nu_s
        )

    drive = jb.build_drive(spec())
    E0 = float(jb.get_parameter(drive, drive.params, "belt.E"))
    windows = (0.1, 0.2, 0.4)

    def means(E):
        p = jb.set_parameter(drive, drive.params, "belt.E", E)
        ts, sig = jb.simulate_signals(drive, p, adjoint="forward")
        w = sig["omega:driven"]
        out = []
        for f in windows:
            sel = (ts >= ts[-1] - f * (ts[-1] - ts[0])).astype(w.dtype)
            out.append(jnp.sum(sel * w) / jnp.sum(sel))
        out.append(w[-1])  # one sample, for comparison
        return jnp.stack(out)

    run = jax.jit(means)
    t0 = time.perf_counter()
    f0 = np.asarray(run(E0))
    t_run = time.perf_counter() - t0
    t0 = time.perf_counter()
    ad = np.asarray(jax.jit(jax.jacfwd(means))(E0))
    t_ad = time.perf_counter() - t0
    fd = {}
    for h in sorted({float(x) for x in args.steps.split(",")}, reverse=True):
        up, down = np.asarray(run(E0 * (1 + h))), np.asarray(run(E0 * (1 - h)))
        fd[h] = (up - down) / (2 * h * E0)
    rich = {h: (4 * fd[h / 2] - fd[h]) / 3 for h in fd if h / 2 in fd}

    def theory(E):
        d = jb.build_drive(spec())
        p = jb.set_parameter(d, d.params, "belt.E", E)
        import dataclasses

        d = dataclasses.replace(d, params=p)
        return creep_theory_for(d).omega_driven

    ht = 1e-3
    theory_slope = (theory(E0 * (1 + ht)) - theory(E0 * (1 - ht))) / (2 * ht * E0)
    labels = [f"mean over the final {f:g}" for f in windows] + ["last sample"]
    out = dict(
        case=f"Benchmark A, {args.elements} elements, t_end {args.t_end} s, {args.law} friction"
        + (f" (nu_s {args.nu_s:g} s/m)" if args.law != "coulomb" else "")
        + ", d omega_driven / d E [rad/s per Pa]",
        E=E0,
        values=dict(zip(labels, f0.tolist())),
        ad_forward=dict(zip(labels, ad.tolist())),
        central_differences={f"h={h:g}": dict(zip(labels, v.tolist())) for h, v in sorted(fd.items())},
        richardson={f"h={h:g},{h / 2:g}": dict(zip(labels, v.tolist())) for h, v in rich.items()},
        creep_theory=theory_slope,
        run_s=t_run,
        jacfwd_s=t_ad,
        load_average=os.getloadavg(),
    )
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
