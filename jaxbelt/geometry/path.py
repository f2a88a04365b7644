"""Installed belt path around an ordered list of circles (pulleys).

Geometry
--------
The belt runs around pulleys ``0, 1, ..., k-1`` in the order given (the direction
of travel) and closes back onto pulley ``0``.  Each pulley ``i`` is a circle with
centre ``c_i`` and *effective* radius ``rho_i > 0`` (radius measured at the belt
axis) and a wrap side ``w_i``: ``+1`` for an ordinary (inner) wrap, the pulley
lies inside the belt loop; ``-1`` for a back-side wrap, the pulley lies outside
the loop and touches the back of the belt (back-side idler).

With the loop orientation ``o`` (``+1`` counter-clockwise, ``-1`` clockwise) the
belt turns with sign ``sigma_i = o * w_i`` on pulley ``i`` (``+1`` left/CCW,
``-1`` right/CW).  For a unit travel direction ``d`` with left normal
``nu = (-d_y, d_x)`` the belt touches a left-turning circle at ``c - rho nu`` and
a right-turning one at ``c + rho nu``; the span from circle ``i`` to ``j``
therefore satisfies ``nu . (c_j - c_i) = sigma_j rho_j - sigma_i rho_i`` with
``d . (c_j - c_i) > 0``.

Orientation detection
---------------------
The total signed turning of any closed tangent path is a multiple of ``2 pi``;
a simple (non self-intersecting) loop read with orientation ``o`` turns by
exactly ``o * 2 pi``.  Both readings (``o = +1`` and ``o = -1``) are evaluated:
a reading is *valid* when its turning is ``o * 2 pi``, no span passes through a
foreign pulley and no two spans cross.  The valid counter-clockwise reading
wins, then the valid clockwise one (both are valid only when they describe the
same loop, e.g. two pulleys); if neither is valid, the reading whose turning is
closer to ``+-2 pi`` is used (:func:`check_belt_path` reports why).  Turning
alone is not enough: an idler listed between two pulleys can give ``+-2 pi`` in
both readings while only one of them is a simple loop.  The decision is a
discrete ``jnp.where`` (no gradient flows through it), so :func:`belt_path`
stays traceable and differentiable in the geometry.  Pass ``orientation=+1/-1``
to force a reading.

Arc-length convention
---------------------
``s = 0`` is the point where the belt *arrives* on pulley ``0``.  The path then
consists of ``2k`` segments: arc on pulley 0, span 0 (pulley 0 -> 1), arc on
pulley 1, span 1, ..., span ``k-1`` (pulley ``k-1`` -> 0), which ends at ``s = L``.

:func:`belt_path` performs no validation (it must be traceable); call
:func:`jaxbelt.geometry.check.check_belt_path` on concrete inputs first to get readable errors.
The geometry below is written once for ``numpy`` and ``jax.numpy`` (the ``xp`` argument): the
checks (numpy, ``check.py``) read exactly the path that :func:`belt_path` traces. (About 430
lines: the container, that shared geometry, the traced constructor and the evaluation along the
path are one piece; the checks and suggestions live in ``check.py``.)
"""

from __future__ import annotations

import functools
import math
import typing
from typing import Any, Sequence

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

__all__ = [
    "BeltPath",
    "belt_path",
    "path_reading",
    "point_on_path",
    "place_belt",
    "span_midpoints",
]

_TWO_PI = 2.0 * math.pi


# --------------------------------------------------------------------------- #
# Data container
# --------------------------------------------------------------------------- #
@typing.final
class BeltPath(eqx.Module):
    """Installed belt path.  All array fields are jnp arrays; do not subclass.

    Segment ``2i`` is the arc on pulley ``i``, segment ``2i+1`` the span from
    pulley ``i`` to pulley ``(i+1) % k``; ``s = 0`` is the arrival point on pulley 0.
    """

    centers: Float[Array, "k 2"]
    radii: Float[Array, " k"]  # effective radii (belt axis)
    turn: Float[Array, " k"]  # +1 belt turns left (CCW) on the pulley, -1 right
    wrap_side: Float[Array, " k"]  # +1 inner, -1 back side (as given)
    span_start: Float[Array, "k 2"]  # tangent point where the span leaving pulley i starts
    span_end: Float[Array, "k 2"]  # tangent point where it arrives on pulley i+1
    span_length: Float[Array, " k"]
    span_dir: Float[Array, "k 2"]  # unit travel direction of each span
    arrive_angle: Float[Array, " k"]  # polar angle (about c_i) of the arrival point on pulley i
    wrap_angle: Float[Array, " k"]  # arc angle covered on pulley i, in (0, 2 pi) for valid layouts
    length: Float[Array, ""]  # total path length
    segment_start_s: Float[Array, " 2*k"]  # [arc0, span0, arc1, span1, ...] start arc lengths
    orientation: Float[Array, ""]  # +1 loop runs counter-clockwise, -1 clockwise

    @property
    def n_pulleys(self) -> int:
        return self.radii.shape[0]


# --------------------------------------------------------------------------- #
# Core geometry, written for both numpy (checks) and jax.numpy (traced path)
# --------------------------------------------------------------------------- #
def _safe_atan2(xp: Any, y, x):
    """arctan2 with a finite gradient at the (degenerate) origin."""
    zero = (x == 0) & (y == 0)
    return xp.where(zero, 0.0, xp.arctan2(y, xp.where(zero, 1.0, x)))


def _tangent_geometry(xp: Any, centers, radii, turn) -> dict:
    """Spans and wraps for given signed turning ``turn`` (array of +-1)."""
    cj = xp.roll(centers, -1, axis=0)
    rj = xp.roll(radii, -1, axis=0)
    tj = xp.roll(turn, -1, axis=0)
    delta = cj - centers  # (k, 2)
    dd = xp.sum(delta * delta, axis=-1)
    a = tj * rj - turn * radii  # required nu . delta
    l2 = dd - a * a
    # guarded square root / division: finite values and gradients even when degenerate
    pos = l2 > 0
    span_len = xp.where(pos, xp.sqrt(xp.where(pos, l2, 1.0)), 0.0)
    dd_safe = xp.where(dd > 0, dd, 1.0)
    rot = xp.stack([-delta[:, 1], delta[:, 0]], axis=-1)  # delta rotated +90 deg
    d = (span_len[:, None] * delta - a[:, None] * rot) / dd_safe[:, None]
    nu = (span_len[:, None] * rot + a[:, None] * delta) / dd_safe[:, None]
    start = centers - (turn * radii)[:, None] * nu
    end = cj - (tj * rj)[:, None] * nu

    # wrap on pulley i: from direction of span i-1 to direction of span i
    d_prev = xp.roll(d, 1, axis=0)
    nu_prev = xp.roll(nu, 1, axis=0)
    cross = d_prev[:, 0] * d[:, 1] - d_prev[:, 1] * d[:, 0]
    dot = xp.sum(d_prev * d, axis=-1)
    signed = _safe_atan2(xp, cross, dot)  # CCW direction change in (-pi, pi]
    wrap = xp.mod(turn * signed, _TWO_PI)  # CCW for left turns, CW for right turns
    # arrival point on pulley i = c_i - turn_i rho_i nu_{i-1}; its polar angle:
    arrive_angle = _safe_atan2(xp, -turn * nu_prev[:, 1], -turn * nu_prev[:, 0])
    turning = xp.sum(turn * wrap)
    return dict(
        span_start=start,
        span_end=end,
        span_length=span_len,
        span_dir=d,
        arrive_angle=arrive_angle,
        wrap_angle=wrap,
        turning=turning,
    )


def _defects(xp: Any, centers, radii, start, end):
    """Boolean defect matrices of a reading (division-free, no gradients needed).

    cut[i, m]:   span i passes through the disc of pulley m (m not an end of span i):
                 the line passes closer than rho_m and the centre projects inside the span.
    cross[i, j]: spans i and j cross properly (each one's ends strictly on both sides
                 of the other's line, with a small relative tolerance).
    """
    k = radii.shape[0]
    idx = xp.arange(k)
    sx, sy = start[:, 0], start[:, 1]
    rx, ry = end[:, 0] - sx, end[:, 1] - sy  # span vectors
    seg2 = rx * rx + ry * ry
    # -- span i (rows) against pulley m (columns)
    ux = centers[None, :, 0] - sx[:, None]
    uy = centers[None, :, 1] - sy[:, None]
    crs = rx[:, None] * uy - ry[:, None] * ux  # |seg| * distance of c_m from the line
    dot0 = rx[:, None] * ux + ry[:, None] * uy  # > 0: projection after the start
    own = (idx[None, :] == idx[:, None]) | (idx[None, :] == (idx[:, None] + 1) % k)
    near = crs * crs < (radii[None, :] * (1.0 - 1e-9)) ** 2 * seg2[:, None]
    cut = near & (dot0 > 0) & (dot0 < seg2[:, None]) & ~own
    # -- span i (rows) against span j (columns)
    dqx = sx[None, :] - sx[:, None]
    dqy = sy[None, :] - sy[:, None]
    den = rx[:, None] * ry[None, :] - ry[:, None] * rx[None, :]  # cross(r_i, r_j)
    o1 = rx[:, None] * dqy - ry[:, None] * dqx  # cross(r_i, q_j - p_i)
    o2 = o1 + den  # cross(r_i, q_j + r_j - p_i)
    o3 = ry[None, :] * dqx - rx[None, :] * dqy  # cross(r_j, p_i - q_j)
    o4 = o3 - den  # cross(r_j, p_i + r_i - q_j)
    tol = 1e-18 * seg2[:, None] * seg2[None, :]
    crossm = (o1 * o2 < -tol) & (o3 * o4 < -tol)
    return cut, crossm


_TURN_TOL = 0.5  # rad; total turnings are multiples of 2 pi


def _reading(xp: Any, centers, radii, w, o: int) -> dict:
    """Geometry of the reading with orientation ``o`` plus its validity flags."""
    g = _tangent_geometry(xp, centers, radii, o * w)
    g["turn_score"] = xp.abs(g["turning"] - o * _TWO_PI)
    cut, crossm = _defects(xp, centers, radii, g["span_start"], g["span_end"])
    g["cut"], g["cross"] = cut, crossm
    g["ok"] = (g["turn_score"] < _TURN_TOL) & ~xp.any(cut) & ~xp.any(crossm)
    return g


def _use_ccw(xp: Any, gp: dict, gm: dict):
    """Orientation rule shared by belt_path and check_belt_path.

    A valid counter-clockwise reading wins, then a valid clockwise one; if neither
    is valid, the reading whose turning is closer to +-2 pi (CCW on ties).
    """
    fallback = gp["turn_score"] <= gm["turn_score"] + 1.0
    return gp["ok"] | (~gm["ok"] & fallback)


def _segment_lengths(xp: Any, radii, g: dict):
    """Lengths of the path's ``2k`` segments in arc-length order: arc 0, span 0, arc 1, span 1, ..."""
    k = radii.shape[0]
    return xp.stack([radii * g["wrap_angle"], g["span_length"]], axis=1).reshape(2 * k)


def _static_wrap_side(wrap_side) -> np.ndarray:
    if isinstance(wrap_side, jax.core.Tracer):
        raise TypeError(
            "wrap_side must be static (a tuple or numpy array of +1/-1), not a traced "
            "array; with jax.jit pass it as a static argument (e.g. a tuple)."
        )
    w = np.asarray(wrap_side)
    if w.ndim != 1:
        raise ValueError(f"wrap_side must be a 1-D sequence of +1/-1, got shape {w.shape}")
    if not np.all((w == 1) | (w == -1)):
        bad = [i for i, v in enumerate(w.tolist()) if v not in (1, -1)]
        raise ValueError(
            f"wrap_side must contain only +1 (inner) or -1 (back side); "
            f"pulley(s) {bad} have {[w.tolist()[i] for i in bad]}"
        )
    return w.astype(np.int64)


def _check_orientation_arg(orientation) -> None:
    if orientation is not None and orientation not in (1, -1):
        raise ValueError(f"orientation must be None, +1 (CCW) or -1 (CW), got {orientation!r}")


# --------------------------------------------------------------------------- #
# Traceable constructor
# --------------------------------------------------------------------------- #
def belt_path(
    centers: Float[ArrayLike, "k 2"],
    radii: Float[ArrayLike, " k"],
    wrap_side: Sequence[int] | np.ndarray,
    *,
    orientation: int | None = None,
) -> BeltPath:
    """Build the installed belt path.

    ``centers`` (k, 2) and ``radii`` (k,) may be traced (differentiable);
    ``wrap_side`` (k,) of +1 (inner) / -1 (back side) is static.  The loop
    orientation is detected automatically (see module docstring) unless
    ``orientation`` (+1 CCW / -1 CW, static) is given; with concrete inputs the
    decision is taken on the host (numpy, float64, same rule as
    :func:`~jaxbelt.geometry.check.check_belt_path`), with traced inputs on the device.  No validation is
    done here; use :func:`check_belt_path` on concrete inputs.
    """
    _check_orientation_arg(orientation)
    w = _static_wrap_side(wrap_side)
    centers = jnp.asarray(centers)
    radii = jnp.asarray(radii)
    dtype = jnp.promote_types(jnp.promote_types(centers.dtype, radii.dtype), jnp.result_type(float))
    k = w.shape[0]
    if centers.shape != (k, 2) or radii.shape != (k,):
        raise ValueError(
            f"shape mismatch: centers {centers.shape} (expected ({k}, 2)), "
            f"radii {radii.shape} (expected ({k},)) for {k} wrap sides"
        )
    centers, radii = centers.astype(dtype), radii.astype(dtype)
    if orientation is None and not any(isinstance(x, jax.core.Tracer) for x in (centers, radii)):
        # concrete geometry: take the (discrete) orientation decision on the host, in
        # float64, exactly as check_belt_path does; the kernel compiled for a fixed
        # orientation is much smaller than the one deciding it on the device
        c_np = np.asarray(centers, dtype=np.float64)
        r_np = np.asarray(radii, dtype=np.float64)
        orientation = _choose(c_np, r_np, w, None)[0]
    # wrap_side is validated statically but enters the compiled kernel as data, so one
    # compilation serves every wrap-side pattern with the same number of pulleys
    return _belt_path_jit(centers, radii, np.asarray(w, dtype=dtype), orientation)  # numpy: no eager conversion


@functools.partial(jax.jit, static_argnums=3)
def _belt_path_jit(centers, radii, w_arr, orientation: int | None) -> BeltPath:
    dtype = centers.dtype

    if orientation is None:
        # discrete decision: no gradient flows through it, so the differentiated
        # graph below is that of a single reading
        cs, rs = jax.lax.stop_gradient(centers), jax.lax.stop_gradient(radii)
        both = jax.vmap(lambda o_: _reading(jnp, cs, rs, w_arr, o_))(jnp.asarray([1.0, -1.0], dtype=dtype))
        use_p = _use_ccw(jnp, jax.tree.map(lambda x: x[0], both), jax.tree.map(lambda x: x[1], both))
        o = jnp.where(use_p, 1.0, -1.0).astype(dtype)
    else:
        o = jnp.asarray(float(orientation), dtype=dtype)
    g = _tangent_geometry(jnp, centers, radii, o * w_arr)

    turn = o * w_arr
    cum = jnp.cumsum(_segment_lengths(jnp, radii, g))
    segment_start_s = jnp.concatenate([jnp.zeros((1,), dtype), cum[:-1]])
    return BeltPath(
        centers=centers,
        radii=radii,
        turn=turn,
        wrap_side=w_arr,
        span_start=g["span_start"],
        span_end=g["span_end"],
        span_length=g["span_length"],
        span_dir=g["span_dir"],
        arrive_angle=g["arrive_angle"],
        wrap_angle=g["wrap_angle"],
        length=cum[-1],
        segment_start_s=segment_start_s,
        orientation=o,
    )


# --------------------------------------------------------------------------- #
# Host reading (numpy, concrete values): shared by belt_path and the checks
# --------------------------------------------------------------------------- #
def _np_reading(c: np.ndarray, r: np.ndarray, w: np.ndarray, o: int) -> dict:
    return _reading(np, c, r, w.astype(np.float64), o)


def _choose(c: np.ndarray, r: np.ndarray, w: np.ndarray, orientation: int | None):
    """(orientation, reading) chosen by the same rule as :func:`belt_path`."""
    if orientation is not None:
        g = _np_reading(c, r, w, orientation)
        o = orientation
    else:
        gp, gm = _np_reading(c, r, w, 1), _np_reading(c, r, w, -1)
        o = 1 if bool(_use_ccw(np, gp, gm)) else -1
        g = gp if o == 1 else gm
    return o, g


def path_reading(
    centers: Float[ArrayLike, "k 2"],
    radii: Float[ArrayLike, " k"],
    wrap_side: Sequence[int] | np.ndarray,
    orientation: int | None = None,
) -> tuple[int, float]:
    """Orientation (+1 CCW, -1 CW) and length of the path :func:`belt_path` builds from concrete
    ``centers`` and ``radii`` (numpy, float64: nothing traced or compiled; the same reading and the
    same segments, so the lengths agree to rounding)."""
    _check_orientation_arg(orientation)
    c, r = np.asarray(centers, dtype=np.float64), np.asarray(radii, dtype=np.float64)
    o, g = _choose(c, r, _static_wrap_side(wrap_side), orientation)
    return o, float(np.cumsum(_segment_lengths(np, r, g))[-1])


# --------------------------------------------------------------------------- #
# Evaluation along the path
# --------------------------------------------------------------------------- #
@jax.jit
def point_on_path(
    path: BeltPath, s: Float[ArrayLike, "..."]
) -> tuple[Float[Array, "... 2"], Float[Array, "... 2"], Float[Array, "..."]]:
    """Position, unit tangent and signed curvature at arc length ``s`` (mod length).

    Curvature is ``+1/rho`` on a left (CCW) turn, ``-1/rho`` on a right turn and
    0 on spans.  Vectorised over any shape of ``s``; jit/grad/vmap friendly.
    """
    dtype = path.length.dtype
    s = jnp.asarray(s, dtype=dtype)
    nseg = path.segment_start_s.shape[0]
    sm = jnp.mod(s, path.length)
    # last segment whose start <= s (zero-length segments are skipped); a direct
    # comparison against the 2k segment starts is cheaper than a binary search here
    idx = jnp.sum(path.segment_start_s <= sm[..., None], axis=-1) - 1
    idx = jnp.clip(idx, 0, nseg - 1)
    t = sm - path.segment_start_s[idx]
    i = idx // 2
    is_arc = (idx % 2) == 0

    # arc on pulley i
    c = path.centers[i]
    r = path.radii[i]
    sg = path.turn[i]
    phi = path.arrive_angle[i] + sg * t / r
    cph, sph = jnp.cos(phi), jnp.sin(phi)
    pos_arc = c + r[..., None] * jnp.stack([cph, sph], axis=-1)
    tan_arc = sg[..., None] * jnp.stack([-sph, cph], axis=-1)
    kap_arc = sg / r

    # span i
    d = path.span_dir[i]
    pos_span = path.span_start[i] + t[..., None] * d

    pos = jnp.where(is_arc[..., None], pos_arc, pos_span)
    tan = jnp.where(is_arc[..., None], tan_arc, d)
    kap = jnp.where(is_arc, kap_arc, jnp.zeros_like(kap_arc))
    return pos, tan, kap


def place_belt(
    path: BeltPath,
    n_nodes: int,
    stress_free_length: Float[ArrayLike, ""],
    s_offset: Float[ArrayLike, ""] = 0.0,
) -> Float[Array, "n_nodes 2 2"]:
    """ANCF nodal coordinates of the installed belt, shape ``(n_nodes, 2, 2)``.

    Node ``k`` sits at ``s_k = s_offset + k * L / n_nodes``; ``q[k, 0]`` is its
    position and ``q[k, 1] = dr/dx`` with ``x`` the stress-free material coordinate,
    i.e. the unit tangent times the uniform stretch ``L / stress_free_length``.
    """
    n = int(n_nodes)
    if n < 1:
        raise ValueError(f"n_nodes must be >= 1, got {n_nodes!r}")
    return _place_belt_jit(path, n, stress_free_length, s_offset)


@functools.partial(jax.jit, static_argnums=1)
def _place_belt_jit(path: BeltPath, n: int, stress_free_length, s_offset):
    dtype = path.length.dtype
    s = jnp.asarray(s_offset, dtype) + jnp.arange(n, dtype=dtype) * (path.length / n)
    pos, tan, _ = point_on_path(path, s)
    stretch = path.length / jnp.asarray(stress_free_length, dtype)
    return jnp.stack([pos, tan * stretch], axis=1)


def span_midpoints(path: BeltPath) -> tuple[Float[Array, "k 2"], Float[Array, "k 2"]]:
    """Midpoint of each span and its unit travel direction, each ``(k, 2)``."""
    return 0.5 * (path.span_start + path.span_end), path.span_dir
