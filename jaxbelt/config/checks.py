"""Primitive checks: every refusal reads ``key = value: what is allowed`` (a ``ConfigError``).

Plain Python and numpy only: validation makes no JAX array and compiles nothing.
"""

from __future__ import annotations

import math
import sys
import warnings
from contextlib import contextmanager
from contextvars import ContextVar
from types import FrameType
from typing import TypeVar

import numpy as np

from .._errors import ConfigError

__all__ = [
    "_require",
    "_given",
    "_is_number",
    "_finite",
    "_positive",
    "_non_negative",
    "_integer",
    "_pair",
    "_pulley_label",
    "_warn",
    "collected_warnings",
]


def _require(cond: bool, field_name: str, value, allowed: str):
    if not cond:
        shown = repr(value)
        if len(shown) > 160:  # a 400-digit integer or a long table: enough to recognise it
            shown = shown[:120] + " ... " + shown[-20:]
        raise ConfigError(f"{field_name} = {shown}: {allowed}{_array_hint(value)}")


def _array_hint(value) -> str:
    """Why a 0-d array (a JAX or NumPy array holding one number) is refused where a number is expected:
    the message would otherwise read 'Array(0.1): must be a finite number > 0'."""
    if getattr(value, "shape", None) == () and not isinstance(value, (int, float, np.generic)):
        return f" (this is a 0-d {type(value).__name__}, not a number: give float(x))"
    return ""


T = TypeVar("T")


def _given(value: T | None, field_name: str, allowed: str) -> T:
    """``value``, refused as ``_require`` refuses when it is missing (None)."""
    if value is None:
        raise ConfigError(f"{field_name} = None: {allowed}")
    return value


def _is_number(x) -> bool:
    """A real number (not a bool, not a string); huge ints that overflow a float are not."""
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        return False
    try:
        float(x)
    except OverflowError:
        return False
    return True


def _finite(field_name: str, value, allowed: str = "must be a finite number"):
    _require(_is_number(value) and math.isfinite(float(value)), field_name, value, allowed)


def _positive(field_name: str, value):
    _require(
        value is not None and _is_number(value) and math.isfinite(float(value)) and value > 0,
        field_name,
        value,
        "must be a finite number > 0",
    )


def _non_negative(field_name: str, value):
    _require(
        _is_number(value) and math.isfinite(float(value)) and value >= 0,
        field_name,
        value,
        "must be a finite number >= 0",
    )


def _integer(field_name: str, value, lo: int, hi: int | None = None):
    ok = isinstance(value, (int, np.integer)) and not isinstance(value, bool) and value >= lo
    ok = ok and (hi is None or value <= hi)
    _require(bool(ok), field_name, value, f"must be an integer >= {lo}" + (f" and <= {hi}" if hi is not None else ""))


def _pair(field_name: str, value, what: str = "(x, y) in m") -> tuple[float, float]:
    """Two finite numbers (a list or tuple), as floats."""
    ok = (
        isinstance(value, (list, tuple, np.ndarray))
        and len(value) == 2
        and all(_is_number(x) and math.isfinite(float(x)) for x in value)
    )
    _require(ok, field_name, value, f"must be two finite numbers {what}")
    return float(value[0]), float(value[1])


def _pulley_label(i: int, p) -> str:
    """How messages name pulley ``i``: ``pulleys.<name>`` (the dotted key), else ``pulleys[i]``."""
    name = getattr(p, "name", None)
    return f"pulleys.{name}" if isinstance(name, str) and name.strip() else f"pulleys[{i}]"


# The messages of the build under way (``collected_warnings``): the drive keeps them for its summary,
# since a Python warning alone is shown once per process and never reaches summary.json.
_COLLECTED: ContextVar[list[str] | None] = ContextVar("jaxbelt_build_warnings", default=None)


@contextmanager
def collected_warnings():
    """Collect the messages ``_warn`` gives inside the block (each once, in order), as well as warning."""
    token = _COLLECTED.set([])
    try:
        yield _COLLECTED.get()
    finally:
        _COLLECTED.reset(token)


def _warn(message: str) -> None:
    """A ``UserWarning`` attributed to the first caller outside ``config/`` (the line that built the
    drive), however deep in the build the check that warns sits; inside ``collected_warnings`` also
    recorded."""
    notes = _COLLECTED.get()
    if notes is not None and message not in notes:
        notes.append(message)
    frame: FrameType | None = sys._getframe(0)
    level = 1
    while frame is not None and frame.f_globals.get("__name__", "").startswith(__package__ + "."):
        frame, level = frame.f_back, level + 1
    warnings.warn(message, UserWarning, stacklevel=level)
