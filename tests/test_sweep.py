"""Batched, sharded sweeps: one vmapped computation split over several (forced host) devices."""

import json
import os
import subprocess
import sys
import textwrap

import pytest

SCRIPT = textwrap.dedent("""
    import os, json, warnings
    os.environ["XLA_FLAGS"] = "--xla_force_host_platform_device_count=4"
    import jax
    jax.config.update("jax_enable_x64", True)
    warnings.simplefilter("ignore")
    import dataclasses
    import numpy as np, jax.numpy as jnp
    import jaxbelt as jb
    from jaxbelt import set_parameter, simulate_signals

    drive = jb.build_drive(jb.benchmark_a(n_elements=20, t_end=0.15, save_dt=0.01))
    res = jb.sweep(drive, {"contact.mu": [0.3, 0.5, 0.7], "belt.E": [8e6, 1.2e7]})  # 6 points on 4 devices
    w = res.figures["omega:driven:mean"]
    # the same points one at a time, with the time step the sweep chose for all of them
    drive = dataclasses.replace(drive, dt=res.timing["dt"])
    single = []
    for mu, E in res.points:
        p = set_parameter(drive, set_parameter(drive, drive.params, "contact.mu", mu), "belt.E", E)
        ts, s = simulate_signals(drive, p)
        sel = np.asarray(ts) >= float(ts[-1]) - 0.2 * float(ts[-1] - ts[0])
        single.append(float(np.asarray(s["omega:driven"])[sel].mean()))
    print(json.dumps(dict(devices=res.timing["devices"], points=res.points.tolist(), swept=w.tolist(),
                          single=single, faults=res.figures["fault"].tolist(),
                          unclosed=res.figures["energy_unclosed"].tolist())))
""")


def test_sweep_sharded_over_four_devices_equals_separate_runs():
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, env=env, timeout=1200)
    assert out.returncode == 0, out.stderr[-3000:]
    r = json.loads(out.stdout.strip().splitlines()[-1])
    assert r["devices"] == 4 and len(r["points"]) == 6
    assert all(f == 0 for f in r["faults"])
    # every point carries its energy closure (the run's audit, test_energy_audit): these runs close
    assert all(0.0 <= u < 1e-3 for u in r["unclosed"]), r["unclosed"]
    # batched and single runs are different compiled programs: equal to rounding, amplified by
    # stick/slip switches over the run (measured 4e-9 relative)
    for a, b in zip(r["swept"], r["single"]):
        assert abs(a / b - 1) < 1e-6
    # and the sweep resolves the physics: a stiffer belt transmits with less creep
    sw = r["swept"]
    assert sw[1] != sw[0]


# belt.pretension changes the installed belt inside the batched program (stress-free length, so the
# element length and the mass matrix's inverse). Its batched LAPACK LU fanned out into XLA's intra-op
# pool from a worker of that pool and wedged both workers on two devices (3 points padded to 4 and 4
# points: 2 per device). The child gets two CPUs, the pool size where it was seen.
PRETENSION = textwrap.dedent("""
    import os, json, warnings, dataclasses
    os.environ["XLA_FLAGS"] = "--xla_force_host_platform_device_count=2"
    import jax
    jax.config.update("jax_enable_x64", True)
    warnings.simplefilter("ignore")
    import numpy as np
    import jaxbelt as jb

    drive = jb.build_drive(jb.benchmark_a(n_elements=30, t_end=0.02, save_dt=0.005))
    spans = ["tension:driver-driven", "tension:driven-driver"]
    out = dict(base_dt=drive.dt)
    for grid in ([300.0, 400.0, 500.0], [200.0, 300.0, 400.0, 500.0]):  # one step for both: the same largest T
        lines = []
        res = jb.sweep(drive, {"belt.pretension": grid}, progress=lines.append)
        one = dataclasses.replace(drive, dt=res.timing["dt"])
        single, limits = [], []
        for T in grid:
            p = jb.set_parameter(drive, drive.params, "belt.pretension", T)
            limits.append(jb.dynamics.stable_time_step(drive.model, p))
            ts, s = jb.simulate_signals(one, p)
            sel = np.asarray(ts) >= float(ts[-1]) - 0.2 * float(ts[-1] - ts[0])
            single.append([float(np.asarray(s[k])[sel].mean()) for k in spans])
        out[str(len(grid))] = dict(devices=res.timing["devices"], dt=res.timing["dt"], limits=limits, lines=lines,
                                   faults=res.figures["fault"].tolist(), single=single,
                                   swept=[[float(res.figures[k + ":mean"][i]) for k in spans]
                                          for i in range(len(grid))])
    print(json.dumps(out))
""")


def _two_cpus():
    cpus = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else []
    if len(cpus) > 2:
        os.sched_setaffinity(0, cpus[:2])


@pytest.mark.long
def test_pretension_sweep_on_two_devices_finishes_and_installs_each_pretension():
    # both grids run 4 slots (3 points padded) with one time step: the second sweep loads the first's program
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    # a generous limit, so that a wedged run fails the test instead of hanging the suite
    out = subprocess.run(
        [sys.executable, "-c", PRETENSION], capture_output=True, text=True, env=env, timeout=900, preexec_fn=_two_cpus
    )
    assert out.returncode == 0, out.stderr[-3000:]
    r = json.loads(out.stdout.strip().splitlines()[-1])
    for n, grid in (("3", [300.0, 400.0, 500.0]), ("4", [200.0, 300.0, 400.0, 500.0])):
        g = r[n]
        assert g["devices"] == 2 and all(f == 0 for f in g["faults"]), g
        # progress: a line before compiling and one before running, with the counts
        assert any(l.startswith(f"compiling one program for {n} points") for l in g["lines"]), g["lines"]
        assert any(l.startswith("compiled in") and f"running {n} points" in l for l in g["lines"]), g["lines"]
        # one step for all points: 0.9 x the smallest limit (the most pretensioned belt is the shortest,
        # its elements the stiffest), below the base drive's own step for 400 N
        assert g["dt"] == pytest.approx(0.9 * min(g["limits"]), rel=1e-12)
        assert g["dt"] < r["base_dt"]
        for T, (t1, t2), single in zip(grid, g["swept"], g["single"]):
            # at rest (the driver starts at 0.05 s) both spans carry the installed tension; gravity sag and
            # the contact compliance shift it by about 0.5 %
            assert abs((t1 + t2) / 2 / T - 1) < 0.01, (T, t1, t2)
            # batched = one point at a time with the same step (different compiled programs: rounding)
            assert t1 == pytest.approx(single[0], rel=1e-9) and t2 == pytest.approx(single[1], rel=1e-9)
