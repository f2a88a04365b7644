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
def duty():
    spec = jb.benchmark_a(n_elements=20, t_end=1.2, save_dt=0.005)
    # steady early: the speed ramp ends at 0.3 s, the load at 0.35 s; the figures average 0.72-1.2 s
    # (three periods of the driven pulley's torsional mode, ~7 Hz)
    spec.pulleys[0].speed = {"ramp": [0.05, 0.3, 0.0, 12.0]}
    spec.pulleys[1].load = {"smooth_step": [0.1, 0.35, 0.0, 10.0]}
    spec.pulleys[1].viscous = 0.1
    drive = jb.build_drive(spec)
    # 0.2 and 0.3 kW at 300 and 600 rpm of the driver (the driven pulley, same radius, turns as fast)
    return drive, duty_study(drive, [300.0, 600.0], powers={"driven": [0.2, 0.3]}, window=0.4)


def test_loads_tensions_hub_loads_and_safety_follow_the_closed_forms(duty):
    drive, res = duty
    R = float(drive.params.pulleys.radius[1])
    omega = np.array([300.0, 600.0]) * 2 * math.pi / 60
    np.testing.assert_allclose(res.loads["driven"], np.array([200.0, 300.0]) / omega, rtol=1e-12)  # P / omega
    assert np.all(res.faults == 0)
    tight, slack = res.spans["driven-driver"]["tension"], res.spans["driver-driven"]["tension"]
    Q = res.loads["driven"] + float(drive.params.pulleys.viscous[1]) * res.pulleys["driven"]["speed"]
    np.testing.assert_allclose(np.abs(tight - slack), Q / R, rtol=0.02)  # steady: T1 - T2 = Q / R
    m = float(drive.params.belt.mass_per_length)
    v = omega * float(drive.params.pulleys.radius[0])
    np.testing.assert_allclose(res.spans["driven-driver"]["tension_eff"], tight - m * v**2, rtol=1e-12)
    # parallel spans of equal pulleys: hub load = T1e + T2e, the effective tensions (the centrifugal part
    # m'v^2 of the tension is carried by the belt's own inertia on the arc, not by the hub); 1 %
    eff = res.spans["driven-driver"]["tension_eff"] + res.spans["driver-driven"]["tension_eff"]
    np.testing.assert_allclose(res.pulleys["driven"]["hub_load"], eff, rtol=0.01)
    mu = float(drive.params.mu)
    t1, t2 = res.spans["driven-driver"]["tension_eff"], res.spans["driver-driven"]["tension_eff"]
    np.testing.assert_allclose(res.pulleys["driven"]["slip_safety"], mu * math.pi / np.abs(np.log(t1 / t2)), rtol=1e-9)
    header, rows = res.rows()
    assert header[0] == "rpm" and rows.shape == (2, len(header))


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
    out = subprocess.run(
        [sys.executable, "-m", "jaxbelt", "duty", "x.toml", "--rpm", "a,b"], capture_output=True, text=True, timeout=120
    )
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1
