"""Contact states and fault codes are named IntEnums (``jaxbelt.ContactState``, ``jaxbelt.dynamics.Fault``) with
user messages; they equal the integers stored in arrays and files, and the summary's status text
comes from ``Fault.message``."""

import equinox as eqx
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt import ContactState
from jaxbelt.dynamics import Fault
from jaxbelt.outputs.contact import FREE, SLIP, STICK


def test_values_and_messages():
    assert [int(s) for s in ContactState] == [0, 1, 2]
    assert [s.name for s in ContactState] == ["FREE", "STICK", "SLIP"]
    assert [s.message for s in ContactState] == ["free", "stick", "slip"]
    assert [int(f) for f in Fault] == [0, 1, 2, 3]
    assert [f.name for f in Fault] == ["OK", "NONFINITE", "PENETRATION", "SAVES_LOST"]
    assert [f.message for f in Fault][:3] == ["ok", "non-finite state", "belt penetrated a pulley"]
    assert Fault.SAVES_LOST.message.startswith("saved history not recorded")
    # the module constants of the contact outputs are the members themselves
    assert (FREE, STICK, SLIP) == (0, 1, 2)
    assert FREE is ContactState.FREE and STICK is ContactState.STICK and SLIP is ContactState.SLIP
    assert Fault(int(np.float64(2.0))) is Fault.PENETRATION


@pytest.fixture(scope="module")
def short_run():
    # Benchmark A on a coarse mesh (26 elements), 20 ms after the settle phase: cheap, no fault.
    return jb.run(jb.benchmark_a(n_elements=26, t_end=0.02, save_dt=2e-3))


def test_summary_status_comes_from_fault_message(short_run):
    r = short_run
    final = r.trajectory.final
    assert Fault(int(final.fault)) is Fault.OK
    tr = r.trajectory
    for code in (Fault.NONFINITE, Fault.PENETRATION):
        bad = eqx.tree_at(lambda s: (s.fault, s.fault_time), final, (jnp.asarray(float(code)), jnp.asarray(0.0125)))
        status = jb.summary(r.drive, tr.ts, tr.states, bad)["status"]
        assert status.startswith(f"diverged at t = 0.0125 s ({code.message}): reduce solver.dt"), status
        other = Fault.PENETRATION if code is Fault.NONFINITE else Fault.NONFINITE
        assert other.message not in status


def test_contact_states_compare_equal_to_members(short_run):
    r = short_run
    dist = jb.contact_distribution(r.drive, r.trajectory.final)
    for name, d in dist.items():
        st = d["state"]
        assert st.dtype.kind == "i"
        assert set(np.unique(st).tolist()) <= set(ContactState)
        # the belt wraps both pulleys: some points touch, and every point is exactly one state
        touching = st != ContactState.FREE
        assert touching.any(), name
        n_each = [int(np.sum(st == s)) for s in ContactState]
        assert sum(n_each) == st.size
        assert n_each == [int(np.sum(st == k)) for k in (0, 1, 2)]


def test_step_produces_fault_members():
    drive = jb.build_drive(jb.benchmark_a(n_elements=26, t_end=0.02))
    ops = jb.dynamics.drive_operators(drive.model, drive.params)
    s0 = drive.state0
    step = eqx.filter_jit(lambda s, t: jb.dynamics.drive_step(drive.model, drive.params, ops, s, t, drive.dt))
    ok = step(s0, 0.0)
    assert ok.fault.dtype == s0.fault.dtype and float(ok.fault) == Fault.OK
    nan = step(eqx.tree_at(lambda s: s.q, s0, s0.q.at[0, 0, 0].set(jnp.nan)), 0.0)
    assert float(nan.fault) == Fault.NONFINITE and float(nan.fault_time) == 0.0
    # Belt pulled 60 % of the way toward the pulley centres: far deeper than the allowance.
    centers = jnp.asarray(np.asarray(drive.params.pulleys.center)).mean(axis=0)
    squeezed = s0.q.at[:, 0, :].set(centers + 0.4 * (s0.q[:, 0, :] - centers))
    deep = step(eqx.tree_at(lambda s: s.q, s0, squeezed), 0.0)
    assert float(deep.fault) == Fault.PENETRATION
    # the first fault sticks
    assert float(step(nan, drive.dt).fault) == Fault.NONFINITE
