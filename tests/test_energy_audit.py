"""Energy audit: stored energy change equals the work of motors, loads, damping and contact (1 %)."""

import numpy as np

import jaxbelt as jb


def test_benchmark_a_energy_balance_closes_within_1_percent():
    r = jb.run(jb.benchmark_a(n_elements=30, t_end=2.45, save_dt=1e-2))
    a = r.summary["energy"]
    # measured 0.044 % at 40 elements over the full benchmark (949 J supplied)
    assert abs(a["residual_relative"]) < 0.01, a
    # the terms carry physics: the load absorbs most of the driver work, friction slip is the
    # creep loss (~ torque x speed loss x time in steady state), dissipations are non-negative
    assert a["work_absorbed_by_loads_J"] > 0.8 * a["work_supplied_J"]
    assert a["friction_slip_J"] > 0 and a["belt_damping_J"] >= 0
    assert a["contact_damping_J"] > -1e-6 * a["work_supplied_J"]
    ts = r.signals["t"]
    steady = ts > 2.0
    creep_loss_rate = np.mean(r.signals["torque:driven"][steady]) * (12.0 - np.mean(r.signals["omega:driven"][steady]))
    assert creep_loss_rate > 0
