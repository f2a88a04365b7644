"""The belt's shape on its pulleys (from a run or a loaded result file) and an animation of the belt running."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ._common import _save


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

    from ..geometry.path import belt_path, point_on_path

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
    from ..pulleys.carrier import carrier_centers

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
    _fit_view(ax, pts, centers, radii)


def _fit_view(ax, pts, centers, radii) -> None:
    """Equal axes around the belt's points and every pulley's circle, with an 8 % margin."""
    lo = np.minimum(pts.min(0), (centers - radii[:, None]).min(0))
    hi = np.maximum(pts.max(0), (centers + radii[:, None]).max(0))
    pad = 0.08 * float(np.max(hi - lo))
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_aspect("equal")


_TIGHT_COLOR, _SLACK_COLOR = "#d62728", "#1f77b4"


def _draw_travel(ax, drive, belt: dict | None = None) -> str:
    """An arrow on each span of the installed path in the direction of travel, tight and slack
    spans coloured and labelled (``belt``: a run summary's, whose tensions decided them); returns the sense of
    travel in words."""
    from ..outputs.signals import span_names
    from ..outputs.summary import belt_direction

    info = {**belt_direction(drive), **(belt or {})}
    tag_of = {info["tight_span"]: "tight", info["slack_span"]: "slack"}
    tags = [tag_of.get(f"{a}-{b}", "") for a, b in span_names(drive)]
    _travel_arrows(ax, drive.path, info["spans_in_travel_order"], tags)
    return info["direction"]


def _travel_arrows(ax, installed, in_travel_order: bool, tags) -> None:
    """The arrows of ``_draw_travel`` on the spans of the ``installed`` path (``tags``: "tight",
    "slack" or "" per span)."""
    from ..geometry.path import span_midpoints

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
    travel, the tight span (entering the driver; leaving it where the run's tensions say the driver is
    driven back) in red and the slack span in blue.
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
    sense = _draw_travel(ax, drive, (getattr(result, "summary", None) or {}).get("belt"))
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

    from ..geometry.path import belt_path, point_on_path

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
    _fit_view(ax, pts, np.asarray(r["pulley_centers"], dtype=float), radii)
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

    from ..pulleys.carrier import carrier_centers

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
