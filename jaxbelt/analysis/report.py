"""A drive report: one self-contained HTML document (tables and embedded PNG plots), like a belt supplier's.

One page per section (CSS page breaks when printed): the document (input, version, date, criteria and
the verdict of every check), geometry (pulleys, spans, layout), installation and static load (statics at
installation and under the configured loads, per pulley), tensioner positions across the belt length
with the margin to the stops, linearised modes with a resonance map over the idle-to-red-line band, and,
given duty points, their steady figures and dynamic results (tension amplitudes, arm peak-to-peak, slip,
clutch overrun, hub-load peaks) per pulley, span and tensioner; then the input file.

Every value is checked against ``ReportCriteria`` (documented defaults, ``docs/cli.md``) and marked PASS or
FAIL where it stands. Tables are long (one row per pulley, span or tensioner and case or duty point), so
the page keeps its width whatever the number of pulleys and duty points. Every table has an ``id`` and
every image an ``alt`` naming it: ``REPORT_PARTS`` lists them (the tests check the page against it).

About 1000 lines, over the usual 400: the sections share the table, mark and check helpers and read
in the order of the document (most of the length is the formatter's one cell per line).
"""

from __future__ import annotations

import base64
import dataclasses
import datetime
import hashlib
import html
import io
import math
import re
from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from .._errors import ConfigError
from ..config.validate import resolve_model
from ..outputs.theory import mass_per_current_length
from ..outputs.window import window_from_start

if TYPE_CHECKING:
    from .._drive import Drive
    from .duty import DutyResult

__all__ = ["drive_report", "ReportCriteria", "ReportSource", "configured_torques", "duty_dynamics", "REPORT_PARTS"]

REPORT_PARTS = {
    "tables": ["document", "criteria", "verdict", "belt", "pulleys", "spans", "installation", "tension-window"]
    + ["tensioners", "modes"],
    "images": ["layout", "resonance map"],
    "texts": ["input"],
    "duty_tables": ["duty-points", "duty-pulleys", "duty-spans", "duty-tensioners"],
    "duty_images": ["duty"],
}
DEFAULT_ORDERS = (1, 2, 3, 4, 6)  # engine orders of the resonance map (with the driver's configured ones)


@dataclasses.dataclass(frozen=True)
class ReportCriteria:
    """What the report checks (PASS/FAIL marks) and the operating range of the resonance map.

    ``min_slip_safety``: every pulley's slip safety factor (static load case, duty-point mean and dynamic
    minimum), default 1 (the capstan limit); ``stop_margin_deg`` / ``stop_margin_mm``: distance of an arm /
    slider from its nearest stop in every belt-length case and duty point; ``tension_window`` (lo, hi) [N]:
    the installation tension of every belt-length case, by default the nominal belt's within
    ``tension_window_rel`` (+-25 %); ``hub_peak_ratio``: a duty point's dynamic hub-load peak over its mean;
    ``hub_load_max``: pulley -> largest hub load [N] (static and peak; ``"*"``: every pulley), default none;
    ``idle_rpm`` (default: the driver's configured speed) .. ``red_line_rpm``: the band of the resonance map.
    """

    min_slip_safety: float = 1.0
    stop_margin_deg: float = 5.0
    stop_margin_mm: float = 3.0
    tension_window: tuple[float, float] | None = None
    tension_window_rel: float = 0.25
    hub_peak_ratio: float = 1.5
    hub_load_max: Mapping[str, float] = dataclasses.field(default_factory=dict)
    idle_rpm: float | None = None
    red_line_rpm: float = 6000.0

    def __post_init__(self):
        for name in ("min_slip_safety", "stop_margin_deg", "stop_margin_mm", "tension_window_rel", "red_line_rpm"):
            _require(getattr(self, name), name, lo=0.0)
        _require(self.hub_peak_ratio, "hub_peak_ratio", lo=1.0)
        if self.red_line_rpm <= 0:
            raise ConfigError(f"report: red_line_rpm = {self.red_line_rpm!r}: must be > 0")
        if self.idle_rpm is not None:
            _require(self.idle_rpm, "idle_rpm", lo=0.0)
            if self.idle_rpm >= self.red_line_rpm:
                raise ConfigError(
                    f"report: idle {self.idle_rpm:g} rpm must lie below the red line {self.red_line_rpm:g} rpm"
                )
        if self.tension_window is not None:
            lo, hi = (float(x) for x in self.tension_window)
            if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo < hi):
                raise ConfigError(f"report: tension window {self.tension_window!r}: need 0 <= lo < hi [N]")
        for k, v in self.hub_load_max.items():
            _require(v, f"hub_load_max[{k!r}]", lo=0.0)

    def hub_limit(self, pulley: str) -> float:
        return float(self.hub_load_max.get(pulley, self.hub_load_max.get("*", math.inf)))


def _require(x, name: str, lo: float) -> None:
    ok = isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and x >= lo
    if not ok:
        raise ConfigError(f"report: {name} = {x!r}: must be a finite number >= {lo:g}")


@dataclasses.dataclass(frozen=True)
class ReportSource:
    """Where the drive came from, echoed in the document: the file's name and text, the command line and
    the date (default: now, UTC)."""

    path: str
    text: str
    command: str | None = None
    date: str | None = None


# ------------------------------------------------------------------ cells, marks, tables


class _Html(str):
    """Markup put into a cell as it is (everything else is escaped)."""


_NUMERIC = re.compile(r"^([-+]?\d+(\.\d+)?|inf|-inf|-|>100)( / ([-+]?\d+(\.\d+)?|-))?$")  # right-aligned cells


def _n(x, digits: int = 1) -> str:
    """A number with ``digits`` decimals; "-" for none or NaN, "inf" for infinity (an idler's safety)."""
    if x is None:
        return "-"
    x = float(x)
    if math.isnan(x):
        return "-"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    s = f"{x:.{digits}f}"
    return s[1:] if s.startswith("-") and float(s) == 0 else s  # no "-0.0"


def _sf(x) -> str:
    return ">100" if x is not None and math.isfinite(float(x)) and float(x) >= 100 else _n(x, 2)


def _mark(ok: bool | None) -> _Html:
    if ok is None:
        return _Html('<span class="na">n/a</span>')
    return _Html('<span class="pass">PASS</span>' if ok else '<span class="fail">FAIL</span>')


def _flag(text: str, bad: bool) -> _Html:
    """A value marked as failing its criterion (red cell)."""
    return _Html(f'<span class="bad">{html.escape(text)}</span>' if bad else html.escape(text))


def _table(table_id: str, header: list[str], rows: list[list], caption: str = "", group: bool = False) -> str:
    """A table; with ``group`` the first cell of consecutive rows with the same first cell is merged (a
    pulley's, span's or tensioner's rows together)."""

    def cell(x) -> str:
        return x if isinstance(x, _Html) else html.escape(str(x))

    def td(x) -> str:
        numeric = isinstance(x, _Html) or _NUMERIC.match(str(x))
        return f"<td>{cell(x)}</td>" if numeric else f'<td class="text">{cell(x)}</td>'

    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = []
    for i, r in enumerate(rows):
        first = not group or i == 0 or rows[i - 1][0] != r[0]
        span = sum(1 for _ in _run(rows, i)) if group and first else 1
        cells = [f'<th scope="row" rowspan="{span}">{cell(r[0])}</th>' if first else ""]
        cells += [td(x) for x in r[1:]]
        cls = ' class="group"' if group and first else ""
        body.append(f"<tr{cls}>{''.join(cells)}</tr>")
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    return f'<table id="{table_id}">{cap}<thead><tr>{head}</tr></thead><tbody>{"".join(body)}</tbody></table>'


def _run(rows, i):
    j = i
    while j < len(rows) and rows[j][0] == rows[i][0]:
        yield j
        j += 1


def _png(fig) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    return base64.b64encode(buf.getvalue()).decode()


def _image(alt: str, fig, caption: str = "") -> str:
    cap = f"<figcaption>{html.escape(caption)}</figcaption>" if caption else ""
    return f'<figure><img alt="{html.escape(alt)}" src="data:image/png;base64,{_png(fig)}"/>{cap}</figure>'


@dataclasses.dataclass
class _Check:
    criterion: str
    where: str
    value: float
    limit: str
    ok: bool | None
    point: int | None = None  # the duty point checked (None: statics)
    worst_low: bool = True  # the smallest value is the worst one (else the largest)


# ------------------------------------------------------------------ inputs derived from the drive


def _driver(drive: Drive) -> int | None:
    drivers = [i for i, p in enumerate(drive.pulleys) if p.role == "driver"]
    return drivers[0] if len(drivers) == 1 else None


def _driver_rpm(drive: Drive) -> float | None:
    """The driver's configured final speed [rpm] (None for a torque driver)."""
    d = _driver(drive)
    if d is None or not drive.model.kinematic[d]:
        return None
    return abs(float(np.asarray(drive.params.pulleys.speed.values)[d, -1])) * 60 / (2 * math.pi)


def configured_torques(drive: Drive) -> dict[str, float]:
    """The torque [N m] each pulley but the driver absorbs once its laws hold their last values: the final
    ``load``/``torque`` (``power_kw`` at the nominal speed, as built) and the viscous load at the speed the
    driver's final speed gives it (creep neglected). Pulleys absorbing nothing are left out."""
    pp = drive.params.pulleys
    final = np.asarray(pp.torque.values)[:, -1]  # counter-clockwise positive, applied to the pulley
    radius, viscous = np.asarray(pp.radius), np.asarray(pp.viscous)
    d, rpm = _driver(drive), _driver_rpm(drive)
    out = {}
    for i, name in enumerate(drive.model.pulley_names):
        if i == d:
            continue
        sense = drive.running_sense[i] if drive.running_sense else 1
        q = -float(final[i]) * sense  # absorbed: opposing the running sense
        if rpm is not None and d is not None and viscous[i] > 0:
            q += float(viscous[i]) * rpm * 2 * math.pi / 60 * float(radius[d] / radius[i])
        if abs(q) > 0:
            out[name] = q
    return out


def duty_dynamics(drive: Drive, duty, window: float = 0.2) -> list[dict] | None:
    """Per duty point the window statistics of its signals (``outputs.fead.fead_summary``: slip mean and
    peak, minimum slip safety factor, hub-load peak, arm mean and peak-to-peak, span tension amplitudes)
    plus each arm's range and each one-way clutch's overrun; None when the duty result keeps no signals.

    The signals are read from the result's ``signals_file`` (``duty_study(..., out_dir=...)``: the sweep's
    ``sweep_signals.npz``) or ``signals`` (name -> (points, times) array), the times under ``"t"``; the
    window is the final ``window`` fraction of the run, as the duty figures' (``duty_study``'s default)."""
    sig = getattr(duty, "signals", None)
    path = getattr(duty, "signals_file", None)
    if sig is None and path is not None:
        with np.load(path) as z:
            sig = {k: z[k] for k in z.files}
    if sig is None:
        return None
    t = np.asarray(sig["t"], dtype=float)
    starts = getattr(duty, "window_start", None)
    names = [k for k in sig if k not in ("t", "point")]
    return [
        _point_dynamics(
            drive,
            {"t": t, **{k: np.asarray(sig[k][j], dtype=float) for k in names}},
            window_from_start(t, None if starts is None else starts[j], window),
        )
        for j in range(len(np.atleast_1d(duty.rpm)))
    ]


def _point_dynamics(drive: Drive, sig: dict, sel) -> dict:
    from ..outputs.fead import fead_summary

    res = fead_summary(drive, sig, sel)
    names = list(drive.model.pulley_names)
    for i, p in enumerate(names):
        if f"arm_angle:{p}" in sig or f"travel:{p}" in sig:
            key, scale = (f"arm_angle:{p}", 180 / math.pi) if f"arm_angle:{p}" in sig else (f"travel:{p}", 1e3)
            x = sig[key][sel] * scale
            res["pulleys"][p].update(position_min=float(x.min()), position_max=float(x.max()))
        if f"rotor_omega:{p}" in sig:
            sense = drive.running_sense[i] if drive.running_sense else 1
            w, rotor = sig[f"omega:{p}"][sel], sig[f"rotor_omega:{p}"][sel]
            ahead = sense * (rotor - w)  # the rotor running ahead of its sheave: the clutch overruns
            tol = 1e-3 * max(float(np.mean(np.abs(w))), 1.0)
            res["pulleys"][p].update(
                overrun_share_pct=100.0 * float(np.mean(ahead > tol)),
                overrun_max_rpm=max(float(ahead.max()), 0.0) * 60 / (2 * math.pi),
            )
    return res


# ------------------------------------------------------------------ the document


def drive_report(
    drive: Drive,
    *,
    torques: dict | None = None,
    length_cases: dict | None = None,
    modes_count: int = 8,
    duty=None,
    title: str | None = None,
    criteria: ReportCriteria | None = None,
    source: ReportSource | None = None,
    duty_window: float = 0.2,
    model: str | None = None,
) -> str:
    """The report as an HTML string (write it with ``jaxbelt.io.atomic_write``).

    ``torques``: pulley -> absorbed torque [N m] of the static load case (default: ``configured_torques``);
    ``length_cases``: label -> length change [m] (``statics_table``; the nominal belt is always first);
    ``duty``: an optional ``DutyResult`` (``analysis.duty.duty_study``, its ``window`` as ``duty_window``)
    for the duty-point sections (dynamic results where it keeps its signals: ``duty_dynamics``);
    ``criteria``: the checks (default ``ReportCriteria()``); ``source``: the input file echoed; ``model``: the
    tier of the modes ("ancf": the ANCF belt's, rotational and span modes; "spans": the spans tier's rotational
    modes; None: the drive's ``solver.model``) - the duty result says its own; every dynamic section names the
    tier that made it.

    Parameters: its nine keyword options are the user's choices for one report, each with a default and passed
    by name; the checks and the input file are already records (``ReportCriteria``, ``ReportSource``), and a
    record of the rest would only rename them."""
    from .statics import statics_table

    model = resolve_model(drive, model, "report")
    crit = criteria or ReportCriteria()
    cases = {"nominal": 0.0, **{k: v for k, v in (length_cases or {}).items() if k != "nominal"}}
    loaded_by = "as given (--torque)" if torques is not None else "configured loads at their final values"
    torques = configured_torques(drive) if torques is None else dict(torques)
    installed = statics_table(drive, None, cases)
    try:
        loaded, load_error = statics_table(drive, torques, cases), None
    except ConfigError as e:  # loads beyond what the belt carries: said in the report, not a crash
        loaded, load_error = None, str(e)
    checks: list[_Check] = []
    idle = crit.idle_rpm if crit.idle_rpm is not None else (_driver_rpm(drive) or 0.0)
    sections = [
        _geometry_section(drive, installed["nominal"], loaded["nominal"] if loaded else None),
        _statics_section(drive, installed["nominal"], loaded, torques, loaded_by, load_error, crit, checks),
        _tensioner_section(drive, installed, loaded, crit, checks),
        _modes_section(drive, _modes(drive, modes_count, model), (idle, crit.red_line_rpm), model, loaded or installed),
    ]
    if duty is not None:
        sections.append(_duty_section(drive, duty, duty_window, crit, checks))
    title = title or "Belt drive report"
    front = _front_section(drive, _Document(title, source, loaded_by, cases, duty, model), crit, checks)
    echo = _input_section(drive, source)
    body = "".join([front, *sections, echo])
    return (
        f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
        f"<style>{_STYLE}</style></head><body>{body}</body></html>"
    )


_STYLE = (
    "body{font-family:sans-serif;font-size:13px;max-width:1180px;margin:0 auto;padding:0 12px;color:#111}"
    "h1{font-size:22px}h2{font-size:18px;border-bottom:2px solid #333;padding-bottom:2px}"
    "section.page{padding-bottom:12px;margin-bottom:24px;border-bottom:1px dashed #999}"
    "table{border-collapse:collapse;margin:8px 0 14px;max-width:100%}"
    "caption{text-align:left;font-weight:bold;padding:2px 0}"
    "td,th{border:1px solid #bbb;padding:2px 6px;text-align:right;vertical-align:top}"
    "thead th{background:#eee;text-align:center}tbody th{text-align:left;font-weight:normal}"
    "tr.group>*{border-top:2px solid #555}td.text,th.text{text-align:left}"
    ".pass{color:#075;font-weight:bold}.fail{color:#fff;background:#c00;font-weight:bold;padding:0 3px}"
    ".bad{color:#c00;font-weight:bold}.na{color:#888}.note{color:#444}"
    "figure{margin:8px 0}img{max-width:100%;height:auto}"
    "pre{white-space:pre-wrap;overflow-wrap:anywhere;font-size:11px;background:#f6f6f6;padding:6px}"
    "@page{size:A4;margin:12mm}"
    "@media print{body{max-width:none;font-size:10px}section.page{break-before:page;border:none}"
    "section.page:first-of-type{break-before:auto}figure,tr{break-inside:avoid}caption{break-after:avoid}"
    "img{max-height:100mm;width:auto}}"
)


def _section(sid: str, heading: str, parts: list[str]) -> str:
    return f'<section class="page" id="{sid}"><h2>{html.escape(heading)}</h2>{"".join(parts)}</section>'


TIERS = {"ancf": "ANCF belt", "spans": "spans tier"}


def _models_text(duty, modes_model: str) -> str:
    """Which model made which section."""
    text = f"statics: the string model; modes: {TIERS[modes_model]}"
    if duty is not None:
        text += f"; duty points: {TIERS[getattr(duty, 'timing', {}).get('model', 'ancf')]}"
    return text + " (docs/spans.md: where the tiers differ)"


def _modes(drive: Drive, count: int, model: str):
    """The modes of ``model``'s tier as a ``Modes`` record."""
    from .modes import Modes, linear_modes

    if model == "ancf":
        return linear_modes(drive, count=count)
    from ..spans import spans_campbell_modes

    found = spans_campbell_modes(drive, count=count)  # both kinds, as the ANCF tier's modes section lists them
    return Modes(
        frequencies=np.array([m["frequency_hz"] for m in found]),
        kinds=[m["kind"] for m in found],
        span=[m.get("span") for m in found],
        rotational_share=np.array([1.0 if m["kind"] == "rotational" else 0.0 for m in found]),
        shapes={},
        contact_stiffness=float(drive.params.contact_stiffness),
    )


@dataclasses.dataclass(frozen=True)
class _Document:
    """What the front page's document table describes: the title, the input file (None: built in Python), how the
    static load case was loaded, the belt-length cases (label -> length change [m]), the duty result (or None) and
    the tier of the modes."""

    title: str
    source: ReportSource | None
    loaded_by: str
    cases: dict
    duty: DutyResult | None = None
    modes_model: str = "ancf"


def _front_section(drive, document: _Document, crit, checks) -> str:
    from .. import __version__

    title, source, loaded_by, cases = document.title, document.source, document.loaded_by, document.cases
    duty, modes_model = document.duty, document.modes_model
    date = (source.date if source and source.date else None) or datetime.datetime.now(datetime.timezone.utc).strftime(
        "%Y-%m-%d %H:%M UTC"
    )
    rows = [["drive", _description(source.text) if source else "(built in Python)"]]
    if source is not None:
        rows += [["input file", source.path], ["SHA-256", hashlib.sha256(source.text.encode()).hexdigest()[:16]]]
        if source.command:
            rows.append(["command", source.command])
    rows += [["jaxbelt version", __version__], ["generated", date]]
    rows.append(["models", _models_text(duty, modes_model)])
    rows.append(["static load case", loaded_by])
    rows.append(["belt-length cases", ", ".join(f"{k} {1e3 * v:+.1f} mm" for k, v in cases.items())])
    if duty is not None:
        rows.append(["duty points [rpm]", ", ".join(_n(r, 0) for r in np.atleast_1d(duty.rpm))])
    crit_rows = [
        ["slip safety factor", f">= {crit.min_slip_safety:g} (static load case, duty-point mean and minimum)"],
        [
            "margin to the tensioner stops",
            f">= {crit.stop_margin_deg:g} deg (arm), >= {crit.stop_margin_mm:g} mm (slider)",
        ],
        ["installation tension", _window_text(crit)],
        ["hub-load peak", f"<= {crit.hub_peak_ratio:g} x the duty point's mean" + _hub_max_text(crit)],
        ["duty points", "steady state, no fault, no gross slip"],
    ]
    doc = _table("document", ["item", "value"], rows)
    crit_t = _table("criteria", ["criterion", "limit"], crit_rows, caption="Criteria (ReportCriteria; CLI options)")
    verdict = _verdict(checks)
    failed = sum(1 for c in checks if c.ok is False)
    head = f"<h1>{html.escape(title)}</h1><p><b>{failed} of {len(checks)} checks fail.</b></p>"
    return f'<section class="page" id="document-page">{head}{doc}{crit_t}{verdict}</section>'


def _window_text(crit: ReportCriteria) -> str:
    if crit.tension_window is not None:
        return f"{crit.tension_window[0]:g} .. {crit.tension_window[1]:g} N, every belt-length case"
    return f"nominal belt's +- {100 * crit.tension_window_rel:g} %, every belt-length case"


def _hub_max_text(crit: ReportCriteria) -> str:
    return "".join(f"; {k}: <= {v:g} N" for k, v in crit.hub_load_max.items())


def _description(text: str) -> str:
    """The first sentence of a configuration's leading comment block (else "-")."""
    lines: list[str] = []
    for line in text.splitlines():
        s = line.strip()
        if not s.startswith("#"):
            break
        s = s.lstrip("#").strip()
        if not s:
            if lines:
                break
            continue
        lines.append(s)
    words = " ".join(lines)
    for stop in (": ", ". "):
        words = words.split(stop)[0]
    return (words[:157] + "...") if len(words) > 160 else (words or "-")


def _verdict(checks: list[_Check]) -> str:
    """One row per criterion: how many values were checked, how many fail, and the worst one."""
    rows = []
    for name in dict.fromkeys(c.criterion for c in checks):
        group = [c for c in checks if c.criterion == name]
        judged = [c for c in group if c.ok is not None and math.isfinite(c.value)]
        worst = (min if group[0].worst_low else max)(judged, key=lambda c: c.value) if judged else None
        failed = sum(1 for c in group if c.ok is False)
        oks = [c.ok for c in group if c.ok is not None]
        rows.append(
            [
                name,
                group[0].limit,
                str(len(group)),
                _flag(str(failed), failed > 0),
                f"{_n(worst.value, 2)} ({worst.where})" if worst else "-",
                _mark(all(oks) if oks else None),
            ]
        )
    return _table(
        "verdict", ["criterion", "limit", "checked", "failed", "worst (where)", "result"], rows, caption="Verdict"
    )


def _geometry_section(drive: Drive, nominal, loaded) -> str:
    """Belt data, the pulley table, the span table and the layout with the static hub loads."""
    spec, b = drive.spec.belt, nominal.belt
    names = list(drive.model.pulley_names)
    radius = np.asarray(drive.params.pulleys.radius)
    m = float(drive.params.belt.mass_per_length)
    belt_rows = [
        [
            "type",
            f"{spec.type}"
            + (f", {spec.ribs} ribs, groove {spec.groove_angle_deg:g} deg" if spec.type == "poly-v" else ""),
        ],
        ["path length at installation [mm]", _n(1e3 * b["path_length"], 1)],
        ["stress-free length [mm]", _n(1e3 * b["stress_free_length"], 1)],
        ["EA [N]", _n(b["EA"], 0)],
        ["mass per stress-free length [kg/m]", _n(m, 4)],
        ["elements", str(drive.model.n_elements)],
    ]
    d = _driver(drive)
    sense = drive.running_sense or (1,) * len(names)
    torques = configured_torques(drive)
    rows = []
    for i, (p, name) in enumerate(zip(drive.pulleys, names)):
        grooved = drive.model.friction_factor[i] > 1.0
        contact = "back side" if drive.model.wrap_side[i] < 0 else ("grooved" if grooved else "flat")
        ratio = sense[i] * sense[d] * float(radius[d] / radius[i]) if d is not None else math.nan
        spec_p = drive.spec.pulleys[i]
        rows.append(
            [
                name,
                p.role,
                _n(1e3 * p.center[0], 1),
                _n(1e3 * p.center[1], 1),
                _n(2e3 * p.radius, 1),
                _n(2e3 * float(radius[i]), 1),
                contact,
                _n(nominal.pulleys[name]["wrap_deg"], 1),
                _n(ratio, 3),
                f"{float(drive.params.pulleys.inertia[i]):.3g}",
                spec_p.clutch or "-",
                _n(torques.get(name), 2) if i != d else "driver",
            ]
        )
    header = ["pulley", "role", "x [mm]", "y [mm]", "surface dia. [mm]", "belt-axis dia. [mm]", "contact"]
    header += ["wrap [deg]", "speed ratio [-]", "inertia [kg m2]", "clutch", "load [N m]"]
    spans = []
    for j, sp in enumerate(nominal.spans):
        T0 = sp["tension"]
        m_cur = mass_per_current_length(m, T0, float(drive.params.belt.EA))  # the span's current length
        f1 = math.sqrt(T0 / m_cur) / (2 * sp["length"]) if T0 > 0 and sp["length"] > 0 else math.nan
        spans.append(
            [
                sp["name"],
                names[j],
                names[(j + 1) % len(names)],
                _n(1e3 * sp["length"], 1),
                _n(T0, 1),
                _n(loaded.spans[j]["tension"], 1) if loaded else "-",
                _n(f1, 1),
            ]
        )
    span_header = [
        "span",
        "from",
        "to",
        "length [mm]",
        "T installation [N]",
        "T static load [N]",
        "f1 at installation [Hz]",
    ]
    note = (
        "<p class='note'>Speed ratio: the pulley's speed over the driver's (negative: turning the other way); "
        "diameters at the pulley surface and at the belt axis; f1: first transverse frequency of the span as "
        "a string between fixed ends, (1/2L) sqrt(T/m').</p>"
    )
    return _section(
        "geometry",
        "Geometry",
        [
            _table("belt", ["belt", "value"], belt_rows),
            _table("pulleys", header, rows, caption="Pulleys (in the belt's direction of travel)"),
            _table("spans", span_header, spans, caption="Spans (tangent to tangent, statics)"),
            note,
            _image("layout", _layout_figure(drive, loaded or nominal)),
        ],
    )


def _statics_section(drive: Drive, installed, loaded, torques, loaded_by, load_error, crit, checks) -> str:
    """Per pulley the installation (no torque) and the static load case, nominal belt."""
    rows = []
    for name, p0 in installed.pulleys.items():
        rows.append(
            [
                name,
                "installation",
                _n(0.0, 2),
                _n(p0["tension_in"]),
                _n(p0["tension_out"]),
                _n(p0["hub_load"]),
                _n(p0["hub_load_deg"]),
                "-",
                _mark(None),
            ]
        )
        if loaded is None:
            continue
        p = loaded["nominal"].pulleys[name]
        sf = p["slip_safety"]
        ok = sf >= crit.min_slip_safety if math.isfinite(sf) else True
        hub_ok = p["hub_load"] <= crit.hub_limit(name)
        checks.append(_Check("slip safety factor", f"{name}, static load", sf, f">= {crit.min_slip_safety:g}", ok))
        if math.isfinite(crit.hub_limit(name)):
            checks.append(
                _Check(
                    "hub load",
                    f"{name}, static load",
                    p["hub_load"],
                    f"<= {crit.hub_limit(name):g} N",
                    hub_ok,
                    worst_low=False,
                )
            )
        rows.append(
            [
                name,
                "static load",
                _n(p["torque"], 2),
                _n(p["tension_in"]),
                _n(p["tension_out"]),
                _flag(_n(p["hub_load"]), not hub_ok),
                _n(p["hub_load_deg"]),
                _flag(_sf(sf), not ok),
                _mark(ok and hub_ok),
            ]
        )
    header = ["pulley", "case", "torque [N m]", "T in [N]", "T out [N]", "hub load [N]", "hub direction [deg]"]
    header += ["slip safety [-]", "check"]
    text = (
        f"<p>Nominal belt. Static load case: {html.escape(loaded_by)}"
        f" ({', '.join(f'{k} {v:.2f} N m' for k, v in torques.items()) or 'none'}); the driver supplies their tension "
        "steps, sum Q R_driver / R. "
        "Statics: the belt a string on rigid pulleys (no bending, sag or centrifugal tension); slip safety factor "
        "mu_eff wrap / ln(T_tight / T_slack) (> 1: no gross slip); hub load: force of the belt on the pulley, "
        "direction counter-clockwise from +x.</p>"
    )
    if load_error:
        text += f"<p class='bad'>Static load case: {html.escape(load_error)}</p>"
    return _section("statics", "Installation and static load", [text, _table("installation", header, rows, group=True)])


def _stops(drive: Drive, i: int) -> tuple[float, float]:
    n = drive.params.pulleys.carrier[i]
    return float(n.get("stops.min", -math.inf)), float(n.get("stops.max", math.inf))


def _position_scale(coordinate: str) -> tuple[float, str]:
    return (180 / math.pi, "deg") if coordinate == "arm_angle" else (1e3, "mm")


def _tensioner_section(drive: Drive, installed, loaded, crit, checks) -> str:
    """Per tensioner and belt-length case: installation tension, position at installation and under the
    static load, the margin to the nearest stop (its check) and the installation-tension window."""
    names = list(drive.model.pulley_names)
    T_nom = 0.5 * (installed["nominal"].belt["min_tension"] + installed["nominal"].belt["max_tension"])
    lo, hi = crit.tension_window or (T_nom * (1 - crit.tension_window_rel), T_nom * (1 + crit.tension_window_rel))
    case_rows = []
    for label, st in installed.items():
        T = 0.5 * (st.belt["min_tension"] + st.belt["max_tension"])
        ok = lo <= T <= hi
        checks.append(_Check("installation tension", label, T, f"{lo:.0f} .. {hi:.0f} N", ok))
        case_rows.append(
            [label, _n(1e3 * st.belt["length_change"], 1), _flag(_n(T), not ok), f"{lo:.0f} .. {hi:.0f}", _mark(ok)]
        )
    parts = [
        _table(
            "tension-window",
            ["case", "length change [mm]", "installation tension [N]", "window [N]", "check"],
            case_rows,
            caption="Installation tension per belt-length case",
        )
    ]
    rows = []
    for i, c in enumerate(drive.model.carriers):
        if not c.movable:
            continue
        name, coord = names[i], c.coordinate or "coordinate"
        scale, unit = _position_scale(coord)
        low, high = (s * scale for s in _stops(drive, i))
        need = crit.stop_margin_deg if unit == "deg" else crit.stop_margin_mm
        rest = float(drive.params.pulleys.carrier[i]["rest"]) * scale
        for label, st in installed.items():
            x0 = st.pulleys[name][coord] * scale
            x1 = loaded[label].pulleys[name][coord] * scale if loaded else math.nan
            xs = [x for x in (x0, x1) if math.isfinite(x)]
            margin = min(min(x - low, high - x) for x in xs) if math.isfinite(low) or math.isfinite(high) else math.inf
            ok = margin >= need if math.isfinite(margin) else None
            if ok is not None:
                checks.append(_Check("margin to the stops", f"{name}, {label}", margin, f">= {need:g} {unit}", ok))
            stops = f"{_n(low, 1)} .. {_n(high, 1)}" if ok is not None else "none"
            rows.append(
                [
                    f"{name} [{unit}]",
                    label,
                    _n(x0, 2),
                    _n(x1, 2),
                    _n(rest, 2),
                    stops,
                    _flag(_n(margin, 2), ok is False),
                    _mark(ok),
                ]
            )
    header = [
        "tensioner",
        "case",
        "installation",
        "static load",
        "spring rest (free)",
        "stops",
        "margin to stop",
        "check",
    ]
    if rows:
        parts.append(
            _table("tensioners", header, rows, caption="Tensioner positions across the belt length", group=True)
        )
    else:
        parts.append(_table("tensioners", ["tensioner"], [["none: no movable carrier"]]))
    return _section("tensioner-positions", "Tensioner positions and installation tension", parts)


def _orders(drive: Drive) -> list[float]:
    exc = drive.params.pulleys.excitation
    extra: set[float] = set()
    d = _driver(drive)
    if exc is not None and d is not None:
        extra = {float(k) for k, a in zip(np.asarray(exc.order)[d], np.asarray(exc.amplitude)[d]) if a != 0 and k > 0}
    return sorted(set(map(float, DEFAULT_ORDERS)) | extra)


def _modes_section(drive: Drive, modes, band: tuple, model: str, statics_cases: dict) -> str:
    """The linearised modes, how each one-way clutch enters them, and the resonance map with the crossings
    of the engine orders inside the idle-to-red-line ``band`` [rpm]; the span modes run at the nominal belt's
    span tensions of ``statics_cases`` (the static load case's, else the installed ones) and the belt speed of
    each crank speed (``campbell``)."""
    from .campbell import campbell_lines, order_crossings

    idle, red = band
    orders = _orders(drive)
    table = modes.table()
    tensions = {s["name"]: s["tension"] for s in statics_cases["nominal"].spans}
    lines = campbell_lines(drive, table, np.linspace(0.0, 1.05 * red, 841), tensions, "static load case")
    hits = {(c["mode"], c["order"]): c["rpm"] for c in reversed(order_crossings(lines, orders, idle, red))}

    rows = [
        [r["mode"], _n(r["frequency_hz"], 2), r["kind"], r["span"] or "-", _n(r["rotational_share"], 3)]
        + [_n(hits[r["mode"], k], 0) if (r["mode"], k) in hits else "-" for k in orders]
        for r in table
    ]
    header = ["mode", "frequency [Hz]", "kind", "span", "rotational share [-]"]
    header += [f"order {k:g} at [rpm]" for k in orders]
    caption = (
        f"Modes (frequencies at rest) and the crank speeds at which engine order k excites them inside the band "
        f"idle .. red line, {idle:.0f} .. {red:.0f} rpm: 60 f / k for rotational modes; a span's transverse mode "
        "where k n / 60 meets its running frequency, which falls with the belt speed as 1 - v^2 / c^2 at the "
        "span's static tension"
    )
    parts = [_table("modes", header, rows, caption=caption)]
    clutches = getattr(modes, "clutches", None) or {}
    if clutches:
        parts.append(
            "<p>One-way clutches linearised as: "
            + html.escape(", ".join(f"{k}: {v}" for k, v in clutches.items()))
            + ".</p>"
        )
    cap = "Solid: rotational modes, dashed: transverse span modes; circles: rotational modes crossed by an order "
    cap += "inside the band (shaded)."
    parts.append(_image("resonance map", _resonance_map(lines, orders, idle, red), cap))
    what = "contacts stuck" if model == "ancf" else "wraps stuck; the spans' transverse modes from the span model"
    return _section("modes-page", f"Linearised modes ({TIERS[model]}: drive at rest, {what})", parts)


def _layout_figure(drive: Drive, st):
    """Pulleys, spans and the static hub-load vectors (arrows, length proportional to the load)."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle

    path = drive.path
    centers, radii = np.asarray(path.centers), np.asarray(path.radii)
    lo, hi = (centers - radii[:, None]).min(axis=0), (centers + radii[:, None]).max(axis=0)
    aspect = float((hi[1] - lo[1]) / max(hi[0] - lo[0], 1e-9))
    fig = Figure(figsize=(7.5, min(max(7.5 * aspect, 3.5), 8.0) + 0.8), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    hubs = [st.pulleys[n] for n in drive.model.pulley_names]
    scale = (
        0.25 * float(np.ptp(centers[:, 0]) + np.ptp(centers[:, 1]) + 1e-3) / max(max(h["hub_load"] for h in hubs), 1e-9)
    )
    for (x, y), r, name, h in zip(centers, radii, drive.model.pulley_names, hubs):
        ax.add_patch(Circle((x, y), r, fill=False, lw=1.2))
        ax.annotate(name, (x, y - r), fontsize=7, ha="center", va="top")
        a, L = math.radians(h["hub_load_deg"]), scale * h["hub_load"]
        ax.annotate(
            "", (x + L * math.cos(a), y + L * math.sin(a)), (x, y), arrowprops=dict(arrowstyle="->", color="C3")
        )
        ax.annotate(f"{h['hub_load']:.0f} N", (x + L * math.cos(a), y + L * math.sin(a)), fontsize=6, color="C3")
    for a, b in zip(np.asarray(path.span_start), np.asarray(path.span_end)):
        ax.plot([a[0], b[0]], [a[1], b[1]], "k-", lw=1)
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set(xlabel="x [m]", ylabel="y [m]", title="layout and static hub loads (arrows, static load case)")
    return fig


def _resonance_map(lines, orders, idle: float, red: float):
    """Modes (``campbell.CampbellLines``: rotational ones flat, span modes falling with the belt speed) against
    the engine orders (rays k n / 60), every order labelled where its ray leaves the plot, the idle-to-red-line
    band shaded and the rotational modes' crossings inside it marked."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 5), layout="constrained")
    ax = fig.add_subplot(1, 1, 1)
    x_max = 1.05 * red
    f = np.array([m["frequency_hz"] for m in lines.modes], dtype=float)
    kinds = [m["kind"] for m in lines.modes]
    y_max = max(float(np.max(f)) * 1.1 if f.size else 0.0, 1.0)
    ax.axvspan(idle, red, color="C2", alpha=0.12, lw=0, label=f"idle .. red line ({idle:.0f} .. {red:.0f} rpm)")
    for k in orders:
        x_end = min(x_max, 60 * y_max / k)
        ax.plot([0, x_end], [0, k * x_end / 60], "k-", lw=0.7)
        label = f"order {k:g}"
        if x_end < x_max:  # leaves through the top
            ax.text(x_end, y_max, label, fontsize=8, ha="center", va="bottom", clip_on=False)
        else:  # leaves through the right edge
            ax.text(x_max, k * x_max / 60, " " + label, fontsize=8, ha="left", va="center", clip_on=False)
    for i, (fi, kind, line) in enumerate(zip(f, kinds, lines.frequency)):
        rot = kind == "rotational"
        ax.plot(lines.rpm, line, color="C0" if rot else "C1", lw=1.2, ls="-" if rot else "--")
        ax.text(0.01 * x_max, fi, f"mode {i + 1}: {fi:.1f} Hz", fontsize=7, va="bottom", color="C0" if rot else "C1")
        for k in orders if rot else ():  # the rotational modes' crossings (the span modes are in the table)
            n = 60 * fi / k
            if idle <= n <= red:
                ax.plot(n, fi, "o", ms=5, mfc="none", color="C3")
    ax.set(
        xlabel="crank speed [rpm]",
        ylabel="frequency [Hz]",
        xlim=(0, x_max),
        ylim=(0, y_max),
    )
    ax.set_title("resonance map", pad=16)
    ax.legend(loc="lower right", fontsize=8)
    ax.grid(alpha=0.3)
    return fig


def _duty_section(drive: Drive, duty, window: float, crit: ReportCriteria, checks: list[_Check]) -> str:
    """Per duty point: its state (steady, fault, gross slip) and failed checks; per pulley, span and
    tensioner its steady figures and, where the duty result keeps signals, the dynamic ones."""
    rpm = np.atleast_1d(np.asarray(duty.rpm, dtype=float))
    names = list(drive.model.pulley_names)
    try:
        dyn, dyn_note = duty_dynamics(drive, duty, window), ""
    except (KeyError, ValueError, IndexError, TypeError, OSError) as e:  # signals of another layout: said
        dyn, dyn_note = None, f" (its signals could not be read: {e})"
    first = len(checks)
    pulleys, spans, tensioners = [], [], []
    cfg = configured_torques(drive)
    for name in names:
        for j, r in enumerate(rpm):
            pulleys.append(_duty_pulley_row(name, j, r, duty, cfg, dyn, crit, checks))
    for s, d in duty.spans.items():
        for j, r in enumerate(rpm):
            sd = dyn[j]["spans"].get(s, {}) if dyn else {}
            amp, rms, defl = (sd.get(k) for k in ("tension_amplitude", "tension_rms", "deflection_amplitude_mm"))
            spans.append([s, _n(r, 0), _n(d["tension"][j]), _n(d["tension_eff"][j]), _n(amp), _n(rms), _n(defl, 2)])
    for name, x in getattr(duty, "tensioners", {}).items():
        tensioners += _duty_tensioner_rows(drive, name, x, rpm, dyn, crit, checks)
    point_checks = _duty_points(drive, duty, rpm, checks[first:], crit, checks)
    note = (
        "<p class='note'>Steady figures: means over the final window of each duty point's run; effective "
        "tension T - m'v^2; slip safety factor from the mean effective tensions, its minimum over the window "
        "from the instantaneous friction use; amplitude: half the peak-to-peak over the window; clutch "
        "overrun: share of the window the rotor runs ahead of its sheave / the largest speed difference.</p>"
    )
    if dyn is None:
        note += (
            "<p class='note'>Dynamic results (amplitudes, peaks, minimum slip safety, arm travel, clutch "
            f"overrun): not available, this duty result keeps no signals{html.escape(dyn_note)}.</p>"
        )
    ph = ["pulley", "driver [rpm]", "load [N m]", "power [kW]", "speed [rpm]", "hub load mean [N]", "hub load peak [N]"]
    ph += ["slip safety mean [-]", "slip safety min [-]", "slip mean / peak [%]", "clutch overrun [% / rpm]", "check"]
    sh = ["span", "driver [rpm]", "T mean [N]", "T - m'v2 [N]", "amplitude [N]", "rms [N]", "deflection amplitude [mm]"]
    th = ["tensioner", "driver [rpm]", "mean", "peak-to-peak", "min", "max", "margin to stop", "check"]
    parts = [
        point_checks,
        note,
        _table(
            "duty-pulleys",
            ph,
            pulleys,
            caption="Per pulley (load: the mean torque the pulley absorbed at the point, its viscous part at the "
            "point's speed; power: load times the speed where the load acts, a one-way clutch's rotor)",
            group=True,
        ),
        _table("duty-spans", sh, spans, caption="Per span", group=True),
        _table("duty-tensioners", th, tensioners or [["none", *["-"] * 7]], caption="Per tensioner", group=True),
        _image("duty", _duty_figure(duty, crit)),
    ]
    return _section("duty", f"Duty points ({TIERS[getattr(duty, 'timing', {}).get('model', 'ancf')]})", parts)


def _duty_tensioner_rows(drive: Drive, name: str, x, rpm, dyn, crit: ReportCriteria, checks: list[_Check]) -> list:
    """A tensioner's mean position per duty point, its range over the window and the margin of that range
    (else of the mean) to the nearest stop."""
    i = list(drive.model.pulley_names).index(name)
    scale, unit = _position_scale(drive.model.carriers[i].coordinate or "")
    low, high = (v * scale for v in _stops(drive, i))
    need = crit.stop_margin_deg if unit == "deg" else crit.stop_margin_mm
    rows = []
    for j, r in enumerate(rpm):
        pd = dyn[j]["pulleys"].get(name, {}) if dyn else {}
        lo_x, hi_x = pd.get("position_min", float(x[j])), pd.get("position_max", float(x[j]))
        margin = min(lo_x - low, high - hi_x)
        ok = margin >= need if math.isfinite(margin) else None
        if ok is not None:
            checks.append(_Check("margin to the stops", f"{name}, {r:.0f} rpm", margin, f">= {need:g} {unit}", ok, j))
        ranged = "position_min" in pd
        rows.append(
            [f"{name} [{unit}]", _n(r, 0), _n(x[j], 2)]
            + ([_n(hi_x - lo_x, 2), _n(lo_x, 2), _n(hi_x, 2)] if ranged else ["-"] * 3)
            + [_flag(_n(margin, 2), ok is False), _mark(ok)]
        )
    return rows


def _duty_figure(duty, crit: ReportCriteria):
    from ..viz import plot_duty

    return plot_duty(duty, min_safety=crit.min_slip_safety)


def _duty_points(drive: Drive, duty, rpm: np.ndarray, found: list[_Check], crit: ReportCriteria, checks) -> str:
    """The overview: per duty point its belt speed, steadiness and status (where the duty result says
    them: ``steady``, ``status``), the weakest pulley and how many of its checks fail."""
    steady, status = getattr(duty, "steady", None), getattr(duty, "status", None)
    faults = np.atleast_1d(np.asarray(duty.faults))
    d = _driver(drive)
    R = float(np.asarray(drive.params.pulleys.radius)[d]) if d is not None else math.nan
    rows = []
    for j, r in enumerate(rpm):
        st = None if steady is None or steady[j] is None else bool(steady[j])
        ok = int(faults[j]) == 0 and st is not False
        text = str(status[j]) if status is not None else ("ok" if int(faults[j]) == 0 else f"fault {int(faults[j])}")
        checks.append(_Check("duty points steady, no fault", f"{r:.0f} rpm", math.nan, "steady, no fault", ok, j))
        sfs = {n: float(v["slip_safety"][j]) for n, v in duty.pulleys.items()}
        sfs = {n: v for n, v in sfs.items() if math.isfinite(v)}
        weakest = min(sfs, key=lambda n: sfs[n]) if sfs else None
        bad = weakest is not None and sfs[weakest] < crit.min_slip_safety
        failed = sum(1 for c in found if c.point == j and c.ok is False) + (not ok)
        rows.append(
            [str(j + 1), _n(r, 0), _n(r * 2 * math.pi / 60 * R, 2), "-" if st is None else ("yes" if st else "NO")]
            + [text, _flag(f"{_sf(sfs[weakest])} ({weakest})", bad) if weakest else "-", _flag(str(failed), failed > 0)]
            + [_mark(failed == 0)]
        )
    header = ["point", "driver [rpm]", "belt speed [m/s]", "steady", "status", "weakest slip safety", "failed checks"]
    return _table("duty-points", header + ["verdict"], rows, caption="Duty points")


def _duty_pulley_row(name, j, r, duty, cfg, dyn, crit: ReportCriteria, checks: list[_Check]) -> list:
    """One pulley at one duty point: load, power, speed, hub load mean and peak, slip safety mean and
    minimum, slip, clutch overrun, and its checks."""
    d = duty.pulleys[name]
    w = abs(float(d["speed"][j]))
    # what the pulley absorbed at this point (a viscous part at this point's speed, not at the file's): the mean
    # torque of the belt on it, at the speed where its load acts (a clutch pulley's rotor)
    loaded = name in duty.loads or name in cfg
    if "torque" not in d:  # a duty record without the measured torques (made by hand): the applied load
        load = float(duty.loads[name][j]) if name in duty.loads else cfg.get(name, math.nan)
    else:
        load = abs(float(d["torque"][j])) if loaded else math.nan
    w_load = abs(float(d.get("load_speed", d["speed"])[j]))
    sf = float(d["slip_safety"][j])
    pd = dyn[j]["pulleys"].get(name, {}) if dyn else {}
    sf_min = pd.get("slip_safety_factor_min", math.nan)
    at = f"{name}, {r:.0f} rpm"
    sf_ok = not sf < crit.min_slip_safety
    min_ok = not sf_min < crit.min_slip_safety
    checks.append(_Check("slip safety factor", at, sf, f">= {crit.min_slip_safety:g}", sf_ok, j))
    if pd:
        checks.append(
            _Check("slip safety factor", at + " (minimum)", sf_min, f">= {crit.min_slip_safety:g}", min_ok, j)
        )
    mean, peak = float(d["hub_load"][j]), pd.get("hub_load_peak", math.nan)
    hub_ok = True
    if math.isfinite(peak) and mean > 0:
        hub_ok = peak <= crit.hub_peak_ratio * mean and peak <= crit.hub_limit(name)
        limit = f"<= {crit.hub_peak_ratio:g} x mean" + (
            f", <= {crit.hub_limit(name):g} N" if math.isfinite(crit.hub_limit(name)) else ""
        )
        checks.append(_Check("hub-load peak", at, peak / mean, limit, hub_ok, j, worst_low=False))
    slip = f"{_n(pd.get('slip_mean_pct'), 2)} / {_n(pd.get('slip_peak_pct'), 2)}" if pd else "-"
    over = f"{_n(pd['overrun_share_pct'], 1)} / {_n(pd['overrun_max_rpm'], 0)}" if "overrun_share_pct" in pd else "-"
    return [
        name,
        _n(r, 0),
        _n(load, 2),
        _n(load * w_load / 1e3, 3),
        _n(w * 60 / (2 * math.pi), 0),
        _n(mean),
        _flag(_n(peak), not hub_ok),
        _flag(_sf(sf), not sf_ok),
        _flag(_sf(sf_min), not min_ok),
        slip,
        over,
        _mark(sf_ok and min_ok and hub_ok),
    ]


def _input_section(drive: Drive, source: ReportSource | None) -> str:
    """The input echoed: the file as read (else the specification written as TOML)."""
    if source is not None:
        text, what = source.text, f"The input file {source.path} as read."
    else:
        from ..config.toml import dump_toml

        text, what = dump_toml(drive.spec), "The drive's specification, written as TOML."
    return _section(
        "input-page", "Input", [f"<p>{html.escape(what)}</p>", f'<pre id="input">{html.escape(text)}</pre>']
    )
