"""The signal registry: every signal has a unit, and the traced signals (``simulate_signals``) agree
with the run's numpy signals (``signals.csv``) for every name."""

from pathlib import Path

import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt.outputs import QUANTITIES, quantity_of, signal_columns, signal_units

SERPENTINE = Path(__file__).resolve().parents[1] / "examples" / "serpentine_tensioner.toml"
T_END = 0.05  # as test_determinism.py and test_interrupt.py: the same compiled program (persistent cache)


@pytest.fixture(scope="module")
def serpentine():
    spec = jb.load_config(SERPENTINE)
    spec.solver.t_end = T_END
    return jb.run(spec)


def test_every_signal_has_a_unit_and_a_known_quantity(serpentine):
    drive = serpentine.drive
    names = jb.signal_names(drive)
    assert names == list(serpentine.signals)[1:]  # the run's columns after t, in the same order
    units = signal_units(drive)
    assert list(units) == ["t", *names]
    for name, q in signal_columns(drive):
        assert q in QUANTITIES and quantity_of(name) is q
        assert units[name] and name.startswith(q.prefix + ":")
    kinds = {quantity_of(n).prefix for n in names}
    fead = {"slip", "friction_use", "hub_load", "hub_direction", "speed", "deflection"}  # outputs/fead.py
    assert kinds == {"omega", "torque", "tension", "arm_angle", *fead}, kinds  # the serpentine has an arm tensioner
    assert units["omega:crank"] == "rad/s" and units["arm_angle:tensioner"] == "rad"


def test_traced_and_numpy_signals_agree(serpentine):
    """The traced signals (gradients, identify, sweeps) and the numpy ones (run's outputs) of the same states.
    (run integrates in compiled chunks, simulate in one program: their trajectories agree to round-off,
    tests/test_resume.py; here both signal paths read the run's own states.)"""
    from jaxbelt.outputs.signals import signals_of

    traj = serpentine.trajectory
    ts, traced = traj.ts, signals_of(serpentine.drive, serpentine.drive.params, traj.states)
    numpy_ = serpentine.signals
    np.testing.assert_array_equal(np.asarray(ts), numpy_["t"])
    assert list(traced) == list(numpy_)[1:]
    for name, value in traced.items():
        ref = numpy_[name]
        scale = max(float(np.max(np.abs(ref))), 1.0)
        np.testing.assert_allclose(np.asarray(value), ref, rtol=0, atol=1e-12 * scale, err_msg=name)


def test_file_layout_documents_every_quantity_with_its_unit():
    from jaxbelt import io

    for q in QUANTITIES:
        assert f"``{q.pattern}`` [{q.unit}]" in io.__doc__, q
