"""Named physical parameters of a drive, read and written as traced values.

Identification, sweeps and the command line speak in configuration keys (``belt.E``,
``contact.mu``, ``pulleys.driven.load``); this module maps each key onto the leaves of
``DriveParams`` with pure functions, so ``jax.grad``/``jax.jacfwd``/``vmap`` pass straight through:

    p = set_parameter(drive, drive.params, "belt.E", E)     # E may be a tracer

A changed key gives the parameters that a file edit of that key would build (``--vary``, ``--fit``
and editing the TOML agree): the belt keeps what its spec fixed, the installed **pretension** for a
belt given by ``pretension``, the **stress-free length** for one given by ``stress_free_length``,
``effective_length`` or ``installed_effective_length`` (``drive.installed_by``, static; the last is the
one exception to the file-edit rule: a file edit of the tensioner, EA or the layout rebuilds that belt
from its installed length). Keys, what they change, and what is held fixed:

==================================  ==========================================  ===================================
key                                 changes                                     held fixed
==================================  ==========================================  ===================================
``belt.E``                          the stiffnesses the spec derives from E     pretension-defined belt: the
                                    (``E·A`` unless ``EA`` is given, ``E·I``    pretension (the stress-free length
                                    unless ``EI`` is given; both, ratio kept,   follows); length-defined: the
                                    when the spec gives no E)                   stress-free length (tension follows)
``belt.EA``                         EA                                          as ``belt.E``
``pulleys.<name>.radius``           effective radius (at the belt axis), so     as ``belt.E``
                                    the installed belt path
``belt.pretension``                 stress-free length = L_path/(1 + T/EA)      EA and the path
``belt.stress_free_length``         stress-free length                          EA and the path (tension follows)
``belt.EI``, ``belt.eta`` (=        that coefficient only                       everything else (no effect on the
axial_damping/A),                                                               installed state)
``belt.axial_damping``,
``belt.bending_damping``,
``belt.mass_per_length``
``contact.mu``, ``.stiffness``,     that coefficient only                       everything else
``.damping``, ``.nu_s``, the
friction law's own keys that the
spec gives (``.mu_kinetic``,
``.stribeck_velocity`` of
static-kinetic)
``pulleys.<name>.inertia``,         that coefficient only (the installed path   everything else
``.viscous``,                       is taken at the installed carrier
``.tensioner.stiffness``,           position)
``.preload``, ``.damping``,
``.inertia`` (arm inertia [kg m^2];
a slider's moving mass [kg]),
``.mu`` (a pulley with its own),
``.excitation.<order>.amplitude``
(or ``.amplitude_deg``),
``.excitation.<order>.phase_deg``
``pulleys.<name>.rotor_inertia``    a one-way clutch pulley's rotor inertia;    everything else
(clutch pulleys),                   a decoupler's torsion spring and damper
``.clutch_stiffness``,
``.clutch_damping`` (decouplers)
``.tensioner.friction_torque``,     a lossy tensioner's (pivot friction,        everything else; a lossy tensioner
``.tensioner.damping_unload``,      unloading damping or stops: listed for      whose spec gives no
``.tensioner.stops.min``,           those only) Coulomb pivot friction [N m]    ``damping_unload`` damps
``.tensioner.stops.max`` (stops     (slider: guide [N]), unloading damping,     symmetrically: its
given)                              one stop [rad] (slider: [m])                ``.tensioner.damping`` sets both
``pulleys.<name>.load``/            the final level of the applied load/torque  the law's shape (values scaled; a
``.torque``/``.speed``              law or prescribed speed [rad/s], in the     law ending at 0 is shifted)
                                    senses of the configuration (a load
                                    against the pulley's running sense, see
                                    docs/config.md); the speed driver's
                                    ``.speed`` also scales every ``power_kw``
                                    load's torque to P / omega (as a file
                                    edit: the power is sized at that speed)
==================================  ==========================================  ===================================

Several keys at once: ``set_parameters`` applies ``belt.E`` first and ``belt.pretension`` /
``belt.stress_free_length`` last, so the result does not depend on the order the keys are given in
(a varied pretension is the pretension of the result, whatever else varies).
"""

from __future__ import annotations

from typing import NoReturn

import equinox as eqx
import jax.numpy as jnp
import numpy as np

from .._drive import Drive
from .._errors import ConfigError, did_you_mean
from ..config import excitation as _excitation, laws as _laws
from ..geometry.installed import installed_path as installed_path, installed_pretension
from .._types import DriveParams

__all__ = ["parameter_keys", "get_parameter", "set_parameter", "set_parameters", "installed_path"]

_BELT = {
    "EA": "EA",
    "EI": "EI",
    "axial_damping": "axial_damping",
    "bending_damping": "bending_damping",
    "mass_per_length": "mass_per_length",
    "stress_free_length": "stress_free_length",
}
_CONTACT = {"mu": "mu", "stiffness": "contact_stiffness", "damping": "contact_damping", "nu_s": "nu_s"}
_PULLEY = {"inertia": "inertia", "viscous": "viscous", "radius": "radius"}


def parameter_keys(drive: Drive) -> list[str]:
    keys = [f"belt.{k}" for k in ("E", "eta", "pretension", *_BELT)] + [f"contact.{k}" for k in _contact(drive)]
    for name, kin in zip(drive.model.pulley_names, drive.model.kinematic):
        keys += [f"pulleys.{name}.{k}" for k in _PULLEY]
        keys.append(f"pulleys.{name}.speed" if kin else f"pulleys.{name}.load")
        if not kin:
            keys.append(f"pulleys.{name}.torque")
        keys += [f"pulleys.{name}.{k}" for k in _carrier_keys(drive, drive.model.pulley_names.index(name))]
    return keys + _excitation.parameter_keys(drive)  # own mu, engine orders


def _contact(drive: Drive) -> dict:
    """contact keys -> where each sits in ``DriveParams`` (a selector for getting and ``eqx.tree_at``):
    the common ones, then the friction law's own keys that the drive's spec gives (``params.friction``)."""
    out = {k: (lambda p, f=f: getattr(p, f)) for k, f in _CONTACT.items()}
    for key in type(drive.model.friction_law).keys:
        if key.name in drive.params.friction:
            out[key.name] = lambda p, k=key.name: p.friction[k]
    return out


def _carrier_keys(drive: Drive, i: int) -> dict[str, str]:
    """The parameter keys of pulley ``i``'s carrier (after ``pulleys.<name>.``: its ``prefix`` and key) -> the
    number in ``PulleyParams.carrier[i]``: the keys its class marks ``parameter``, but for a number the drive does
    not have (an infinite one: a stop that is not there)."""
    carrier, numbers = drive.model.carriers[i], drive.params.pulleys.carrier[i]
    return {
        carrier.prefix + key.name: key.name
        for key in carrier.keys
        if key.parameter and bool(np.all(np.isfinite(np.asarray(numbers[key.name]))))
    }


def _is_driver_speed(drive: Drive, key: str) -> bool:
    parts = key.split(".")
    if len(parts) != 3 or parts[0] != "pulleys" or parts[2] != "speed" or parts[1] not in drive.model.pulley_names:
        return False
    return bool(_power_loads(drive, drive.model.pulley_names.index(parts[1])))


def _followers(drive: Drive, key: str) -> tuple[str, ...]:
    """The carrier numbers that follow the one ``key`` sets (``AbstractCarrier.followers``), or none."""
    parts = key.split(".")
    if parts[0] != "pulleys" or len(parts) < 3 or parts[1] not in drive.model.pulley_names:
        return ()
    i = drive.model.pulley_names.index(parts[1])
    number = _carrier_keys(drive, i).get(".".join(parts[2:]))
    return () if number is None else drive.model.carriers[i].followers(number)


def _unknown(drive: Drive, key: str) -> NoReturn:
    raise ConfigError(f"{key!r} is not a parameter of this drive{did_you_mean(key, parameter_keys(drive))}")


def _section_area(drive: Drive) -> float:
    b = drive.spec.belt
    return b.width * b.thickness


def _section_inertia(drive: Drive) -> float:
    b = drive.spec.belt
    return b.width * b.thickness**3 / 12.0


# Keys that move the installed state (EA or the belt path): a pretension-defined belt keeps its pretension.
def _moves_installed_state(key: str) -> bool:
    parts = key.split(".")
    return key in ("belt.E", "belt.EA") or (len(parts) == 3 and parts[0] == "pulleys" and parts[2] == "radius")


def _with_pretension(drive: Drive, params: DriveParams, tension) -> DriveParams:
    """``params`` with the stress-free length that gives the uniform installed ``tension`` (traceable)."""
    L_path = installed_path(drive, params).length
    return eqx.tree_at(lambda p: p.belt.stress_free_length, params, L_path / (1.0 + tension / params.belt.EA))


def _power_loads(drive: Drive, i: int) -> list[int]:
    """The pulleys whose load is a ``power_kw`` sized at pulley ``i``'s speed (``i`` the drive's one speed driver:
    ``config.laws._nominal_speeds``); none otherwise."""
    spec = drive.spec
    if spec is None or not drive.model.kinematic[i] or spec.pulleys[i].role != "driver":
        return []
    speed_drivers = [k for k, p in enumerate(spec.pulleys) if p.role == "driver" and drive.model.kinematic[k]]
    if speed_drivers != [i]:
        return []
    return [j for j, p in enumerate(spec.pulleys) if p.power_kw is not None]


def _law_sign(drive: Drive, i: int, key: str) -> float:
    """The key's value as written (load against the running sense, ...) per unit of the stored
    counter-clockwise-positive law (its own inverse: the factor is +-1)."""
    return _laws._law_sign(drive.spec.pulleys[i], key, drive.running_sense[i], drive.spec)


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
            return b.EA / _section_area(drive) if "EA" in drive.E_sets else b.EI / _section_inertia(drive)
        if k == "eta":
            return b.axial_damping / _section_area(drive)
        if k == "pretension":
            return installed_pretension(drive, params)
    if parts[0] == "contact" and len(parts) == 2 and parts[1] in _contact(drive):
        return _contact(drive)[parts[1]](params)
    if parts[0] == "pulleys" and len(parts) >= 3:
        i = _pulley_index(drive, parts[1], key)
        pp = params.pulleys
        rest = ".".join(parts[2:])
        if rest in _PULLEY:
            return getattr(pp, _PULLEY[rest])[i]
        if (slot := _excitation.parameter_slot(drive, i, rest)) is not None:
            select, at, factor = slot
            return select(params)[at] * factor
        if rest in ("load", "torque", "speed"):
            law = pp.speed if rest == "speed" else pp.torque
            return _law_sign(drive, i, rest) * law.values[i, -1]
        if (number := _carrier_keys(drive, i).get(rest)) is not None:
            return pp.carrier[i][number]
    _unknown(drive, key)


def set_parameter(drive: Drive, params: DriveParams, key: str, value) -> DriveParams:
    """A copy of ``params`` with ``key`` set to ``value`` (traceable in ``value``); what is held fixed
    is in the module's table."""
    value = jnp.asarray(value, dtype=jnp.result_type(float))
    if drive.installed_by == "pretension" and _moves_installed_state(key):
        tension = get_parameter(drive, params, "belt.pretension")
        return _with_pretension(drive, _set(drive, params, key, value), tension)
    return _set(drive, params, key, value)


# Pairs that set the same leaf: giving both is ambiguous.
_CONFLICTS = [("belt.E", "belt.EA"), ("belt.eta", "belt.axial_damping"), ("belt.pretension", "belt.stress_free_length")]


def check_together(drive: Drive, keys) -> None:
    """``ConfigError`` for keys that cannot be set together (both set the same parameter, or one key twice)."""
    keys = list(keys)
    twice = sorted({k for k in keys if keys.count(k) > 1})
    if twice:
        raise ConfigError(f"{twice[0]} is given twice: give each key once (keys: {', '.join(keys)})")
    for a, b in _CONFLICTS + [(f"pulleys.{n}.load", f"pulleys.{n}.torque") for n in drive.model.pulley_names]:
        if a in keys and b in keys:
            raise ConfigError(f"{a} and {b} set the same parameter: give only one of them")


def set_parameters(drive: Drive, params: DriveParams, values) -> DriveParams:
    """``set_parameter`` for several keys (a dict or (key, value) pairs), independent of their order:
    ``belt.E`` first (so a given ``belt.EI`` overrides its scaling; so ``.tensioner.damping``, which a
    lossy tensioner without ``damping_unload`` also unloads with), ``belt.pretension`` /
    ``belt.stress_free_length`` last (so they hold whatever the other keys change)."""
    items = list(values.items()) if isinstance(values, dict) else list(values)
    check_together(drive, [k for k, _ in items])
    last = ("belt.pretension", "belt.stress_free_length")
    # a number others follow (a symmetric lossy tensioner's damping; a driver's speed, which power loads
    # follow) first: a given follower wins
    first = lambda k: k == "belt.E" or bool(_followers(drive, k)) or _is_driver_speed(drive, k)  # noqa: E731
    rank = lambda kv: 0 if first(kv[0]) else 2 if kv[0] in last else 1  # noqa: E731
    for k, v in sorted(items, key=rank):  # stable: the given order within each rank
        params = set_parameter(drive, params, k, v)
    return params


def _set(drive: Drive, params: DriveParams, key: str, value) -> DriveParams:
    parts = key.split(".")
    if parts[0] == "belt" and len(parts) == 2:
        k = parts[1]
        if k in _BELT:
            return eqx.tree_at(lambda p: getattr(p.belt, _BELT[k]), params, value)
        if k == "E":  # the stiffnesses the spec derives from E follow it (E·A, E·I; both when it gives no E)
            scale = value / get_parameter(drive, params, "belt.E")
            return eqx.tree_at(
                lambda p: (p.belt.EA, p.belt.EI),
                params,
                tuple(getattr(params.belt, f) * (scale if f in drive.E_sets else 1.0) for f in ("EA", "EI")),
            )
        if k == "eta":
            return eqx.tree_at(lambda p: p.belt.axial_damping, params, value * _section_area(drive))
        if k == "pretension":
            return _with_pretension(drive, params, value)
    if parts[0] == "contact" and len(parts) == 2 and parts[1] in _contact(drive):
        return eqx.tree_at(_contact(drive)[parts[1]], params, value)
    if parts[0] == "pulleys" and len(parts) >= 3:
        i = _pulley_index(drive, parts[1], key)
        rest = ".".join(parts[2:])
        if rest in _PULLEY:
            field = _PULLEY[rest]
            arr = getattr(params.pulleys, field)
            return eqx.tree_at(lambda p: getattr(p.pulleys, field), params, arr.at[i].set(value))
        if (slot := _excitation.parameter_slot(drive, i, rest)) is not None:
            select, at, factor = slot
            return eqx.tree_at(select, params, select(params).at[at].set(value / factor))
        if rest in ("load", "torque", "speed"):
            sign = _law_sign(drive, i, rest)
            law_name = "speed" if rest == "speed" else "torque"
            law = getattr(params.pulleys, law_name)
            old = law.values[i]
            final = old[-1]
            # scale the law's shape to the new final level (a law ending at 0 is shifted instead)
            safe = jnp.where(final == 0, 1.0, final)
            new = jnp.where(final == 0, old + sign * value, old * (sign * value) / safe)
            params = eqx.tree_at(lambda p: getattr(p.pulleys, law_name).values, params, law.values.at[i].set(new))
            if rest == "speed" and (users := _power_loads(drive, i)):
                # `power_kw` is a torque sized at the driver's final speed: as a file edit of that speed
                # rebuilds it, the torque follows, P / omega (a duty point, a speed sweep)
                ratio = jnp.abs(final) / jnp.where(new[-1] == 0, jnp.abs(final), jnp.abs(new[-1]))
                torque = params.pulleys.torque.values
                params = eqx.tree_at(lambda p: p.pulleys.torque.values, params, torque.at[users, :].multiply(ratio))
            return params
        if (number := _carrier_keys(drive, i).get(rest)) is not None:
            # the number and those that follow it in this drive (a symmetric lossy tensioner's unloading damping)
            for name in (number, *drive.model.carriers[i].followers(number)):
                params = eqx.tree_at(lambda p: p.pulleys.carrier[i][name], params, value)
            return params
    _unknown(drive, key)
