"""Sweep checks before anything is compiled: every point's values, the shared time step, and a batched
program free of LAPACK kernels (they fan out into XLA's intra-op pool and wedged sharded sweeps)."""

import dataclasses
import warnings

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt.analysis import check_together
from jaxbelt.analysis.sweep import _point_program, _shared_time_step


class _Compiling(Exception):
    pass


def _stop_at_compile(lines):
    """A progress callback that records the lines and stops the sweep where compiling would start."""

    def say(msg):
        lines.append(msg)
        if msg.startswith("compiling"):
            raise _Compiling

    return say


@pytest.fixture(scope="module")
def spec():
    return jb.benchmark_a(n_elements=26, t_end=0.02, save_dt=0.005)


@pytest.fixture(scope="module")
def drive(spec):
    return jb.build_drive(spec)


@pytest.mark.parametrize(
    "key, values, needles",
    [
        (
            "contact.mu",
            [-0.5, 0.0, 0.5],
            [
                "sweep point 1 of 3 (contact.mu = -0.5)",
                "contact.mu = -0.5: must be a finite number > 0",
                "2 of 3 points are refused",
            ],
        ),
        (
            "belt.pretension",
            [400.0, 2000.0],
            ["sweep point 2 of 2 (belt.pretension = 2000)", "a belt cannot be installed beyond 20 % strain"],
        ),
        (
            "belt.EA",
            [7600.0, -1.0],
            ["sweep point 2 of 2 (belt.EA = -1)", "belt.EA = -1.0: must be a finite number > 0"],
        ),
        ("belt.E", [1e7, 0.0], ["(belt.E = 0)", "belt.E = 0.0: must be a finite number > 0"]),
        ("belt.mass_per_length", [0.0], ["belt.mass_per_length = 0.0: must be a finite number > 0"]),
        ("pulleys.driven.radius", [0.1, 0.3], ["(pulleys.driven.radius = 0.3)", "pulleys: "]),
    ],
)
def test_out_of_range_points_are_refused_before_compiling(drive, key, values, needles):
    lines = []
    with pytest.raises(jb.ConfigError) as err:
        jb.sweep(drive, {key: values}, progress=_stop_at_compile(lines))
    for needle in needles:
        assert needle in str(err.value), str(err.value)
    assert lines == []  # refused before the time step was even chosen


def test_valid_points_pass_the_same_checks(drive):
    lines = []
    with pytest.raises(_Compiling):
        jb.sweep(
            drive,
            {"contact.mu": [0.2, 0.8], "belt.pretension": [300.0, 500.0], "pulleys.driven.radius": [0.09, 0.11]},
            progress=_stop_at_compile(lines),
        )
    assert lines[-1].startswith("compiling one program for 8 points"), lines


def test_without_solver_dt_the_step_is_the_smallest_stable_one_over_the_grid(drive):
    EA = [3800.0, 7600.0, 30400.0]
    limits = [
        jb.dynamics.stable_time_step(drive.model, jb.set_parameter(drive, drive.params, "belt.EA", v)) for v in EA
    ]
    # what went wrong before: the configuration's own step, run for the four times stiffer belt, is above
    # that point's stability limit
    assert drive.dt > limits[2]
    dt, note = _shared_time_step(drive, ["belt.EA"], np.array(EA)[:, None])
    assert dt == pytest.approx(0.9 * min(limits), rel=1e-12) and dt < drive.dt
    lines = []
    with pytest.raises(_Compiling):
        jb.sweep(drive, {"belt.EA": EA}, progress=_stop_at_compile(lines))
    assert "point 3: belt.EA = 30400" in lines[0], lines


def test_a_given_solver_dt_above_a_points_limit_is_refused_naming_the_point(spec):
    base = jb.build_drive(spec)
    drive = jb.build_drive(dataclasses.replace(spec, solver=dataclasses.replace(spec.solver, dt=base.dt)))
    stiff = jb.dynamics.stable_time_step(drive.model, jb.set_parameter(drive, drive.params, "belt.EA", 30400.0))
    with pytest.raises(jb.ConfigError) as err:
        jb.sweep(drive, {"belt.EA": [7600.0, 30400.0]})
    msg = str(err.value)
    assert msg.startswith(
        f"solver.dt = {base.dt!r}: exceeds the stability limit {stiff:.4g} s of sweep point 2 of 2 (belt.EA = 30400"
    ), msg
    assert f"use solver.dt <= {0.9 * stiff:.4g} s" in msg, msg
    # a softer belt is fine with the given step, and the sweep keeps it
    dt, note = _shared_time_step(drive, ["belt.EA"], np.array([[3800.0], [7600.0]]))
    assert dt == base.dt and "(solver.dt)" in note


def test_batched_program_has_no_lapack_kernel_for_any_key(drive):
    # Varying every key at once batches everything that can be batched (mass matrix, installed path, ...).
    # (of keys that set the same quantity, e.g. belt.E and belt.EA, one: set_parameters refuses both)
    keys = []
    for k in jb.parameter_keys(drive):
        try:
            check_together(drive, keys + [k])
            keys.append(k)
        except jb.ConfigError:
            pass
    assert {"belt.E", "belt.pretension", "belt.mass_per_length", "contact.mu"} <= set(keys)
    base = np.array([float(jb.get_parameter(drive, drive.params, k)) for k in keys])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        text = (
            jax.jit(jax.vmap(_point_program(drive, keys, None, None, 0.2)))
            .lower(jnp.asarray(np.stack([base, 1.01 * base])))
            .as_text()
        )
    assert "stablehlo.while" in text  # the whole batched run (its loops) is in the text the check reads
    assert "lapack" not in text.lower()  # a LAPACK kernel would be a custom call named lapack_...
