"""Duty-point study: one steady run per engine speed (all speeds one batched, sharded sweep) and a
supplier-style table per speed: span tensions (total and effective), hub loads, slip safety factor per
pulley and tensioner positions.

Each duty point sets the driver's final speed (``pulleys.<driver>.speed``) and each accessory's final
load (``pulleys.<name>.load`` [N m]); a power [kW] becomes the torque ``P / omega`` at the accessory's
speed ``omega_driver R_driver / R`` (creep, a few percent, neglected). The figures are means over the
final ``window`` of each run (see ``sweep``); the slip safety factor of a pulley is
``mu_eff wrap / ln(T1e / T2e)`` with the mean effective tensions ``T - m' v^2`` of its two spans, as in
the run summary (``outputs.fead``).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._drive import Drive
from .._errors import ConfigError
from .sweep import sweep

__all__ = ["DutyResult", "duty_study"]


@dataclasses.dataclass
class DutyResult:
    rpm: np.ndarray  # (S,) driver speeds
    loads: dict  # pulley -> (S,) load torques [N m] applied
    spans: dict  # span -> {"tension": (S,), "tension_eff": (S,)} [N]
    pulleys: dict  # pulley -> {"hub_load": (S,) [N], "slip_safety": (S,), "speed": (S,) [rad/s]}
    tensioners: dict  # tensioner -> (S,) arm angle [deg] or travel [mm]
    faults: np.ndarray  # (S,) 0 ok
    timing: dict

    def rows(self) -> tuple[list[str], np.ndarray]:
        """Header and one row per speed (for ``duty.csv``)."""
        cols = {"rpm": self.rpm}
        cols.update({f"load:{n}": v for n, v in self.loads.items()})
        for s, d in self.spans.items():
            cols[f"tension:{s}"], cols[f"tension_eff:{s}"] = d["tension"], d["tension_eff"]
        for p, d in self.pulleys.items():
            cols[f"hub_load:{p}"], cols[f"slip_safety:{p}"] = d["hub_load"], d["slip_safety"]
        cols.update({f"position:{n}": v for n, v in self.tensioners.items()})
        cols["fault"] = self.faults
        return list(cols), np.column_stack(list(cols.values()))


def _driver(drive: Drive) -> int:
    drivers = [i for i, p in enumerate(drive.pulleys) if p.role == "driver" and drive.model.kinematic[i]]
    if len(drivers) != 1:
        raise ConfigError("duty study: needs exactly one driver with a prescribed speed ('speed' or 'speed_rpm')")
    return drivers[0]


def _load_columns(drive: Drive, rpm: np.ndarray, torques: dict, powers: dict) -> dict:
    names = list(drive.model.pulley_names)
    radius = np.asarray(drive.params.pulleys.radius)
    d = _driver(drive)
    omega = rpm * 2 * math.pi / 60
    loads = {}
    for kind, table in (("torque", torques), ("power", powers)):
        for name, values in table.items():
            if name not in names:
                from .._errors import did_you_mean

                raise ConfigError(f"duty study: {kind} of {name!r}: no such pulley{did_you_mean(name, names)}")
            i = names.index(name)
            if i == d or drive.pulleys[i].role not in ("driven",):
                raise ConfigError(
                    f"duty study: {kind} of {name!r}: only driven pulleys take a load (it is a {drive.pulleys[i].role})"
                )
            v = np.asarray(values, dtype=float).ravel()
            if v.shape != rpm.shape or not np.all(np.isfinite(v)) or np.any(v < 0):
                raise ConfigError(
                    f"duty study: {kind} of {name!r} = {v.tolist()}: need one finite value >= 0 per "
                    f"speed ({rpm.size} speeds)"
                )
            if name in loads:
                raise ConfigError(f"duty study: {name!r} has both a torque and a power; give one")
            w = omega * radius[d] / radius[i]  # accessory speed without creep
            loads[name] = v if kind == "torque" else v * 1e3 / w
    return loads


def duty_study(
    drive: Drive,
    rpm,
    *,
    torques: dict | None = None,
    powers: dict | None = None,
    t_end: float | None = None,
    window: float = 0.2,
    progress=False,
    chunk_size: int | None = None,
) -> DutyResult:
    """Steady operation at each driver speed ``rpm`` (S,) with accessory ``torques`` [N m] or ``powers`` [kW]
    per speed (pulley -> (S,)); pulleys not named keep their configured loads."""
    rpm = np.asarray(rpm, dtype=float).ravel()
    if rpm.size == 0 or not np.all(np.isfinite(rpm)) or np.any(rpm <= 0):
        raise ConfigError(
            f"duty study: speeds = {rpm.tolist()}: need at least one, and every speed > 0 and finite [rpm]"
        )
    d = _driver(drive)
    names = list(drive.model.pulley_names)
    loads = _load_columns(drive, rpm, dict(torques or {}), dict(powers or {}))
    points = {f"pulleys.{names[d]}.speed": rpm * 2 * math.pi / 60}
    points.update({f"pulleys.{n}.load": v for n, v in loads.items()})
    res = sweep(drive, points=points, t_end=t_end, window=window, progress=progress, chunk_size=chunk_size)
    return _tabulate(drive, rpm, loads, res)


def _tabulate(drive: Drive, rpm, loads, res) -> DutyResult:
    from ..outputs.fead import mu_effective
    from ..outputs.signals import span_names

    fig = res.figures
    names = list(drive.model.pulley_names)
    k = len(names)
    m = float(drive.params.belt.mass_per_length)
    d = _driver(drive)
    v = rpm * 2 * math.pi / 60 * float(drive.params.pulleys.radius[d])  # belt speed
    spans = {}
    for a, b in span_names(drive):
        T = fig[f"tension:{a}-{b}:mean"]
        spans[f"{a}-{b}"] = dict(tension=T, tension_eff=T - m * v**2)
    span_list = list(spans)
    mu = np.asarray(mu_effective(drive.model, drive.params))
    wrap = np.asarray(drive.path.wrap_angle)
    pulleys = {}
    for i, name in enumerate(names):
        t1, t2 = spans[span_list[(i - 1) % k]]["tension_eff"], spans[span_list[i]]["tension_eff"]
        with np.errstate(divide="ignore", invalid="ignore"):
            log = np.abs(np.log(np.maximum(t1, 1e-9) / np.maximum(t2, 1e-9)))
            safety = np.where(log > 1e-12, mu[i] * wrap[i] / log, np.inf)
        pulleys[name] = dict(
            hub_load=fig.get(f"hub_load:{name}:mean", np.full(rpm.shape, np.nan)),
            slip_safety=safety,
            speed=fig[f"omega:{name}:mean"],
        )
    tensioners = {}
    for i, c in enumerate(drive.model.carriers):
        if c.movable:
            x = fig[f"{c.coordinate}:{names[i]}:mean"]
            tensioners[names[i]] = np.degrees(x) if c.coordinate == "arm_angle" else 1e3 * x
    return DutyResult(
        rpm=rpm,
        loads=loads,
        spans=spans,
        pulleys=pulleys,
        tensioners=tensioners,
        faults=fig["fault"],
        timing=res.timing,
    )
