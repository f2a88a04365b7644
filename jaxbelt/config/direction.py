"""The sense the belt runs round the drive: from ``belt.direction``, else from the sign of the first
driver's speed or torque; and the warnings where that sense is probably not what the file means.
"""

from __future__ import annotations

import numpy as np

from .checks import _pulley_label, _warn
from .laws import _driver_law
from .spec import DriveSpec

__all__ = []

_SENSE_WORDS = {1: "counter-clockwise", -1: "clockwise"}
_SENSE_KEYS = {1: "ccw", -1: "cw"}


def _travel(spec: DriveSpec, listed: int, sides):
    """Sense of travel (+1 counter-clockwise, -1 clockwise) and how the path is built from it:
    (travel, order of the listed pulleys in the model, orientation to force on the path or None,
    whether spans run in path order, what set the sense). ``listed``: the orientation of the path
    read in the listed order (``geometry.path.path_reading``)."""
    k = len(sides)
    if spec.belt.direction is not None:
        travel = 1 if spec.belt.direction == "ccw" else -1
        # the reverse listing keeps pulley 0 first (s = 0 stays where it was); two pulleys read
        # either way, so the orientation is forced as well
        order = list(range(k)) if listed == travel else [0, *range(k - 1, 0, -1)]
        return travel, order, travel, True, f'belt.direction = "{spec.belt.direction}"'
    travel, source = 1, "default (no driver with a non-zero speed or torque)"
    for i, (p, w) in enumerate(zip(spec.pulleys, sides)):
        if p.role == "driver":
            key, v = _driver_law(p)
            peak = float(v[np.argmax(np.abs(v))]) if v.size else 0.0
            if peak != 0.0:  # a driver on its back side turns against the loop
                travel, source = (1 if peak > 0 else -1) * w, f"the sign of {_pulley_label(i, p)}.{key}"
                break
    return travel, list(range(k)), None, listed == travel, source


def _direction_warnings(spec: DriveSpec, travel: int, along: bool, source: str) -> None:
    """One-line warnings where the sense of travel is probably not what the file means
    (``spec.pulleys`` in model order; ``along``: spans run in that order)."""
    k, word, other = len(spec.pulleys), _SENSE_WORDS[travel], _SENSE_KEYS[-travel]
    if not along:
        _warn(
            f"the pulleys are listed {_SENSE_WORDS[-travel]} but the belt runs {word} (set by {source}): spans "
            f"are named and contact angles measured against the travel; set belt.direction = "
            f'"{_SENSE_KEYS[travel]}" to keep this sense (spans then named in travel order), or belt.direction = '
            f'"{other}" to run the belt in the listed order'
        )
    if spec.belt.direction is not None:
        for i, p in enumerate(spec.pulleys):
            if p.role == "driver":
                key, v = _driver_law(p)
                if v.size and float(v[np.argmax(np.abs(v))]) < 0:
                    _warn(
                        f'{_pulley_label(i, p)}.{key} is negative: with belt.direction = "{spec.belt.direction}" '
                        f"a driver's {key} counts in that sense, so it drives the belt {_SENSE_WORDS[-travel]} and "
                        f'loads then drive the pulleys; give a positive {key} (and belt.direction = "{other}" if '
                        f"the belt should run {_SENSE_WORDS[-travel]})"
                    )
    seq = list(range(k)) if along else [0, *range(k - 1, 0, -1)]  # model indices in travel order
    pl = [spec.pulleys[i] for i in seq]
    for i, p in enumerate(pl):
        if p.role != "driver":
            continue
        # walk against the travel from the driver to the pulley that takes power off the belt: that
        # stretch is the tight side
        tens: list[str] = []
        j = (i - 1) % k
        while j != i and pl[j].role != "driver":
            if pl[j].role == "driven" or pl[j].load is not None or pl[j].power_kw is not None:
                if tens:
                    fix = (
                        f'set belt.direction = "{other}"'
                        if spec.belt.direction is not None
                        else f'set belt.direction = "{other}" (pulleys may then be listed in either order)'
                    )
                    _warn(
                        f"pulley {tens[0]!r} (a tensioner) sits on the tight side of the belt, between {pl[j].name!r} "
                        f"and the driver {p.name!r} with the belt running {word} ({source}); a tensioner belongs on "
                        f"the slack side, after the driver: if the belt should run the other way, {fix}"
                    )
                break
            if pl[j].tensioner is not None or pl[j].role == "tensioner":
                tens.append(pl[j].name)
            j = (j - 1) % k
