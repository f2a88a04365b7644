"""One diffrax step = several Moreau–Jean steps (``MoreauJean.substeps``, chosen in ``simulate``).

Macro-stepping must not change the physics: on a time grid where settle phase, save interval and run
all hold whole macro steps, the trajectory equals the one taken a step per diffrax step, to round-off
(the inner time and step size are formed as t0 + i h/k instead of by diffrax, nothing else differs).
"""

from __future__ import annotations

import importlib

import numpy as np
import pytest

import jaxbelt as jb

# the module itself: jaxbelt.dynamics.simulate (the attribute) is the function the room re-exports
simulate_module = importlib.import_module("jaxbelt.dynamics.simulate")


@pytest.mark.parametrize("k", [1, 7, 30])
def test_substeps_choice_divides_the_save_stride(k):
    stride = {1: 1, 7: 35, 30: 30}[k]  # 35 = 5 x 7: the largest divisor up to 32
    assert simulate_module._substeps(stride) == k
    assert stride % simulate_module._substeps(stride) == 0


@pytest.mark.long
@pytest.mark.filterwarnings("ignore:pulley .* is wrapped by belt elements")  # 24 elements: coarse on purpose
def test_macro_steps_reproduce_single_steps_to_round_off(monkeypatch):
    drive = jb.build_drive(jb.benchmark_a(n_elements=24, t_end=0.1))
    dt = drive.dt
    # 10 steps per save, 300 settle steps, 3000 run steps: every boundary is a whole number of macro steps
    kw = dict(t_end=3000 * dt, dt=dt, save_dt=10 * dt, settle_time=300 * dt)
    runs = {}
    for max_sub in (1, 32):
        monkeypatch.setattr(simulate_module, "MAX_SUBSTEPS", max_sub)
        traj = simulate_module.simulate(drive.model, drive.params, drive.state0, **kw)
        runs[max_sub] = traj
    one, macro = runs[1], runs[32]
    assert simulate_module._substeps(10) == 10
    assert int(one.num_steps) == int(macro.num_steps) == 3300
    np.testing.assert_array_equal(np.asarray(one.ts), np.asarray(macro.ts))
    w1, w2 = np.asarray(one.states.omega), np.asarray(macro.states.omega)
    # 3300 steps of a contact problem with stick/slip: round-off grows but stays far below the physics
    np.testing.assert_allclose(w2, w1, rtol=0, atol=1e-9 * np.abs(w1).max())
    q1, q2 = np.asarray(one.states.q), np.asarray(macro.states.q)
    np.testing.assert_allclose(q2, q1, rtol=0, atol=1e-11)
