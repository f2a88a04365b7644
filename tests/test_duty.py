"""Duty-point study (one batched sweep over driver speeds and loads) against closed forms: the tension
difference Q / R, the accessory torque from its power P / omega, the hub load as the vector sum of the span
tensions, and the slip safety factor from the run's own effective tensions."""

import math
import subprocess
import sys

import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt.analysis.duty import duty_study

pytestmark = pytest.mark.filterwarnings("ignore:pulley .* is wrapped by belt elements")


@pytest.fixture(scope="module")
def duty(tmp_path_factory):
    spec = jb.benchmark_a(n_elements=20, t_end=1.2, save_dt=0.005)
    # as configured, a start-up (speed ramp to 0.3 s, load to 0.35 s); the duty study runs each point
    # from a running start with its load ramped in over 0.3 s; the figures average 0.72-1.2 s (three
    # periods of the driven pulley's torsional mode, ~7 Hz)
    spec.pulleys[0].speed = {"ramp": [0.05, 0.3, 0.0, 12.0]}
    spec.pulleys[1].load = {"smooth_step": [0.1, 0.35, 0.0, 10.0]}
    spec.pulleys[1].viscous = 0.1
    drive = jb.build_drive(spec)
    out = tmp_path_factory.mktemp("duty")
    # 0.2 and 0.3 kW at 300 and 600 rpm of the driver (the driven pulley, same radius, turns as fast); a third
    # point loaded far beyond what the belt can carry (60 N m: T1 - T2 = 600 N against T0 ~ 380 N, e^{mu pi} = 4.8)
    res = duty_study(
        drive,
        [300.0, 600.0, 300.0],
        torques={"driven": [200.0 / (300 * math.pi / 30), 300.0 / (600 * math.pi / 30), 60.0]},
        window=0.4,
        load_ramp=0.3,
        out_dir=out,
    )
    return drive, res


def test_loads_tensions_hub_loads_and_safety_follow_the_closed_forms(duty):
    drive, res = duty
    R = float(drive.params.pulleys.radius[1])
    omega = np.array([300.0, 600.0]) * 2 * math.pi / 60
    np.testing.assert_allclose(res.loads["driven"][:2], np.array([200.0, 300.0]) / omega, rtol=1e-12)  # P / omega
    assert np.all(res.faults == 0)
    ok = slice(0, 2)
    tight, slack = res.spans["driven-driver"]["tension"][ok], res.spans["driver-driven"]["tension"][ok]
    Q = res.loads["driven"][ok] + float(drive.params.pulleys.viscous[1]) * res.pulleys["driven"]["speed"][ok]
    # steady: the belt's torque on the driven pulley is the load Q (1 %) ...
    np.testing.assert_allclose(res.pulleys["driven"]["torque"][ok], Q, rtol=0.01)
    # ... and T1 - T2 = Q / R. The mid-span tensions of this 20-element mesh at 3-6 m/s carry a bias
    # measured at +1.5 ... +4.2 % of Q / R whatever the start (rest or running) and the mesh (20, 32, 48
    # elements: +4.2, +2.7, +2.3 % at 600 rpm), against +0.3 % for Benchmark A at 1.2 m/s: 5 % here
    np.testing.assert_allclose(np.abs(tight - slack), Q / R, rtol=0.05)
    m, EA = float(drive.params.belt.mass_per_length), float(drive.params.belt.EA)
    # T_eff at the span's own mean belt speed: the tight span runs onto the driver's entry stick arc, at the
    # driver's surface speed (0.5 %)
    v = res.spans["driven-driver"]["speed"][ok]
    np.testing.assert_allclose(v, omega * float(drive.params.pulleys.radius[0]), rtol=5e-3)
    m_cur = m / (1.0 + tight / EA)  # per current length, at the span's tension
    np.testing.assert_allclose(res.spans["driven-driver"]["tension_eff"][ok], tight - m_cur * v**2, rtol=1e-12)
    # parallel spans of equal pulleys: hub load = T1e + T2e, the effective tensions (the centrifugal part
    # m'v^2 of the tension is carried by the belt's own inertia on the arc, not by the hub); 1 %
    eff = res.spans["driven-driver"]["tension_eff"][ok] + res.spans["driver-driven"]["tension_eff"][ok]
    np.testing.assert_allclose(res.pulleys["driven"]["hub_load"][ok], eff, rtol=0.01)
    mu = float(drive.params.mu)
    t1, t2 = res.spans["driven-driver"]["tension_eff"][ok], res.spans["driver-driven"]["tension_eff"][ok]
    np.testing.assert_allclose(
        res.pulleys["driven"]["slip_safety"][ok], mu * math.pi / np.abs(np.log(t1 / t2)), rtol=1e-9
    )
    header, rows = res.rows()
    assert header[0] == "rpm" and header[-1] == "steady" and rows.shape == (3, len(header))


def test_points_start_running_and_are_checked_for_steadiness(duty):
    """A duty point is steady operation, not a start-up: at t = 0 the driven pulley already turns with the
    belt (running start), and each point's window goes through the run's steadiness and gross-slip checks."""
    drive, res = duty
    assert list(res.steady) == [True, True, False]
    assert res.status[:2] == ["ok", "ok"]
    assert res.status[2].startswith("gross slip") and "'driven'" in res.status[2]
    with np.load(res.signals_file) as z:
        t, w_driver, w_driven = z["t"], z["omega:driver"], z["omega:driven"]
    assert t[0] == 0.0
    # the same radius: at t = 0 both turn at the driver's speed (before the load comes in), 0.1 %
    np.testing.assert_allclose(w_driven[:2, 0], [10 * math.pi, 20 * math.pi], rtol=1e-3)
    np.testing.assert_allclose(w_driver[:2, 0], [10 * math.pi, 20 * math.pi], rtol=1e-12)
    # the overloaded point: the driven pulley falls far behind the belt (gross slip), not creep (~1 %)
    assert res.pulleys["driven"]["speed"][2] < 0.9 * 10 * math.pi


def test_bad_duty_input_is_refused_before_compiling(duty):
    drive, _ = duty
    with pytest.raises(jb.ConfigError, match="one finite value >= 0 per speed"):
        duty_study(drive, [300.0, 600.0], torques={"driven": [1.0]})
    with pytest.raises(jb.ConfigError, match="did you mean 'driven'"):
        duty_study(drive, [300.0], powers={"drivn": [0.1]})
    with pytest.raises(jb.ConfigError, match="only driven pulleys"):
        duty_study(drive, [300.0], torques={"driver": [1.0]})
    with pytest.raises(jb.ConfigError, match="speed > 0"):
        duty_study(drive, [0.0])
    for argv in (
        ["duty", "x.toml", "--rpm", "a,b"],
        ["duty", "x.toml", "--rpm", "800", "--load-ramp", "-0.1"],
        ["identify", "x.toml", "--measured", "m.csv", "--fit", "belt.E", "--iterations", "0"],
    ):
        out = subprocess.run([sys.executable, "-m", "jaxbelt", *argv], capture_output=True, text=True, timeout=120)
        assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1, (argv, out.stderr)


def test_a_torque_law_that_switches_in_time_becomes_a_duty_points_load():
    """A duty point holds each accessory at its final load, ramped in from 0: a driven pulley given by a
    ``torque`` law too (the BSG example's starter-generator, -8 N m generator until 0.3 s then +8 N m motor).
    Left as configured, a point's load (``pulleys.sg.load = 8``) scaled the whole law by -1: the point motored
    8 N m until 0.3 s, where its window lay, and reported the motor's tensions as the generator's."""
    from helpers import EXAMPLES

    from jaxbelt.analysis.duty import _running_drive

    drive = jb.build_drive(jb.load_config(EXAMPLES / "bsg_pendulum.toml"))
    running = _running_drive(drive, 0.075)
    i = running.model.pulley_names.index("sg")
    assert running.spec.pulleys[i].torque == {"smooth_step": [0.0, 0.075, 0.0, 8.0]}  # its final value, ramped in
    params = jb.set_parameter(running, running.params, "pulleys.sg.load", 8.0)
    law = np.asarray(params.pulleys.torque.values[i])
    sense = running.running_sense[i]
    assert law[0] == 0.0 and law[-1] * sense == pytest.approx(-8.0)  # a brake of 8 N m against the running sense


def test_a_motoring_point_needs_a_pulley_with_a_torque_law():
    """A negative duty torque drives the belt: accepted on a pulley configured with a ``torque`` law (the BSG
    example's starter-generator, a boost point), refused on a brake (``load``/``power_kw``), where a negative value
    is more likely a sign slip than a motor. Measured with ``jaxbelt duty --torque sg=8,-8`` (800 / 1,500 rpm,
    0.3 s): the arm at -69.32 / -62.78 deg, the statics' -69.35 / -62.81 deg."""
    from helpers import EXAMPLES

    from jaxbelt.analysis.duty import _load_columns

    bsg = jb.build_drive(jb.load_config(EXAMPLES / "bsg_pendulum.toml"))
    loads = _load_columns(bsg, np.array([800.0, 1500.0]), {"sg": [8.0, -8.0]}, {})
    np.testing.assert_array_equal(loads["sg"], [8.0, -8.0])
    brake = jb.build_drive(jb.benchmark_a(n_elements=20, t_end=0.1))
    with pytest.raises(jb.ConfigError, match="a negative .driving. value needs a pulley configured with a torque law"):
        _load_columns(brake, np.array([300.0]), {"driven": [-1.0]}, {})
