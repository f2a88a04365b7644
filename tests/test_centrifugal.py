"""Centrifugal tension on a fixed-centre drive: a belt installed at T0 and run up to speed v keeps its span
tension (its length between fixed pulleys does not change), while the pulleys feel less of it: the belt on
the arc carries m' v^2 of the tension with its own inertia, so the contact pressure is (T - m' v^2) / r and
the hub load of a pulley with parallel spans drops from 2 T0 to 2 (T0 - m' v^2).

Benchmark A's geometry (two 100 mm pulleys), no load, belt at 7.4 m/s: v / c = 0.4 with the span wave
speed c = sqrt(T0 / m'), and m' v^2 = 47.8 N, 16 % of T0 = 300 N: a 96 N drop of the hub load that the
1 % tolerances below resolve ten times over.

Not explained yet (measured, not asserted): at higher speed the hub load exceeds 2 (T0 - m' v^2) by more,
+1.6 % at v / c = 0.55 and +4.2 % at v / c = 0.7 (the same with 40 and 80 elements), while the spans keep T0.
"""

import pytest

import jaxbelt as jb

T0 = 300.0
OMEGA = 74.0  # rad/s: 7.4 m/s on the 0.1 m pulleys


@pytest.fixture(scope="module")
def running():
    spec = jb.benchmark_a(n_elements=40, t_end=0.5, save_dt=2e-3)
    spec.belt.stress_free_length = None
    spec.belt.pretension = T0
    spec.pulleys[0].speed = {"ramp": [0.0, 0.2, 0.0, OMEGA]}
    spec.pulleys[1].load = None
    spec.pulleys[1].viscous = 0.0
    spec.pulleys[1].inertia = 0.02
    drive = jb.build_drive(spec)
    return float(drive.params.belt.mass_per_length), jb.run(drive).summary


def test_span_tension_stays_at_its_installed_value(running):
    """Both spans' mean tension within 1 % of T0 (measured -0.7 % and +0.1 %), although m' v^2 is 16 % of it."""
    _, s = running
    assert s["status"] == "ok"
    for span in s["spans"]:
        assert span["tension_mean"] == pytest.approx(T0, rel=0.01), span["name"]


def test_hub_load_drops_by_the_centrifugal_tension(running):
    """Hub loads within 1 % of 2 (T0 - m' v^2) = 504.5 N (measured 506.9 and 506.7 N, +0.5 %; at rest they
    are 2 T0 = 600 N), and each span's effective tension (the summary's T - m' v^2) within 1 % of
    T0 - m' v^2 (measured -0.8 % and +0.2 %)."""
    m, s = running
    v = OMEGA * 0.1
    expected = 2.0 * (T0 - m * v**2)
    for name in ("driver", "driven"):
        assert s["pulleys"][name]["hub_load_mean"] == pytest.approx(expected, rel=0.01), name
    for span in s["spans"]:
        assert span["tension_eff_mean"] == pytest.approx(T0 - m * v**2, rel=0.01), span["name"]
