"""A drive report: one self-contained HTML page (tables and embedded PNG plots), like a belt supplier's.

Sections: geometry and installation (statics of the nominal belt, the length-tolerance and wear cases and
the tensioner positions), linearised modes with a resonance map against the engine orders, and, given
duty points, the tensions, hub loads and slip safety factors per speed. Every table has an ``id`` and
every image an ``alt`` naming it; ``REPORT_PARTS`` lists them (the tests check the page against it).
"""

from __future__ import annotations

import base64
import html
import io
import math

import numpy as np

from .._drive import Drive

__all__ = ["drive_report", "REPORT_PARTS"]

REPORT_PARTS = {
    "tables": ["installation", "tensioners", "modes"],
    "images": ["layout", "resonance map"],
    "duty_tables": ["duty"],
    "duty_images": ["duty"],
}


def _png(fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=90)
    return base64.b64encode(buf.getvalue()).decode()


def _table(table_id: str, header: list[str], rows: list[list]) -> str:
    def cell(x):
        if isinstance(x, float):
            return "-" if not math.isfinite(x) else f"{x:.4g}"
        return html.escape(str(x))

    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{cell(x)}</td>" for x in r) + "</tr>" for r in rows)
    return f'<table id="{table_id}"><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>'


def _image(alt: str, fig) -> str:
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{_png(fig)}"/>'


def _layout_figure(drive: Drive, nominal):
    """Pulleys, spans and the static hub-load vectors (arrows, length proportional to the load)."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle

    fig = Figure(figsize=(6, 6), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    path = drive.path
    centers, radii = np.asarray(path.centers), np.asarray(path.radii)
    hubs = [nominal.pulleys[n] for n in drive.model.pulley_names]
    scale = 0.25 * float(np.ptp(centers[:, 0]) + np.ptp(centers[:, 1]) + 1e-3) / max(h["hub_load"] for h in hubs)
    for (x, y), r, name, h in zip(centers, radii, drive.model.pulley_names, hubs):
        ax.add_patch(Circle((x, y), r, fill=False, lw=1.2))
        ax.annotate(name, (x, y), fontsize=7, ha="center", va="center")
        a = math.radians(h["hub_load_deg"])
        L = scale * h["hub_load"]
        ax.annotate(
            "", (x + L * math.cos(a), y + L * math.sin(a)), (x, y), arrowprops=dict(arrowstyle="->", color="C3")
        )
    for a, b in zip(np.asarray(path.span_start), np.asarray(path.span_end)):
        ax.plot([a[0], b[0]], [a[1], b[1]], "k-", lw=1)
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set(xlabel="x [m]", ylabel="y [m]", title="layout and static hub loads (arrows)")
    return fig


def _resonance_map(modes, rpm_max: float, orders=(1, 2, 3, 4, 6)):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7, 4.5), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    rpm = np.linspace(0, rpm_max, 50)
    for k in orders:
        ax.plot(rpm, k * rpm / 60, "k-", lw=0.7)
        ax.annotate(f"order {k}", (rpm[-1], k * rpm[-1] / 60), fontsize=7, ha="right", va="bottom")
    for f, kind in zip(modes.frequencies, modes.kinds):
        ax.axhline(f, color="C0" if kind == "rotational" else "C1", lw=1.2, ls="-" if kind == "rotational" else "--")
    ax.set(
        xlabel="crank speed [rpm]",
        ylabel="frequency [Hz]",
        title="resonance map (solid: rotational, dashed: transverse span modes)",
        ylim=(0, max(float(np.max(modes.frequencies)) * 1.1, 1.0)),
    )
    ax.grid(alpha=0.3)
    return fig


def drive_report(
    drive: Drive,
    *,
    torques=None,
    length_cases=None,
    modes_count: int = 8,
    duty=None,
    title: str | None = None,
    rpm_max: float = 6000.0,
) -> str:
    """The report as an HTML string (write it with ``jaxbelt.io.atomic_write``). ``duty``: an optional
    ``DutyResult`` (``analysis.duty.duty_study``) for the per-speed section."""
    from .modes import linear_modes
    from .statics import statics_table

    cases = statics_table(drive, torques, length_cases)
    title = title or "Belt drive report"
    parts = [f"<h1>{html.escape(title)}</h1>"]
    parts += _installation_section(drive, cases["nominal"])
    parts += _tensioner_section(cases)
    parts += _modes_section(linear_modes(drive, count=modes_count), rpm_max)
    if duty is not None:
        from ..viz import plot_duty

        header, table = duty.rows()
        parts.append("<h2>Duty points</h2>" + _table("duty", header, [list(map(float, r)) for r in table]))
        parts.append(_image("duty", plot_duty(duty)))
    style = (
        "body{font-family:sans-serif;max-width:1100px;margin:auto}table{border-collapse:collapse;margin:1em 0}"
        "td,th{border:1px solid #bbb;padding:2px 6px;text-align:right}img{max-width:100%}"
    )
    return (
        f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{html.escape(title)}"
        f"</title><style>{style}</style></head><body>{''.join(parts)}</body></html>"
    )


def _installation_section(drive: Drive, nominal) -> list[str]:
    """Belt lengths and tension range, the layout with hub loads, and the per-pulley installation table."""
    b = nominal.belt
    text = (
        f"<h2>Geometry and installation</h2><p>Belt path length {b['path_length'] * 1000:.1f} mm, stress-free "
        f"length {b['stress_free_length'] * 1000:.1f} mm, EA {b['EA']:.4g} N; tensions "
        f"{b['min_tension']:.1f}..{b['max_tension']:.1f} N (statics: string on rigid pulleys; at rest total "
        "tension = effective tension).</p>"
    )
    fields = ["wrap_deg", "torque", "tension_in", "tension_out", "hub_load", "hub_load_deg", "slip_safety"]
    rows = [[n, *(p[f] for f in fields)] for n, p in nominal.pulleys.items()]
    header = ["pulley", "wrap [deg]", "torque [N m]", "T in [N]", "T out [N]", "hub load [N]"]
    header += ["hub direction [deg]", "slip safety"]
    return [text, _image("layout", _layout_figure(drive, nominal)), _table("installation", header, rows)]


def _tensioner_section(cases) -> list[str]:
    """Tensioner arm angles and slider travels for each belt-length case."""
    nominal = cases["nominal"]
    movable = [(n, k) for n, p in nominal.pulleys.items() for k in ("arm_angle", "travel") if k in p]
    rows = []
    for label, st in cases.items():
        pos = [math.degrees(st.pulleys[n][k]) if k == "arm_angle" else 1e3 * st.pulleys[n][k] for n, k in movable]
        rows.append([label, 1e3 * st.belt["length_change"], st.belt["min_tension"], st.belt["max_tension"], *pos])
    header = ["case", "length change [mm]", "T min [N]", "T max [N]"]
    header += [f"{n} [{'deg' if k == 'arm_angle' else 'mm'}]" for n, k in movable]
    return ["<h2>Tensioner positions across the belt length</h2>" + _table("tensioners", header, rows)]


def _modes_section(modes, rpm_max: float) -> list[str]:
    """The linearised modes' table and their resonance map against the engine orders."""
    rows = [[r["mode"], r["frequency_hz"], r["kind"], r["span"] or "", r["rotational_share"]] for r in modes.table()]
    return [
        "<h2>Linearised modes (drive at rest, contacts stuck)</h2>",
        _table("modes", ["mode", "frequency [Hz]", "kind", "span", "rotational share"], rows),
        _image("resonance map", _resonance_map(modes, rpm_max)),
    ]
