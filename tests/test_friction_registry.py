"""A friction law is one class plus one table entry: a toy law defined here, registered by one line in
``FRICTION_LAWS``, is at once a valid ``contact.friction_law`` name whose own key is a TOML key of
``[contact]``, a ``ContactSpec`` attribute, validated by the law's own check, built into
``DriveParams.friction``, written back by ``dump_toml`` and varied by ``set_parameter``; no other module
names it."""

import dataclasses
import typing
import warnings

import jax
import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt import dump_toml, get_parameter, parameter_keys, set_parameter
from jaxbelt.config import spec_from_dict, valid_keys
from jaxbelt.contact.friction import FRICTION_LAWS, AbstractFrictionLaw, LawKey, is_finite_number


def _fraction(value, mu):
    return None if is_finite_number(value) and 0 < value <= 1 else "must be a number in (0, 1]"


@typing.final
class Scaled(AbstractFrictionLaw):
    """Coulomb with the bound scaled by ``mu_scale`` (a worn surface): ``|lam_t| <= (mu mu_scale) lam_n``."""

    keys = (LawKey("mu_scale", "-: fraction of mu the surface carries", required=True, check=_fraction),)

    def bound(self, lam_n, params):
        return params["mu"] * params["mu_scale"] * lam_n

    def slip_bound(self, lam_n, params):
        return self.bound(lam_n, params)

    def local_update(self, lam_t, u_t, d_t, lam_n, params):
        b = self.bound(lam_n, params)
        return jax.numpy.clip(lam_t - u_t / d_t, -b, b)


@pytest.fixture
def scaled(monkeypatch):
    monkeypatch.setitem(FRICTION_LAWS, "scaled", Scaled)  # the one line a new law adds


def _data(**contact):
    """A two-pulley drive as parsed TOML (coarse on purpose: builds and a 20 ms run)."""
    return {
        "belt": {
            "n_elements": 16,
            "width": 0.02,
            "thickness": 0.004,
            "EA": 5000.0,
            "EI": 2e-3,
            "mass_per_length": 0.1,
            "axial_damping": 0.1,
            "pretension": 200.0,
            "type": "flat",
            "inner_offset": 0.0,
        },
        "pulleys": [
            {"name": "A", "center": [0.0, 0.0], "radius": 0.1, "role": "driver", "speed": 20.0},
            {
                "name": "B",
                "center": [0.3, 0.0],
                "radius": 0.1,
                "role": "driven",
                "inertia": 0.01,
                "load": {"ramp": [0.0, 0.01, 0.0, 8.0]},
            },
        ],
        "contact": {"stiffness": 1e8, "damping": 2e3, **contact},
        "solver": {"t_end": 0.02, "save_dt": 2e-3, "settle_time": 0.01},
    }


def _build(spec):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # coarse mesh
        return jb.build_drive(spec)


def test_a_new_law_is_a_file_key_a_spec_attribute_and_a_parameter(scaled):
    assert "contact.mu_scale" in valid_keys()
    spec = spec_from_dict(_data(mu=0.6, friction_law="scaled", mu_scale=1.0))
    assert spec.contact.mu_scale == 1.0 and spec.contact.law_parameters == {"mu_scale": 1.0}
    assert "mu_scale = 1.0" in dump_toml(spec)
    assert spec_from_dict(_data(mu=0.6, friction_law="scaled", mu_scale=1.0)) == spec
    assert jb.ContactSpec(mu=0.6, friction_law="scaled", mu_scale=1.0) == jb.ContactSpec(
        mu=0.6, friction_law="scaled", law_parameters={"mu_scale": 1.0}
    )
    drive = _build(spec)
    assert isinstance(drive.model.friction_law, Scaled) and set(drive.params.friction) == {"mu_scale"}
    assert "contact.mu_scale" in parameter_keys(drive)
    p = set_parameter(drive, drive.params, "contact.mu_scale", 0.5)
    assert float(get_parameter(drive, p, "contact.mu_scale")) == 0.5
    # mu 0.6 scaled by 0.5 is Coulomb with mu 0.3 bit for bit (halving is exact in floating point).
    coulomb = _build(spec_from_dict(_data(mu=0.3)))
    runs = [
        jb.simulate(d.model, q, d.state0, t_end=0.02, dt=drive.dt, save_dt=2e-3)
        for d, q in ((drive, p), (coulomb, coulomb.params))
    ]
    for x, y in zip(jax.tree_util.tree_leaves(runs[0]), jax.tree_util.tree_leaves(runs[1]), strict=True):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def test_the_law_checks_its_own_key_and_other_laws_refuse_it(scaled):
    def build(**contact):
        _build(spec_from_dict(_data(**contact)))

    with pytest.raises(
        jb.ConfigError,
        match=r"^contact.mu_scale = 2.0: must be a number in \(0, 1\]; "
        r"required with friction_law = 'scaled'$",
    ):
        build(friction_law="scaled", mu_scale=2.0)
    with pytest.raises(jb.ConfigError, match=r"^contact.mu_scale = None: .*required with friction_law = 'scaled'"):
        build(friction_law="scaled")
    with pytest.raises(
        jb.ConfigError,
        match=r"^contact.mu_scale = 0.5: is used only with "
        r"contact.friction_law = 'scaled'$",
    ):
        build(friction_law="static-kinetic", mu_kinetic=0.3, mu_scale=0.5)
    with pytest.raises(
        jb.ConfigError,
        match=r"^contact.mu_kinetic = 0.3: is used only with "
        r"contact.friction_law = 'static-kinetic'$",
    ):
        build(friction_law="scaled", mu_scale=0.5, mu_kinetic=0.3)
    with pytest.raises(jb.ConfigError, match=r"contact.mu_scale = 'x': expected a number"):
        build(friction_law="scaled", mu_scale="x")
    with pytest.raises(jb.ConfigError, match=r"contact.friction_law = 'scaledd': .*'scaled'"):
        build(friction_law="scaledd")


def test_unregistered_law_keys_are_unknown_keys():
    with pytest.raises(jb.ConfigError, match=r"unknown key 'contact.mu_scale'"):
        spec_from_dict(_data(mu_scale=0.5))
    with pytest.raises(jb.ConfigError, match=r"contact.friction_law = 'scaled': must be one of 'coulomb'"):
        spec_from_dict(_data(friction_law="scaled"))
    with pytest.raises(jb.ConfigError, match=r"contact.mu_scale = 0.5: is not a key of any friction law"):
        _build(dataclasses.replace(spec_from_dict(_data()), contact=jb.ContactSpec(law_parameters={"mu_scale": 0.5})))
    with pytest.raises(TypeError):
        jb.ContactSpec(mu_scale=0.5)  # not a keyword of ContactSpec while no law declares it
