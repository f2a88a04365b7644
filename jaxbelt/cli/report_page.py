"""``jaxbelt report``: one self-contained HTML drive report (statics, tensioner positions, modes, duty points)."""

from __future__ import annotations

from pathlib import Path

from .common import EXIT_OK, UsageError, load_spec, output_dir, with_config_context

__all__ = ["command"]


@with_config_context
def command(args, cfg: Path) -> int:
    from ..analysis.report import drive_report
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
    spec = load_spec(cfg, args.t_end)
    out_dir = output_dir(args, cfg, "_report", results=("report.html",))
    drive = build_drive(spec)
    _check_torques(drive, torques)  # an unknown pulley is named before the duty runs, not after
    duty = None
    if rpm is not None:
        from ..analysis.duty import duty_study

        duty = duty_study(drive, rpm, powers=powers)
    page = drive_report(drive, torques=torques, length_cases=cases, duty=duty, title=f"{cfg.stem}")
    out_dir.mkdir(parents=True, exist_ok=True)
    with atomic_write(out_dir / "report.html", "w", inputs=[cfg]) as fh:
        fh.write(page)
    print(f"{cfg.stem}: report written to {out_dir / 'report.html'}")
    return EXIT_OK
