"""Random valid drives (property-based): 2-5 pulleys of random radii around a random ellipse, one
speed-driven driver, the others driven (with a load) or idlers, belt data in realistic ranges, run
for 0.5 s (a start-up: solver.expect_steady = false): no NaN, no gross slip, status "ok", and the belt
stays on its pulleys (every pulley still has contact at the end; every node stays within 10 % of the
smallest radius of the installed path, or in a free span within 3 % of its length if that is more: spans
may vibrate).

Every drive traces and compiles anew (its own pulley and element counts and time step: about 10 s
each), so there are few examples (1 drawn, plus one 4-pulley and one 5-pulley drive always) and
they are derandomized: CI runs the same drives every time.
"""

from __future__ import annotations

import math
import time
import warnings

import numpy as np
import pytest
from helpers import state_at
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import jaxbelt as jb
from jaxbelt.dynamics import BeltNumbers, rate_bounds, step_limit

T_END = 0.5
TOLERANCE = 0.10  # of the smallest radius: how far a node may leave the installed path on a pulley
SPAN_TOLERANCE = 0.03  # of the span's length: transverse vibration allowed in a free span
LOG: list = []  # one line per drive tried (printed with -s)
MAX_ELEMENT_STEPS = 2e6  # elements x steps of one drive (a few seconds of run time): larger drawings are redrawn


def random_drive(k: int, seed: int) -> jb.DriveSpec:
    """A valid drive of ``k`` pulleys from ``seed``: draws are repeated until the layout passes
    ``check_belt_path`` with every wrap >= 30 deg and every span >= 5 cm, the static sag of the spans
    is small and the run is not too costly (``MAX_ELEMENT_STEPS``)."""
    rng = np.random.default_rng(seed)
    for _ in range(10000):
        radii = rng.uniform(0.04, 0.12, k)
        a, b = rng.uniform(0.12, 0.35), rng.uniform(0.12, 0.35)
        rot = rng.uniform(0, 2 * np.pi)
        angles = np.sort(rng.uniform(0, 2 * np.pi, k)) if k > 2 else np.array([0.0, np.pi])
        local = np.stack([a * np.cos(angles), b * np.sin(angles)], axis=1)
        centers = local @ np.array([[np.cos(rot), np.sin(rot)], [-np.sin(rot), np.cos(rot)]])
        try:
            jb.geometry.check_belt_path(centers, radii, (1,) * k)
        except ValueError:
            continue
        path = jb.geometry.belt_path(centers, radii, (1,) * k)
        if int(path.orientation) != 1:  # listed counter-clockwise: the belt travels in list order
            continue
        wraps, spans = np.asarray(path.wrap_angle), np.asarray(path.span_length)
        if wraps.min() < np.radians(30) or spans.min() < 0.05:
            continue
        EA = float(rng.uniform(2e3, 2e4))
        m = float(rng.uniform(0.05, 0.5))
        EI = float(10 ** rng.uniform(-4, -2))
        T0 = float(rng.uniform(50, 500))
        gravity = (0.0, -9.81) if rng.random() < 0.7 else (0.0, 0.0)
        sag = m * abs(gravity[1]) * spans.max() ** 2 / (8 * 0.7 * T0)  # at the loaded slack side
        if sag > 0.3 * TOLERANCE * radii.min():
            continue
        L_path = float(path.length)
        n = max(16, math.ceil(2 * L_path / radii.min()))  # element length <= radius / 2
        damping = EA * float(rng.uniform(2e-5, 1e-4))
        dt = 0.9 * step_limit(*rate_bounds(n, BeltNumbers(EA, EI, damping, 0.0, m, L_path / (1 + T0 / EA))))
        if n * (T_END + 0.1) / dt > MAX_ELEMENT_STEPS:  # keep the suite's run time bounded
            continue
        driver = int(rng.integers(k))
        omega = float(rng.uniform(10, 40))
        mu = float(rng.uniform(0.3, 0.6))
        # loads within what friction transmits: a pulley wrapped by theta carries at most a tension
        # difference 2 T0 (e^(mu theta) - 1) / (e^(mu theta) + 1); all loads together stay below 40 %
        # of what the driver can pass on
        grip = np.exp(mu * wraps)
        capacity = 2 * T0 * (grip - 1) / (grip + 1)  # N, per pulley
        loaded = rng.random(k) < 0.6
        loaded[driver] = False
        force = np.where(loaded, rng.uniform(0.0, 0.3, k) * capacity, 0.0)  # N, load torque / radius
        force *= min(1.0, 0.4 * capacity[driver] / max(force.sum(), 1e-12))
        pulleys = []
        for i in range(k):
            name = f"p{i}"
            inertia = float(rng.uniform(0.5, 2.0) * 40 * radii[i] ** 4 + 2e-4)  # a steel-ish disc
            if i == driver:
                pulleys.append(
                    jb.PulleySpec(
                        name,
                        tuple(centers[i]),
                        float(radii[i]),
                        role="driver",
                        inertia=inertia,
                        speed={"smooth_step": [0.0, 0.15, 0.0, omega]},
                    )
                )
            elif loaded[i]:
                pulleys.append(
                    jb.PulleySpec(
                        name,
                        tuple(centers[i]),
                        float(radii[i]),
                        role="driven",
                        inertia=inertia,
                        load={"smooth_step": [0.2, 0.3, 0.0, float(force[i] * radii[i])]},
                        viscous=float(rng.uniform(0, 2e-3)),
                    )
                )
            else:
                pulleys.append(jb.PulleySpec(name, tuple(centers[i]), float(radii[i]), role="idler", inertia=inertia))
        belt = jb.BeltSpec(
            n_elements=n,
            EA=EA,
            EI=EI,
            mass_per_length=m,
            axial_damping=damping,
            pretension=T0,
            inner_offset=0.0,
            back_offset=0.0,
        )
        contact = jb.ContactSpec(mu=mu, stiffness=1e8, damping=2e3)
        solver = jb.SolverSpec(t_end=T_END, save_dt=5e-3, expect_steady=False)  # 0.5 s of a start-up
        return jb.DriveSpec(belt=belt, pulleys=pulleys, contact=contact, solver=solver, gravity=gravity)
    raise AssertionError(f"k = {k}, seed {seed}: no valid layout in 10000 draws")


def _offsets(path, points: np.ndarray, r_min: float, samples: int = 20000):
    """Distance of each point from the installed path, and what it may be there: TOLERANCE x the
    smallest radius along the pulley arcs; in a free span also SPAN_TOLERANCE x the span's length
    (a span may vibrate transversely; that is not the belt leaving a pulley)."""
    s = np.linspace(0.0, float(path.length), samples, endpoint=False)
    pos = np.asarray(jb.geometry.point_on_path(path, s)[0])
    seg = np.searchsorted(np.asarray(path.segment_start_s), s, side="right") - 1  # arc i = 2i, span i = 2i + 1
    span_len = np.asarray(path.span_length)[seg // 2]
    allowed = np.where(seg % 2 == 0, TOLERANCE * r_min, np.maximum(TOLERANCE * r_min, SPAN_TOLERANCE * span_len))
    d = np.linalg.norm(points[:, None, :] - pos[None, :, :], axis=-1)
    nearest = d.argmin(axis=1)
    return d[np.arange(len(points)), nearest], allowed[nearest], seg[nearest] % 2 == 0


@pytest.mark.long
@settings(max_examples=1, derandomize=True, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(2, 5), st.integers(0, 2**32 - 1))
@example(4, 2026)  # the larger drives, whatever the draws: 4 and 5 pulleys
@example(5, 2026)
def test_random_valid_drive_runs_and_keeps_its_belt(k, seed):
    spec = random_drive(k, seed)
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the generator respects element length <= radius / 2
        result = jb.run(spec)
    wall = time.perf_counter() - t0
    drive = result.drive
    LOG.append(
        f"k {k}, seed {seed}: {len(spec.pulleys)} pulleys "
        f"({', '.join(p.role for p in spec.pulleys)}), {spec.belt.n_elements} elements, "
        f"EA {spec.belt.EA:.0f} N, m {spec.belt.mass_per_length:.3f} kg/m, T0 {spec.belt.pretension:.0f} N, "
        f"dt {drive.dt:.2e} s, {result.timing['num_steps']} steps, compile {result.timing['compile_s']:.1f} s, "
        f"run {result.timing['run_s']:.1f} s, wall {wall:.1f} s: {result.summary['status']}, "
        f"contact-solver residual median {result.summary.get('lcp_residual_median', float('nan')):.1e}"
    )
    print("\n" + LOG[-1])

    assert result.summary["status"] == "ok", LOG[-1]
    assert np.isclose(result.ts[-1], T_END, atol=spec.solver.save_dt)
    for name, values in result.signals.items():
        assert np.all(np.isfinite(values)), f"{name} has non-finite values ({LOG[-1]})"

    last = state_at(result.trajectory.states, -1)
    contact = jb.contact_distribution(drive, last)
    for name, c in contact.items():
        assert np.any(c["state"] != jb.ContactState.FREE), f"pulley {name}: the belt has left it ({LOG[-1]})"

    nodes = np.asarray(last.q)[:, 0, :]
    r_min = float(np.min(np.asarray(drive.params.pulleys.radius)))
    off, allowed, on_arc = _offsets(drive.path, nodes, r_min)
    arc_off = off[on_arc].max() if on_arc.any() else 0.0
    LOG[-1] += (
        f", max node offset on the arcs {arc_off * 1e3:.2f} mm ({100 * arc_off / r_min:.1f} % of r_min), "
        f"anywhere {off.max() * 1e3:.2f} mm ({100 * np.max(off / allowed):.0f} % of its allowance)"
    )
    k = int(np.argmax(off / allowed))
    assert np.all(off < allowed), (
        f"node {k} is {off[k] * 1e3:.2f} mm off the installed path "
        f"({'on a pulley' if on_arc[k] else 'in a span'}; "
        f"allowed {allowed[k] * 1e3:.2f} mm; "
        f"{LOG[-1]})"
    )
    # the driver follows its prescribed speed, the others turn the same way (the belt drives them)
    omegas = {p.name: result.signals[f"omega:{p.name}"][-1] for p in spec.pulleys}
    for p in spec.pulleys:
        assert omegas[p.name] > 0, (p.name, omegas, LOG[-1])


def test_zz_random_drives_log():
    """Prints what the property test tried (run with -s)."""
    if not LOG:
        pytest.skip("the property test did not run")
    print("\nrandom drives tried:\n" + "\n".join(LOG))
