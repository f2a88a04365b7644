"""Reference cases as DriveSpecs: Benchmark A (two equal pulleys, public ANCF benchmark) and friends.

See ``shared/reference/belt_drive_reference.md`` §3. The benchmark's belt is defined there with
respect to the *installed* length (EA = 8000 N with a -5 % pre-stretch); jaxbelt works with
stress-free quantities: EA = 0.95 * 8000 = 7600 N, eta A = 0.95 * 1 N s, rhoA = 1.0415 kg / 0.38 pi m.
"""

from __future__ import annotations

import math

from .spec import BeltSpec, ContactSpec, DriveSpec, PulleySpec, SolverSpec

__all__ = ["benchmark_a"]


def benchmark_a(
    n_elements: int = 60,
    t_end: float = 2.45,
    *,
    mu: float = 0.5,
    friction_law: str = "coulomb",
    nu_s: float = 50.0,
    load: float = 25.0,
    dt: float | None = None,
    save_dt: float = 1e-3,
    lcp_iterations: int = 8,
) -> DriveSpec:
    """Benchmark A: R = 0.1 m pulleys 0.1 pi m apart, driver ramped to 12 rad/s, 25 N m load step.

    Parameters: the nine are the benchmark's variants that tests and benchmarks choose by name (mesh,
    run length, friction law and its numbers, load, step, saves, contact iterations), each defaulting to the
    benchmark's value; a record of them would only rename them."""
    L0 = 0.38 * math.pi
    belt = BeltSpec(
        n_elements=n_elements,
        width=0.08,
        thickness=0.01,
        EA=7600.0,
        EI=1.333e-3,
        mass_per_length=1.0415 / L0,
        axial_damping=0.95,
        stress_free_length=L0,
        inner_offset=0.0,
    )  # pulley radii below are given at the belt axis
    pulleys = [
        PulleySpec("driver", (0.0, 0.0), 0.1, role="driver", inertia=0.25, speed={"ramp": [0.05, 0.6, 0.0, 12.0]}),
        PulleySpec(
            "driven",
            (0.1 * math.pi, 0.0),
            0.1,
            role="driven",
            inertia=0.25,
            load={"smooth_step": [1.0, 1.5, 0.0, load]},
            viscous=2.0,
        ),
    ]
    contact = ContactSpec(mu=mu, stiffness=3.2e8, damping=6.4e3, friction_law=friction_law, nu_s=nu_s)
    solver = SolverSpec(dt=dt, t_end=t_end, save_dt=save_dt, lcp_iterations=lcp_iterations)
    return DriveSpec(belt=belt, pulleys=pulleys, contact=contact, solver=solver, gravity=(0.0, -9.81))
