"""What a changed parameter key holds fixed: ``set_parameter`` gives the parameters that building the
edited spec gives (so ``--vary``, ``--fit`` and editing the TOML agree), for both ways of defining the
installed belt, and the summary says which one a drive uses. Builds only, nothing is simulated."""

import copy
import math

import jax
import pytest
from helpers import assert_trees_close

import jaxbelt as jb
from jaxbelt.outputs import installed_state


def _spec(defined_by, EI=None):
    belt = dict(n_elements=16, width=0.03, thickness=0.004, E=5e7, EI=EI, rho=1200.0, eta=4000.0)
    if defined_by == "pretension":
        belt["pretension"] = 300.0
    elif defined_by == "effective_length":  # a poly-V belt by its catalogue length: the same 1.43 m
        belt.update(type="poly-v", effective_length=1.43 - 2 * math.pi * 0.002)
    else:
        belt["stress_free_length"] = 1.43  # path 1.4407 m: 0.75 % strain, 45 N
    return jb.DriveSpec(
        belt=jb.BeltSpec(**belt),
        pulleys=[
            jb.PulleySpec("motor", (0.0, 0.0), 0.06, role="driver", speed=10.0),
            jb.PulleySpec("fan", (0.35, 0.0), 0.12, role="driven", load=5.0),
            jb.PulleySpec("idler", (0.2, 0.25), 0.03),
        ],
    )


pytestmark = pytest.mark.filterwarnings("ignore:pulley .* is wrapped by belt elements")  # coarse on purpose


def _build(spec):
    return jb.build_drive(spec)


def _assert_same_params(a, b, what):
    assert_trees_close(a, b, rtol=1e-12, atol=0, what=what)


# (key, spec edit, the key's new value from the edited spec). Radii at the belt axis: + thickness/2.
EDITS = [
    ("belt.E", lambda s: setattr(s.belt, "E", 5.5e7), lambda s: 5.5e7),
    ("belt.EA", lambda s: setattr(s.belt, "EA", 7000.0), lambda s: 7000.0),
    ("pulleys.fan.radius", lambda s: setattr(s.pulleys[1], "radius", 0.13), lambda s: 0.13 + 0.002),
]


@pytest.mark.parametrize("defined_by", ["pretension", "stress_free_length", "effective_length"])
@pytest.mark.parametrize("key, edit, value", EDITS, ids=[e[0] for e in EDITS])
def test_set_parameter_equals_building_the_edited_spec(defined_by, key, edit, value):
    spec = _spec(defined_by)
    drive = _build(spec)
    edited = copy.deepcopy(spec)
    edit(edited)
    rebuilt = _build(edited)
    p = jb.set_parameter(drive, drive.params, key, value(edited))
    _assert_same_params(p, rebuilt.params, f"{key} on a belt defined by {defined_by}")
    before = installed_state(drive)
    after = installed_state(drive, p)
    assert before["defined_by"] == after["defined_by"] == defined_by
    held = "pretension" if defined_by == "pretension" else "stress_free_length"
    assert after[held] == pytest.approx(before[held], rel=1e-12)
    moved = "stress_free_length" if held == "pretension" else "pretension"
    assert abs(after[moved] / before[moved] - 1) > 1e-4  # the other one follows


def test_E_changes_only_the_stiffnesses_the_spec_derives_from_it():
    """With EI given explicitly, editing E in the file leaves EI alone; so does the key."""
    spec = _spec("pretension", EI=8e-3)
    drive = _build(spec)
    edited = copy.deepcopy(spec)
    edited.belt.E = 6e7
    p = jb.set_parameter(drive, drive.params, "belt.E", 6e7)
    _assert_same_params(p, _build(edited).params, "belt.E with EI given")
    assert float(p.belt.EI) == 8e-3 and float(jb.get_parameter(drive, p, "belt.E")) == pytest.approx(6e7, rel=1e-14)


def test_several_keys_do_not_depend_on_their_order():
    """A varied pretension is the result's pretension whatever else varies (and however the keys are listed)."""
    drive = _build(_spec("stress_free_length"))
    a = jb.set_parameters(drive, drive.params, {"belt.pretension": 250.0, "belt.E": 6e7, "pulleys.fan.radius": 0.125})
    b = jb.set_parameters(
        drive, drive.params, [("pulleys.fan.radius", 0.125), ("belt.E", 6e7), ("belt.pretension", 250.0)]
    )
    _assert_same_params(a, b, "order of keys")
    assert float(jb.get_parameter(drive, a, "belt.pretension")) == pytest.approx(250.0, rel=1e-12)
    with pytest.raises(jb.ConfigError, match="belt.E and belt.EA set the same parameter"):
        jb.set_parameters(drive, drive.params, {"belt.EA": 7000.0, "belt.E": 6e7})


def test_held_quantity_is_differentiable():
    """Keeping the pretension is traceable: d(stress-free length)/dE = L_path T / (EA + T)^2 * A."""
    drive = _build(_spec("pretension"))
    L0 = lambda E: jb.set_parameter(drive, drive.params, "belt.E", E).belt.stress_free_length  # noqa: E731
    A, T = 0.03 * 0.004, 300.0
    L_path = float(drive.path.length)
    expected = L_path * T * A / (5e7 * A + T) ** 2
    assert float(jax.grad(L0)(5e7)) == pytest.approx(expected, rel=1e-10)


def test_summary_reports_the_installed_state():
    drive = _build(_spec("pretension"))
    st = installed_state(drive)
    assert st["defined_by"] == "pretension" and st["pretension"] == pytest.approx(300.0, rel=1e-12)
    assert st["stress_free_length"] == pytest.approx(float(drive.path.length) / (1 + 300.0 / (5e7 * 1.2e-4)))
