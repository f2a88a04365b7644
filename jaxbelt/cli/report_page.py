"""``jaxbelt report``: one self-contained HTML drive report (statics, tensioner positions, modes, duty points)."""

from __future__ import annotations

from pathlib import Path

from .common import EXIT_OK, load_spec, output_dir, with_config_context

__all__ = ["command"]


@with_config_context
def command(args, cfg: Path) -> int:
    from ..analysis.report import drive_report
    from ..config.build import build_drive
    from ..io import atomic_write
    from .duty import _numbers, _per_pulley
    from .statics import _cases, _parse_torques

    spec = load_spec(cfg, args.t_end)
    out_dir = output_dir(args, cfg, "_report")
    drive = build_drive(spec)
    duty = None
    if args.rpm:
        from ..analysis.duty import duty_study

        duty = duty_study(drive, _numbers("--rpm", args.rpm), powers=_per_pulley("--power", args.power))
    page = drive_report(
        drive, torques=_parse_torques(args.torque), length_cases=_cases(args), duty=duty, title=f"{cfg.stem}"
    )
    out_dir.mkdir(parents=True, exist_ok=True)
    with atomic_write(out_dir / "report.html", "w", inputs=[cfg]) as fh:
        fh.write(page)
    print(f"{cfg.stem}: report written to {out_dir / 'report.html'}")
    return EXIT_OK
