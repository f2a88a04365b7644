"""Conventions that used to be taken silently the wrong way (issue 16): an arm's rest angle given in
degrees (``rest_deg``; ``rest`` beyond a full turn refused, an implausible spring load warned
about), a poly-V belt's catalogue (effective) length, and layout fixes stated in the
configuration's terms that give the drive that was meant. Built from the serpentine example; no
simulation runs (the summary is taken of the drive at rest)."""

from __future__ import annotations

import copy
import math
import re
import tomllib
import warnings
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt import dump_toml, summary
from jaxbelt.config import read_toml, spec_from_dict

ROOT = Path(__file__).resolve().parents[1]
SERP = read_toml(ROOT / "examples" / "serpentine_tensioner.toml")
# the example's tensioner arm: pivot (0.10, -0.13), pulley centre (0.18, -0.13): length 0.08 m, angle 0;
# stiffness 20 N m/rad, preload -12 N m; the belt is installed at 150 N
ARM_L, T0, K, PRELOAD = 0.08, 150.0, 20.0, -12.0


def _data(belt: dict | None = None, tensioner: dict | None = None) -> dict:
    """The example with keys of [belt] and of the tensioner set (None: removed)."""
    d = copy.deepcopy(SERP)
    for table, changes in ((d["belt"], belt), (d["pulleys"][1]["tensioner"], tensioner)):
        for key, value in (changes or {}).items():
            if value is None:
                table.pop(key, None)
            else:
                table[key] = value
    return d


def _build(d: dict):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        drive = jb.build_drive(spec_from_dict(d))
    return drive, [str(w.message) for w in caught]


def _refused(d: dict) -> str:
    with pytest.raises(jb.ConfigError) as exc:
        jb.build_drive(spec_from_dict(d))
    msg = str(exc.value)
    assert "\n" not in msg
    return msg


def _at_rest_summary(drive) -> dict:
    states = jax.tree.map(lambda x: jnp.stack([x, x]), drive.state0)
    return summary(drive, np.array([0.0, 1e-3]), states, drive.state0)


# --------------------------------------------------------------------------- 10. angles in degrees
def test_arm_rest_in_degrees():
    drive, msgs = _build(_data(tensioner={"rest_deg": 12.0}))
    assert msgs == []
    assert float(drive.params.pulleys.carrier[1]["rest"]) == pytest.approx(12.0 * math.pi / 180.0, rel=1e-15)
    same, _ = _build(_data(tensioner={"rest": 12.0 * math.pi / 180.0}))
    np.testing.assert_allclose(
        drive.params.pulleys.carrier[1]["rest"], same.params.pulleys.carrier[1]["rest"], rtol=1e-15
    )
    # written back and read again unchanged
    again = spec_from_dict(tomllib.loads(dump_toml(drive.spec)))
    assert again.pulleys[1].tensioner.rest_deg == 12.0 and again.pulleys[1].tensioner.rest is None


def test_arm_rest_beyond_a_turn_is_refused_with_a_degrees_hint():
    # before: built silently, a spring torque of -12 + 20 * 12 = 228 N m at installation
    msg = _refused(_data(tensioner={"rest": 12.0}))
    assert msg.startswith("pulleys.tensioner.tensioner.rest = 12.0: an arm's rest angle is in radians")
    assert "687.5 deg" in msg and "rest_deg = 12" in msg


@pytest.mark.parametrize(
    "tensioner,expected",
    [
        ({"rest": 0.2, "rest_deg": 12.0}, ["tensioner.rest/rest_deg = (0.2, 12.0)", "give the rest angle once"]),
        ({"rest_deg": 400.0}, ["tensioner.rest_deg = 400.0", "[-360, 360] deg"]),
        (
            {"kind": "slider", "pivot": None, "rest_deg": 10.0},
            ["tensioner.rest_deg = 10.0", "a slider's rest is a travel"],
        ),
        ({"rest_deg": math.nan}, ["tensioner.rest_deg = nan", "finite"]),
    ],
)
def test_rest_deg_refusals(tensioner, expected):
    msg = _refused(_data(tensioner=tensioner))
    for text in expected:
        assert text in msg, msg


def test_implausible_spring_load_warns():
    # rest = 5 rad (meant as 5 deg): torque -12 + 20 * (5 - 0) = 88 N m against at most 2 T L = 24 N m
    _, msgs = _build(_data(tensioner={"rest": 5.0}))
    assert len(msgs) == 1, msgs
    m = msgs[0]
    assert m.startswith("pulleys.tensioner.tensioner: the spring torque at installation")
    assert f"= {PRELOAD + K * 5.0:g} N m" in m and f"= {2 * T0 * ARM_L:g} N m" in m
    assert "rest_deg = 5" in m
    # a plausible rest angle (torque -12 + 20 * 0.5 = -2 N m): no warning
    assert _build(_data(tensioner={"rest": 0.5}))[1] == []
    # a slider: force 10 N/mm over 0.5 m = 5000 - 12 N against at most 2 T = 300 N
    _, msgs = _build(_data(tensioner={"kind": "slider", "pivot": None, "stiffness": 1e4, "rest": 0.5}))
    assert len(msgs) == 1 and f"= {PRELOAD + 1e4 * 0.5:g} N" in msgs[0] and f"(2·T = {2 * T0:g} N" in msgs[0]


# --------------------------------------------------------------------------- 11. effective length
def test_effective_length_sets_the_pitch_length():
    ref, _ = _build(_data())  # installed at pretension 150 N
    L0 = float(ref.params.belt.stress_free_length)
    L_path = float(ref.path.length)
    # ISO 9981 (PK): pitch line 2 mm outside the effective line, so L_pitch = L_eff + 2 pi * 2 mm
    L_eff = L0 - 2 * math.pi * 0.002
    drive, msgs = _build(_data(belt={"pretension": None, "effective_length": L_eff}))
    assert msgs == []
    np.testing.assert_allclose(float(drive.params.belt.stress_free_length), L0, rtol=1e-13)
    EA = float(drive.params.belt.EA)
    np.testing.assert_allclose(EA * (L_path / float(drive.params.belt.stress_free_length) - 1), T0, rtol=1e-9)
    # another offset (a manufacturer's value)
    other, _ = _build(_data(belt={"pretension": None, "effective_length": L_eff, "effective_offset": 0.0015}))
    np.testing.assert_allclose(float(other.params.belt.stress_free_length), L_eff + 2 * math.pi * 0.0015, rtol=1e-13)
    s = _at_rest_summary(drive)["belt"]["installed_state"]
    assert s["defined_by"] == "effective_length"
    assert s["effective_length"] == L_eff and s["effective_offset"] == 0.002
    np.testing.assert_allclose(s["stress_free_length"], L0, rtol=1e-13)
    assert _at_rest_summary(ref)["belt"]["installed_state"]["defined_by"] == "pretension"


@pytest.mark.parametrize(
    "belt,expected",
    [
        (
            {"effective_length": 1.15},
            ["belt.stress_free_length/effective_length/installed_effective_length/pretension", "exactly one"],
        ),
        ({"pretension": None, "type": "flat", "effective_length": 1.15}, ["belt.effective_length = 1.15", "poly-V"]),
        ({"effective_offset": 0.002}, ["belt.effective_offset = 0.002", "only with belt.effective_length"]),
        (
            {"pretension": None, "effective_length": 1.15, "effective_offset": 2.0},
            ["belt.effective_offset = 2.0", "[0, 0.01] m"],
        ),
        ({"pretension": None, "effective_length": 1.18}, ["belt.effective_length = 1.18", "pitch line", "slack"]),
        ({"pretension": None, "effective_length": -1.0}, ["belt.effective_length = -1.0", "> 0"]),
    ],
)
def test_effective_length_refusals(belt, expected):
    msg = _refused(_data(belt=belt))
    for text in expected:
        assert text in msg, msg


# --------------------------------------------------------------------------- 12. layout fixes by name
def _named_orders(msg: str) -> list[list[str]]:
    return [m.split(", ") for m in re.findall(r"\[\[pulleys\]\] tables in the order ([\w, ]+?)(?:;|\.$)", msg)]


def test_layout_fix_by_name_gives_the_drive_meant():
    ref, _ = _build(_data())
    names = [p["name"] for p in SERP["pulleys"]]  # crank, tensioner, alternator, idler
    d = _data()
    d["pulleys"] = [d["pulleys"][i] for i in (0, 3, 1, 2)]  # the idler listed second
    msg = _refused(d)
    orders = _named_orders(msg)
    assert orders and orders[0] == names, msg  # the listed loop first
    for order in orders:  # each suggestion applied is accepted
        fixed = copy.deepcopy(d)
        fixed["pulleys"] = [next(p for p in d["pulleys"] if p["name"] == n) for n in order]
        drive, _ = _build(fixed)
        np.testing.assert_allclose(float(drive.path.length), float(ref.path.length), rtol=1e-12)
        sides = dict(zip(drive.model.pulley_names, drive.model.wrap_side))
        assert sides == dict(zip(ref.model.pulley_names, ref.model.wrap_side))
        if order != names:  # only the same loop the other way round
            assert order == [names[0], *names[:0:-1]] and "travelled the other way round" in msg


def test_layout_wrap_fix_by_name_uses_that_sides_offset():
    # the tensioner on the belt's back cannot be wrapped anywhere: the inner side is offered as
    # another drive; its radius then takes inner_offset (2 mm here), and the fix applied passes
    d = _data(belt={"inner_offset": 0.002, "back_offset": 0.0})
    d["pulleys"][1]["wrap"] = "back"
    msg = _refused(d)
    assert 'pulleys.tensioner.wrap = "inner" (a different drive)' in msg
    assert "belt cannot wrap pulley 1 with its back" in msg
    d["pulleys"][1]["wrap"] = "inner"
    drive, _ = _build(d)
    assert float(drive.params.pulleys.radius[1]) == pytest.approx(0.04 + 0.002, rel=1e-15)
