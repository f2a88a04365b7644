"""``jaxbelt modes``: linearised natural frequencies about the installed state, with their parameter
sensitivities, or (``--running``) about steady running; prints a table, writes modes.json."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from .common import EXIT_FAILED, EXIT_OK, UsageError, fmt, load_spec, one_line, output_dir, with_config_context

__all__ = ["command", "default_sensitivity_keys"]


def default_sensitivity_keys(drive) -> list[str]:
    """The parameters an accessory-drive engineer changes: belt stiffness and pretension, every tensioner's
    spring and arm inertia, every pulley's inertia (those the drive has)."""
    from ..analysis.parameters import parameter_keys

    have = set(parameter_keys(drive))
    wanted = ["belt.EA", "belt.pretension"]
    for name in drive.model.pulley_names:
        wanted += [f"pulleys.{name}.tensioner.stiffness", f"pulleys.{name}.tensioner.inertia"]
        wanted += [f"pulleys.{name}.inertia", f"pulleys.{name}.rotor_inertia"]
    return [k for k in wanted if k in have]


@with_config_context
def command(args, cfg: Path) -> int:
    from ..analysis.modes import linear_modes, mode_sensitivities, settled_state
    from ..analysis.running_modes import running_state
    from ..analysis.parameters import get_parameter
    from ..config.build import build_drive
    from ..io import atomic_write, to_jsonable

    if args.count < 1:
        raise UsageError(f"--count {args.count}: must be a whole number >= 1")
    model = getattr(args, "model", "ancf")
    if model == "spans" and (args.running or args.clutch != "auto"):
        raise UsageError(
            "--model spans: its modes are about the installed state with clutches engaged (no --running, --clutch)"
        )
    spec = load_spec(cfg, args.t_end, args.scheme)
    out_dir = output_dir(args, cfg, "_modes", results=("modes.json",))
    drive = build_drive(spec)
    # the defaults only about the installed state: a running linearisation's sensitivities cost a derivative
    # through the run to the running state each, so they are computed when asked for (--sensitivity)
    keys = (
        (default_sensitivity_keys(drive) if not args.running else []) if args.sensitivity is None else args.sensitivity
    )
    values = {k: float(get_parameter(drive, drive.params, k)) for k in keys}  # unknown key: refused before compiling
    if model == "spans":
        return _spans(args, cfg, drive, values, out_dir)
    about = "running" if args.running else "installed"
    reached: list[str] = []  # the run to the running state through run's checks: is it steady running?
    state = running_state(drive, status=reached) if args.running else settled_state(drive)
    modes = linear_modes(drive, count=args.count, state=state, about=about, clutch=args.clutch)
    sens = (
        mode_sensitivities(drive, keys, count=args.count, state=state, about=about, clutch=args.clutch) if keys else {}
    )
    table = modes.table()
    for row in table:
        j, f = row["mode"] - 1, row["frequency_hz"]
        row["sensitivity"] = {k: float(v[j]) for k, v in sens.items()}  # Hz per unit of the parameter
        # dimensionless: % change of f per % change of p
        row["relative_sensitivity"] = {k: float(v[j]) * values[k] / f if f > 0 else math.nan for k, v in sens.items()}
    out_dir.mkdir(parents=True, exist_ok=True)
    summary = {"modes": table, "about": modes.about, "belt_speed": modes.belt_speed, "clutches": modes.clutches}
    if args.running:
        summary["status"] = reached[0] if reached else "ok"
    with atomic_write(out_dir / "modes.json", "w", inputs=[cfg]) as fh:
        json.dump(to_jsonable({**summary, "contact_stiffness": modes.contact_stiffness}), fh, indent=1)
    if not args.quiet:
        _print_table(cfg.stem, table, keys, modes)
    print(f"{cfg.stem}: {len(table)} modes written to {out_dir / 'modes.json'}")
    if summary.get("status", "ok") != "ok":  # linearised about a state that is not steady running
        print(
            f"jaxbelt modes: the run to the running state is not steady running, so these modes are not its: "
            f"{one_line(summary['status'])}",
            file=sys.stderr,
        )
        return EXIT_FAILED
    return EXIT_OK


def _spans(args, cfg: Path, drive, values: dict, out_dir: Path) -> int:
    """``modes --model spans``: the spans tier's rotational modes about the installed state (``spans.modes``),
    their damping ratios and exact sensitivities; modes.json says which tier."""
    import numpy as np

    from ..analysis.parameters import set_parameters
    from ..io import atomic_write, to_jsonable
    from ..spans import spans_mode_sensitivities, spans_modes, spans_span_modes

    keys = list(values)
    found = spans_modes(drive, count=args.count)
    sens = np.zeros((len(found), 0))
    if keys:
        at = lambda v: set_parameters(drive, drive.params, [(k, v[i]) for i, k in enumerate(keys)])  # noqa: E731
        _, sens = spans_mode_sensitivities(
            drive, at, np.array([values[k] for k in keys]), count=args.count, key=tuple(keys)
        )
    table = []
    for j, m in enumerate(found):
        row = dict(m, rotational_share=1.0, sensitivity={k: float(sens[j, i]) for i, k in enumerate(keys)})
        f = m["frequency_hz"]
        row["relative_sensitivity"] = {k: float(sens[j, i]) * values[k] / f for i, k in enumerate(keys)}
        table.append(row)
    transverse = [m for m in spans_span_modes(drive) if m["mode"] <= args.count]
    out_dir.mkdir(parents=True, exist_ok=True)
    summary = {"modes": table, "span_modes": transverse, "about": "installed", "model": "spans", "belt_speed": 0.0}
    with atomic_write(out_dir / "modes.json", "w", inputs=[cfg]) as fh:
        json.dump(to_jsonable(summary), fh, indent=1)
    if not args.quiet:
        print(
            f"{cfg.stem}: spans tier, rotational modes about the installed state (wraps stuck, clutches engaged, "
            "belt at rest)"
        )
        print(f"  {'mode':>4}{'f [Hz]':>10}{'damping':>10}")
        for row in table:
            print(f"  {row['mode']:>4}{fmt(row['frequency_hz'], '.2f'):>10}{fmt(row['damping_ratio'], '.4f'):>10}")
        _print_sensitivities(table, keys)
        print("  the spans' first transverse modes at their installed tensions (the span model of span-tension):")
        for row in transverse:
            print(f"  {row['mode']:>4}{fmt(row['frequency_hz'], '.2f'):>10}  {row['span']}")
    print(f"{cfg.stem}: {len(table)} modes written to {out_dir / 'modes.json'}")
    return EXIT_OK


def _print_sensitivities(table: list[dict], keys: list[str]) -> None:
    if keys:
        print("  relative sensitivities (p / f) d f / d p: % change of f per % of p (d f / d p in modes.json)")
        for row in table:
            parts = [f"{k} {fmt(v, '+.3f')}" for k, v in row["relative_sensitivity"].items() if math.isfinite(v)]
            print(f"  mode {row['mode']}: " + ", ".join(parts))


def _print_table(stem: str, table: list[dict], keys: list[str], modes) -> None:
    if modes.about == "running":
        print(
            f"{stem}: linearised modes about steady running (belt at {modes.belt_speed:.3g} m/s, contacts held "
            "stuck; sensitivities at this belt speed and these pulley loads)"
        )
    else:
        print(f"{stem}: linearised modes about the installed state (contacts held stuck, belt at rest)")
    if modes.clutches:  # how each one-way clutch is linearised (engaged: its rotor is in the modes)
        print("  clutches: " + ", ".join(f"{name} {how}" for name, how in modes.clutches.items()))
    print(f"  {'mode':>4}{'f [Hz]':>10}  {'kind':<11}{'span':<26}{'rot. share':>10}")
    for row in table:
        print(
            f"  {row['mode']:>4}{fmt(row['frequency_hz'], '.2f'):>10}  {row['kind']:<11}{row['span'] or '-':<26}"
            f"{fmt(row['rotational_share'], '.2f'):>10}"
        )
    _print_sensitivities(table, keys)
