"""``jaxbelt statics``: installation statics without a dynamic run; prints a table, writes statics.json."""

from __future__ import annotations

import math
from pathlib import Path

from .common import EXIT_FAILED, EXIT_OK, UsageError, fmt, load_spec, output_dir, with_config_context

__all__ = ["command"]


def _parse_torques(items: list[str]) -> dict:
    torques = {}
    for text in items:
        name, sep, value = text.partition("=")
        try:
            q = float(value)
        except ValueError:
            q = math.nan
        if not sep or not name.strip() or not math.isfinite(q):
            raise UsageError(f"--torque {text}: expected PULLEY=Q with Q a finite number [N m], e.g. alternator=4.5")
        if name.strip() in torques:
            raise UsageError(f"--torque {text}: '{name.strip()}' is given twice; give each pulley once")
        torques[name.strip()] = q
    return torques


def _cases(args) -> dict:
    cases = {"nominal": 0.0}
    if args.length_tolerance > 0:
        cases.update(shortest=-args.length_tolerance / 1000, longest=args.length_tolerance / 1000)
    if args.wear > 0:
        cases["worn"] = (args.length_tolerance + args.wear) / 1000  # the longest belt, stretched by wear
    return cases


@with_config_context
def command(args, cfg: Path) -> int:
    from ..analysis.statics import statics_table
    from ..config.build import build_drive
    from ..io import atomic_write, to_jsonable

    torques = _parse_torques(args.torque)
    spec = load_spec(cfg, args.t_end, args.scheme)
    out_dir = output_dir(args, cfg, "_statics", results=("statics.json",))
    drive = build_drive(spec)
    table = statics_table(drive, torques, _cases(args))
    out_dir.mkdir(parents=True, exist_ok=True)
    import json

    with atomic_write(out_dir / "statics.json", "w", inputs=[cfg]) as fh:
        json.dump(to_jsonable({k: v.as_dict() for k, v in table.items()}), fh, indent=1)
    if getattr(args, "model", "ancf") == "spans" and not args.quiet:  # one model serves both tiers
        print(f"{cfg.stem}: the spans tier's equilibrium at rest is this statics (its installed state solves it)")
    if not args.quiet:
        _print_table(cfg.stem, table)
    slipping = {case: sorted(st.gross_slip) for case, st in table.items() if st.gross_slip}
    print(f"{cfg.stem}: statics of {len(table)} case(s) written to {out_dir / 'statics.json'}")
    if slipping:  # no equilibrium the belt can hold: its tensions are not the drive's (exit 1, as a run's)
        cases = "; ".join(f"{case} belt: {', '.join(names)}" for case, names in slipping.items())
        print(f"{cfg.stem}: gross slip ({cases}): the torques exceed what friction can carry there")
        return EXIT_FAILED
    return EXIT_OK


def _print_table(stem: str, table: dict) -> None:
    nominal = table["nominal"]
    print(f"{stem}: installation statics (belt as a string on rigid pulleys; tensions total = effective at rest)")
    print(f"  {'pulley':<14}{'wrap':>8}{'torque':>9}{'T in':>9}{'T out':>9}{'hub load':>10}{'dir':>8}{'slip SF':>9}")
    for name, p in nominal.pulleys.items():
        print(
            f"  {name:<14}{fmt(p['wrap_deg'], '.1f'):>8}{fmt(p['torque'], '.3g'):>9}{fmt(p['tension_in'], '.1f'):>9}"
            f"{fmt(p['tension_out'], '.1f'):>9}{fmt(p['hub_load'], '.1f'):>10}{fmt(p['hub_load_deg'], '.1f'):>8}"
            f"{fmt(p['slip_safety'], '.3g') if math.isfinite(p['slip_safety']) else '-':>9}"
        )
    print(
        "  (wrap, hub-load direction in degrees; torque absorbed [N m], the driver's supplied; tensions [N]; "
        "slip SF: mu_eff wrap / ln(T_tight / T_slack), - where no torque)"
    )
    movable = [(n, k) for n, p in nominal.pulleys.items() for k in ("arm_angle", "travel") if k in p]
    for label, st in table.items():
        belt = st.belt
        parts = [
            f"{label:<9} L0 {belt['stress_free_length'] * 1000:.1f} mm",
            f"T {belt['min_tension']:.1f}..{belt['max_tension']:.1f} N",
        ]
        for n, k in movable:
            v = st.pulleys[n][k]
            parts.append(f"{n} {math.degrees(v):.2f} deg" if k == "arm_angle" else f"{n} {v * 1000:.2f} mm")
        print("  " + ", ".join(parts))
