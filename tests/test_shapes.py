"""The jaxtyping shape annotations of the model's data hold at run time: parameters, operators, belt path
and states of built drives (Benchmark A and the serpentine example), and states after a few steps. A
dimension name means one size throughout: n elements, p pulleys, nc contact points (checked by
helpers.check_shapes with jaxtyping's own isinstance checks, no type checker needed)."""

from pathlib import Path

import jax
import numpy as np
import pytest
from helpers import build_quietly, check_shapes

import jaxbelt as jb
from jaxbelt.dynamics import drive_operators, drive_step

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
QUAD = ("ops.belt.quad",)  # quadrature tables: a dict of small arrays, no shape annotation


def _dims(model):
    return dict(n=model.n_elements, p=model.n_pulleys, nc=model.n_contacts)


def _check_drive(drive):
    dims = _dims(drive.model)
    # the carriers' numbers: one mapping per pulley, each number of the shape its class declares (CarrierKey.shape)
    check_shapes(drive.params, dims, "params", allow_unannotated=("params.pulleys.carrier",))
    assert len(drive.params.pulleys.carrier) == dims["p"]
    for carrier, numbers in zip(drive.model.carriers, drive.params.pulleys.carrier):
        declared = {key.name: key.shape for key in carrier.keys}
        assert {k: np.shape(v) for k, v in numbers.items()} == declared, (carrier, declared)
        assert all(np.asarray(v).dtype == np.float64 for v in numbers.values())
    check_shapes(drive.state0, dims, "state0")
    check_shapes(drive.path, None, "path")  # its own k: the pulleys in path order
    assert drive.path.n_pulleys == dims["p"]
    for law in (drive.params.pulleys.speed, drive.params.pulleys.torque):  # a stack of laws, one per pulley
        assert law.times.shape[:-1] == (dims["p"],)


def _check_steps(drive, n_steps=3):
    """The operators and the states after ``n_steps`` steps, checked while tracing them (their shapes and
    dtypes are fixed then; jax.eval_shape: nothing is computed or compiled)."""
    model, dims, h = drive.model, _dims(drive.model), drive.dt

    def steps(params, state):
        ops = drive_operators(model, params)
        check_shapes(ops, dims, "ops", allow_unannotated=QUAD)
        for i in range(n_steps):
            state = drive_step(model, params, ops, state, i * h, h)
            check_shapes(state, dims, f"state after {i + 1} steps")
        return state

    jax.eval_shape(steps, drive.params, drive.state0)


@pytest.mark.parametrize(
    "spec",
    [
        lambda: jb.benchmark_a(n_elements=26, t_end=0.02),
        lambda: jb.load_config(EXAMPLES / "serpentine_tensioner.toml"),
        lambda: jb.load_config(EXAMPLES / "accessory_drive.toml"),  # lossy arm, one-way clutch
        lambda: jb.load_config(EXAMPLES / "bsg_pendulum.toml"),  # a pendulum's second idler
    ],
    ids=["benchmark_a", "serpentine_tensioner", "accessory_drive", "bsg_pendulum"],
)
def test_shapes_hold_when_built_and_after_three_steps(spec):
    drive = build_quietly(spec())
    _check_drive(drive)
    _check_steps(drive)


def test_a_wrong_size_is_reported_with_the_field_and_the_bound_sizes():
    drive = build_quietly(jb.benchmark_a(n_elements=26, t_end=0.02))
    dims = dict(_dims(drive.model), nc=drive.model.n_contacts + 1)
    with pytest.raises(AssertionError, match=r"state0\.lam_n: .*float64\[52\].*'nc'.*'nc': 53"):
        check_shapes(drive.state0, dims, "state0")
