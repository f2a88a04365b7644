"""``jaxbelt runup``: the crank ramped through a speed range with its engine orders; amplitudes and order
content of the tensioner and span signals against rpm, resonance crossings; runup.csv, runup.json, orders.png."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

from .common import EXIT_FAILED, EXIT_OK, UsageError, fmt, load_spec, output_dir, with_config_context

__all__ = ["command"]


def _rpm_range(text: str) -> tuple[float, float]:
    lo, sep, hi = (text or "").partition(":")
    try:
        a, b = float(lo), float(hi)
    except ValueError:
        a = b = math.nan
    if not sep or not (math.isfinite(a) and math.isfinite(b) and a > 0 and b > 0 and a != b):
        raise UsageError(f"--rpm {text}: expected START:END, two different speeds > 0 [rpm], e.g. 800:3000")
    return a, b


def _orders(text: str) -> tuple[float, ...]:
    try:
        out = tuple(float(x) for x in text.split(",") if x.strip())
    except ValueError:
        out = ()
    if not out or not all(math.isfinite(k) and k > 0 for k in out):
        raise UsageError(f"--orders {text}: expected comma-separated engine orders > 0, e.g. 1,2,4")
    return out


def _shown(name: str) -> tuple[str, float]:
    """The unit a signal's amplitudes are written in and the factor from the signal's own: arm angles in
    degrees (an engineer reads a tensioner arm's swing in degrees), the others as the signal registry's."""
    from ..outputs.signals import quantity_of

    unit = quantity_of(name).unit
    return ("deg", 180.0 / math.pi) if unit == "rad" else (unit, 1.0)


@with_config_context
def command(args, cfg: Path) -> int:
    from ..analysis.runup import run_up
    from ..io import atomic_write, csv_number, to_jsonable
    from ..viz import plot_run_up

    rpm_start, rpm_end = _rpm_range(args.rpm)
    orders = _orders(args.orders)
    spec = load_spec(cfg, None, args.scheme)
    out_dir = output_dir(args, cfg, "_runup", results=("runup.csv", "runup.json", "orders.png"))
    res = run_up(
        spec,
        rpm_start,
        rpm_end,
        args.duration,
        signals=args.signal,
        orders=orders,
        revolutions=args.revolutions,
        lead_time=args.lead_time,
        modes=not args.no_modes,
        model=args.model,
    )
    out_dir.mkdir(parents=True, exist_ok=True)
    names = list(res.amplitude)
    scale = {n: _shown(n)[1] for n in names}  # arm angles in degrees, the rest in the signals' units
    deg = {n: "_deg" if _shown(n)[0] == "deg" else "" for n in names}
    with atomic_write(out_dir / "runup.csv", "w", inputs=[cfg]) as fh:
        w = csv.writer(fh)
        w.writerow(
            ["rpm"]
            + [f"amplitude{deg[n]}:{n}" for n in names]
            + [f"order{k:g}{deg[n]}:{n}" for n in names for k in orders]
        )
        for j, rpm in enumerate(res.rpm):
            w.writerow(
                [csv_number(rpm)]
                + [csv_number(scale[n] * res.amplitude[n][j]) for n in names]
                + [csv_number(scale[n] * res.orders[n][k][j]) for n in names for k in orders]
            )
    status = res.result.summary["status"]
    with atomic_write(out_dir / "runup.json", "w", inputs=[cfg]) as fh:
        json.dump(to_jsonable({"status": status, "crossings": res.crossings, "orders": orders}), fh, indent=1)
    if not args.no_plots:
        plot_run_up(res, path=out_dir / "orders.png")
    else:  # an earlier run's order plot would not match this runup.csv
        from .run import remove_stale

        remove_stale(out_dir, ["orders.png"], [])
    if not args.quiet:
        print(f"{cfg.stem}: run-up {rpm_start:g} -> {rpm_end:g} rpm in {args.duration:g} s, {len(res.rpm)} windows")
        for c in res.crossings:
            where = f", span {c['span']} running at" if c.get("span") else ","
            print(
                f"  mode {c['mode']} ({c['kind']}{where} {fmt(c['frequency_hz'], '.2f')} Hz) crossed by order "
                f"{c['order']:g} at {fmt(c['rpm'], '.0f')} rpm"
            )
        for n in names:
            j = int(max(range(len(res.rpm)), key=lambda i: res.amplitude[n][i])) if len(res.rpm) else 0
            if len(res.rpm):
                unit, k = _shown(n)
                print(
                    f"  {n}: largest half peak-to-peak {fmt(k * res.amplitude[n][j])} {unit} at "
                    f"{fmt(res.rpm[j], '.0f')} rpm"
                )
    print(f"{cfg.stem}: run-up written to {out_dir / 'runup.csv'} (status {status})")
    return EXIT_OK if status == "ok" else EXIT_FAILED
