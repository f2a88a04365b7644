"""A run's summary window is checked before its figures are sold as a duty point (outputs.steadiness):
prescribed laws still changing, speeds / tensions / arm drifting, a pulley (the driver too) in gross slip;
the running start (solver.start = "running") that duty points use; belt speeds a belt cannot run refused."""

import math
import subprocess
import sys

import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt.analysis.run import run
from jaxbelt.config import dump_toml
from jaxbelt.outputs.steadiness import DRIFT_SPEED, _fit, laws_end

pytestmark = pytest.mark.filterwarnings("ignore:pulley .* is wrapped by belt elements")


def test_trend_and_level_see_through_partial_periods_of_the_engine_orders():
    """A drift of 3 units over a window of 2.4 periods of an order whose amplitude is 40: the fit with the
    order's harmonics returns the drift and the level to 1e-9 (a straight line fitted alone is off by ~20 %)."""
    t = np.linspace(0.3, 0.36, 121)
    w = 2 * math.pi * 40.0  # the fundamental: 40 Hz, 2.4 periods in the window
    x = 100.0 + 50.0 * (t - 0.33) + 40.0 * np.sin(w * t + 0.3) + 7.0 * np.cos(2 * w * t)
    level, trend = _fit(t, x, [w])
    assert abs(trend - 3.0) < 1e-9 and abs(level - 100.0) < 1e-9
    _, plain = _fit(t, x, [])
    assert abs(plain - 3.0) > 0.5  # why the orders are fitted
    # no full period in the window: nothing fitted, no ill-posed fit
    assert math.isfinite(_fit(t, x, [2 * math.pi * 5.0])[1])


def _spec(**kw):
    spec = jb.benchmark_a(n_elements=20, t_end=kw.pop("t_end", 1.0), save_dt=0.002)
    for k, v in kw.items():
        setattr(spec.solver, k, v)
    return spec


def test_laws_end_is_the_last_change_of_any_speed_or_load_law():
    spec = _spec()
    spec.pulleys[1].load = {"smooth_step": [0.2, 0.4, 0.0, 10.0]}
    assert laws_end(jb.build_drive(spec)) == pytest.approx(0.6)  # the driver's ramp ends at 0.6 s
    spec.pulleys[0].speed = 12.0
    assert laws_end(jb.build_drive(spec)) == pytest.approx(0.4)
    spec.pulleys[1].load = 10.0
    assert laws_end(jb.build_drive(spec)) == 0.0


@pytest.fixture(scope="module")
def driver_slips():
    """Benchmark A with a slippery driver (mu 0.12) and a grippy driven pulley (mu 0.8) under 10 N m: the belt
    sticks to the driven pulley and slides over the whole arc of the driver, whose speed is prescribed
    (the old check looked at free pulleys only)."""
    spec = _spec()
    spec.pulleys[0].mu = 0.12
    spec.pulleys[1].mu = 0.8
    spec.pulleys[1].load = {"smooth_step": [0.2, 0.4, 0.0, 10.0]}
    return spec, run(spec)


def test_a_driver_in_gross_slip_sets_the_status(driver_slips):
    _, res = driver_slips
    s = res.summary
    assert s["status"].startswith("gross slip: the belt slides over the whole arc of 'driver'")
    assert "lower the load" in s["status"]
    assert s["steadiness"]["gross_slip"] == ["driver"]
    # the driver's surface runs ~4x the belt: far beyond creep ((T1 - T2) / EA ~ 1e-2)
    belt = np.mean([abs(sp["speed_mean"]) for sp in s["spans"]])
    assert 12.0 * 0.1 > 2 * belt
    assert s["pulleys"]["driver"]["stick_arc_deg"] < 1.0


def test_the_command_line_exits_1_on_gross_slip(driver_slips, tmp_path):
    spec, _ = driver_slips
    cfg = tmp_path / "slips.toml"
    cfg.write_text(dump_toml(spec))
    out = subprocess.run(
        [sys.executable, "-m", "jaxbelt", "run", str(cfg), "--out", str(tmp_path / "o"), "--no-plots", "--quiet"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 1, out.stderr
    assert "a pulley slips grossly" in out.stderr and "'driver'" in out.stderr


def test_a_window_inside_a_load_ramp_is_not_steady_unless_a_transient_is_meant():
    """Benchmark A's load comes in over 1.0-1.5 s: a run to 1.2 s averages the ramp itself."""
    res = run(_spec(t_end=1.2))
    s = res.summary
    assert s["status"].startswith("not steady: prescribed laws still change until t = 1.5 s")
    assert "solver.t_end" in s["status"] and s["steadiness"]["steady"] is False
    res = run(_spec(t_end=1.2, expect_steady=False))
    assert res.summary["status"] == "ok" and res.summary["steadiness"]["steady"] is None


def test_a_belt_faster_than_its_wave_speed_is_refused_before_compiling():
    spec = _spec()
    spec.pulleys[0].speed = {"ramp": [0.0, 0.5, 0.0, 1e4]}  # 1000 m/s: rpm meant as rad/s, say
    with pytest.raises(jb.ConfigError, match=r"pulleys.driver.speed .* wave speed sqrt\(T0/m'\) = 2\d.\d+ m/s"):
        jb.build_drive(spec)


def test_a_running_start_reaches_the_steady_state_a_start_up_reaches():
    """The same drive started from rest (Benchmark A's ramps, 2.45 s) and running at 12 rad/s with its load
    ramped in over 0.3 s (1.2 s): same driven speed (0.05 %), tensions (1 %); at t = 0 the running start has
    the driven pulley at the driver's speed and the crank angle at zero."""
    rest = run(jb.benchmark_a(n_elements=30, save_dt=0.002))
    spec = jb.benchmark_a(n_elements=30, t_end=1.2, save_dt=0.002)
    spec.pulleys[0].speed = 12.0
    spec.pulleys[1].load = {"smooth_step": [0.0, 0.3, 0.0, 25.0]}
    spec.solver.start = "running"
    running = run(spec)
    a, b = rest.summary, running.summary
    assert a["status"] == "ok" and b["status"] == "ok"
    w_rest, w_run = a["pulleys"]["driven"]["omega_mean"], b["pulleys"]["driven"]["omega_mean"]
    assert abs(w_run - w_rest) < 5e-4 * w_rest
    for x, y in zip(a["spans"], b["spans"]):
        assert abs(x["tension_mean"] - y["tension_mean"]) < 0.01 * x["tension_mean"]
    sig = running.signals
    assert sig["t"][0] == 0.0 and abs(sig["omega:driven"][0] - 12.0) < 1e-2
    assert abs(float(running.trajectory.states.theta[0, 0])) < 1e-12  # the engine orders start at angle 0
    # only the driven pulley's speed was checked for drift, each within its limit
    assert abs(b["steadiness"]["drift"]["omega:driven"]) * 0.1 < DRIFT_SPEED * 1.2


def test_a_running_start_needs_a_moving_speed_driver():
    spec = _spec(start="running")  # Benchmark A's driver ramps from 0: nothing to start at
    with pytest.raises(jb.ConfigError, match="is 0 at t = 0"):
        jb.build_drive(spec)
    spec = _spec(start="sideways")
    with pytest.raises(jb.ConfigError, match="solver.start"):
        jb.build_drive(spec)


def test_a_driver_spinning_under_a_belt_that_does_not_move_is_gross_slip():
    """mu = 1e-6: the driver turns at 12 rad/s (1.2 m/s at its surface) and friction does not take the belt
    along. The gross-slip check measured slip against the belt speed alone and skipped
    a belt below 1 mm/s: status "ok" (an audit's find). Against the fastest surface it is gross slip on the
    driver (the status may say "implausible" first: a driven pulley that does not turn); the spans tier says gross
    slip."""
    spec = _spec(t_end=0.3)
    spec.pulleys[0].speed = 12.0
    spec.pulleys[1].load = 5.0
    spec.contact.mu = 1e-6
    s = run(spec).summary
    assert s["status"] != "ok" and "driver" in s["steadiness"]["gross_slip"], s["status"]
    belt = max(abs(sp["speed_mean"]) for sp in s["spans"])
    assert belt < 0.2 * 1.2  # the belt far slower than the driver's surface (measured 0.17 m/s)
    from jaxbelt.spans import run_spans

    spans = run_spans(jb.build_drive(spec)).summary
    assert spans["status"].startswith("gross slip"), spans["status"]
