"""The accessory-drive (FEAD) table of a run: per pulley slip, slip safety factor, hub load and arm
motion; per span total and effective tension, dynamic amplitude and mid-span deflection.

Reads only the summary dict (``summary.json`` of a finished run or ``RunResult.summary``), so that a
stored run prints the same table: ``print_fead_table(summary)``.
"""

from __future__ import annotations

import math
import sys
from typing import TextIO

from .common import fmt

__all__ = ["print_fead_table", "fead_table_lines"]


def _sf(x) -> str:
    """A safety factor: "inf" for a pulley that transmits nothing (idlers), else 2 decimals."""
    if x is None or (isinstance(x, float) and math.isinf(x)):
        return f"{'inf':>6}"
    return f"{fmt(x, '6.2f')}" if x < 100 else f"{'>100':>6}"


def fead_table_lines(summary: dict) -> list[str]:
    """The table as lines (empty when the summary has no accessory-drive outputs)."""
    pulleys = summary.get("pulleys", {})
    if not pulleys or "slip_safety_factor" not in next(iter(pulleys.values())):
        return []
    gross = list((summary.get("steadiness") or {}).get("gross_slip") or [])
    w = summary.get("window_s", [math.nan, math.nan])
    width = max([len(n) for n in pulleys] + [6])
    lines = [
        f"accessory-drive table (over t = {fmt(w[0])} .. {fmt(w[1])} s; slip safety factor from the effective "
        "tensions T - m'v^2; hub load: force of the belt on the pulley, direction ccw from +x)",
        f"  {'pulley':<{width}}  {'slip mean/peak [%]':>18}  {'SF mean/min':>13}  {'hub load mean/peak [N]':>22}"
        f"  {'dir [deg]':>9}  {'arm [deg] / slider [mm] mean/p-p':>32}",
    ]
    for name, p in pulleys.items():
        arm = (
            f"{fmt(p['arm_angle_mean_deg'], '8.2f')} /{fmt(p['arm_angle_p2p_deg'], '7.3f')} deg"
            if "arm_angle_mean_deg" in p
            else f"{fmt(p['travel_mean_mm'], '8.2f')} /{fmt(p['travel_p2p_mm'], '7.3f')} mm"
            if "travel_mean_mm" in p
            else ""
        )
        lines.append(
            f"  {name:<{width}}  {fmt(p['slip_mean_pct'], '8.3f')} /{fmt(p['slip_peak_pct'], '7.2f')}  "
            f"{_sf(p['slip_safety_factor'])}{'*' if name in gross else ' '}/{_sf(p['slip_safety_factor_min'])}  "
            f"{fmt(p['hub_load_mean'], '11.1f')} /{fmt(p['hub_load_peak'], '8.1f')}  "
            f"{fmt(p['hub_load_direction_deg'], '9.1f')}  {arm:>32}"
        )
    if gross:
        lines.append(
            f"  * in gross slip ({', '.join(gross)}): the belt slides over the whole wrap, its tensions at the capstan "
            "limit, so the safety factor reads about 1 (the status says so)"
        )
    spans = summary.get("spans", [])
    width = max([len(sp["name"]) for sp in spans] + [4])
    lines.append(
        f"  {'span':<{width}}  {'T [N]':>8}  {'T-mv^2 [N]':>10}  {'amp p-p/2 [N]':>13}  {'rms [N]':>8}"
        f"  {'v [m/s]':>8}  {'deflection mean/amp [mm]':>24}"
    )
    for sp in spans:
        lines.append(
            f"  {sp['name']:<{width}}  {fmt(sp['tension_mean'], '8.1f')}  {fmt(sp['tension_eff_mean'], '10.1f')}  "
            f"{fmt(sp['tension_amplitude'], '13.2f')}  {fmt(sp['tension_rms'], '8.2f')}  "
            f"{fmt(sp['speed_mean'], '8.3f')}  {fmt(sp.get('deflection_mean_mm'), '12.3f')} /"
            f"{fmt(sp.get('deflection_amplitude_mm'), '10.3f')}"
        )
    return lines


def print_fead_table(summary: dict, file: TextIO | None = None) -> None:
    """Print the accessory-drive table of a run summary (nothing when it has none)."""
    out = sys.stdout if file is None else file
    for line in fead_table_lines(summary):
        print(line, file=out)
