"""Centrifugal tension on a fixed-centre drive: a belt installed at T0 and run up to speed v keeps its span
tension (its length between fixed pulleys does not change), while the pulleys feel less of it: the belt on
the arc carries m' v^2 of the tension with its own inertia, so the contact pressure is (T - m' v^2) / r and
the hub load of a pulley with parallel spans drops from 2 T0 to 2 (T0 - m' v^2).

m' is the mass per *current* length, m0 / (1 + T/EA) of the mass m0 per stress-free length
(``belt.mass_per_length``): m' v^2 is the belt's momentum flux through a cross-section, v in current
length per second. With m0 the term is T/EA = 3.9 % too large here, which at v / c = 0.7 read as a
hub load 4.1 % above 2 (T0 - m0 v^2) (80 elements; the "unexplained excess at high speed" of earlier
notes) and put the summary's effective tensions 4.0 % below what the hub load carries.

Benchmark A's geometry (two 100 mm pulleys), no load; c = sqrt(T0 / m') the span wave speed of the
installed belt (18.9 m/s).
"""

import math

import pytest

import jaxbelt as jb
from jaxbelt.outputs import effective_tension, mass_per_current_length

T0 = 300.0
R = 0.1


def _free_running(v_over_c: float, n_elements: int, t_end: float, dt: float | None = None):
    spec = jb.benchmark_a(n_elements=n_elements, t_end=t_end, save_dt=2e-3)
    if dt is not None:
        spec.solver.scheme, spec.solver.dt = "implicit", dt
    spec.belt.stress_free_length = None
    spec.belt.pretension = T0
    m_cur = mass_per_current_length(spec.belt.mass_per_length, T0, spec.belt.EA)
    v = v_over_c * math.sqrt(T0 / m_cur)
    spec.pulleys[0].speed = {"ramp": [0.0, 0.2, 0.0, v / R]}
    spec.pulleys[1].load = None
    spec.pulleys[1].viscous = 0.0
    spec.pulleys[1].inertia = 0.02
    return m_cur, v, jb.run(jb.build_drive(spec)).summary


@pytest.fixture(scope="module")
def running():
    """v / c = 0.4 (7.6 m/s, m' v^2 = 48 N, 16 % of T0), 40 elements."""
    return _free_running(0.4, 40, 0.5)


@pytest.fixture(scope="module")
def fast():
    """v / c = 0.7 (13.2 m/s, m' v^2 = 147 N, half of T0), 80 elements (at 40 the landing of the contact
    points on the pulleys adds +0.5 % to the hub loads: a discretisation effect that falls with the mesh,
    +0.2 % at 80 and +0.1 % at 160 elements). Its implicit step 1.4e-4 s: a belt point travels 0.25 of the
    contact-point spacing per step, as the default rule allowed before it took 0.17 (9.7e-5 s here) for run-ups
    through a span's resonance; a steady free-running belt has none, and this run is the suite's cost."""
    return _free_running(0.7, 80, 1.5, dt=1.4e-4)


def test_mass_per_current_length():
    """m' = m0 / (1 + T/EA) and T_eff = T - m' v^2, on floats."""
    assert mass_per_current_length(0.8724, 400.0, 7600.0) == pytest.approx(0.8724 * 7600.0 / 8000.0, rel=1e-15)
    assert effective_tension(400.0, 2.0, 0.8724, 7600.0) == pytest.approx(400.0 - 4.0 * 0.8724 * 0.95, rel=1e-15)


def test_span_tension_stays_at_its_installed_value(running):
    """Both spans' mean tension within 1 % of T0 (measured -0.5 % and +0.3 %), although m' v^2 is 16 % of it."""
    _, _, s = running
    assert s["status"] == "ok"
    for span in s["spans"]:
        assert span["tension_mean"] == pytest.approx(T0, rel=0.01), span["name"]


def test_hub_load_drops_by_the_centrifugal_tension(running):
    """Hub loads within 1 % of 2 (T0 - m' v^2) = 504.0 N (measured +0.02 %; at rest they are 2 T0 = 600 N),
    and each span's effective tension (the summary's T - m' v^2) within 1 % of T0 - m' v^2."""
    m, v, s = running
    expected = 2.0 * (T0 - m * v**2)
    for name in ("driver", "driven"):
        assert s["pulleys"][name]["hub_load_mean"] == pytest.approx(expected, rel=0.01), name
    for span in s["spans"]:
        assert span["tension_eff_mean"] == pytest.approx(T0 - m * v**2, rel=0.01), span["name"]


def test_hub_load_at_high_speed_is_the_closed_form(fast):
    """At v / c = 0.7 the hub loads are within 0.3 % of 2 (T0 - m' v^2) = 306.0 N with m' per current length
    (measured +0.19 % and +0.26 %; with m0 the closed form is 294.4 N, 4.1 % below), the spans at T0 within
    0.3 % (measured +0.05 %, +0.09 %)."""
    m, v, s = fast
    assert s["status"] == "ok"
    expected = 2.0 * (T0 - m * v**2)
    for name in ("driver", "driven"):
        assert s["pulleys"][name]["hub_load_mean"] == pytest.approx(expected, rel=0.003), name
    for span in s["spans"]:
        assert span["tension_mean"] == pytest.approx(T0, rel=0.003), span["name"]


def test_effective_tensions_carry_the_hub_load(fast):
    """The summary's effective tensions T - m' v^2 of the two spans add up to each pulley's hub load within
    0.3 % (parallel spans, 180 deg wraps): measured -0.01 %; with m' = m0 they fell 4.0 % short, and
    the slip safety factors and the duty study read the same wrong term."""
    _, _, s = fast
    total = sum(span["tension_eff_mean"] for span in s["spans"])
    for name in ("driver", "driven"):
        assert total == pytest.approx(s["pulleys"][name]["hub_load_mean"], rel=0.003), name
