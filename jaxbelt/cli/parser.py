"""The ``jaxbelt`` argument parser: one sub-parser per command, sharing the config/output options."""

from __future__ import annotations

import argparse
import math

from ..config.validate import MODELS
from .common import EXIT_USAGE

__all__ = ["build_parser"]


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line instead of usage + message
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def _positive_float(text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not (math.isfinite(x) and x > 0):
        raise argparse.ArgumentTypeError(f"{text}: must be a finite number > 0")
    return x


def _positive_int(text: str) -> int:
    try:
        x = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a whole number") from None
    if x < 1:
        raise argparse.ArgumentTypeError(f"{text}: must be a whole number >= 1")
    return x


def _nonnegative_float(text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not (math.isfinite(x) and x >= 0):
        raise argparse.ArgumentTypeError(f"{text}: must be a finite number >= 0")
    return x


def _fraction(text: str) -> float:
    x = _positive_float(text)
    if x > 1:
        raise argparse.ArgumentTypeError(f"{text}: must be a fraction of the run in (0, 1], e.g. 0.2")
    return x


# each command's default output directory is out/<config name><suffix> (cli.common.output_dir)
OUT_SUFFIX = {
    "run": "",
    "sweep": "_sweep",
    "identify": "_identify",
    "statics": "_statics",
    "duty": "_duty",
    "report": "_report",
    "modes": "_modes",
    "runup": "_runup",
    "span-tension": "_span_tension",
}


def _common(command: str) -> argparse.ArgumentParser:
    """The options every command shares, with the command's own default output directory in --help (a
    parent parser shares its actions with its children: one per command)."""
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "--t-end",
        type=_positive_float,
        metavar="T",
        help="simulated time [s] (default: solver.t_end of the configuration)",
    )
    common.add_argument(
        "--scheme",
        choices=("auto", "explicit", "implicit"),
        help="time integration (default: solver.scheme of the configuration, auto if not given): explicit, the "
        "step from the belt's stability limit; implicit, a step chosen for accuracy (solver.max_frequency); auto, "
        "the implicit one where its step is at least 4 x the explicit one",
    )
    common.add_argument(
        "--out", metavar="DIR", help=f"output directory (default: ./out/<config name>{OUT_SUFFIX[command]})"
    )
    common.add_argument("--quiet", "-q", action="store_true", help="no progress bar, terse output")
    common.add_argument(
        "--no-cache",
        action="store_true",
        help="do not use the compilation cache (default: $JAXBELT_CACHE_DIR, else ~/.cache/jaxbelt/jax; "
        "JAXBELT_CACHE_DIR= turns it off too)",
    )
    return common


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    p = _Parser(
        prog="jaxbelt",
        description="Planar belt-drive dynamics (jaxbelt): run a drive described "
        "in a TOML file and write results and plots.",
        epilog="Exit codes: 0 ok, 1 simulation did not finish cleanly or implausible result, 2 bad input, "
        "130 interrupted.",
    )
    p.add_argument("--version", action="version", version=f"jaxbelt {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True
    _add_run(sub, _common("run"))
    _add_sweep(sub, _common("sweep"))
    _add_identify(sub, _common("identify"))
    _add_statics(sub, _common("statics"))
    _add_duty(sub, _common("duty"))
    _add_report(sub, _common("report"))
    _add_modes(sub, _common("modes"))
    _add_runup(sub, _common("runup"))
    _add_span_tension(sub, _common("span-tension"))
    return p


def _add_span_tension(sub, common) -> None:
    s = sub.add_parser(
        "span-tension",
        parents=[common],
        help="a span's tension from its measured transverse frequency (sonic meter), or its frequencies",
        description="Tension of one span from its measured n-th transverse frequency, with the corrections a "
        "plain string formula lacks (mass per current length, bending, the ends' compliant contact on the pulleys, "
        "belt speed) and its uncertainty; or, with --tension, the span's frequencies. The span length is the "
        "tangent-to-tangent length of the installation statics unless --span-length is given. Writes "
        "span_tension.json into DIR.",
    )
    s.add_argument("config", metavar="CONFIG.toml", help="drive configuration (see docs/config.md)")
    s.add_argument("--span", required=True, metavar="A-B", help="the span between neighbouring pulleys A and B")
    s.add_argument("--frequency", type=_positive_float, metavar="F", help="measured transverse frequency [Hz]")
    s.add_argument("--tension", type=_positive_float, metavar="T", help="span tension [N]: print its frequencies")
    s.add_argument("--mode", type=_positive_int, default=1, metavar="N", help="mode number of F (default 1)")
    s.add_argument(
        "--frequency-uncertainty", type=_nonnegative_float, default=0.0, metavar="DF", help="of F [Hz] (default 0)"
    )
    s.add_argument("--span-length", type=_positive_float, metavar="MM", help="measured span length [mm]")
    s.add_argument(
        "--length-uncertainty", type=_nonnegative_float, default=0.0, metavar="MM", help="of the span length [mm]"
    )
    speed = s.add_mutually_exclusive_group()
    speed.add_argument("--speed", type=_nonnegative_float, metavar="RPM", help="driver speed (default: at rest)")
    speed.add_argument("--belt-speed", type=_nonnegative_float, metavar="V", help="belt speed [m/s]")
    fit = s.add_argument_group("a parameter from a measured span spectrum (belt at rest)")
    fit.add_argument(
        "--spectrum",
        metavar="N1=F1,N2=F2,...",
        help="measured frequencies [Hz] of the span's modes N (e.g. 1=80.2,2=161.0); with --fit",
    )
    fit.add_argument(
        "--fit",
        metavar="KEY",
        help="the parameter that sets the installed tension, identified from --spectrum (e.g. belt.pretension, "
        "belt.EA, pulleys.<tensioner>.tensioner.preload); its value in CONFIG starts the fit; writes span_fit.json",
    )


def _add_runup(sub, common) -> None:
    u = sub.add_parser(
        "runup",
        parents=[common],
        help="run-up through a crank speed range: order amplitudes against rpm, resonance crossings",
        description="The driver's speed ramped from START to END rpm (its excitation orders kept over crank "
        "angle); per window of crank revolutions the half peak-to-peak and the order amplitudes of the "
        "tensioner and span-tension signals (or --signal ones); writes runup.csv, runup.json, orders.png.",
    )
    u.add_argument("config", metavar="CONFIG.toml", help="drive configuration (see docs/config.md)")
    u.add_argument("--rpm", required=True, metavar="START:END", help="crank speed range [rpm]")
    u.add_argument("--duration", type=_positive_float, required=True, metavar="S", help="ramp duration [s]")
    u.add_argument("--orders", default="1,2,4", metavar="K1,K2,...", help="engine orders tracked (default 1,2,4)")
    u.add_argument("--signal", action="append", default=None, metavar="NAME", help="signal to track (repeatable)")
    u.add_argument("--revolutions", type=int, default=4, metavar="N", help="crank revolutions per window (default 4)")
    u.add_argument(
        "--lead-time", type=_positive_float, default=0.2, metavar="S", help="start-up before the ramp (default 0.2)"
    )
    u.add_argument("--no-modes", action="store_true", help="skip the linearised modes (no resonance crossings)")
    u.add_argument(
        "--model",
        choices=MODELS,
        default=None,
        help="ancf: the ANCF belt; spans: the reduced tier (docs/spans.md), its own modes for the crossings "
        "(default: the file's solver.model, else ancf)",
    )
    u.add_argument("--no-plots", action="store_true", help="do not write orders.png")


def _add_modes(sub, common) -> None:
    m = sub.add_parser(
        "modes",
        parents=[common],
        help="linearised natural frequencies and their parameter sensitivities",
        description="Natural frequencies and mode kinds (rotational or a span's transverse mode) of the drive "
        "about its installed state, with d f / d p for each parameter key; with --running about steady "
        "running (the end of the configured run, belt speed included); writes modes.json into DIR.",
    )
    m.add_argument("config", metavar="CONFIG.toml", help="drive configuration (see docs/config.md)")
    m.add_argument("--count", type=int, default=6, metavar="N", help="number of modes (default 6)")
    m.add_argument(
        "--sensitivity",
        action="append",
        default=None,
        metavar="KEY",
        help="parameter key for d f / d p (repeatable; default: belt EA and pretension, tensioner springs and "
        "arm inertias, pulley inertias; with --running none unless given)",
    )
    m.add_argument(
        "--running",
        action="store_true",
        help="modes about steady running: run the drive to its t_end (or --t-end) and linearise there, with "
        "the belt's gyroscopic and centrifugal terms (sensitivities at that belt speed and those pulley loads)",
    )
    m.add_argument(
        "--clutch",
        choices=("auto", "locked", "open"),
        default="auto",
        help="one-way clutch pulleys: linearised engaged (an OAP locked, a decoupler through its spring) or open; "
        "auto (default): engaged when the rotor's load brakes it (--running: when the clutch transmits torque)",
    )
    _add_model(m, ": rotational modes about the installed state, clutches engaged, exact sensitivities")


def _add_report(sub, common) -> None:
    r = sub.add_parser(
        "report",
        parents=[common],
        help="one self-contained HTML drive report",
        description="Geometry and installation, tensioner positions across the belt length, linearised modes "
        "with a resonance map, and (with --rpm) duty points: report.html in DIR.",
    )
    r.add_argument("config", metavar="CONFIG.toml", help="drive configuration (see docs/config.md)")
    _add_statics_options(r)
    _add_duty_points(r, required=False)
    from .report_page import add_criteria_options

    add_criteria_options(r)
    r.add_argument(
        "--resume",
        action="store_true",
        help="continue the duty points of a report killed before it finished (same DIR: DIR/points)",
    )
    _add_model(r, ": its modes and duty points (the statics are the string model's either way)")


def _add_statics_options(p) -> None:
    """The options of ``statics`` (also ``report``'s): absorbed torques and the belt-length cases."""
    p.add_argument(
        "--torque",
        action="append",
        default=[],
        metavar="PULLEY=Q",
        help="torque a pulley absorbs [N m] (repeatable; the driver supplies the sum)",
    )
    p.add_argument(
        "--length-tolerance",
        type=_nonnegative_float,
        default=0.0,
        metavar="MM",
        help="belt length tolerance +-MM: adds the shortest and longest belt (default 0: nominal only)",
    )
    p.add_argument(
        "--wear",
        type=_nonnegative_float,
        default=0.0,
        metavar="MM",
        help="stretch of a worn belt [mm]: adds the worn case (default 0)",
    )


def _add_model(p, what: str) -> None:
    """``--model``: which tier runs the command (docs/spans.md)."""
    p.add_argument(
        "--model",
        choices=MODELS,
        default=None,
        help=f"ancf: the ANCF belt; spans: the reduced tier (docs/spans.md){what} (default: the file's solver.model, "
        "else ancf)",
    )


def _add_duty_points(p, required: bool = True) -> None:
    """The duty points of ``duty`` (also ``report``'s): driver speeds and the power absorbed per speed."""
    p.add_argument("--rpm", metavar="R1,R2,...", help="driver speeds [rpm]" + ("" if required else " (optional)"))
    p.add_argument(
        "--power", action="append", default=[], metavar="PULLEY=P1,P2,...", help="absorbed power per speed [kW]"
    )


def _add_duty(sub, common) -> None:
    d = sub.add_parser(
        "duty",
        parents=[common],
        help="duty-point study: steady runs at several engine speeds (batched)",
        description="Steady operation at each driver speed with the accessory loads given per speed: span "
        "tensions, hub loads, slip safety factors, tensioner positions; writes duty.csv, duty.png and "
        "duty_points.json (each point's status) into DIR and each point's signals into DIR/points/. Every point "
        "starts running at its speed and ramps its loads in (--load-ramp); a point whose window is not steady "
        "or slips grossly is flagged (exit 1).",
    )
    d.add_argument("config", metavar="CONFIG.toml", help="drive configuration (see docs/config.md)")
    _add_duty_points(d)
    d.add_argument(
        "--torque",
        action="append",
        default=[],
        metavar="PULLEY=Q1,Q2,...",
        help="load torque per speed [N m]; negative on a pulley configured with a torque law: it drives (a "
        "motoring starter-generator)",
    )
    d.add_argument(
        "--window",
        type=_fraction,
        default=0.2,
        metavar="F",
        help="fraction of each run averaged for the figures (default 0.2)",
    )
    d.add_argument(
        "--load-ramp",
        type=_nonnegative_float,
        default=None,
        metavar="S",
        help="seconds over which each point's accessory loads rise from 0 after t = 0 (default 0.1, at most a "
        "quarter of the run)",
    )
    d.add_argument("--resume", action="store_true", help="continue a duty study killed before it finished (same DIR)")
    _add_model(d, ", every point at the smallest of the points' stable steps")


def _add_statics(sub, common) -> None:
    s = sub.add_parser(
        "statics",
        parents=[common],
        help="installation statics: tensions, hub loads, tensioner positions (no dynamic run)",
        description="Span tensions, hub loads, wrap angles, slip safety and tensioner positions of the drive at "
        "rest, for the nominal belt and across its length tolerance and wear; writes statics.json into DIR.",
    )
    s.add_argument("config", metavar="CONFIG.toml", help="drive configuration (see docs/config.md)")
    _add_statics_options(s)
    _add_model(s, ": the same string model either way (it is the spans tier's equilibrium at rest)")


def _add_run(sub, common) -> None:
    r = sub.add_parser(
        "run",
        parents=[common],
        help="simulate one drive",
        description="Simulate a drive and write summary.json, signals.csv, result.npz and PNG plots into DIR.",
    )
    r.add_argument(
        "config",
        metavar="CONFIG.toml",
        nargs="?",
        help="drive configuration (see docs/config.md); with --resume, default: the checkpoint's",
    )
    r.add_argument(
        "--resume",
        metavar="DIR",
        help="continue the run whose output directory DIR holds a checkpoint (refused if the configuration changed)",
    )
    r.add_argument(
        "--checkpoint-every",
        type=_nonnegative_float,
        default=5.0,
        metavar="S",
        help="write DIR/checkpoint.npz at most every S seconds of computing (default 5; 0: after every chunk)",
    )
    r.add_argument(
        "--window",
        type=_fraction,
        default=0.2,
        metavar="F",
        help="averaging window for the summary: final fraction of the run (default 0.2)",
    )
    r.add_argument("--animate", action="store_true", help="also write belt.gif, the belt running")
    r.add_argument(
        "--exaggerate",
        type=_positive_float,
        default=1.0,
        metavar="X",
        help="deformation exaggeration factor of the animation (default 1)",
    )
    r.add_argument("--no-plots", action="store_true", help="write the data files only")
    r.add_argument(
        "--model",
        choices=MODELS,
        default=None,
        help="ancf: the ANCF belt; spans: the reduced tier (docs/spans.md: spans as axial springs, creep and gross "
        "slip per wrap; signals.csv and summary.json only, no plots or resume); default: the file's solver.model, "
        "else ancf",
    )


def _add_sweep(sub, common) -> None:
    s = sub.add_parser(
        "sweep",
        parents=[common],
        help="grid over configuration keys (batched)",
        description="Run a grid over numeric configuration keys as one batched computation.",
    )
    s.add_argument("config", metavar="CONFIG.toml", help="drive configuration (see docs/config.md)")
    s.add_argument(
        "--vary",
        action="append",
        default=[],
        metavar="KEY=START:STOP:N",
        help="a key and its grid, e.g. contact.mu=0.2:0.6:5 (repeatable)",
    )
    s.add_argument(
        "--window",
        type=_fraction,
        default=0.2,
        metavar="F",
        help="fraction of the run averaged for the figures (default 0.2)",
    )
    s.add_argument(
        "--points",
        metavar="FILE.csv",
        help="a list of points instead of a grid: a CSV file whose header names the keys, one row per point "
        "(e.g. a Monte Carlo sample of parameter spreads)",
    )
    s.add_argument(
        "--chunk-size",
        type=int,
        default=None,
        metavar="N",
        help="points per device and chunk (default: as many as fit in memory, at most 64); each finished chunk "
        "is added to the result files",
    )
    s.add_argument(
        "--resume",
        action="store_true",
        help="continue the sweep in the output directory, skipping the points already done",
    )
    _add_model(s, ", every point at the smallest of the points' stable steps")
    _add_processes(s)


def _add_processes(p: argparse.ArgumentParser) -> None:
    """The options of a command that runs on several processes (``sweep``, ``identify``; see common.start_processes)."""
    d = p.add_argument_group("several processes (jax.distributed)")
    d.add_argument("--coordinator", metavar="HOST:PORT", help="address of process 0, reachable by every process")
    d.add_argument("--num-processes", type=int, metavar="N", help="number of processes of the run")
    d.add_argument("--process-id", type=int, metavar="I", help="this process's index, 0 .. N-1 (0 writes the files)")
    d.add_argument(
        "--distributed",
        action="store_true",
        help="join the processes the cluster describes (SLURM, Open MPI: jax.distributed.initialize())",
    )


def _add_identify(sub, common) -> None:
    i = sub.add_parser(
        "identify",
        parents=[common],
        help="fit parameters to a measured signals file",
        description="Identify parameters from measured signals (signals.csv layout).",
    )
    i.add_argument("config", metavar="CONFIG.toml", help="drive configuration (see docs/config.md)")
    i.add_argument("--measured", metavar="FILE.csv", help="measured signals, signals.csv layout")
    i.add_argument("--fit", metavar="KEYS", help="comma-separated keys to fit, e.g. belt.E,belt.eta,contact.mu")
    i.add_argument(
        "--bounds",
        type=_positive_float,
        default=2.0,
        metavar="B",
        help="search each parameter within [start/B, start*B] (default 2)",
    )
    i.add_argument(
        "--iterations", type=_positive_int, default=30, metavar="N", help="iterations per window at most (default 30)"
    )
    i.add_argument("--method", choices=["lm", "adam", "lbfgs"], default="lm", help="optimiser (default lm)")
    i.add_argument(
        "--window",
        action="append",
        default=[],
        metavar="T0:T1",
        help="fit this time window first (repeatable, in order); the whole record is fitted last",
    )
    i.add_argument(
        "--sigma",
        action="append",
        default=[],
        metavar="COLUMN=LEVEL",
        help="measurement noise of a column, in its unit (repeatable); with every column's given, a "
        "misfit far above it is warned about; otherwise the noise is estimated from the residuals",
    )
    _add_model(i, ": the measured columns are its signals")
    _add_processes(i)
