"""``belt.installed_effective_length``: a poly-V belt given by its effective length as installed on the
drawn layout (a drive report's belt length), against the catalogue length (``effective_length``, the
unstretched belt) that is the same belt (docs/config.md, [belt])."""

import dataclasses
import math

import jax.numpy as jnp
import numpy as np
import pytest
from helpers import _tensioner_spec

import jaxbelt as jb
from jaxbelt.analysis.statics import statics

OFFSET = 0.002  # effective line to pitch line, the PK default [m]


@pytest.fixture(scope="module")
def drawn():
    """The tensioner drive (poly-V belt, EA 8 kN, arm tensioner with a -12 N m preload) and the effective
    length of its drawn layout: the pitch-line path less 2 pi x the offset."""
    drive = jb.build_drive(_tensioner_spec())
    return drive, float(drive.path.length) - 2.0 * math.pi * OFFSET


def _installed_spec(length: float) -> jb.DriveSpec:
    spec = _tensioner_spec()
    spec.belt.pretension, spec.belt.installed_effective_length = None, length
    return spec


def _tension_at_drawn_arm(drive) -> float:
    """The uniform tension whose hub load balances the arm's preload at its drawn angle (closed form):
    preload + T (d_out - d_in) . d(centre)/d(angle) = 0, rest at the drawn angle, no weight."""
    spec = drive.spec.pulleys[2]
    t = spec.tensioner
    dx, dy = spec.center[0] - t.pivot[0], spec.center[1] - t.pivot[1]
    L, psi0 = math.hypot(dx, dy), math.atan2(dy, dx)
    d = np.asarray(drive.path.span_dir)
    lever = (d[2] - d[1]) @ (L * np.array([-math.sin(psi0), math.cos(psi0)]))
    return -t.preload / lever


def test_installed_length_fixes_the_belt_the_tensioner_stretches(drawn):
    """Built with the drawn layout's effective length L: the stress-free (pitch) length is
    (L + 2 pi e - T sum(phi_i / R_i) / k) / (1 + T/EA) with T the tension that holds the arm at its drawn angle
    and the last term the path the contact compliance k takes at T (each wrap phi_i sinks T / (R_i k)); so at
    installation (statics, with that compliance, as the run has it) the arm stands at its drawn angle under T,
    and on rigid pulleys the belt's effective path would be L (both to round-off); the catalogue length of that
    belt, L0 - 2 pi e, builds the same drive. Until 2026-11-29 the compliance was left out: an audit's 6PK drive
    then installed at 269.6 N and 0.68 deg off its drawn arm angle instead of 284.6 N (0.83 mm of path)."""
    base, L = drawn
    drive = jb.build_drive(_installed_spec(L))
    T = _tension_at_drawn_arm(drive)
    EA = float(drive.params.belt.EA)
    L0 = float(drive.params.belt.stress_free_length)
    k = float(drive.params.contact_stiffness)
    sink = T * float(np.sum(np.asarray(drive.path.wrap_angle) / np.asarray(drive.path.radii))) / k
    assert sink > 1e-5  # the compliance matters: 10s of um
    assert L0 == pytest.approx((L + 2.0 * math.pi * OFFSET - sink) / (1.0 + T / EA), rel=1e-12)
    st = statics(drive)
    psi0 = float(base.state0.psi[2])
    assert st.pulleys["tens"]["arm_angle"] == pytest.approx(psi0, abs=1e-9)
    assert st.belt["contact_path_shortening"] == pytest.approx(sink, rel=1e-6)
    for span in st.spans:
        assert span["tension"] == pytest.approx(T, rel=1e-9), span["name"]
    rigid = statics(drive, params=dataclasses.replace(drive.params, contact_stiffness=jnp.asarray(1e30)))
    assert rigid.pulleys["tens"]["arm_angle"] != pytest.approx(psi0, abs=1e-6)  # a shorter belt on rigid pulleys
    catalogue = _tensioner_spec()
    catalogue.belt.pretension, catalogue.belt.effective_length = None, L0 - 2.0 * math.pi * OFFSET
    same = jb.build_drive(catalogue)
    assert float(same.params.belt.stress_free_length) == pytest.approx(L0, rel=1e-14)
    assert statics(same).pulleys["tens"]["arm_angle"] == pytest.approx(psi0, abs=1e-9)
    installed = jb.run(dataclasses.replace(_installed_spec(L), solver=jb.SolverSpec(t_end=0.002))).summary
    state = installed["belt"]["installed_state"]
    assert state["defined_by"] == "installed_effective_length" and state["installed_effective_length"] == L
    assert state["effective_length"] == pytest.approx(L0 - 2.0 * math.pi * OFFSET, rel=1e-14)
    # the drive report's length is not the catalogue length: read as one, the belt is 2 T/EA x L too long
    assert T > 100.0 and L0 < L


def test_a_length_off_the_drawn_layout_warns(drawn):
    _, L = drawn
    with pytest.warns(UserWarning, match=r"installed_effective_length .* by \+5 mm"):
        jb.build_drive(_installed_spec(L + 0.005))


def test_refused_without_one_tensioner_on_a_flat_belt_or_with_another_length_key(drawn):
    _, L = drawn
    spec = _installed_spec(L)
    spec.belt.type = "flat"
    with pytest.raises(jb.ConfigError, match="belt.installed_effective_length .* poly-V"):
        jb.build_drive(spec)
    spec = _installed_spec(L)
    spec.pulleys[2].tensioner, spec.pulleys[2].role = None, "idler"  # fixed centres: no installation tension
    with pytest.raises(jb.ConfigError, match="exactly one tensioner"):
        jb.build_drive(spec)
    spec = _installed_spec(L)
    spec.pulleys[2].tensioner.preload = 12.0  # the spring pushes the belt slack
    with pytest.raises(jb.ConfigError, match="do not pull the belt taut"):
        jb.build_drive(spec)
    spec = _installed_spec(L)
    spec.belt.effective_length = L
    with pytest.raises(jb.ConfigError, match="give exactly one of them"):
        jb.build_drive(spec)
