"""TOML drive configurations: load into a ``DriveSpec``, edit by dotted key, write back.

The file mirrors the dataclasses of ``config.spec`` one to one (same key names, SI units)::

    gravity = [0.0, -9.81]          # top-level keys come before the first [table]

    [belt]        -> BeltSpec
    [contact]     -> ContactSpec
    [solver]      -> SolverSpec
    [[pulleys]]   -> PulleySpec, one table per pulley in the belt's direction of travel (either
                     order round the loop when belt.direction is given)
    [pulleys.tensioner] -> TensionerSpec of the pulley just above it

This module checks the *shape* of the file: known keys (a wrong key gets the nearest valid one
suggested), value types, allowed words, time-law tables. Ranges and the geometry are checked by
``build_drive``, which names the same keys. Every problem is a ``ConfigError`` whose message names
the key path, the value and what is expected.

The schema is read from the dataclasses themselves, so a field added to a spec class is a valid
key at once. About 440 lines, over the usual 400: reading, dotted-key editing and writing share that
one schema reader and its messages.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import types
import typing
from typing import Any, Literal

import numpy as np
import tomli_w

if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.10: the same parser, from PyPI
    import tomli as tomllib

from .._errors import ConfigError, closest
from .routed import flat_fields, flat_hints  # the friction laws' and the carriers' keys sit flat in their tables
from ..pulleys import timelaw as tl
from . import spec as _spec
from .checks import _is_number  # one definition of "a real number" for TOML and Python specs
from .laws import _check_law
from .spec import BeltSpec, ContactSpec, DriveSpec, PulleySpec, SolverSpec, TensionerSpec

__all__ = ["load_config", "read_toml", "spec_from_dict", "get_key", "set_key", "dump_toml", "valid_keys"]

_SECTIONS = {"belt": BeltSpec, "contact": ContactSpec, "solver": SolverSpec}
_TOP_KEYS = ("gravity", "belt", "pulleys", "contact", "solver")
_LAW_KEYS = ("constant", "ramp", "smooth_step", "table", "angle_table", "base", "smooth", "period_deg")
_AXES = {"x": 0, "y": 1}


# --------------------------------------------------------------------------- schema
def _hints(cls) -> dict[str, Any]:
    return flat_hints(cls, typing.get_type_hints(cls, vars(_spec)))


def _fields(cls) -> list[str]:
    return flat_fields(cls, [f.name for f in dataclasses.fields(cls)])


def _unwrap_optional(tp):
    """(inner type, optional?) for ``X | None``; unions of several types are returned whole."""
    args = typing.get_args(tp)
    if typing.get_origin(tp) in (typing.Union, types.UnionType) and type(None) in args:
        rest = tuple(a for a in args if a is not type(None))
        if len(rest) == 1:
            return rest[0], True
        return typing.Union[rest], True
    return tp, False


def _is_law(tp) -> bool:
    inner, _ = _unwrap_optional(tp)
    return typing.get_origin(inner) in (typing.Union, types.UnionType) and tl.TimeLaw in typing.get_args(inner)


def valid_keys() -> list[str]:
    """Every dotted key of the schema (pulleys written as ``pulleys.<name>.<key>``)."""
    keys = ["gravity"]
    for sec, cls in _SECTIONS.items():
        keys += [f"{sec}.{k}" for k in _fields(cls)]
    keys += [f"pulleys.<name>.{k}" for k in _fields(PulleySpec)]
    keys += [f"pulleys.<name>.tensioner.{k}" for k in _fields(TensionerSpec)]
    return keys


def _unknown(path: str, key: str, choices) -> ConfigError:
    where = f"{path}.{key}" if path else key
    if path and key in _TOP_KEYS:
        return ConfigError(
            f"unknown key '{where}': '{key}' is a top-level key; in TOML it must stand before "
            "the first [table] (a key below a table header belongs to that table)"
        )
    near = closest(key, choices)
    hint = (
        f"did you mean '{path + '.' if path else ''}{near}'?"
        if near
        else "valid keys here: " + ", ".join(sorted(choices))
    )
    return ConfigError(f"unknown key '{where}': {hint}")


def _type_error(path: str, value, expected: str) -> ConfigError:
    return ConfigError(f"{path} = {_show(value)}: expected {expected}")


def _show(value) -> str:
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_show(v)}" for k, v in value.items()) + "}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_show(v) for v in value) + "]"
    return repr(value)


# --------------------------------------------------------------------------- conversion
def _convert(path: str, value, tp):
    """Check ``value`` (from TOML) against the annotation ``tp`` and convert it."""
    if _is_law(tp):
        return _convert_law(path, value)
    inner, optional = _unwrap_optional(tp)
    if dataclasses.is_dataclass(inner):
        if not isinstance(value, dict):
            raise _type_error(path, value, f"a table [{path}]")
        return _build(inner, value, path)
    if inner is bool:
        if not isinstance(value, bool):
            raise _type_error(path, value, "true or false")
        return value
    if inner is int:
        if isinstance(value, float) and not isinstance(value, bool) and value.is_integer():
            return int(value)
        if not isinstance(value, int) or isinstance(value, bool):
            raise _type_error(path, value, "an integer")
        return value
    if inner is float:
        if not _is_number(value):
            raise _type_error(path, value, "a number")
        return float(value)
    if inner is str:
        if not isinstance(value, str):
            raise _type_error(path, value, "a string")
        return value
    if typing.get_origin(inner) is Literal:
        allowed = typing.get_args(inner)
        if value not in allowed:
            near = closest(str(value), [str(a) for a in allowed]) if isinstance(value, str) else ""
            hint = f" (did you mean '{near}'?)" if near else ""
            raise ConfigError(f"{path} = {_show(value)}: must be one of " + ", ".join(repr(a) for a in allowed) + hint)
        return value
    if typing.get_origin(inner) is tuple:
        args = typing.get_args(inner)
        if not isinstance(value, (list, tuple)) or len(value) != len(args) or not all(_is_number(v) for v in value):
            raise _type_error(path, value, f"a list of {len(args)} numbers, e.g. [0.0, 0.1]")
        return tuple(float(v) for v in value)
    return value  # an annotation this loader does not know: passed through for build_drive to judge


def _convert_law(path: str, value):
    """A time law: a number or an inline table ``{ramp = [...]}`` etc.; kept as the dict."""
    if _is_number(value):
        return float(value)
    if not isinstance(value, dict):
        raise _type_error(
            path,
            value,
            "a number or an inline table such as { ramp = [t0, t1, v0, v1] }, "
            "{ smooth_step = [t0, t1, v0, v1] } or { table = [[t, v], ...] }",
        )
    for k in value:
        if k not in _LAW_KEYS:
            raise _unknown(path, k, _LAW_KEYS)
    if "smooth" in value and not isinstance(value["smooth"], bool):
        raise _type_error(f"{path}.smooth", value["smooth"], "true or false")
    if "base" in value and not _is_number(value["base"]):
        raise _type_error(f"{path}.base", value["base"], "a number")
    _check_law(value, path)  # raises ConfigError naming the path for bad shapes (numpy only)
    return dict(value)


def _build(cls, table: dict, path: str):
    hints = _hints(cls)
    names = _fields(cls)
    kwargs = {}
    for key, value in table.items():
        if key not in names:
            raise _unknown(path, key, names)
        kwargs[key] = _convert(f"{path}.{key}", value, hints[key])
    try:
        return cls(**kwargs)
    except TypeError:
        missing = [
            f.name
            for f in dataclasses.fields(cls)
            if f.name not in kwargs and f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING
        ]
        raise ConfigError(
            f"{path}: missing required key" + ("s " if len(missing) > 1 else " ") + ", ".join(f"'{m}'" for m in missing)
        ) from None


def _pulley_path(i: int, table) -> str:
    name = table.get("name") if isinstance(table, dict) else None
    return f"pulleys.{name}" if isinstance(name, str) and name else f"pulleys[{i}]"


def spec_from_dict(data: dict) -> DriveSpec:
    """A ``DriveSpec`` from a parsed TOML document (checks keys and types, not ranges)."""
    if not isinstance(data, dict):
        raise ConfigError("a drive configuration must be a TOML document (a table of keys)")
    for key in data:
        if key not in _TOP_KEYS:
            raise _unknown("", key, _TOP_KEYS)
    if "belt" not in data:
        raise ConfigError("missing table [belt]")
    if "pulleys" not in data:
        raise ConfigError("missing pulleys: add one [[pulleys]] table per pulley, in the belt's direction of travel")
    kwargs = {}
    for sec, cls in _SECTIONS.items():
        if sec in data:
            if not isinstance(data[sec], dict):
                raise _type_error(sec, data[sec], f"a table [{sec}]")
            kwargs[sec] = _build(cls, data[sec], sec)
    pulleys = data["pulleys"]
    if not isinstance(pulleys, list) or not all(isinstance(p, dict) for p in pulleys):
        raise _type_error("pulleys", pulleys, "an array of tables, one [[pulleys]] table per pulley")
    kwargs["pulleys"] = [_build(PulleySpec, p, _pulley_path(i, p)) for i, p in enumerate(pulleys)]
    if "gravity" in data:
        kwargs["gravity"] = _convert("gravity", data["gravity"], _hints(DriveSpec)["gravity"])
    return DriveSpec(**kwargs)


def read_toml(path: str | os.PathLike) -> dict:
    """Parse a TOML file. A syntax error becomes a ``ConfigError`` naming file, line and column;
    a missing file raises ``FileNotFoundError``."""
    with open(path, "rb") as fh:
        raw = fh.read()
    try:
        return tomllib.loads(raw.decode("utf-8-sig"))  # a byte-order mark (Windows editors) is not TOML
    except UnicodeDecodeError as err:
        raise ConfigError(f"{os.fspath(path)}: not a UTF-8 text file ({err.reason} at byte {err.start})") from None
    except tomllib.TOMLDecodeError as err:
        raise ConfigError(f"{os.fspath(path)}: TOML syntax error: {err}") from None


def load_config(path: str | os.PathLike) -> DriveSpec:
    """Read a drive configuration file into a ``DriveSpec`` (keys and types checked; call
    ``build_drive`` for ranges and geometry)."""
    return spec_from_dict(read_toml(path))


# --------------------------------------------------------------------------- dotted keys
def _split(key: str) -> list[str]:
    parts = key.split(".")
    if not key or any(p == "" for p in parts):
        raise ConfigError(f"'{key}' is not a dotted key such as 'contact.mu' or 'pulleys.driven.load'")
    return parts


def _pulley_index(pulleys: list, name: str, key: str) -> int:
    names = [p.get("name") for p in pulleys if isinstance(p, dict)]
    if name in names:
        return names.index(name)
    if name.isdigit() and int(name) < len(pulleys):
        return int(name)
    near = closest(name, [n for n in names if isinstance(n, str)])
    hint = f"did you mean '{near}'?" if near else "pulleys: " + ", ".join(map(str, names))
    raise ConfigError(f"{key}: no pulley named '{name}': {hint}")


def _resolve(data: dict, key: str, create: bool):
    """(container, slot, schema type or None) for a dotted key; ``container[slot]`` is the value."""
    parts = _split(key)
    head = parts[0]
    if head not in _TOP_KEYS:
        raise _unknown("", head, _TOP_KEYS)
    if head == "gravity":
        node, tp, rest, path = data, _hints(DriveSpec)["gravity"], parts[1:], "gravity"
        slot: str | int = "gravity"
    else:
        cls: type  # the spec class (a dataclass) that holds the next part of the key
        if head == "pulleys":
            if len(parts) < 3:
                raise ConfigError(
                    f"{key}: address a pulley's key as 'pulleys.<name>.<key>', e.g. 'pulleys.driven.load'"
                )
            pulleys = data.get("pulleys")
            if not isinstance(pulleys, list):
                raise ConfigError(f"{key}: the configuration has no [[pulleys]]")
            node = pulleys[_pulley_index(pulleys, parts[1], key)]
            cls, rest, path = PulleySpec, parts[2:], f"pulleys.{parts[1]}"
        else:
            if len(parts) < 2:
                raise ConfigError(f"{key}: name a key of [{head}], e.g. '{head}.{_fields(_SECTIONS[head])[0]}'")
            if head not in data:
                if not create:
                    raise KeyError(key)
                data[head] = {}
            node, cls, rest, path = data[head], _SECTIONS[head], parts[1:], head
        while True:
            name, rest = rest[0], rest[1:]
            names = _fields(cls)
            if name not in names:
                raise _unknown(path, name, names)
            tp = _hints(cls)[name]
            inner, _ = _unwrap_optional(tp)
            path = f"{path}.{name}"
            if isinstance(inner, type) and dataclasses.is_dataclass(inner) and rest:
                if name not in node:
                    if not create:
                        raise KeyError(key)
                    node[name] = {}
                node, cls = node[name], inner
                continue
            slot = name
            break
    # below a schema key: indices into [x, y] pairs or into a law's inline table
    for part in rest:
        if slot not in node:
            raise KeyError(key)
        node = node[slot]
        if isinstance(node, list):
            idx = _AXES.get(part, int(part) if part.isdigit() else None)
            if idx is None or idx >= len(node):
                raise ConfigError(f"{key}: '{part}' is not an index of {path} = {_show(node)} (use 0, 1, ... or x, y)")
            slot, path, tp = idx, f"{path}.{part}", None
        elif isinstance(node, dict):
            if part not in node:
                raise _unknown(path, part, list(node))
            slot, path, tp = part, f"{path}.{part}", None
        else:
            raise ConfigError(f"{key}: {path} = {_show(node)} has no part '{part}'")
    return node, slot, tp, path


def get_key(data: dict, key: str):
    """Value of a dotted key (``contact.mu``, ``pulleys.driven.load``, ``gravity.y``,
    ``pulleys.driven.load.smooth_step.3``) in a parsed TOML document; ``KeyError`` if not set."""
    node, slot, _, _ = _resolve(data, key, create=False)
    try:
        return node[slot]
    except (KeyError, IndexError):
        raise KeyError(key) from None


def set_key(data: dict, key: str, value) -> dict:
    """Set a dotted key in a parsed TOML document (in place; also returned).

    Pulleys are addressed by name: ``pulleys.driven.load``, ``pulleys.tens.tensioner.stiffness``.
    A time-law key set to a number becomes that constant. Components of pairs (``center``,
    ``pivot``, ``gravity``) are addressed as ``.x``/``.y`` (or ``.0``/``.1``), entries of a law
    table by position, e.g. ``pulleys.driven.load.smooth_step.3`` (the final value of the step).
    The key and the value's type are checked; ranges are ``build_drive``'s business.
    """
    node, slot, tp, path = _resolve(data, key, create=True)
    if isinstance(value, np.generic) or (hasattr(value, "item") and getattr(value, "shape", None) == ()):
        value = value.item()  # numpy / JAX scalars from a grid
    if isinstance(value, tuple):
        value = list(value)  # the document holds what TOML gives: lists
    if tp is not None:
        _convert(path, value, tp)
    elif not _is_number(value) and not isinstance(value, type(_get(node, slot))):
        raise _type_error(path, value, "a number")
    node[slot] = value
    return data


def _get(node, slot):
    try:
        return node[slot]
    except (KeyError, IndexError):
        return None


# --------------------------------------------------------------------------- writing
def _toml_ready(v):
    """``v`` as the plain Python values ``tomli_w`` writes (numpy numbers and arrays, tuples and time
    laws converted); ``TypeError`` for what TOML cannot hold (e.g. ``None`` inside a list)."""
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return float(v)
    if isinstance(v, str):
        return v
    if isinstance(v, (list, tuple, np.ndarray)):
        return [_toml_ready(x) for x in v]
    if isinstance(v, dict):
        return {str(k): _toml_ready(x) for k, x in v.items()}
    if isinstance(v, tl.TimeLaw):
        return _toml_ready(_law_as_dict(v))
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def _law_as_dict(law: tl.TimeLaw):
    t, v, s = (np.asarray(x, dtype=float) for x in (law.times, law.values, law.smooth))
    if t.size == 1:
        return float(v[0])
    if np.any(s[1:] != s[1]):
        raise ValueError("a time law mixing smooth and linear intervals has no TOML form; give it as a table")
    out: dict[str, object] = {"table": [[float(a), float(b)] for a, b in zip(t, v)]}
    if s[1] > 0.5:
        out["smooth"] = True
    return out


def _table(obj) -> dict:
    """A spec dataclass as a TOML table: keys left at ``None`` and nested specs left out."""
    return {
        name: _toml_ready(v)
        for name in _fields(type(obj))
        if (v := getattr(obj, name)) is not None and not dataclasses.is_dataclass(v)
    }


def dump_toml(spec: DriveSpec) -> str:
    """TOML text of a ``DriveSpec`` (``load_config`` of it gives back an equal spec). Keys left
    at ``None`` are omitted; every other key is written, defaults included. The text is written by
    ``tomli_w`` (every string escaped as TOML requires)."""
    pulleys = []
    for p in spec.pulleys:
        pulleys.append(_table(p))
        if p.tensioner is not None:
            pulleys[-1]["tensioner"] = _table(p.tensioner)
    doc = {
        "gravity": _toml_ready(spec.gravity),
        "belt": _table(spec.belt),
        "pulleys": pulleys,
        "contact": _table(spec.contact),
        "solver": _table(spec.solver),
    }
    return tomli_w.dumps(doc)
