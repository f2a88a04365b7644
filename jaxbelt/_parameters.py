"""Named physical parameters of a drive, read and written as traced values.

Identification, sweeps and the command line speak in configuration keys (``belt.E``,
``contact.mu``, ``pulleys.driven.load``); this module maps each key onto the leaves of
``DriveParams`` with pure functions, so ``jax.grad``/``jax.jacfwd``/``vmap`` pass straight through:

    p = set_parameter(drive, drive.params, "belt.E", E)     # E may be a tracer

Keys and what they change:

* ``belt.E``      scales EA and EI together (their ratio is the section's)
* ``belt.EA``, ``belt.EI``, ``belt.eta`` (eta A = axial_damping / A), ``belt.axial_damping``,
  ``belt.bending_damping``, ``belt.mass_per_length``, ``belt.stress_free_length``
* ``belt.pretension`` uniform installed tension; sets the stress-free length from the path
* ``contact.mu``, ``contact.stiffness``, ``contact.damping``, ``contact.nu_s``
* ``pulleys.<name>.inertia``, ``.viscous``, ``.radius`` (effective, at the belt axis)
* ``pulleys.<name>.load`` / ``.torque`` the final level of the applied load/torque law (the law's
  shape is kept, its values scaled); ``pulleys.<name>.speed`` the final prescribed speed [rad/s];
  in the senses of the configuration (a load against the pulley's running sense, see docs/config.md)
* ``pulleys.<name>.tensioner.stiffness`` / ``.preload`` / ``.damping``
"""

from __future__ import annotations

import difflib

import equinox as eqx
import jax.numpy as jnp

from . import _drive
from ._drive import ConfigError, Drive
from ._layout import belt_path
from ._model import DriveParams
from ._pulley import carrier_centers

__all__ = ["parameter_keys", "get_parameter", "set_parameter", "installed_path"]

_BELT = {"EA": "EA", "EI": "EI", "axial_damping": "axial_damping", "bending_damping": "bending_damping",
         "mass_per_length": "mass_per_length", "stress_free_length": "stress_free_length"}
_CONTACT = {"mu": "mu", "stiffness": "contact_stiffness", "damping": "contact_damping", "nu_s": "nu_s"}
_PULLEY = {"inertia": "inertia", "viscous": "viscous", "radius": "radius"}
_TENSIONER = {"stiffness": "spring", "preload": "preload", "damping": "carrier_damping"}


def parameter_keys(drive: Drive) -> list[str]:
    keys = [f"belt.{k}" for k in ("E", "eta", "pretension", *_BELT)] + [f"contact.{k}" for k in _CONTACT]
    for name, kin, kind in zip(drive.model.pulley_names, drive.model.kinematic, drive.model.carrier_kind):
        keys += [f"pulleys.{name}.{k}" for k in _PULLEY]
        keys.append(f"pulleys.{name}.speed" if kin else f"pulleys.{name}.load")
        if not kin:
            keys.append(f"pulleys.{name}.torque")
        if kind != 0:
            keys += [f"pulleys.{name}.tensioner.{k}" for k in _TENSIONER]
    return keys


def _unknown(drive: Drive, key: str):
    near = difflib.get_close_matches(key, parameter_keys(drive), n=1)
    hint = f" (did you mean {near[0]!r}?)" if near else ""
    raise ConfigError(f"{key!r} is not a parameter of this drive{hint}")


def _section_area(drive: Drive) -> float:
    b = drive.spec.belt
    return b.width * b.thickness


def installed_path(drive: Drive, params: DriveParams):
    """The belt path for the pulley geometry in ``params`` (traceable)."""
    centers, _ = carrier_centers(drive.model, params.pulleys, drive.state0.psi)
    return belt_path(centers, params.pulleys.radius, drive.model.wrap_side)


def _law_sign(drive: Drive, i: int, key: str) -> float:
    """The key's value as written (load against the running sense, ...) per unit of the stored
    counter-clockwise-positive law (its own inverse: the factor is +-1)."""
    return _drive._law_sign(drive.spec.pulleys[i], key, drive.running_sense[i], drive.spec)


def _pulley_index(drive: Drive, name: str, key: str) -> int:
    try:
        return drive.model.pulley_names.index(name)
    except ValueError:
        _unknown(drive, key)


def get_parameter(drive: Drive, params: DriveParams, key: str):
    parts = key.split(".")
    b = params.belt
    if parts[0] == "belt" and len(parts) == 2:
        k = parts[1]
        if k in _BELT:
            return getattr(b, _BELT[k])
        if k == "E":
            return b.EA / _section_area(drive)
        if k == "eta":
            return b.axial_damping / _section_area(drive)
        if k == "pretension":
            return b.EA * (installed_path(drive, params).length / b.stress_free_length - 1.0)
    if parts[0] == "contact" and len(parts) == 2 and parts[1] in _CONTACT:
        return getattr(params, _CONTACT[parts[1]])
    if parts[0] == "pulleys" and len(parts) >= 3:
        i = _pulley_index(drive, parts[1], key)
        pp = params.pulleys
        rest = ".".join(parts[2:])
        if rest in _PULLEY:
            return getattr(pp, _PULLEY[rest])[i]
        if rest in ("load", "torque", "speed"):
            law = pp.speed if rest == "speed" else pp.torque
            return _law_sign(drive, i, rest) * law.values[i, -1]
        if parts[2] == "tensioner" and len(parts) == 4 and parts[3] in _TENSIONER:
            return getattr(pp, _TENSIONER[parts[3]])[i]
    _unknown(drive, key)


def set_parameter(drive: Drive, params: DriveParams, key: str, value) -> DriveParams:
    """A copy of ``params`` with ``key`` set to ``value`` (traceable in ``value``)."""
    value = jnp.asarray(value, dtype=jnp.result_type(float))
    parts = key.split(".")
    if parts[0] == "belt" and len(parts) == 2:
        k = parts[1]
        if k in _BELT:
            return eqx.tree_at(lambda p: getattr(p.belt, _BELT[k]), params, value)
        if k == "E":
            scale = value / get_parameter(drive, params, "belt.E")
            return eqx.tree_at(lambda p: (p.belt.EA, p.belt.EI), params,
                               (params.belt.EA * scale, params.belt.EI * scale))
        if k == "eta":
            return eqx.tree_at(lambda p: p.belt.axial_damping, params, value * _section_area(drive))
        if k == "pretension":
            L_path = installed_path(drive, params).length
            return eqx.tree_at(lambda p: p.belt.stress_free_length, params, L_path / (1.0 + value / params.belt.EA))
    if parts[0] == "contact" and len(parts) == 2 and parts[1] in _CONTACT:
        return eqx.tree_at(lambda p: getattr(p, _CONTACT[parts[1]]), params, value)
    if parts[0] == "pulleys" and len(parts) >= 3:
        i = _pulley_index(drive, parts[1], key)
        rest = ".".join(parts[2:])
        if rest in _PULLEY:
            field = _PULLEY[rest]
            arr = getattr(params.pulleys, field)
            return eqx.tree_at(lambda p: getattr(p.pulleys, field), params, arr.at[i].set(value))
        if rest in ("load", "torque", "speed"):
            sign = _law_sign(drive, i, rest)
            law_name = "speed" if rest == "speed" else "torque"
            law = getattr(params.pulleys, law_name)
            old = law.values[i]
            final = old[-1]
            # scale the law's shape to the new final level (a law ending at 0 is shifted instead)
            safe = jnp.where(final == 0, 1.0, final)
            new = jnp.where(final == 0, old + sign * value, old * (sign * value) / safe)
            return eqx.tree_at(lambda p: getattr(p.pulleys, law_name).values, params, law.values.at[i].set(new))
        if parts[2] == "tensioner" and len(parts) == 4 and parts[3] in _TENSIONER:
            field = _TENSIONER[parts[3]]
            arr = getattr(params.pulleys, field)
            return eqx.tree_at(lambda p: getattr(p.pulleys, field), params, arr.at[i].set(value))
    _unknown(drive, key)
