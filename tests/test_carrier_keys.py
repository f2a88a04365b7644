"""A carrier kind is one class plus one table line, like a friction law: a toy kind defined here (a slider whose
direction is given as an angle, ``angle_deg``), registered by one line in ``CARRIERS``, is at once a valid
``tensioner.kind`` whose own key is a TOML key of ``[pulleys.tensioner]`` and a ``TensionerSpec`` attribute,
checked by its own check, refused on another kind, built into ``PulleyParams.carrier``, written back by
``dump_toml`` and varied through its parameter keys; no other module names it. And the shipped kinds: a key of
another kind is refused, every key is documented."""

import copy
import math
import re
import tomllib
import typing
import warnings
from pathlib import Path
from typing import ClassVar

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt import dump_toml, get_parameter, parameter_keys, set_parameter
from jaxbelt.config import spec_from_dict, valid_keys
from jaxbelt.pulleys.carriers import CARRIERS, AbstractMovableCarrier, CarrierKey, SpecKey, tensioner_spec_keys
from jaxbelt.pulleys.carrier import carrier_centers

jax.config.update("jax_enable_x64", True)

ROOT = Path(__file__).resolve().parents[1]
SERP = tomllib.loads((ROOT / "examples" / "serpentine_tensioner.toml").read_text())
TENSIONER = 1  # the serpentine's tensioner pulley


@typing.final
class AngledSlider(AbstractMovableCarrier):
    """A slider whose direction of travel is an angle from the x axis: centre = origin + psi (cos a, sin a)."""

    name: ClassVar[str] = "angled"
    coordinate: ClassVar[str | None] = "travel"
    keys: ClassVar[tuple[CarrierKey, ...]] = (*AbstractMovableCarrier.keys, CarrierKey("angle", "rad"))
    spec_keys: ClassVar[tuple[SpecKey, ...]] = (
        *AbstractMovableCarrier.spec_keys,
        SpecKey("angle_deg", "deg: the direction of travel from the x axis", default=90.0, check="finite"),
    )

    @classmethod
    def anchor(cls, values, center):
        return (float(center[0]), float(center[1])), dict(angle=math.radians(values["angle_deg"])), 0.0

    @classmethod
    def dcenter_at(cls, numbers, psi):
        return np.array([math.cos(numbers["angle"]), math.sin(numbers["angle"])])

    def center(self, pp, k, psi):
        return pp.center[k] + jnp.asarray(psi)[..., None] * self.dcenter(pp, k, psi)

    def dcenter(self, pp, k, psi):
        a = self.numbers(pp, k)["angle"]
        return jnp.broadcast_to(jnp.stack([jnp.cos(a), jnp.sin(a)]), jnp.shape(psi) + (2,))


@pytest.fixture
def angled(monkeypatch):
    monkeypatch.setitem(CARRIERS, "angled", AngledSlider)  # the one line a new kind adds


def _data(**tensioner):
    """The serpentine example with its tensioner's table replaced (a stiff slider by default)."""
    d = copy.deepcopy(SERP)
    d["pulleys"][TENSIONER]["tensioner"] = dict(stiffness=2e4, preload=300.0, damping=50.0, inertia=0.3, **tensioner)
    return d


def _build(d):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return jb.build_drive(spec_from_dict(d))


def test_a_new_kind_is_a_table_line_away(angled):
    assert "pulleys.<name>.tensioner.angle_deg" in valid_keys()
    toy = _build(_data(kind="angled", angle_deg=30.0))
    slider = _build(_data(kind="slider", direction=[math.cos(math.pi / 6), math.sin(math.pi / 6)]))
    assert isinstance(toy.model.carriers[TENSIONER], AngledSlider)
    assert float(toy.params.pulleys.carrier[TENSIONER]["angle"]) == pytest.approx(math.pi / 6, rel=1e-15)
    # the same carrier as a slider along that direction: centres and the installed belt agree to round-off
    psi = jnp.asarray([0.0, 0.004, 0.0, 0.0])
    for a, b in zip(
        carrier_centers(toy.model, toy.params.pulleys, psi), carrier_centers(slider.model, slider.params.pulleys, psi)
    ):
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=0, atol=1e-15)
    np.testing.assert_allclose(
        float(toy.params.belt.stress_free_length), float(slider.params.belt.stress_free_length), rtol=1e-15
    )
    # an attribute, written back and read again unchanged
    assert toy.spec.pulleys[TENSIONER].tensioner.angle_deg == 30.0
    again = spec_from_dict(tomllib.loads(dump_toml(toy.spec)))
    assert again == toy.spec and "angle_deg = 30.0" in dump_toml(toy.spec)
    # its numbers are parameters as its class marks them: the spring, not the angle
    keys = [k for k in parameter_keys(toy) if "tensioner.tensioner." in k]
    assert keys == [f"pulleys.tensioner.tensioner.{k}" for k in ("stiffness", "preload", "damping", "inertia")]
    p = set_parameter(toy, toy.params, "pulleys.tensioner.tensioner.stiffness", 3e4)
    assert float(get_parameter(toy, p, "pulleys.tensioner.tensioner.stiffness")) == 3e4
    assert float(p.pulleys.carrier[TENSIONER]["stiffness"]) == 3e4


def test_a_new_kinds_key_is_checked_and_refused_elsewhere(angled):
    with pytest.raises(jb.ConfigError, match=r"tensioner\.angle_deg = nan: must be a finite number"):
        _build(_data(kind="angled", angle_deg=math.nan))
    with pytest.raises(jb.ConfigError, match=r"tensioner\.angle_deg = 30\.0: is used only with kind = 'angled'"):
        _build(_data(kind="slider", angle_deg=30.0))


@pytest.mark.parametrize(
    "table,message",
    [
        (dict(kind="slider", pivot=[0.1, 0.0]), r"tensioner\.pivot = \(0\.1, 0\.0\): is an arm's pivot"),
        (dict(kind="arm", pivot=[0.1, -0.13], direction=[0.0, 1.0]), r"tensioner\.direction = .*: is a slider's"),
        (dict(kind="arm", pivot=[0.1, -0.13], partner="idler"), r"tensioner\.partner = 'idler': names a pendulum's"),
    ],
)
def test_a_key_of_another_kind_is_refused(table, message):
    with pytest.raises(jb.ConfigError, match=message):
        _build(_data(**table))


def test_every_key_of_the_tensioner_kinds_is_documented():
    text = (ROOT / "docs" / "config.md").read_text()
    section = text[text.index("## `[pulleys.tensioner]`") :]
    section = section[: section.index("\n## ")]
    documented = set(re.findall(r"^\| `([a-z_]+)` \|", section, flags=re.M))
    assert set(tensioner_spec_keys()) | {"kind"} <= documented, set(tensioner_spec_keys()) - documented


def test_array_valued_keys_are_read_and_refused_like_lists():
    """A pivot given as a numpy array (a user's computed layout) builds the arm, and is refused on a slider with
    the same message as a list (no 'truth value of an array' error from comparing it with a default)."""
    spec = spec_from_dict(_data(kind="arm", pivot=[0.1, -0.13]))
    spec.pulleys[TENSIONER].tensioner.pivot = np.array([0.1, -0.13])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        drive = jb.build_drive(spec)
    assert float(drive.params.pulleys.carrier[TENSIONER]["length"]) > 0
    spec.pulleys[TENSIONER].tensioner.kind = "slider"
    with pytest.raises(jb.ConfigError, match=r"tensioner\.pivot = array\(\[ ?0\.1 *, *-0\.13\]\): is an arm's pivot"):
        jb.build_drive(spec)
