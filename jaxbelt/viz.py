"""Plots of a run: speeds, span tensions, contact forces over the wrap with stick/slip zones, the
belt shape, and an animation of the belt running.

Every function returns a ``matplotlib.figure.Figure`` and, given ``path``, saves it there. The
figures are created without pyplot (no global figure registry, no GUI backend needed, nothing
to close), so the functions work the same on a headless machine, in a script and in a notebook
(where a returned figure is displayed as usual).

Signal plots take their labels from the signal registry (``outputs/signals.py``). One module of
about 620 lines, over the usual 400: the figures share the saving and drawing helpers, and
``plot_run`` calls the plot functions through this module's names (tests replace one to check that
a failing plot becomes a warning).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from .outputs.signals import OMEGA, TENSION, TIME, TORQUE

__all__ = [
    "plot_speeds",
    "plot_tensions",
    "plot_torques",
    "plot_contact",
    "plot_belt",
    "animate_belt",
    "plot_run",
    "belt_polyline",
    "plot_sweep",
    "plot_duty",
    "plot_fead",
    "plot_spectrum",
]

_STICK_COLOR, _SLIP_COLOR = "#2ca02c", "#d62728"
_SWEPT = {q.prefix for q in (OMEGA, TORQUE, TENSION)}  # the sweep figures plotted by plot_sweep


def _signals(obj) -> dict:
    return obj.signals if hasattr(obj, "signals") else obj


def _save(fig: Figure, path) -> Figure:
    if path is not None:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        _save_atomic(fig, Path(path))
    return fig


def _save_atomic(fig: Figure, path: Path, **kw):
    from .io import atomic_write

    fmt = path.suffix.lstrip(".") or "png"
    with atomic_write(path, "wb") as fh:
        fig.savefig(fh, format=fmt, dpi=kw.pop("dpi", 120), **kw)


def _time_plot(sig: dict, quantity, path, figsize=(8, 4.5)) -> Figure:
    """Every signal of ``quantity`` (a ``Quantity`` of the signal registry) against time."""
    prefix = f"{quantity.prefix}:"
    fig = Figure(figsize=figsize, layout="constrained")
    ax = fig.add_subplot()
    t = np.asarray(sig["t"])
    for key, value in sig.items():
        if key.startswith(prefix):
            ax.plot(t, np.asarray(value), label=key[len(prefix) :], lw=1.2)
    ax.set_xlabel(TIME.axis_label)
    ax.set_ylabel(quantity.axis_label)
    ax.set_title(quantity.title)
    ax.grid(True, alpha=0.3)
    if ax.lines:
        ax.legend(loc="best", fontsize="small")
    return _save(fig, path)


def plot_speeds(result, path=None) -> Figure:
    """Angular velocity of every pulley against time (``result``: a RunResult or a signals dict)."""
    return _time_plot(_signals(result), OMEGA, path)


def plot_tensions(result, path=None) -> Figure:
    """Tension at the middle of every span against time."""
    return _time_plot(_signals(result), TENSION, path)


def plot_torques(result, path=None) -> Figure:
    """Torque the belt exerts on every pulley against time."""
    return _time_plot(_signals(result), TORQUE, path)


def _runs(mask: np.ndarray):
    """(start, stop) index pairs of the True runs of a boolean array."""
    m = np.concatenate([[False], np.asarray(mask, bool), [False]])
    d = np.diff(m.astype(int))
    return list(zip(np.nonzero(d == 1)[0], np.nonzero(d == -1)[0]))


def plot_contact(contact: dict, path=None, title: str | None = None) -> Figure:
    """Normal and friction force per unit belt length over each pulley's wrap angle.

    ``contact`` is ``jaxbelt.contact_distribution(drive, state)`` (or ``load_result(...)["contact"]``).
    Stick zones are shaded green, slip zones red; angles from the installed belt entry in the
    direction of travel (points touching just before the entry are shown at negative angles).
    """
    from .outputs.contact import FREE, SLIP, STICK

    names = list(contact)
    n = max(len(names), 1)
    fig = Figure(figsize=(8, 2.6 * n + 0.6), layout="constrained")
    axes = fig.subplots(n, 1, squeeze=False)[:, 0]
    for ax, name in zip(axes, names):
        d = contact[name]
        ang = np.asarray(d["angle_deg"], float)
        wrap = float(d.get("wrap_deg", 360.0))
        ang = np.where(ang > wrap + 0.5 * (360.0 - wrap), ang - 360.0, ang)
        order = np.argsort(ang)
        ang = ang[order]
        p, f, st = (np.asarray(d[k])[order] for k in ("pressure", "friction", "state"))
        touching = st != FREE
        # zones: each point stands for the arc halfway to its neighbours
        if ang.size:
            mids = 0.5 * (ang[1:] + ang[:-1])
            lo = np.concatenate([[ang[0] - (mids[0] - ang[0] if mids.size else 1.0)], mids])
            hi = np.concatenate([mids, [ang[-1] + (ang[-1] - mids[-1] if mids.size else 1.0)]])
            lo = np.maximum(lo, min(0.0, ang[0]))
            hi = np.minimum(hi, max(wrap, ang[-1]))
            for code, color, label in ((STICK, _STICK_COLOR, "stick"), (SLIP, _SLIP_COLOR, "slip")):
                for k, (a, b) in enumerate(_runs(st == code)):
                    ax.axvspan(lo[a], hi[b - 1], color=color, alpha=0.15, lw=0, label=label if k == 0 else None)
        ax.axvspan(0.0, wrap, fill=False, hatch="", ec="0.5", ls=":", lw=0.8)
        pm = np.where(touching, p, np.nan)
        fm = np.where(touching, f, np.nan)
        ax.plot(ang, pm / 1e3, "-", color="#1f77b4", lw=1.3, label="normal $p$")
        ax.plot(ang, fm / 1e3, "-", color="#ff7f0e", lw=1.3, label="friction $f$")
        for code, marker, color in ((STICK, "o", _STICK_COLOR), (SLIP, "x", _SLIP_COLOR)):
            sel = st == code
            ax.plot(ang[sel], fm[sel] / 1e3, marker, color=color, ms=3, ls="none")
        ax.axhline(0.0, color="0.6", lw=0.6)
        arcs = f"stick {float(d.get('stick_arc_deg', np.nan)):.1f}°, slip {float(d.get('slip_arc_deg', np.nan)):.1f}°"
        ax.set_title(f"{name}: wrap {wrap:.1f}°, {arcs}", fontsize="medium")
        ax.set_ylabel("force / length [kN/m]")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize="x-small", ncols=2)
    axes[-1].set_xlabel("wrap angle from belt entry [deg]")
    if title:
        fig.suptitle(title)
    return _save(fig, path)


def _hermite(q: np.ndarray, element_length: float, per_element: int) -> np.ndarray:
    """Points along the cubic ANCF belt: ``per_element`` per element, loop closed."""
    n = q.shape[0]
    xi = np.linspace(0.0, 1.0, per_element, endpoint=False)
    L = element_length
    S = np.stack(
        [1 - 3 * xi**2 + 2 * xi**3, L * (xi - 2 * xi**2 + xi**3), 3 * xi**2 - 2 * xi**3, L * (xi**3 - xi**2)], -1
    )  # (k, 4)
    nxt = np.roll(np.arange(n), -1)
    e = np.stack([q[:, 0], q[:, 1], q[nxt, 0], q[nxt, 1]], axis=1)  # (n, 4, 2)
    pts = np.einsum("kc,ncd->nkd", S, e).reshape(-1, 2)
    return np.concatenate([pts, pts[:1]])


def belt_polyline(drive, q, per_element: int = 8, exaggeration: float = 1.0, reference=None) -> np.ndarray:
    """Belt centre line of the nodal coordinates ``q`` as a closed polyline ``(m, 2)``.

    With ``exaggeration`` != 1 every point's offset from the ``reference`` polyline (default: the
    installed belt path; pass the path around moved tensioners) is scaled by that factor, which makes
    span vibration and contact penetration visible.
    """
    q = np.asarray(q, dtype=float)
    L = float(drive.params.belt.stress_free_length) / q.shape[0]
    pts = _hermite(q, L, per_element)
    if exaggeration != 1.0:
        ref = _reference_path(drive) if reference is None else reference
        near = _nearest_on_polyline(pts, ref)
        pts = near + exaggeration * (pts - near)
    return pts


def _reference_path(drive, centers=None, n: int = 2000) -> np.ndarray:
    """Dense polyline of the belt path around the pulleys (installed, or around ``centers``)."""
    import jax.numpy as jnp

    from .geometry.path import belt_path, point_on_path

    path = drive.path
    if centers is not None:
        path = belt_path(jnp.asarray(centers), path.radii, tuple(int(w) for w in np.asarray(path.wrap_side)))
    s = np.linspace(0.0, float(path.length), n + 1)
    pos, _, _ = point_on_path(path, s)
    return np.asarray(pos)


def _nearest_on_polyline(pts: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Nearest point on the (dense, closed) polyline ``ref`` for each of ``pts``: the nearest
    vertex, then the better projection onto its two adjacent segments."""
    d2 = np.sum(pts * pts, 1)[:, None] - 2.0 * pts @ ref.T + np.sum(ref * ref, 1)[None, :]
    k = np.argmin(d2, axis=1)
    m = ref.shape[0]
    best, best_d = ref[k], np.full(pts.shape[0], np.inf)
    for a_i, b_i in ((np.maximum(k - 1, 0), k), (k, np.minimum(k + 1, m - 1))):
        a, b = ref[a_i], ref[b_i]
        ab = b - a
        t = np.clip(np.sum((pts - a) * ab, 1) / np.maximum(np.sum(ab * ab, 1), 1e-300), 0.0, 1.0)
        proj = a + t[:, None] * ab
        d = np.sum((pts - proj) ** 2, 1)
        better = d < best_d
        best[better], best_d[better] = proj[better], d[better]
    return best


def _pulley_geometry(drive, state):
    """Centres (p, 2) of every pulley in ``state`` (tensioners moved), surface radii, spin angles."""
    from .pulleys.carrier import carrier_centers

    centers, _ = carrier_centers(drive.model, drive.params.pulleys, np.asarray(state.psi))
    radii = np.asarray([p.radius for p in drive.pulleys], dtype=float)
    return np.asarray(centers), radii, np.asarray(state.theta)


def _draw_pulleys(ax, drive, state):
    from matplotlib.patches import Circle

    centers, radii, theta = _pulley_geometry(drive, state)
    artists = []
    for c, r, th, p in zip(centers, radii, theta, drive.pulleys):
        face = {"driver": "#c6dbef", "driven": "#fdd0a2", "tensioner": "#d9f0d3"}.get(p.role, "#e5e5e5")
        circ = Circle(c, r, fc=face, ec="0.25", lw=1.0, zorder=1)
        ax.add_patch(circ)
        (spoke,) = ax.plot(
            [c[0], c[0] + r * math.cos(th)], [c[1], c[1] + r * math.sin(th)], color="0.25", lw=1.0, zorder=2
        )
        ax.plot([c[0]], [c[1]], "k+", ms=5, zorder=2)
        ax.annotate(
            p.name, c, xytext=(0, -10), textcoords="offset points", ha="center", va="top", fontsize="x-small", zorder=4
        )
        if p.pivot is not None:
            pv = p.pivot
            ax.plot([pv[0], c[0]], [pv[1], c[1]], "-", color="#4d9221", lw=3, alpha=0.7, zorder=2)
            ax.plot([pv[0]], [pv[1]], "o", color="#4d9221", ms=5, zorder=3)
        artists.append((circ, spoke))
    return artists


def _limits(ax, drive, pts):
    centers = np.asarray([p.center for p in drive.pulleys], dtype=float)
    radii = np.asarray([p.radius for p in drive.pulleys], dtype=float)
    lo = np.minimum(pts.min(0), (centers - radii[:, None]).min(0))
    hi = np.maximum(pts.max(0), (centers + radii[:, None]).max(0))
    pad = 0.08 * float(np.max(hi - lo))
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")


_TIGHT_COLOR, _SLACK_COLOR = "#d62728", "#1f77b4"


def _draw_travel(ax, drive) -> str:
    """An arrow on each span of the installed path in the direction of travel, tight and slack
    spans coloured and labelled; returns the sense of travel in words."""
    from .outputs.signals import span_names
    from .outputs.summary import belt_direction

    info = belt_direction(drive)
    tag_of = {info["tight_span"]: "tight", info["slack_span"]: "slack"}
    tags = [tag_of.get(f"{a}-{b}", "") for a, b in span_names(drive)]
    _travel_arrows(ax, drive.path, info["spans_in_travel_order"], tags)
    return info["direction"]


def _travel_arrows(ax, installed, in_travel_order: bool, tags) -> None:
    """The arrows of ``_draw_travel`` on the spans of the ``installed`` path (``tags``: "tight",
    "slack" or "" per span)."""
    from .geometry.path import span_midpoints

    mid, d = (np.asarray(x, dtype=float) for x in span_midpoints(installed))
    o = float(installed.orientation)
    outward = -o * np.stack([-d[:, 1], d[:, 0]], axis=1)  # the loop's inside is left of a counter-clockwise path
    d = d * (1.0 if in_travel_order else -1.0)
    lengths = np.asarray(installed.span_length, dtype=float)
    size = float(np.ptp(np.asarray(installed.centers, dtype=float), axis=0).max() + 2 * np.max(installed.radii))
    for tag, m, dk, out, length in zip(tags, mid, d, outward, lengths):
        color = _TIGHT_COLOR if tag == "tight" else _SLACK_COLOR if tag == "slack" else "0.35"
        half = 0.5 * min(0.3 * length, 0.08 * size)
        base = m + 0.03 * size * out
        ax.annotate(
            "",
            xy=base + half * dk,
            xytext=base - half * dk,
            zorder=5,
            arrowprops=dict(arrowstyle="-|>", color=color, lw=2.0, mutation_scale=14),
        )
        if tag:
            ax.annotate(
                tag, base + 0.04 * size * out, ha="center", va="center", color=color, fontsize="small", zorder=5
            )


def plot_belt(result, state=None, path=None, exaggeration: float = 1.0, show_nodes: bool = True) -> Figure:
    """Belt shape and pulleys at one state (default: the last saved state of ``result``).

    ``result`` is a RunResult, a ``Drive`` (with ``state`` given) or a result file read back
    (``jaxbelt.io.load_result``; ``state``: the index of a saved state, default the last). Pulleys are
    drawn with their surface radius at their current centre (tensioner arms moved), the belt as its
    centre line from the ANCF nodes (nodes marked); arrows beside the spans show the direction of
    travel, the tight span (entering the driver) in red and the slack span (leaving it) in blue.
    """
    import jax

    if isinstance(result, dict):
        return _plot_loaded_belt(result, -1 if state is None else state, path, exaggeration, show_nodes)
    drive = result.drive if hasattr(result, "drive") else result
    if state is None:
        state = jax.tree.map(lambda x: x[-1], result.trajectory.states)
    q = np.asarray(state.q)
    fig = Figure(figsize=(8, 5.5), layout="constrained")
    ax = fig.add_subplot()
    _draw_pulleys(ax, drive, state)
    ref = _reference_path(drive, _pulley_geometry(drive, state)[0]) if exaggeration != 1.0 else None
    pts = belt_polyline(drive, q, exaggeration=exaggeration, reference=ref)
    ax.plot(pts[:, 0], pts[:, 1], "-", color="#08306b", lw=1.6, zorder=3, label="belt (centre line)")
    if show_nodes and exaggeration == 1.0:
        ax.plot(q[:, 0, 0], q[:, 0, 1], ".", color="#08306b", ms=3, zorder=3, label="nodes")
    sense = _draw_travel(ax, drive)
    _limits(ax, drive, pts)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, alpha=0.3)
    ttl = f"Belt running {sense}"
    if hasattr(result, "trajectory") and state is not None:
        ttl += f" at t = {float(np.asarray(result.trajectory.ts)[-1]):.4g} s"
    if exaggeration != 1.0:
        ttl += f" (deformation x{exaggeration:g})"
    ax.set_title(ttl)
    ax.legend(loc="upper right", fontsize="x-small")
    return _save(fig, path)


def _plot_loaded_belt(r: dict, i: int, path, exaggeration: float, show_nodes: bool) -> Figure:
    """``plot_belt`` of a loaded ``result.npz``: the same figure, drawn from the file's arrays."""
    import jax.numpy as jnp
    from matplotlib.patches import Circle

    from .geometry.path import belt_path, point_on_path

    if "pulley_center_history" not in r:
        raise ValueError(
            "plot_belt: this result.npz was written by an older jaxbelt and holds no drawing data (pulley "
            "centres, roles, spans): run again, or pass the RunResult"
        )
    q = np.asarray(r["state/q"][i], dtype=float)
    centers, radii = np.asarray(r["pulley_center_history"][i]), np.asarray(r["pulley_surface_radii"])
    theta, names, roles = np.asarray(r["state/theta"][i]), list(r["pulley_names"]), list(r["pulley_roles"])
    sides, orientation = tuple(int(w) for w in r["pulley_wrap_side"]), int(r["path_orientation"])
    axis_radii = jnp.asarray(r["pulley_radii"])

    def path_round(c):
        return belt_path(jnp.asarray(c), axis_radii, sides, orientation=orientation)

    fig = Figure(figsize=(8, 5.5), layout="constrained")
    ax = fig.add_subplot()
    for c, rad, th, name, role, pv in zip(centers, radii, theta, names, roles, r["pulley_pivots"]):
        face = {"driver": "#c6dbef", "driven": "#fdd0a2", "tensioner": "#d9f0d3"}.get(role, "#e5e5e5")
        ax.add_patch(Circle(c, rad, fc=face, ec="0.25", lw=1.0, zorder=1))
        ax.plot([c[0], c[0] + rad * math.cos(th)], [c[1], c[1] + rad * math.sin(th)], color="0.25", lw=1.0, zorder=2)
        ax.plot([c[0]], [c[1]], "k+", ms=5, zorder=2)
        ax.annotate(
            name, c, xytext=(0, -10), textcoords="offset points", ha="center", va="top", fontsize="x-small", zorder=4
        )
        if np.all(np.isfinite(pv)):
            ax.plot([pv[0], c[0]], [pv[1], c[1]], "-", color="#4d9221", lw=3, alpha=0.7, zorder=2)
            ax.plot([pv[0]], [pv[1]], "o", color="#4d9221", ms=5, zorder=3)
    pts = _hermite(q, float(r["stress_free_length"]) / q.shape[0], 8)
    if exaggeration != 1.0:  # offsets from the path round the pulleys where they are now
        around = path_round(centers)
        ref = np.asarray(point_on_path(around, np.linspace(0.0, float(around.length), 2001))[0])
        near = _nearest_on_polyline(pts, ref)
        pts = near + exaggeration * (pts - near)
    ax.plot(pts[:, 0], pts[:, 1], "-", color="#08306b", lw=1.6, zorder=3, label="belt (centre line)")
    if show_nodes and exaggeration == 1.0:
        ax.plot(q[:, 0, 0], q[:, 0, 1], ".", color="#08306b", ms=3, zorder=3, label="nodes")
    _travel_arrows(ax, path_round(r["pulley_centers"]), bool(r["spans_in_travel_order"]), list(r["span_tags"]))
    drawn = np.asarray(r["pulley_centers"], dtype=float)
    lo = np.minimum(pts.min(0), (drawn - radii[:, None]).min(0))
    hi = np.maximum(pts.max(0), (drawn + radii[:, None]).max(0))
    pad = 0.08 * float(np.max(hi - lo))
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, alpha=0.3)
    ttl = f"Belt running {r['belt_direction']} at t = {float(np.asarray(r['t'])[i]):.4g} s"
    if exaggeration != 1.0:
        ttl += f" (deformation x{exaggeration:g})"
    ax.set_title(ttl)
    ax.legend(loc="upper right", fontsize="x-small")
    return _save(fig, path)


def animate_belt(
    result,
    path=None,
    *,
    exaggeration: float = 1.0,
    fps: int = 20,
    max_frames: int = 100,
    t_start: float | None = None,
    dpi: int = 72,
):
    """Animation of the belt running, written as a GIF with matplotlib's ``PillowWriter``.

    Frames are evenly spaced over the saved times from ``t_start`` (default: the whole run), at
    most ``max_frames``; ``exaggeration`` scales the belt's offset from its installed path. A
    marker on node 0 shows the belt travelling, spokes show the pulleys turning. Returns the
    Figure; without ``path`` it carries a ``matplotlib.animation.FuncAnimation`` in its
    ``animation`` attribute (e.g. ``HTML(fig.animation.to_jshtml())`` in a notebook).
    """
    ts = np.asarray(result.trajectory.ts)
    idx = _frame_indices(ts, t_start, max_frames)
    fig, update = _belt_frames(result.drive, result.trajectory.states, ts, idx, exaggeration)
    if path is None:
        from matplotlib.animation import FuncAnimation

        fig.animation = FuncAnimation(fig, update, frames=len(idx), interval=1000 / fps, blit=False)
        return fig
    _write_gif(fig, update, len(idx), Path(path), fps, dpi)
    return fig


def _frame_indices(ts: np.ndarray, t_start: float | None, max_frames: int) -> np.ndarray:
    """Indices of at most ``max_frames`` saved states, evenly spaced from ``t_start`` (all if none is later)."""
    idx = np.arange(ts.size) if t_start is None else np.nonzero(ts >= t_start)[0]
    if idx.size == 0:
        idx = np.arange(ts.size)
    return idx[np.unique(np.linspace(0, idx.size - 1, min(max_frames, idx.size)).round().astype(int))]


def _belt_frames(drive, states, ts: np.ndarray, idx: np.ndarray, exaggeration: float):
    """The animation's figure, drawn at frame 0, and ``update(k)`` that redraws it at frame ``k``."""
    import jax

    from .pulleys.carrier import carrier_centers

    q_all = np.asarray(states.q)
    theta_all = np.asarray(states.theta)
    centers_all = np.asarray(
        jax.vmap(lambda psi: carrier_centers(drive.model, drive.params.pulleys, psi)[0])(np.asarray(states.psi)[idx])
    )
    radii = [p.radius for p in drive.pulleys]
    moving = drive.model.any_movable  # tensioners: path around the current centres
    ref = _reference_path(drive) if exaggeration != 1.0 else None

    def reference(k):
        return _reference_path(drive, centers_all[k]) if (exaggeration != 1.0 and moving) else ref

    # fixed margins (no constrained layout: it would be recomputed for every frame)
    fig = Figure(figsize=(6.4, 4.6))
    fig.subplots_adjust(left=0.12, right=0.97, bottom=0.11, top=0.92)
    ax = fig.add_subplot()
    artists = _draw_pulleys(ax, drive, jax.tree.map(lambda x: x[idx[0]], states))
    pts = belt_polyline(drive, q_all[idx[0]], exaggeration=exaggeration, reference=reference(0))
    (line,) = ax.plot(pts[:, 0], pts[:, 1], "-", color="#08306b", lw=1.6, zorder=3)
    (marker,) = ax.plot([], [], "o", color="#e6550d", ms=4, zorder=4)
    sample = range(0, idx.size, max(1, idx.size // 12))
    _limits(
        ax, drive, np.concatenate([belt_polyline(drive, q_all[idx[k]], 4, exaggeration, reference(k)) for k in sample])
    )
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    label = ax.set_title("")
    ex = f", deformation x{exaggeration:g}" if exaggeration != 1.0 else ""

    def update(k):
        i = idx[k]
        pts = belt_polyline(drive, q_all[i], exaggeration=exaggeration, reference=reference(k))
        line.set_data(pts[:, 0], pts[:, 1])
        marker.set_data([q_all[i, 0, 0, 0]], [q_all[i, 0, 0, 1]])
        for (circ, spoke), c, r, th in zip(artists, centers_all[k], radii, theta_all[i]):
            circ.center = (float(c[0]), float(c[1]))
            spoke.set_data([c[0], c[0] + r * math.cos(th)], [c[1], c[1] + r * math.sin(th)])
        label.set_text(f"t = {ts[i]:.3f} s{ex}")
        return [line, marker, label]

    return fig, update


def _write_gif(fig: Figure, update, frames: int, path: Path, fps: int, dpi: int) -> None:
    """Every frame into a GIF at ``path``, atomically (a temporary file replaces it when complete)."""
    from matplotlib.animation import PillowWriter

    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")
    try:
        writer = PillowWriter(fps=fps)
        with writer.saving(fig, tmp, dpi):
            for k in range(frames):
                update(k)
                writer.grab_frame()
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def plot_run(
    result,
    out_dir,
    *,
    contact: dict | None = None,
    animate: bool = False,
    exaggeration: float = 1.0,
    fmt: str = "png",
    warnings_: list | None = None,
) -> dict[str, Path]:
    """All standard plots of a run into ``out_dir``; returns ``{plot name: path}``.

    With a ``warnings_`` list, a plot that fails is skipped and the reason appended there (the other
    plots are still written); without one the error propagates.
    """
    import jax

    from .outputs.contact import contact_distribution
    from .outputs.summary import guarded

    def attempt(what, fn, default=None):
        return fn() if warnings_ is None else guarded(warnings_, what, fn, default)

    out = Path(out_dir)
    if contact is None:
        contact = attempt(
            "contact plot",
            lambda: contact_distribution(result.drive, jax.tree.map(lambda x: x[-1], result.trajectory.states)),
        )
    t_end = float(np.asarray(result.trajectory.ts)[-1])
    plots = {
        "speeds": lambda path: plot_speeds(result, path),
        "tensions": lambda path: plot_tensions(result, path),
        "torques": lambda path: plot_torques(result, path),
        "contact": None
        if contact is None
        else (lambda path: plot_contact(contact, path, title=f"Contact forces at t = {t_end:.4g} s")),
        "belt": lambda path: plot_belt(result, path=path),
    }
    if "slip_safety_factor" in next(iter(result.summary.get("pulleys", {}).values()), {}):
        plots["fead"] = lambda path: plot_fead(result, path)
    if animate:
        plots["animation"] = lambda path: animate_belt(result, path, exaggeration=exaggeration)
    files = {}
    for name, fn in plots.items():
        path = out / ("belt.gif" if name == "animation" else f"{name}.{fmt}")
        if fn is not None and attempt(f"{path.name}", lambda: fn(path) or True, False):
            files[name] = path
    return files


def plot_duty(result, path=None, min_safety: float = 1.0) -> Figure:
    """Duty-point study: slip safety factor (log axis; values below ``min_safety`` marked with a red cross,
    the region below shaded) and hub load of every pulley against the driver speed. Pulleys that transmit
    no torque (safety infinite) are left out of the left panel; factors above 100 are drawn at 100."""
    fig = Figure(figsize=(12, 4.2), layout="constrained")
    ax1, ax2 = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    rpm = np.asarray(result.rpm, dtype=float)
    top = 2.0 * max(min_safety, 1.0)
    for k, (name, d) in enumerate(result.pulleys.items()):
        color = f"C{k % 10}"
        sf = np.asarray(d["slip_safety"], dtype=float)
        if np.any(np.isfinite(sf)):
            y = np.minimum(np.where(np.isfinite(sf), sf, np.nan), 100.0)
            ax1.plot(rpm, y, "o-", ms=3, color=color, label=name)
            low = y < min_safety
            if np.any(low):
                ax1.plot(rpm[low], y[low], "x", ms=9, mew=2, color="#c00")
            top = max(top, float(np.nanmax(y)) * 1.3)
        ax2.plot(rpm, d["hub_load"], "o-", ms=3, color=color, label=name)
    from matplotlib.ticker import FixedLocator, FormatStrFormatter, NullFormatter

    ax1.set_yscale("log")
    bottom = min(0.5 * min_safety, 0.5)
    ax1.set_ylim(bottom, top)
    ax1.yaxis.set_major_locator(FixedLocator([0.2, 0.5, 1, 2, 5, 10, 20, 50, 100]))  # plain numbers, not 10^k
    ax1.yaxis.set_major_formatter(FormatStrFormatter("%g"))
    ax1.yaxis.set_minor_formatter(NullFormatter())
    ax1.axhspan(bottom, min_safety, color="#c00", alpha=0.1, lw=0)
    ax1.axhline(1.0, color="k", lw=0.8, ls="--")
    if min_safety != 1.0:
        ax1.axhline(min_safety, color="#c00", lw=0.8, ls=":")
    ax1.set(
        xlabel="driver speed [rpm]",
        ylabel="slip safety factor [-] (log)",
        title=f"slip safety (> 1: no gross slip; shaded: < {min_safety:g})",
    )
    ax2.set(xlabel="driver speed [rpm]", ylabel="hub load [N]", title="hub load (mean)")
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3, which="both")
    fig.legend(*ax2.get_legend_handles_labels(), loc="outside right upper", fontsize=8)  # one legend, off the data
    return _save(fig, path) if path is not None else fig


def plot_run_up(runup, names=None, path=None) -> Figure:
    """Order plot of a run-up (``analysis.runup.run_up``): per signal the amplitude of each tracked engine
    order and the half peak-to-peak against crank speed, with the resonance crossings (mode i crossed by
    order k at 60 f_i / k rpm) as vertical lines."""
    from .outputs.signals import quantity_of

    names = list(runup.orders) if names is None else list(names)
    ncol = min(2, max(1, len(names)))
    nrow = max(1, math.ceil(len(names) / ncol))
    fig = Figure(figsize=(6 * ncol, 3.6 * nrow), layout="constrained")
    for i, name in enumerate(names):
        ax = fig.add_subplot(nrow, ncol, i + 1)
        ax.plot(runup.rpm, runup.amplitude[name], "k-", lw=1.0, label="half peak-to-peak")
        for k, amp in runup.orders[name].items():
            ax.plot(runup.rpm, amp, "o-", ms=2.5, label=f"order {k:g}")
        for c in runup.crossings:
            ax.axvline(c["rpm"], color="0.6", lw=0.8, ls="--")
            ax.text(c["rpm"], 1.0, f" {c['mode']}/{c['order']:g}", transform=ax.get_xaxis_transform(), fontsize=6,
                    va="top", rotation=90)  # fmt: skip
        ax.set(xlabel="crank speed [rpm]", ylabel=f"amplitude [{quantity_of(name).unit}]", title=name)
        ax.grid(alpha=0.3)
        if i == 0:
            ax.legend(fontsize=7)
    return _save(fig, path) if path is not None else fig


def plot_sweep(result, path=None) -> Figure:
    """Each steady figure (speeds, torques, tensions) against the first varied key, one line per
    value of the other keys."""
    keys, pts = result.keys, np.asarray(result.points)
    names = [n for n in result.figures if n.endswith(":mean") and n.split(":")[0] in _SWEPT]
    ncol = 3
    nrow = max(1, math.ceil(len(names) / ncol))
    fig = Figure(figsize=(4.2 * ncol, 3.2 * nrow), layout="constrained")
    x = pts[:, 0]
    others = [tuple(r) for r in pts[:, 1:]] if pts.shape[1] > 1 else [()] * len(x)
    groups = sorted(set(others))
    for i, name in enumerate(names):
        ax = fig.add_subplot(nrow, ncol, i + 1)
        y = np.asarray(result.figures[name])
        for g in groups:
            sel = np.array([o == g for o in others])
            label = ", ".join(f"{k}={v:.3g}" for k, v in zip(keys[1:], g)) or None
            ax.plot(x[sel], y[sel], "o-", ms=3, label=label)
        ax.set_xlabel(keys[0])
        ax.set_title(name.removesuffix(":mean"), fontsize=9)
        ax.grid(alpha=0.3)
        if i == 0 and len(groups) > 1:
            ax.legend(fontsize=7)
    return _save(fig, path) if path is not None else fig


def _fead_layout(ax, result, pulleys: dict) -> None:
    """Pulleys at their last position with each mean hub-load vector (force of the belt on it)."""
    import jax

    drive = result.drive
    state = jax.tree.map(lambda x: x[-1], result.trajectory.states)
    _draw_pulleys(ax, drive, state)
    centers = _pulley_geometry(drive, state)[0]
    loads = np.array([pulleys[p.name]["hub_load_mean"] for p in drive.pulleys])
    size = float(np.ptp(centers, axis=0).max())
    scale = 0.25 * size / max(float(loads.max()), 1e-12)
    for c, p, load in zip(centers, drive.pulleys, loads):
        a = math.radians(pulleys[p.name]["hub_load_direction_deg"])
        tip = c + scale * load * np.array([math.cos(a), math.sin(a)])
        ax.annotate("", xy=tip, xytext=c, arrowprops=dict(arrowstyle="-|>", color=_SLIP_COLOR, lw=1.8), zorder=5)
        ax.annotate(f"{load:.0f} N", tip, fontsize="x-small", color=_SLIP_COLOR, zorder=5)
    pts = np.concatenate([centers, centers + scale * loads.max()])
    _limits(ax, drive, pts)
    ax.set_title("Mean hub loads (force of the belt on the pulley)")


def plot_fead(result, path=None) -> Figure:
    """The accessory-drive outputs of a run: hub-load vectors on the layout, slip safety factors
    (mean and worst, threshold 1), slip, and span tensions (total and effective, dynamic amplitude)."""
    s = result.summary
    pulleys, spans = s["pulleys"], s["spans"]
    names = list(pulleys)
    x = np.arange(len(names))
    fig = Figure(figsize=(12, 8.5), layout="constrained")
    _fead_layout(fig.add_subplot(2, 2, 1), result, pulleys)
    ax = fig.add_subplot(2, 2, 2)
    cap = 100.0  # idlers transmit nothing: their safety factor is huge (or inf); bars stop at the cap
    for off, key, label in ((-0.2, "slip_safety_factor", "mean tensions"), (0.2, "slip_safety_factor_min", "worst")):
        vals = [min(cap, pulleys[n][key]) if pulleys[n][key] is not None else cap for n in names]
        ax.bar(x + off, vals, 0.4, label=label)
    ax.axhline(1.0, color="k", lw=1.0, ls="--")
    ax.set_yscale("log")
    ax.set_xticks(x, names, rotation=30, fontsize="small")
    ax.set_ylabel(f"slip safety factor (capped at {cap:g})")
    ax.set_title("Slip safety factor mu_eff phi / ln(T1e/T2e) (> 1: no gross slip)")
    ax.legend(fontsize="small")
    ax = fig.add_subplot(2, 2, 3)
    ax.bar(x - 0.2, [pulleys[n]["slip_mean_pct"] for n in names], 0.4, label="mean")
    ax.bar(x + 0.2, [pulleys[n]["slip_peak_pct"] for n in names], 0.4, label="peak |slip|")
    ax.set_xticks(x, names, rotation=30, fontsize="small")
    ax.set_ylabel("slip [%]")
    ax.set_title("Slip: arriving belt speed against surface speed")
    ax.legend(fontsize="small")
    ax = fig.add_subplot(2, 2, 4)
    xs = np.arange(len(spans))
    ax.bar(
        xs - 0.2,
        [sp["tension_mean"] for sp in spans],
        0.4,
        yerr=[sp["tension_amplitude"] for sp in spans],
        label="total T (bar: amplitude p-p/2)",
    )
    ax.bar(xs + 0.2, [sp["tension_eff_mean"] for sp in spans], 0.4, label="effective T - m'v^2")
    ax.set_xticks(xs, [sp["name"] for sp in spans], rotation=30, fontsize="small")
    ax.set_ylabel(f"span tension [{TENSION.unit}]")
    ax.set_title("Span tensions (mean over the window)")
    ax.legend(fontsize="small")
    return _save(fig, path)


def plot_spectrum(result, name: str, path=None, order: bool = False, window: str = "hann", t_start=None) -> Figure:
    """Amplitude spectrum of the signal ``name`` (over time, or with ``order`` over the driver's
    angle) from ``t_start`` (default: the whole record) on; see ``jaxbelt.outputs.spectra``."""
    from .outputs.signals import quantity_of
    from .outputs.spectra import amplitude_spectrum, crank_angle, order_spectrum

    sig = _signals(result)
    t = np.asarray(sig["t"])
    sel = t >= (t[0] if t_start is None else t_start)
    unit = quantity_of(name).unit
    if order:
        sp = order_spectrum(crank_angle(result)[sel], sig[name][sel], window=window, unit=unit)
        axis, label = sp["order"], "engine order [1/rev]"
    else:
        sp = amplitude_spectrum(t[sel], sig[name][sel], window=window, unit=unit)
        axis, label = sp["frequency"], "frequency [Hz]"
    fig = Figure(figsize=(8, 4.5), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(axis, sp["amplitude"], lw=1.2)
    ax.set_xlabel(label)
    ax.set_ylabel(f"amplitude [{unit}]")
    ax.set_title(
        f"{'Order' if order else 'Amplitude'} spectrum of {name} ({window} window, resolution {sp['resolution']:.3g})"
    )
    ax.grid(True, alpha=0.3)
    return _save(fig, path)
