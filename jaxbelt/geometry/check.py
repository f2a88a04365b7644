"""Layout checks of a belt path with concrete (numpy) values, and the fixes they suggest.

:func:`check_belt_path` reads the layout with the geometry :func:`jaxbelt.geometry.path.belt_path`
traces (same readings, same orientation rule) and refuses one whose path cannot close, naming the
pulleys and spans at fault; a :class:`~jaxbelt._errors.LayoutError` carries the pulley orders (and,
flagged as a different drive, the wrap sides) that would pass.
"""

from __future__ import annotations

import itertools
import math
from typing import Sequence

import jax
import numpy as np
from jaxtyping import ArrayLike, Float

from .._errors import LayoutError
from .path import _TURN_TOL, _check_orientation_arg, _choose, _np_reading, _static_wrap_side

__all__ = ["LayoutError", "check_belt_path"]

_MAX_FULL_SEARCH = 6  # pulleys: up to this many, all (k-1)! orders are tried when moving one pulley fails


def _fmt(x: float) -> str:
    return f"{x:.6g}"


def _span_name(i: int, k: int) -> str:
    return f"span {i} (pulley {i} -> pulley {(i + 1) % k})"


def _path_problem(g: dict, c: np.ndarray, r: np.ndarray) -> tuple[str, str] | None:
    """First geometric problem of the numpy reading ``g`` (see :func:`_reading`), or None.

    Assumes radii/overlap/tangent existence have already been checked.
    Returns (kind, message) with kind in {"turning", "cut", "cross"}.
    """
    k = r.shape[0]
    if not g["turn_score"] < _TURN_TOL:
        return "turning", f"total turning {float(g['turning']) / math.pi:.4g}*pi"
    if np.any(g["cut"]):
        i, m = (int(v) for v in np.argwhere(g["cut"])[0])
        p, e, c_m = g["span_start"][i], g["span_end"][i], c[m]
        seg = e - p
        t = float(np.clip((c_m - p) @ seg / max(float(seg @ seg), 1e-300), 0.0, 1.0))
        dist = float(np.linalg.norm(p + t * seg - c_m))
        return "cut", (
            f"{_span_name(i, k)} passes through pulley {m}: distance from its centre "
            f"{_fmt(dist)} < radius {_fmt(r[m])} (the belt would cut through pulley {m}); "
            f"check the pulley order and the wrap side of pulley {m}"
        )
    if np.any(g["cross"]):
        i, j = (int(v) for v in np.argwhere(np.triu(g["cross"]))[0])
        p, rr = g["span_start"][i], g["span_end"][i] - g["span_start"][i]
        q, ss = g["span_start"][j], g["span_end"][j] - g["span_start"][j]
        den = rr[0] * ss[1] - rr[1] * ss[0]
        qp = q - p
        x = p + (qp[0] * ss[1] - qp[1] * ss[0]) / den * rr
        return "cross", (
            f"the belt path self-intersects: {_span_name(i, k)} crosses "
            f"{_span_name(j, k)} at ({_fmt(x[0])}, {_fmt(x[1])}); check the pulley "
            f"order and wrap sides"
        )
    return None


def _basic_problem(c: np.ndarray, r: np.ndarray, w: np.ndarray) -> str | None:
    """Overlap and tangent-existence problems (orientation independent)."""
    k = r.shape[0]
    for i in range(k):
        for j in range(i + 1, k):
            dist = float(np.linalg.norm(c[j] - c[i]))
            if dist < r[i] + r[j]:
                return (
                    f"pulleys {i} and {j} overlap: centre distance {_fmt(dist)} < sum of "
                    f"radii {_fmt(r[i] + r[j])} (r{i}={_fmt(r[i])}, r{j}={_fmt(r[j])})"
                )
    for i in range(k):
        j = (i + 1) % k
        dist = float(np.linalg.norm(c[j] - c[i]))
        a = abs(w[j] * r[j] - w[i] * r[i])  # |sigma_j rho_j - sigma_i rho_i| (o cancels)
        if dist - a <= 1e-9 * max(dist, float(r[i] + r[j])):
            kind = "crossed (inner/back-side)" if w[i] != w[j] else "open"
            return (
                f"cannot build the {kind} tangent span from pulley {i} to pulley {j}: "
                f"|sigma_{j}*rho_{j} - sigma_{i}*rho_{i}| = {_fmt(a)} >= centre distance "
                f"{_fmt(dist)} (the pulleys touch or one contains the other)"
            )
    return None


def _is_valid(c, r, w, orientation=None) -> bool:
    if _basic_problem(c, r, w) is not None:
        return False
    return _path_problem(_choose(c, r, w, orientation)[1], c, r) is None


def check_belt_path(
    centers: Float[ArrayLike, "k 2"],
    radii: Float[ArrayLike, " k"],
    wrap_side: Sequence[int] | np.ndarray,
    *,
    orientation: int | None = None,
    radii_flipped: Float[ArrayLike, " k"] | None = None,
) -> None:
    """Validate a belt layout with concrete (numpy) values; raise ``ValueError``.

    Checks: at least 2 pulleys; finite centres; finite radii > 0; wrap sides
    +-1; no two pulleys overlapping; every tangent span constructible; total
    turning of the chosen reading equal to +-2 pi; no span passing through
    another pulley; no self-intersection.  The orientation is chosen by the same
    rule as :func:`~jaxbelt.geometry.path.belt_path`.

    A path that cannot close raises :class:`LayoutError` (a ``ValueError``) whose message and
    ``suggestions`` give the fixes that pass this check: a pulley order that keeps every wrap side
    and the listed direction of travel, and, flagged as a different drive, a pulley on the other
    side of the belt (with its radius from ``radii_flipped`` if the belt axis lies at another
    radius on that side; default ``radii``).
    """
    _check_orientation_arg(orientation)
    c, r, w = _concrete_layout(centers, radii, wrap_side)
    msg = _basic_problem(c, r, w)
    if msg is not None:
        raise ValueError(msg)
    o, g = _choose(c, r, w, orientation)
    prob = _path_problem(g, c, r)
    if prob is None:
        return
    kind, msg = prob
    if kind == "turning":
        msg = _turning_message(c, r, w, o, g, orientation)
    else:
        msg = f"invalid belt path: {msg}."
        if orientation is not None and _is_valid(c, r, w, -orientation):
            msg += (
                f" Reading the loop {'clockwise' if orientation > 0 else 'counter-clockwise'} "
                f"is valid: pass orientation={-orientation} (or None for automatic detection)."
            )
    r_flip = r if radii_flipped is None else np.asarray(radii_flipped, dtype=np.float64)
    if r_flip.shape != r.shape:
        raise ValueError(f"radii_flipped has shape {r_flip.shape}, expected ({r.shape[0]},)")
    text, fixes = _suggestions(c, r, w, orientation, r_flip)
    raise LayoutError(msg + text, fixes)


def _concrete_layout(centers, radii, wrap_side) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centres, radii and wrap sides as float64/int arrays of matching shapes, at least 2 pulleys,
    finite centres, finite radii > 0; ``ValueError`` (``TypeError`` for traced values) otherwise."""
    try:
        c = np.asarray(centers, dtype=np.float64)
        r = np.asarray(radii, dtype=np.float64)
    except jax.errors.TracerArrayConversionError as exc:  # pragma: no cover - message only
        raise TypeError("check_belt_path needs concrete values; call it outside jit") from exc
    w = _static_wrap_side(wrap_side)
    k = w.shape[0]
    if c.shape != (k, 2) or r.shape != (k,):
        raise ValueError(
            f"shape mismatch: centers {c.shape} (expected ({k}, 2)), radii {r.shape} "
            f"(expected ({k},)) for {k} wrap sides"
        )
    if k < 2:
        raise ValueError(
            f"a belt drive needs at least 2 pulleys, got {k} (pulley indices {list(range(k))}); "
            f"a single pulley gives no spans: there is no tangent from a circle to itself"
        )
    for i in range(k):
        if not np.all(np.isfinite(c[i])):
            raise ValueError(f"pulley {i}: centre {c[i].tolist()} is not finite")
        if not np.isfinite(r[i]) or r[i] <= 0:
            raise ValueError(f"pulley {i}: effective radius must be finite and > 0, got {r[i]!r}")
    return c, r, w


def _turning_message(c, r, w, o: int, g: dict, orientation) -> str:
    """Why the chosen reading ``g`` (orientation ``o``) does not turn by +-2 pi: both readings'
    turnings and each pulley's wrap."""
    k = r.shape[0]
    g_both = {sgn: _np_reading(c, r, w, sgn) for sgn in (1, -1)}
    wraps = ", ".join(
        f"pulley {i}: {math.degrees(float(g['wrap_angle'][i])):.1f} deg ({'left' if o * w[i] > 0 else 'right'} turn)"
        for i in range(k)
    )
    read = (
        f"{float(g_both[1]['turning']) / math.pi:.4g}*pi reading the loop "
        f"counter-clockwise and {float(g_both[-1]['turning']) / math.pi:.4g}*pi "
        f"reading it clockwise"
        if orientation is None
        else f"{float(g['turning']) / math.pi:.4g}*pi with orientation={o}"
    )
    return (
        f"inconsistent belt order / wrap sides for pulleys {list(range(k))}: the total "
        f"turning of the belt is {read}, but a closed belt must turn by exactly +-2*pi. "
        f"Wraps: {wraps}."
    )


def _canonical(order) -> tuple:
    """A cyclic order rotated to start at pulley 0 (the loop is the same from any start)."""
    order = list(order)
    i = order.index(0)
    return tuple(order[i:] + order[:i])


def _kept(order, k: int) -> int:
    """Most pulleys of ``order`` that keep the listed cyclic order (same direction of travel)."""
    best = 0
    for shift in range(k):
        seq = [(v - shift) % k for v in order]
        for rot in range(k):
            tails: list[int] = []  # longest increasing subsequence
            for v in seq[rot:] + seq[:rot]:
                pos = int(np.searchsorted(tails, v))
                tails[pos : pos + 1] = [v]
            best = max(best, len(tails))
    return best


def _order_fixes(c, r, w, orientation) -> list[tuple[tuple, str]]:
    """Orders that make a valid path with every wrap side as given (at most 3, fewest pulleys
    moved first), each with a note of what moved.

    Moving one pulley keeps the others' cyclic order, so the belt still meets them in the listed
    direction, and the listing reversed is never offered; only with four pulleys can two single
    moves give one loop both ways round (the message says so).
    """
    k = r.shape[0]
    ident = tuple(range(k))
    skip = {ident, _canonical(ident[::-1])}
    valid = lambda o: o not in skip and _is_valid(c[list(o)], r[list(o)], w[list(o)], orientation)  # noqa: E731
    fixes: dict[tuple, str] = {}
    for i in reversed(ident):  # a move of pulley 0 is also one of the others: name that one
        for j in range(k):
            order = [m for m in ident if m != i]
            order.insert(j, i)
            o = _canonical(order)
            if o not in fixes and valid(o):
                p = o.index(i)
                fixes[o] = f"pulley {i} moved to between pulleys {o[p - 1]} and {o[(p + 1) % k]}"
    if not fixes and 3 < k <= _MAX_FULL_SEARCH:
        full = [o for o in ((0, *p) for p in itertools.permutations(range(1, k))) if valid(o)]
        if full:
            most = max(_kept(o, k) for o in full)
            fixes = {o: f"{k - most} pulleys moved" for o in full if _kept(o, k) == most}
    out = list(fixes.items())
    if orientation is None:
        # equally faithful orders can be one loop travelled both ways (k = 4); the sense in which the
        # listed centres go round (signed area) is the best guess of what was meant: that one first
        x, y = c[:, 0], c[:, 1]
        sense = 1 if float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)) >= 0 else -1
        out.sort(key=lambda f: _choose(c[list(f[0])], r[list(f[0])], w[list(f[0])], None)[0] != sense)
    return out[:3]


def _side_word(side: int) -> str:
    return (
        "the belt's inner side (wrap_side +1: inside the loop)"
        if side > 0
        else "the belt's back (wrap_side -1: outside the loop, so it turns the other way)"
    )


def _suggestions(c, r, w, orientation, r_flip) -> tuple[str, list]:
    """Message text and the fixes (see :class:`LayoutError`), each checked to pass."""
    k = r.shape[0]
    orders = _order_fixes(c, r, w, orientation)
    flips = [
        i
        for i in range(k)
        if _is_valid(c, np.where(np.arange(k) == i, r_flip, r), np.where(np.arange(k) == i, -w, w), orientation)
    ]
    parts = []
    for n, (o, how) in enumerate(orders):
        if any(_canonical(o[::-1]) == p for p, _ in orders[:n]):  # k = 4: a swap is undone either way round
            how += "; the same loop as the order before, travelled the other way round"
        parts.append(f"list the pulleys in the order {list(o)} ({how}; every wrap side as given)")
    text = ""
    if parts:
        text += " Suggestion: " + "; or ".join(parts) + ": that gives a consistent path."
    # a pulley that no position in the list lets the belt wrap on its side: say so, do not flip silently
    if not orders and k >= 3:
        for i in range(k):
            keep = np.arange(k) != i
            if _is_valid(c[keep], r[keep], w[keep], orientation):
                text += (
                    f" The other pulleys alone make a valid path, but the belt cannot wrap pulley {i} with "
                    f"{'its back' if w[i] < 0 else 'its inner side'} (wrap_side {w[i]:+d}) at any position "
                    f"in the list: check its centre, radius and wrap side."
                )
    if flips:
        what = "; or ".join(f"pulley {i} on {_side_word(-w[i])}" for i in flips)
        text += (
            f" Changing the wrap side of pulley {' or '.join(map(str, flips))} {'also ' if orders else ''}"
            f"closes the path with a different drive from the one given: {what}; do so only if that is the "
            f"drive you mean."
        )
    if not orders and not flips:
        text += (
            " Suggestion: list the pulleys in the belt's direction of travel and flip "
            "wrap_side (+1 inner, -1 back side) where the belt touches the pulley with its back."
        )
    fixes = [("order", list(o)) for o, _ in orders] + [("wrap", i) for i in flips]
    return text, fixes
