"""The contact stiffness follows the belt's section, and the summary reports the path the belt loses by
sinking into the pulleys (docs/config.md, [contact]; jaxbelt/config/contact_defaults.py)."""

import math

import pytest
from helpers import capstan_belt

import jaxbelt as jb
from jaxbelt.config.contact_defaults import CONTACT_STIFFNESS_PER_AREA


def _spec(**contact) -> jb.DriveSpec:
    """The capstan drive's soft belt (20 mm wide, EA 5 kN, 200 N) free-running at 1 m/s on two 0.1 m
    pulleys 0.3 m apart, no load."""
    return jb.DriveSpec(
        belt=capstan_belt(),
        pulleys=[
            jb.PulleySpec("A", (0, 0), 0.1, role="driver", inertia=0.1, speed={"ramp": [0.0, 0.1, 0.0, 10.0]}),
            jb.PulleySpec("B", (0.3, 0), 0.1, role="driven", inertia=0.01),
        ],
        contact=jb.ContactSpec(mu=0.3, **contact),
        solver=jb.SolverSpec(t_end=0.4, save_dt=2e-3),
    )


def test_default_is_the_stiffness_per_area_times_the_width():
    """4e9 N/m^3 (Benchmark A's value per contact area) x belt.width: 8e7 N/m^2 for 20 mm (was 3.2e8
    whatever the belt), 1.14e8 for an 8PK belt (8 x 3.56 mm); Benchmark A's 80 mm keeps 3.2e8."""
    assert CONTACT_STIFFNESS_PER_AREA == 4e9
    spec = _spec()
    assert float(jb.build_drive(spec).params.contact_stiffness) == pytest.approx(8e7, rel=1e-15)
    spec.belt.type, spec.belt.ribs, spec.belt.width = "poly-v", 8, 8 * 3.56e-3
    assert float(jb.build_drive(spec).params.contact_stiffness) == pytest.approx(4e9 * 0.02848, rel=1e-15)
    bench = jb.benchmark_a(n_elements=20)
    bench.contact.stiffness = None
    assert float(jb.build_drive(bench).params.contact_stiffness) == pytest.approx(3.2e8, rel=1e-15)


def test_explicit_values_are_kept_and_one_of_them_is_allowed():
    assert float(jb.build_drive(_spec(stiffness=2.5e8)).params.contact_stiffness) == 2.5e8
    per_area = jb.build_drive(_spec(stiffness_per_area=1e10)).params.contact_stiffness
    assert float(per_area) == pytest.approx(1e10 * 0.02, rel=1e-15)
    with pytest.raises(jb.ConfigError, match="contact.stiffness/stiffness_per_area"):
        jb.build_drive(_spec(stiffness=2.5e8, stiffness_per_area=1e10))
    with pytest.raises(jb.ConfigError, match="contact.stiffness_per_area"):
        jb.build_drive(_spec(stiffness_per_area=-1.0))


def test_summary_reports_the_contact_path_shortening():
    """Free running: the belt sinks delta = (T - m' v^2) / (R k) into each 180 deg wrap, so its path is
    shorter by S = 2 pi delta = 0.155 mm at k = 8e7 N/m^2 (the default here) and T = 197 N; the summary's
    ``belt.contact_path_shortening_mm`` (from the contact forces) within 3 % of that (measured +2.0 %: the
    belt touches a little beyond the tangent points)."""
    r = jb.run(_spec())
    s, d = r.summary, r.drive
    k = float(d.params.contact_stiffness)
    assert s["belt"]["contact_stiffness"] == k == pytest.approx(8e7)
    T = sum(sp["tension_mean"] for sp in s["spans"]) / 2
    m_cur = 0.1 / (1.0 + T / 5000.0)
    closed = 2.0 * math.pi * (T - m_cur * 1.0**2) / (0.1 * k)
    assert s["belt"]["contact_path_shortening_mm"] == pytest.approx(1e3 * closed, rel=0.03)
