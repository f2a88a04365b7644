"""``jaxbelt duty``: steady runs at several engine speeds (one batched sweep); duty.csv, duty.png, a table."""

from __future__ import annotations

import math
import sys
from pathlib import Path

from .common import EXIT_FAILED, EXIT_OK, UsageError, load_spec, output_dir, with_config_context

__all__ = ["command"]


_EXAMPLES = {"--rpm": "800,1500,3000", "--torque": "alternator=4,6,8", "--power": "alternator=0.8,1.2,1.5"}


def _numbers(option: str, text: str, shown: str | None = None) -> list[float]:
    """Comma-separated finite numbers; ``shown``: the option's whole argument, for the message."""
    try:
        values = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        values = []
    if not values or not all(math.isfinite(v) for v in values):
        example = _EXAMPLES.get(option, "1,2,3")
        raise UsageError(f"{option} {shown or text}: expected comma-separated finite numbers, e.g. {example}")
    return values


def _per_pulley(option: str, items: list[str]) -> dict:
    out = {}
    for text in items:
        name, sep, values = text.partition("=")
        if not sep or not name.strip():
            raise UsageError(f"{option} {text}: expected PULLEY=V1,V2,... (one value per speed)")
        if name.strip() in out:
            raise UsageError(f"{option} {text}: '{name.strip()}' is given twice; give each pulley once")
        out[name.strip()] = _numbers(option, values, shown=text)
    return out


@with_config_context
def command(args, cfg: Path) -> int:
    import json

    import numpy as np

    from ..analysis.duty import duty_study
    from ..config.build import build_drive
    from ..io import atomic_write, csv_number

    rpm = _numbers("--rpm", args.rpm or "")
    torques, powers = _per_pulley("--torque", args.torque), _per_pulley("--power", args.power)  # before building
    spec = load_spec(cfg, args.t_end, args.scheme)
    out_dir = output_dir(args, cfg, "_duty", results=("duty.csv", "duty.png", "duty_points.json"))
    drive = build_drive(spec)
    say = None if args.quiet else (lambda msg: print(f"{cfg.stem}: {msg}", flush=True))
    res = duty_study(
        drive,
        rpm,
        torques=torques,
        powers=powers,
        window=args.window,
        progress=say,
        load_ramp=getattr(args, "load_ramp", None),
        out_dir=out_dir / "points",
        resume=bool(getattr(args, "resume", False)),
        inputs=[cfg],
        model=getattr(args, "model", "ancf"),
    )
    header, rows = res.rows()
    out_dir.mkdir(parents=True, exist_ok=True)
    with atomic_write(out_dir / "duty.csv", "w", inputs=[cfg]) as fh:
        fh.write(",".join(header) + "\n" + "".join(",".join(csv_number(x) for x in r) + "\n" for r in rows))
    status = res.status or ["ok"] * len(res.rpm)
    said = res.warnings or [[] for _ in res.rpm]
    with atomic_write(out_dir / "duty_points.json", "w", inputs=[cfg]) as fh:
        points = [
            {"rpm": float(r), "steady": s == "ok", "status": s, "warnings": list(w)}
            for r, s, w in zip(res.rpm, status, said)
        ]
        json.dump(points, fh, indent=1)
    from ..viz import plot_duty

    plot_duty(res, out_dir / "duty.png")
    _print_table(cfg.stem, res)
    diverged = int(np.sum(res.faults != 0))
    tier = _TIER[res.timing.get("model", "ancf")]
    flagged = [(r, s) for r, s in zip(res.rpm, status) if s != "ok" and not s.startswith("diverged")]
    for r, s in flagged:
        print(f"jaxbelt duty: {r:g} rpm: {s}", file=sys.stderr)
    for r, w in zip(res.rpm, said):  # as the point's own run would warn (its mean slip safety factor hides it)
        for line in w:
            print(f"jaxbelt duty: warning: {r:g} rpm: {line}", file=sys.stderr)
    print(
        f"{cfg.stem}: {len(rpm)} duty points ({tier}); {diverged} diverged, {len(flagged)} not steady or slipping "
        "grossly; "
        f"duty.csv, duty_points.json and duty.png in {out_dir}, each point's signals in {out_dir / 'points'}"
    )
    return EXIT_OK if diverged == 0 and not flagged else EXIT_FAILED


_TIER = {"ancf": "ANCF belt", "spans": "spans tier"}


def _sf(x: float) -> str:
    """A slip safety factor for the table (as the run's accessory-drive table: an unloaded pulley is >100)."""
    return "-" if not math.isfinite(x) else (">100" if x > 100 else f"{x:.2f}")


def _print_table(stem: str, res) -> None:
    names = list(res.pulleys)
    print(f"{stem}: slip safety factor (mu_eff wrap / ln(T1e/T2e); > 1: no gross slip) and hub load [N] per speed")
    print("  " + f"{'rpm':>8}" + "".join(f"{n[:12]:>14}" for n in names) + "  steady")
    status = res.status or ["ok"] * len(res.rpm)
    for j, r in enumerate(res.rpm):
        sf = [res.pulleys[n]["slip_safety"][j] for n in names]
        hub = [res.pulleys[n]["hub_load"][j] for n in names]
        cells = "".join(f" {_sf(s) + f' / {h:.0f}':>13}" for s, h in zip(sf, hub))
        mark = "yes" if status[j] == "ok" else status[j].split(":")[0]
        print("  " + f"{r:>8.0f}" + cells + f"  {mark}")
    for s, d in res.spans.items():
        print(
            f"  span {s}: T "
            + ", ".join(f"{t:.1f}" for t in d["tension"])
            + " N (effective "
            + ", ".join(f"{t:.1f}" for t in d["tension_eff"])
            + " N)"
        )
    for n, x in res.tensioners.items():
        print(f"  tensioner {n}: " + ", ".join(f"{v:.2f}" for v in x))
