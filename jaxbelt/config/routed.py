"""Keys a spec class holds in one dict field but shows as attributes, keyword arguments and flat TOML keys: the
keys of a room's table (the friction laws' ``LawKey``s in ``[contact]``, the carriers' ``SpecKey``s in
``[pulleys.tensioner]``), read at each call, so a law or carrier kind added to its table is valid at once.

``routed(field, keys, hints, choices)`` decorates a dataclass (above ``@dataclass``): ``keys()`` gives each routed
name's default (None: absent unless given), ``hints()`` its type in the file, ``choices`` the names of the table a
field picks from (``friction_law``, ``kind``) as a ``Literal`` for the TOML reader. ``flat_fields`` / ``flat_hints``
give ``config/toml.py`` the schema with the routed keys in place of the field.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Mapping
from typing import Any, Literal

__all__ = ["routed", "flat_fields", "flat_hints", "refuse_unknown"]


def refuse_unknown(given: Mapping[str, Any], known, where: str, what: str, require: Callable) -> None:
    """Refuse, by name, each key of ``given`` that no variant of the room declares (``known``: every declared key);
    ``require(ok, key, value, allowed)`` is the configuration's refusal, ``where`` the table's path, ``what`` the
    room's variants in words ("friction law", "tensioner kind")."""
    for name, value in given.items():
        require(name in known, f"{where}.{name}", value, f"is not a key of any {what} (keys: " + ", ".join(known) + ")")


def routed(
    field: str,
    keys: Callable[[], Mapping[str, Any]],
    hints: Callable[[], Mapping[str, Any]],
    choices: Mapping[str, Callable[[], tuple[str, ...]]] | None = None,
):
    def decorate(cls):
        init = cls.__init__
        names = set(cls.__dataclass_fields__)

        @functools.wraps(init)
        def __init__(self, *args, **kwargs):
            given = dict(kwargs.pop(field, None) or {})
            table = keys()
            for key in [k for k in kwargs if k in table and k not in names]:
                _put(given, key, kwargs.pop(key), table[key])
            for key, default in table.items():  # defaults stored: equal specs compare equal, round trips hold
                if default is not None:
                    given.setdefault(key, default)
            init(self, *args, **kwargs, **{field: given})

        def __getattr__(self, name):  # only reached when ordinary lookup fails
            table = keys()
            if name in table:
                return self.__dict__.get(field, {}).get(name, table[name])
            raise AttributeError(f"{cls.__name__!r} object has no attribute {name!r}")

        def __setattr__(self, name, value):
            table = keys()
            if name not in names and name in table:
                _put(self.__dict__.setdefault(field, {}), name, value, table[name])
            else:
                object.__setattr__(self, name, value)

        cls.__init__, cls.__getattr__, cls.__setattr__ = __init__, __getattr__, __setattr__
        cls.__routed__ = (field, keys, hints, dict(choices or {}))
        return cls

    return decorate


def _put(table: dict, key: str, value, default) -> None:
    if value is None and default is None:
        table.pop(key, None)
    else:
        table[key] = default if value is None else value


def flat_fields(cls, names: list[str]) -> list[str]:
    """The file's key names of a spec class: the routed keys in place of their field."""
    route = getattr(cls, "__routed__", None)
    if route is None:
        return names
    field, keys = route[0], route[1]
    i = names.index(field)
    return names[:i] + [k for k in keys() if k not in names] + names[i + 1 :]


def flat_hints(cls, hints: dict) -> dict:
    """Type hints to match ``flat_fields``: each routed key its hint or absent; each choice field one of its
    table's names as it stands now."""
    route = getattr(cls, "__routed__", None)
    if route is None:
        return hints
    field, _, key_hints, choices = route
    out = {k: v for k, v in hints.items() if k != field}
    out.update({k: v | None for k, v in key_hints().items() if k not in out})
    for name, table in choices.items():
        out[name] = Literal[table()]
    return out
