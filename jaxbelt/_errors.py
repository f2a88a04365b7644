"""The errors jaxbelt raises for bad input, and the one "did you mean" helper their messages share.

Every one is a ``ValueError`` whose message names the key (or file, or pulley), the value and what
is allowed, so that a caller can show it as it is.
"""

from __future__ import annotations

import difflib
import math
from typing import Iterable

import numpy as np

__all__ = ["ConfigError", "DataError", "LayoutError", "closest", "did_you_mean", "is_finite_number"]


def is_finite_number(x) -> bool:
    """A finite real number (not a bool, not a string): what a coefficient of a law or carrier key may be."""
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        return False
    try:
        return math.isfinite(float(x))
    except OverflowError:
        return False


class ConfigError(ValueError):
    """A drive configuration that cannot be simulated; the message names the field."""


class DataError(ValueError):
    """A data file (e.g. a measured ``signals.csv``) that cannot be used; the message says why."""


class LayoutError(ValueError):
    """A belt layout refused by :func:`jaxbelt.geometry.check_belt_path`.

    ``suggestions`` lists the fixes that pass the check, most faithful first:
    ``("order", perm)``: list the pulleys in the order ``perm`` (indices into the list given),
    every wrap side as given and the listed direction of travel kept (the drive that was meant
    when a pulley was listed out of order); ``("wrap", i)``: pulley ``i`` on the other side of
    the belt (a different drive from the one given: the message says so).
    """

    def __init__(self, message: str, suggestions=()):
        super().__init__(message)
        self.suggestions = list(suggestions)


def closest(word: str, choices: Iterable[str]) -> str:
    """The valid name ``word`` was most likely meant to be, or "" for none: a case slip ('ea' for
    'EA') beats any near spelling; else the closest spelling (difflib ratio >= 0.6)."""
    choices = list(choices)
    low = {c.lower(): c for c in choices}
    if word.lower() in low:
        return low[word.lower()]
    close = difflib.get_close_matches(word, choices, n=1, cutoff=0.6)
    return close[0] if close else ""


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """``" (did you mean 'x'?)"`` for the closest valid name (see :func:`closest`), else ""."""
    near = closest(word, choices)
    return f" (did you mean {near!r}?)" if near else ""
