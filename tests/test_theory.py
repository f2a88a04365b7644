"""Creep theory (jaxbelt.outputs.theory) against the reference's Benchmark A and basic identities."""

import math
from pathlib import Path

import numpy as np
import pytest

from jaxbelt.outputs import (
    CreepTheory,
    capstan_tension,
    euler_eytelwein_ratio,
    open_belt_geometry,
    rolling_radius_correction,
    two_pulley_creep,
)

# Benchmark A (reference section 3). The centrifugal term uses the mass per *installed* length,
# 0.8288 kg/m (c = 0.8288 * 1.2^2 = 1.193 N). The stress-free value 1.0415 kg / (0.38 pi m) =
# 0.8724 kg/m reproduces the table equally well at its printed precision (T by +0.007 N, slip arc
# by +0.03 deg); a massless belt does not (slip arc 147.2 deg), see test_centrifugal_term_matters.
M_INSTALLED = 0.8288
BENCH = dict(
    radius_driver=0.1,
    radius_driven=0.1,
    center_distance=0.1 * math.pi,
    EA=7600.0,
    mass_per_length=M_INSTALLED,
    mu=0.5,
    omega_driver=12.0,
    load_torque=25.0,
    load_viscous=2.0,
)
REL = 1e-3  # 0.1 % on tensions, torque, omega2
ARC_DEG = 0.2


def bench(**over) -> CreepTheory:
    kw = dict(BENCH, pretension=400.0)
    kw.update(over)
    return two_pulley_creep(**kw)


@pytest.fixture(scope="module")
def res() -> CreepTheory:
    return bench()


def test_benchmark_a_table(res):
    assert not res.gross_slip
    assert res.omega_driven == pytest.approx(11.308, rel=REL)
    assert res.speed_loss == pytest.approx(0.692, abs=1e-3)
    assert res.torque_driver == pytest.approx(47.62, rel=REL)
    assert res.torque_driven == pytest.approx(47.62, rel=REL)
    assert res.T_tight == pytest.approx(658.5, rel=REL)
    assert res.T_slack == pytest.approx(182.3, rel=REL)
    d = res.as_dict()
    for pulley in ("driver", "driven"):
        assert d[f"slip_arc_{pulley}_deg"] == pytest.approx(147.7, abs=ARC_DEG)
        assert d[f"stick_arc_{pulley}_deg"] == pytest.approx(32.3, abs=ARC_DEG)
        assert d[f"wrap_{pulley}_deg"] == pytest.approx(180.0, abs=1e-12)
    assert res.centrifugal == pytest.approx(M_INSTALLED * 1.2**2, rel=1e-12)
    # peak contact pressure (T1 - c)/R ~ 6.6 kN/m, slip friction mu*p ~ 3.3 kN/m
    p_max = (res.T_tight - res.centrifugal) / 0.1
    assert p_max == pytest.approx(6.6e3, rel=0.01)
    assert 0.5 * p_max == pytest.approx(3.3e3, rel=0.01)


def test_stress_free_length_gives_same_state(res):
    alt = two_pulley_creep(**BENCH, stress_free_length=0.38 * math.pi)
    for k, v in res.as_dict().items():
        assert alt.as_dict()[k] == pytest.approx(v, rel=1e-12, abs=1e-12), k


def test_damper_only_speed_loss():
    r = bench(load_torque=0.0)
    assert r.speed_loss == pytest.approx(0.345, abs=0.002)
    assert not r.gross_slip


def test_centrifugal_term_matters():
    m_stress_free = 1.0415 / (0.38 * math.pi)
    alt = bench(mass_per_length=m_stress_free).as_dict()
    assert alt["T_slack"] == pytest.approx(182.3, rel=REL)
    assert alt["slip_arc_driver_deg"] == pytest.approx(147.7, abs=ARC_DEG)
    massless = bench(mass_per_length=0.0).as_dict()
    assert abs(massless["slip_arc_driver_deg"] - 147.7) > 0.3


def test_solution_satisfies_its_equations(res):
    r = res
    R, mu, EA, c = 0.1, 0.5, 7600.0, r.centrifugal
    span, th1, th2, path = open_belt_geometry(0.1, 0.1, 0.1 * math.pi)
    # torque balance and creep
    assert (r.T_tight - r.T_slack) * R == pytest.approx(25.0 + 2.0 * r.omega_driven, rel=1e-12)
    assert r.omega_driven == pytest.approx(12.0 * (EA + r.T_slack) / (EA + r.T_tight), rel=1e-12)
    assert (r.T_tight - c) / (r.T_slack - c) == pytest.approx(math.exp(mu * r.slip_arc_driver), rel=1e-12)
    # closure: integral of T ds around the loop (slip arcs integrated numerically) = T0 * L
    phi = np.linspace(0.0, r.slip_arc_driver, 20001)
    t_driver = capstan_tension(r.T_slack, mu, phi, centrifugal=c)  # same profile on both pulleys
    slip = np.sum(0.5 * (t_driver[1:] + t_driver[:-1]) * np.diff(phi))
    total = (
        (r.T_tight + r.T_slack) * span
        + R * r.stick_arc_driver * r.T_tight
        + R * r.stick_arc_driven * r.T_slack
        + 2 * R * slip
    )
    assert total == pytest.approx(400.0 * path, rel=1e-8)


def test_no_load_keeps_pretension():
    r = bench(load_torque=0.0, load_viscous=0.0)
    assert r.T_tight == pytest.approx(400.0) and r.T_slack == pytest.approx(400.0)
    assert r.slip_arc_driver == 0.0 and r.speed_loss == pytest.approx(0.0, abs=1e-12)
    assert r.stick_arc_driver == pytest.approx(math.pi)


def test_gross_slip_flagged():
    r = bench(load_torque=200.0)
    assert r.gross_slip
    assert r.slip_arc_driver == pytest.approx(math.pi) and r.stick_arc_driver == 0.0
    # tensions sit at the Euler-Eytelwein limit and the transmitted torque is below the demand
    c = r.centrifugal
    assert (r.T_tight - c) / (r.T_slack - c) == pytest.approx(euler_eytelwein_ratio(0.5, math.pi))
    assert r.torque_driven < 200.0
    assert not bench(load_torque=30.0).gross_slip  # capacity ~57 N m


def test_unequal_pulleys():
    kw = dict(BENCH, radius_driver=0.05, radius_driven=0.15, center_distance=0.5, pretension=600.0)
    kw.update(load_torque=10.0, load_viscous=0.0)
    r = two_pulley_creep(**kw)
    span, th1, th2, path = open_belt_geometry(0.05, 0.15, 0.5)
    assert span == pytest.approx(math.sqrt(0.5**2 - 0.1**2))
    assert th1 + th2 == pytest.approx(2 * math.pi) and th1 < math.pi
    assert r.wrap_driver == pytest.approx(th1) and r.wrap_driven == pytest.approx(th2)
    assert r.torque_driven == pytest.approx(10.0, rel=1e-12)
    assert r.torque_driver / r.torque_driven == pytest.approx(0.05 / 0.15)
    assert r.stick_arc_driver == pytest.approx(th1 - r.slip_arc_driver)
    assert r.speed_loss == pytest.approx(12.0 / 3.0 - r.omega_driven)
    # the smaller (driver) wrap limits: a torque beyond its capacity is gross slip
    assert two_pulley_creep(**dict(kw, load_torque=150.0)).gross_slip


def test_capstan_and_euler_eytelwein():
    phi = np.linspace(0.0, 2.0, 7)
    up = capstan_tension(100.0, 0.3, phi)
    assert isinstance(up, np.ndarray) and up.shape == phi.shape
    np.testing.assert_allclose(up, 100.0 * np.exp(0.3 * phi), rtol=1e-14)
    assert up[-1] == pytest.approx(100.0 * euler_eytelwein_ratio(0.3, 2.0))
    down = capstan_tension(100.0, 0.3, phi, increasing=False)
    np.testing.assert_allclose(down, 100.0 * np.exp(-0.3 * phi), rtol=1e-14)
    with_c = capstan_tension(100.0, 0.3, 2.0, centrifugal=10.0)
    assert isinstance(with_c, float)
    assert (with_c - 10.0) / 90.0 == pytest.approx(euler_eytelwein_ratio(0.3, 2.0, centrifugal=10.0))
    assert euler_eytelwein_ratio(0.5, math.pi) == pytest.approx(math.exp(0.5 * math.pi))
    np.testing.assert_allclose(euler_eytelwein_ratio(0.5, np.array([0.0, 1.0])), [1.0, math.exp(0.5)])


def test_rolling_radius_correction():
    assert rolling_radius_correction(6.4e3, 3.2e8) == pytest.approx(2e-5)
    np.testing.assert_allclose(rolling_radius_correction(np.array([0.0, 3.2e3]), 3.2e8), [0.0, 1e-5])
    with pytest.raises(ValueError, match="k_normal"):
        rolling_radius_correction(1.0, 0.0)


def test_as_dict_and_str(res):
    d = res.as_dict()
    assert d["gross_slip"] is False
    assert all(isinstance(v, float) for k, v in d.items() if k != "gross_slip")
    assert d["slip_arc_driver_deg"] == pytest.approx(math.degrees(res.slip_arc_driver))
    s = str(res)
    assert "T_tight" in s and "deg" in s and "gross_slip" in s
    with pytest.raises(AttributeError):
        res.T_tight = 1.0  # frozen


@pytest.mark.parametrize(
    "over, match",
    [
        (dict(radius_driver=0.0), "radius_driver"),
        (dict(radius_driven=-0.1), "radius_driven"),
        (dict(EA=0.0), "EA"),
        (dict(mass_per_length=-1.0), "mass_per_length"),
        (dict(mu=0.0), "mu"),
        (dict(mu=-0.5), "mu"),
        (dict(omega_driver=-1.0), "omega_driver"),
        (dict(load_torque=-1.0), "load_torque"),
        (dict(load_viscous=-1.0), "load_viscous"),
        (dict(radius_driver=0.3, radius_driven=0.1, center_distance=0.15), "center_distance"),
        (dict(center_distance=float("nan")), "center_distance"),
        (dict(pretension=None), "exactly one of pretension or stress_free_length"),
        (dict(stress_free_length=1.0), "exactly one of pretension or stress_free_length"),
        (dict(pretension=0.0), "pretension"),
        (dict(pretension=None, stress_free_length=0.41 * math.pi), "stress_free_length"),
        (dict(pretension=None, stress_free_length=-1.0), "stress_free_length"),
        (dict(omega_driver=1000.0), "lifts off"),
    ],
)
def test_creep_value_errors(over, match):
    with pytest.raises(ValueError, match=match):
        bench(**over)


def test_helper_value_errors():
    with pytest.raises(ValueError, match="phi"):
        capstan_tension(100.0, 0.3, np.array([0.1, -0.1]))
    with pytest.raises(ValueError, match="T_in"):
        capstan_tension(5.0, 0.3, 1.0, centrifugal=10.0)
    with pytest.raises(ValueError, match="mu"):
        capstan_tension(100.0, -0.3, 1.0)
    with pytest.raises(ValueError, match="wrap_angle"):
        euler_eytelwein_ratio(0.3, -1.0)
    with pytest.raises(ValueError, match="centrifugal"):
        euler_eytelwein_ratio(0.3, 1.0, centrifugal=-1.0)


def test_module_is_jax_free():
    src = Path(__file__).parents[1].joinpath("jaxbelt", "outputs", "theory.py").read_text()
    assert "import jax" not in src and "jax_enable_x64" not in src


def test_compliant_contact_closes_the_length_and_rolls_on_the_sunk_radius():
    """``contact_stiffness`` k: the belt sinks (T - c) / (R k) into each pulley.
    - At rest on the audit's two-pulley drive (R 75 / 30 mm, D 316 mm, EA 70 kN, L0 from 400 N on rigid
      pulleys, k 1e8 N/m^2) the uniform tension is T0 / (1 + EA D' / L0), D' = sum theta_i / (R_i k): 362.85 N,
      the installation statics' figure for the same drive (``installed_contact_shortening``), 9 % below 400 N.
    - Running without load: the tension T solves T (1 + b) = T0 + c b (the sink falls with T - c), and the
      driven pulley turns at omega1 (R1 - d1) / (R2 - d2), d_i = (T - c) / (R_i k): a negative speed loss
      (the small pulley's rolling radius shrinks most), here -1.67 rad/s at 2,000 rpm.
    - k -> infinity is the rigid theory; a ``pretension`` is the tension at rest on the compliant pulleys."""
    geom = dict(radius_driver=0.075, radius_driven=0.03, center_distance=math.hypot(0.3, 0.1), EA=7e4)
    _, th1, th2, path = open_belt_geometry(0.075, 0.03, math.hypot(0.3, 0.1))
    L0 = path / (1 + 400.0 / 7e4)
    k = 1e8
    b = 7e4 * (th1 / 0.075 + th2 / 0.03) / (k * L0)
    rest = two_pulley_creep(**geom, mass_per_length=0.1, mu=0.35, omega_driver=0.0, stress_free_length=L0,
                            contact_stiffness=k)  # fmt: skip
    assert rest.T_tight == rest.T_slack == pytest.approx(7e4 * (path / L0 - 1) / (1 + b), rel=1e-12)
    assert rest.T_tight == pytest.approx(362.85, abs=0.01)
    w1 = 2000 * math.pi / 30
    m = 0.1 / (1 + 362.85 / 7e4)
    run = two_pulley_creep(**geom, mass_per_length=m, mu=0.35, omega_driver=w1, stress_free_length=L0,
                           contact_stiffness=k)  # fmt: skip
    c = m * (w1 * 0.075) ** 2
    T = (400.0 + c * b) / (1 + b)
    assert run.T_tight == pytest.approx(T, rel=1e-9) and run.centrifugal == pytest.approx(c)
    d1, d2 = (T - c) / (0.075 * k), (T - c) / (0.03 * k)
    assert run.omega_driven == pytest.approx(w1 * (0.075 - d1) / (0.03 - d2), rel=1e-12)
    assert run.speed_loss == pytest.approx(-1.67, abs=0.01)
    loaded = dict(geom, mass_per_length=m, mu=0.35, omega_driver=w1, load_torque=2.0, stress_free_length=L0)
    rigid, stiff = two_pulley_creep(**loaded), two_pulley_creep(**loaded, contact_stiffness=1e18)
    for name in ("T_tight", "T_slack", "omega_driven", "slip_arc_driver"):
        assert getattr(stiff, name) == pytest.approx(getattr(rigid, name), rel=1e-8)
    given = two_pulley_creep(**geom, mass_per_length=0.1, mu=0.35, omega_driver=0.0, pretension=380.0,
                             contact_stiffness=k)  # fmt: skip
    assert given.T_tight == pytest.approx(380.0, rel=1e-12)
