"""Duty-point study: one steady run per engine speed (all speeds one batched, sharded sweep) and a
supplier-style table per speed: span tensions (total and effective), hub loads, slip safety factor per
pulley and tensioner positions.

A duty point is steady operation, never a start-up: every point starts **running** at its speed
(``solver.start = "running"``: the settle phase brings belt and pulleys to the driver's speed, see
``RunningStart``), with the driver at a constant speed (its engine orders kept) and every accessory load
ramped in from zero over ``load_ramp`` seconds after t = 0 (a smooth step), so no accessory is
accelerated from standstill at full load through the belt. Each point sets the driver's speed
(``pulleys.<driver>.speed``) and each accessory's final load (``pulleys.<name>.load`` [N m]); a power [kW]
becomes the torque ``P / omega`` at the accessory's speed ``omega_driver R_driver / R`` (creep, a few percent,
neglected). The figures are means over the final ``window`` of each run (see ``sweep``); the slip safety
factor of a pulley is ``mu_eff wrap / ln(T1e / T2e)`` with the mean effective tensions ``T - m' v^2`` of its
two spans, as in the run summary (``outputs.fead``). Each point's window is checked as a run's summary
window is (``outputs.steadiness``: laws done, no drift, no gross slip): ``steady``, ``status`` per point;
its signals are kept (``sweep_signals.npz`` in ``out_dir``).
"""

from __future__ import annotations

import copy
import dataclasses
import math
import tempfile
from pathlib import Path

import numpy as np

from .._drive import Drive
from .._errors import ConfigError
from .sweep import point_status, sweep

__all__ = ["DutyResult", "duty_study"]


@dataclasses.dataclass
class DutyResult:
    rpm: np.ndarray  # (S,) driver speeds
    loads: dict  # pulley -> (S,) load torques [N m] applied
    spans: dict  # span -> {"tension": (S,), "tension_eff": (S,)} [N], "speed": (S,) its mean belt speed [m/s]
    # pulley -> {"hub_load": (S,) [N], "slip_safety": (S,), "speed": (S,) [rad/s], "torque": (S,) [N m] (the belt's on
    # it, ccw +), "load_speed": (S,) [rad/s] (where its load acts: a clutch pulley's rotor, else "speed")}
    pulleys: dict
    tensioners: dict  # tensioner -> (S,) arm angle [deg] or travel [mm]
    faults: np.ndarray  # (S,) 0 ok
    timing: dict
    steady: np.ndarray | None = None  # (S,) the window is a steady state with no pulley in gross slip
    status: list | None = None  # (S,) "ok", "diverged ...", "gross slip: ...", "not steady: ..." per point
    signals_file: Path | None = None  # each point's signals (sweep_signals.npz), if kept in an out_dir
    window_start: np.ndarray | None = None  # (S,) each point's window start [s] (whole engine periods to the end)
    warnings: list | None = None  # (S,) per point the warnings its run would print (intermittent gross slip)

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
        if self.steady is not None:
            cols["steady"] = self.steady.astype(float)
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
            # a pulley configured with a `torque` law is an active torque (a starter-generator, a motor): a
            # negative load drives the belt; a brake (`load`, `power_kw`) only absorbs
            active = next(p for p in drive.spec.pulleys if p.name == name).torque is not None
            if v.shape != rpm.shape or not np.all(np.isfinite(v)) or (not active and np.any(v < 0)):
                what = "finite value" if active else "finite value >= 0"
                raise ConfigError(
                    f"duty study: {kind} of {name!r} = {v.tolist()}: need one {what} per speed ({rpm.size} speeds)"
                    + ("" if active else "; a negative (driving) value needs a pulley configured with a torque law")
                )
            if name in loads:
                raise ConfigError(f"duty study: {name!r} has both a torque and a power; give one")
            w = omega * radius[d] / radius[i]  # accessory speed without creep
            loads[name] = v if kind == "torque" else v * 1e3 / w
    return loads


def _configured_powers(drive: Drive, rpm: np.ndarray, torques) -> dict:
    """The configuration's ``power_kw`` loads (final values) of pulleys the study does not load otherwise: a power
    stays a power at every duty speed (its torque P / omega there, a ``load:`` column of the table), as a file
    edit of the driver's speed would build it; kept at the configured torque, 0.8 kW at 800 rpm would be 2.5 kW
    at 2,500."""
    from ..config.laws import _law_values, is_angle_law

    out = {}
    for p in drive.spec.pulleys if drive.spec is not None else []:
        if p.power_kw is not None and not is_angle_law(p.power_kw) and p.name not in (torques or {}):
            out[p.name] = np.full(rpm.shape, float(_law_values(p.power_kw)[-1]))
    return out


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
    load_ramp: float | None = None,
    out_dir=None,
    resume: bool = False,
    inputs=(),
    model: str | None = None,
) -> DutyResult:
    """Steady operation at each driver speed ``rpm`` (S,) with accessory ``torques`` [N m] or ``powers`` [kW]
    per speed (pulley -> (S,)); pulleys not named keep their configured (final) loads: a ``power_kw`` its power
    (the torque P / omega at each speed), a ``load`` or ``torque`` its torque. Every point starts
    running at its speed and ramps its loads in over ``load_ramp`` s (default: 0.1 s, at most a quarter of
    the run). ``out_dir``: the points' sweep files (``sweep.csv``, ``sweep_signals.npz``; resumable with
    ``resume``) go there; else into a temporary folder. ``model``: "ancf" or "spans" (the spans tier,
    docs/spans.md; the same table and checks); None: the drive's ``solver.model``.

    Parameters: besides the drive and the speeds, its eleven keyword options are the user's choices for one
    study (loads, run length, progress, chunking, load ramp, files, tier), each with a default and passed by
    name (``jaxbelt duty`` passes most of them from its options); a record of them would only rename them."""
    rpm = np.asarray(rpm, dtype=float).ravel()
    if rpm.size == 0 or not np.all(np.isfinite(rpm)) or np.any(rpm <= 0):
        raise ConfigError(
            f"duty study: speeds = {rpm.tolist()}: need at least one, and every speed > 0 and finite [rpm]"
        )
    d = _driver(drive)
    names = list(drive.model.pulley_names)
    loads = _load_columns(drive, rpm, dict(torques or {}), _configured_powers(drive, rpm, torques) | dict(powers or {}))
    run_end = float(drive.options.t_end if t_end is None else t_end)
    ramp = min(0.1, 0.25 * run_end) if load_ramp is None else float(load_ramp)
    if not (math.isfinite(ramp) and 0 <= ramp < (1 - window) * run_end):
        raise ConfigError(
            f"duty study: load_ramp = {load_ramp!r}: must be >= 0 s and end before the summary window "
            f"({(1 - window) * run_end:.3g} s)"
        )
    running = _running_drive(drive, ramp)
    points = {f"pulleys.{names[d]}.speed": rpm * 2 * math.pi / 60}
    points.update({f"pulleys.{n}.load": v for n, v in loads.items()})
    with tempfile.TemporaryDirectory(prefix="jaxbelt-duty-") as tmp:
        where = Path(tmp) if out_dir is None else Path(out_dir)
        res = sweep(
            running,
            points=points,
            t_end=t_end,
            window=window,
            progress=progress,
            chunk_size=chunk_size,
            out_dir=where,
            resume=resume,
            inputs=inputs,
            model=model,
        )
        said: list = []
        steady, status = point_status(running, res, where / "sweep_signals.npz", window, warnings=said)
    out = _tabulate(running, rpm, loads, res)
    return dataclasses.replace(
        out,
        steady=steady,
        status=status,
        warnings=said,
        signals_file=None if out_dir is None else where / "sweep_signals.npz",
        window_start=np.asarray(res.figures["window_start_s"]) if "window_start_s" in res.figures else None,
    )


def _running_drive(drive: Drive, ramp: float) -> Drive:
    """The drive as a duty point runs it: started running (``solver.start = "running"``), the driver at the
    constant final speed of its law, every other pulley's load, power or torque a smooth step from 0 at t = 0
    to its final value over ``ramp`` s (a torque law's switch in time, e.g. a starter-generator turning motor,
    is not a duty point: left in, the point's load would scale the whole law, its earlier part too)."""
    from ..config import build_drive
    from ..config.laws import _law_values, is_angle_law

    spec = copy.deepcopy(drive.spec)
    for p in spec.pulleys:
        keys = ("speed", "speed_rpm") if p.role == "driver" else ("load", "power_kw", "torque")
        for key in keys:
            law = getattr(p, key)
            if law is None or is_angle_law(law):
                continue
            final = float(_law_values(law)[-1])
            if p.role == "driver":
                setattr(p, key, final)
            elif ramp > 0 and final != 0:
                setattr(p, key, {"smooth_step": [0.0, ramp, 0.0, final]})
            else:
                setattr(p, key, final)
    spec.solver.start = "running"
    spec.solver.expect_steady = True
    return build_drive(spec)


def _tabulate(drive: Drive, rpm, loads, res) -> DutyResult:
    from ..outputs.fead import mu_effective
    from ..outputs.signals import span_names
    from ..outputs.theory import effective_tension

    fig = res.figures
    names = list(drive.model.pulley_names)
    k = len(names)
    m, EA = float(drive.params.belt.mass_per_length), float(drive.params.belt.EA)
    d = _driver(drive)
    nominal = rpm * 2 * math.pi / 60 * float(drive.params.pulleys.radius[d])  # belt speed at the crank
    spans = {}
    for a, b in span_names(drive):
        T = fig[f"tension:{a}-{b}:mean"]
        # each span's own mean belt speed (creep and slip part them from the crank's: -0.6 % of T_eff measured)
        v = np.abs(fig.get(f"speed:{a}-{b}:mean", nominal))
        spans[f"{a}-{b}"] = dict(tension=T, tension_eff=effective_tension(T, v, m, EA), speed=v)  # m' per current
    span_list = list(spans)
    mu = np.asarray(mu_effective(drive.model, drive.params))
    wrap = np.asarray(drive.path.wrap_angle)
    pulleys = {}
    for i, name in enumerate(names):
        t1, t2 = spans[span_list[(i - 1) % k]]["tension_eff"], spans[span_list[i]]["tension_eff"]
        with np.errstate(divide="ignore", invalid="ignore"):
            log = np.abs(np.log(np.maximum(t1, 1e-9) / np.maximum(t2, 1e-9)))
            safety = np.where(log > 1e-12, mu[i] * wrap[i] / log, np.inf)
        missing = np.full(rpm.shape, np.nan)
        pulleys[name] = dict(
            # the mean hub-load vector's magnitude, as the run summary's hub_load_mean
            hub_load=fig.get(f"hub_load:{name}:vector_mean", fig.get(f"hub_load:{name}:mean", missing)),
            slip_safety=safety,
            speed=fig[f"omega:{name}:mean"],
            torque=fig[f"torque:{name}:mean"],  # the belt's on the pulley, counter-clockwise positive
            # where the load acts: a one-way clutch pulley's rotor, else the pulley itself
            load_speed=fig.get(f"rotor_omega:{name}:mean", fig[f"omega:{name}:mean"]),
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
