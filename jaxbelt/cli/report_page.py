"""``jaxbelt report``: one self-contained HTML drive report (document and verdict, geometry, statics,
tensioner positions, modes, duty points, the input), checked against ``ReportCriteria``."""

from __future__ import annotations

import re
import shlex
import sys
from pathlib import Path

from .common import EXIT_FAILED, EXIT_OK, UsageError, load_spec, output_dir, with_config_context

__all__ = ["command", "add_criteria_options"]


def add_criteria_options(p) -> None:
    """The report's criteria (defaults: ``analysis.report.ReportCriteria``, documented in docs/cli.md)."""
    from .parser import _nonnegative_float, _positive_float

    p.add_argument(
        "--min-safety",
        type=_positive_float,
        default=1.0,
        metavar="SF",
        help="least slip safety factor of every pulley (default 1)",
    )
    p.add_argument(
        "--stop-margin",
        type=_nonnegative_float,
        default=5.0,
        metavar="DEG",
        help="least distance of a tensioner arm from its stops [deg] (default 5)",
    )
    p.add_argument(
        "--stop-margin-mm",
        type=_nonnegative_float,
        default=3.0,
        metavar="MM",
        help="least distance of a tensioner slider from its stops [mm] (default 3)",
    )
    p.add_argument(
        "--tension-window",
        metavar="LO:HI",
        help="installation tension window [N] for every belt-length case (default: the nominal's +-25 %%)",
    )
    p.add_argument(
        "--hub-peak-ratio",
        type=_positive_float,
        default=1.5,
        metavar="R",
        help="largest dynamic hub-load peak over its duty-point mean (default 1.5)",
    )
    p.add_argument(
        "--hub-load-max",
        action="append",
        default=[],
        metavar="[PULLEY=]N",
        help="largest hub load [N] of a pulley (repeatable; without PULLEY= every pulley; default none)",
    )
    p.add_argument(
        "--speed-range",
        metavar="IDLE:RED",
        help="engine speed band of the resonance map [rpm] (default: the driver's configured speed : 6000)",
    )


def _pair(option: str, text: str | None) -> tuple[float, float] | None:
    if text is None:
        return None
    try:
        lo, hi = (float(x) for x in text.split(":"))
    except ValueError:
        raise UsageError(f"{option} {text!r}: give two numbers LO:HI, e.g. 200:400") from None
    return lo, hi


def _criteria(args):
    from .._errors import ConfigError
    from ..analysis.report import ReportCriteria

    hub = {}
    for item in args.hub_load_max:
        name, _, value = item.rpartition("=")
        try:
            hub[name or "*"] = float(value)
        except ValueError:
            raise UsageError(f"--hub-load-max {item!r}: give [PULLEY=]N, e.g. alternator=1200") from None
    speeds = _pair("--speed-range", args.speed_range)
    try:
        return ReportCriteria(
            min_slip_safety=args.min_safety,
            stop_margin_deg=args.stop_margin,
            stop_margin_mm=args.stop_margin_mm,
            tension_window=_pair("--tension-window", args.tension_window),
            hub_peak_ratio=args.hub_peak_ratio,
            hub_load_max=hub,
            idle_rpm=speeds[0] if speeds else None,
            red_line_rpm=speeds[1] if speeds else 6000.0,
        )
    except ConfigError as e:
        raise UsageError(str(e)) from None


@with_config_context
def command(args, cfg: Path) -> int:
    from ..analysis.report import ReportSource, drive_report
    from ..analysis.statics import _check_torques
    from ..config.build import build_drive
    from ..io import atomic_write
    from .duty import _numbers, _per_pulley
    from .statics import _cases, _parse_torques

    # every argument is read before anything is built or computed (a typo in --torque must not wait for the duty runs)
    torques, cases = _parse_torques(args.torque), _cases(args)
    rpm = _numbers("--rpm", args.rpm) if args.rpm else None
    powers = _per_pulley("--power", args.power)
    if powers and rpm is None:
        raise UsageError(
            "--power gives the load at each duty point: give the duty points' speeds too (--rpm R1,R2,...)"
        )
    criteria = _criteria(args)
    spec = load_spec(cfg, args.t_end, args.scheme)
    out_dir = output_dir(args, cfg, "_report", results=("report.html",))
    drive = build_drive(spec)
    _check_torques(drive, torques)  # an unknown pulley is named before the duty runs, not after
    if args.hub_load_max:
        unknown = [n for n in criteria.hub_load_max if n != "*" and n not in drive.model.pulley_names]
        if unknown:
            raise UsageError(f"--hub-load-max {unknown[0]}: no such pulley ({', '.join(drive.model.pulley_names)})")
    duty = _duty(drive, rpm, powers, out_dir, cfg, args) if rpm is not None else None
    source = ReportSource(
        path=str(cfg), text=cfg.read_text(), command=shlex.join(["jaxbelt", *sys.argv[1:]]) if sys.argv else None
    )
    page = drive_report(
        drive,
        torques=torques or None,
        length_cases=cases,
        duty=duty,
        title=f"Belt drive report: {cfg.stem}",
        criteria=criteria,
        source=source,
        model=args.model,
    )
    out_dir.mkdir(parents=True, exist_ok=True)
    with atomic_write(out_dir / "report.html", "w", inputs=[cfg]) as fh:
        fh.write(page)
    verdict = re.search(r"(\d+) of (\d+) checks fail", page)
    print(f"{cfg.stem}: report written to {out_dir / 'report.html'} ({verdict.group(0) if verdict else ''})")
    # as `duty`: a duty point that is not one (diverged, not steady, gross slip) is an exit code, not just a mark
    flagged = []
    if duty is not None:
        flagged = [(r, s) for r, s in zip(duty.rpm, getattr(duty, "status", None) or []) if s != "ok"]
    for r, s in flagged:
        print(f"jaxbelt report: duty point {r:g} rpm: {s}", file=sys.stderr)
    # the drive fails its criteria (static gross slip, a hub load over its limit, ...): an exit code, as a
    # statics in gross slip or a failing duty point, so a script sees it (the report is written either way)
    failed = verdict is not None and int(verdict.group(1)) > 0
    if failed and verdict is not None:
        print(f"jaxbelt report: {verdict.group(0)} (see {out_dir / 'report.html'})", file=sys.stderr)
    return EXIT_FAILED if flagged or failed else EXIT_OK


def _duty(drive, rpm, powers, out_dir: Path, cfg: Path, args):
    """The duty points, their signals kept in DIR/points (for the dynamic results) where ``duty_study``
    keeps them."""
    import inspect

    from ..analysis.duty import duty_study

    say = None if args.quiet else (lambda msg: print(f"{cfg.stem}: {msg}", flush=True))
    kw = dict(powers=powers, progress=say, model=args.model)
    if "out_dir" in inspect.signature(duty_study).parameters:
        kw.update(out_dir=out_dir / "points", inputs=[cfg], resume=bool(getattr(args, "resume", False)))
    return duty_study(drive, rpm, **kw)
