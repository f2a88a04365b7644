"""Command line: ``jaxbelt run | sweep | identify`` (also ``python -m jaxbelt``).

    jaxbelt run CONFIG.toml [--t-end T] [--out DIR] [--window F] [--animate] [--exaggerate X]
                            [--no-plots] [--quiet]

Exit codes: 0 success; 1 the simulation ran but did not finish cleanly or its result is
physically implausible (``status`` in ``summary.json`` says why; the files are still written); 2 bad
input (unknown key, value out of range, missing or unreadable file, an output directory that cannot
be written, bad option), printed as one line on stderr; 130 interrupted.
Set ``JAXBELT_DEBUG=1`` to get the full traceback of an unexpected internal error.
"""

from __future__ import annotations

import argparse
import math
import os
import signal
import sys
import threading
import time
import warnings
from pathlib import Path

__all__ = ["main", "script_main"]

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


class UsageError(Exception):
    """Bad input detected by the CLI itself; printed as one line, exit code 2."""


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


def _fraction(text: str) -> float:
    x = _positive_float(text)
    if x > 1:
        raise argparse.ArgumentTypeError(f"{text}: must be a fraction of the run in (0, 1], e.g. 0.2")
    return x


def _parser() -> argparse.ArgumentParser:
    from .. import __version__

    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("config", metavar="CONFIG.toml", help="drive configuration (see docs/config.md)")
    common.add_argument("--t-end", type=_positive_float, metavar="T",
                        help="simulated time [s] (default: solver.t_end of the configuration)")
    common.add_argument("--out", metavar="DIR", help="output directory (default: ./out/<config name>)")
    common.add_argument("--quiet", "-q", action="store_true", help="no progress bar, terse output")

    p = _Parser(prog="jaxbelt", description="Planar belt-drive dynamics (jaxbelt): run a drive described "
                "in a TOML file and write results and plots.",
                epilog="Exit codes: 0 ok, 1 simulation did not finish cleanly or implausible result, 2 bad input, "
                       "130 interrupted.")
    p.add_argument("--version", action="version", version=f"jaxbelt {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    r = sub.add_parser("run", parents=[common], help="simulate one drive",
                       description="Simulate a drive and write summary.json, signals.csv, result.npz and "
                                   "PNG plots into DIR.")
    r.add_argument("--window", type=_fraction, default=0.2, metavar="F",
                   help="averaging window for the summary: final fraction of the run (default 0.2)")
    r.add_argument("--animate", action="store_true", help="also write belt.gif, the belt running")
    r.add_argument("--exaggerate", type=_positive_float, default=1.0, metavar="X",
                   help="deformation exaggeration factor of the animation (default 1)")
    r.add_argument("--no-plots", action="store_true", help="write the data files only")

    s = sub.add_parser("sweep", parents=[common], help="grid over configuration keys (batched)",
                       description="Run a grid over numeric configuration keys as one batched computation.")
    s.add_argument("--vary", action="append", default=[], metavar="KEY=START:STOP:N",
                   help="a key and its grid, e.g. contact.mu=0.2:0.6:5 (repeatable)")
    s.add_argument("--window", type=_fraction, default=0.2, metavar="F",
                   help="fraction of the run averaged for the figures (default 0.2)")

    i = sub.add_parser("identify", parents=[common], help="fit parameters to a measured signals file",
                       description="Identify parameters from measured signals (signals.csv layout).")
    i.add_argument("--measured", metavar="FILE.csv", help="measured signals, signals.csv layout")
    i.add_argument("--fit", metavar="KEYS", help="comma-separated keys to fit, e.g. belt.E,belt.eta,contact.mu")
    i.add_argument("--bounds", type=_positive_float, default=2.0, metavar="B",
                   help="search each parameter within [start/B, start*B] (default 2)")
    i.add_argument("--iterations", type=int, default=10, metavar="N", help="Levenberg-Marquardt iterations per window")
    i.add_argument("--method", choices=["lm", "adam", "lbfgs"], default="lm", help="optimiser (default lm)")
    i.add_argument("--window", action="append", default=[], metavar="T0:T1",
                   help="fit this time window first (repeatable, in order); the whole record is fitted last")
    i.add_argument("--sigma", action="append", default=[], metavar="COLUMN=LEVEL",
                   help="measurement noise of a column, in its unit (repeatable); with every column's given, a "
                        "misfit far above it is warned about; otherwise the noise is estimated from the residuals")
    return p


# --------------------------------------------------------------------------- helpers
def _one_line(msg) -> str:
    return " ".join(str(msg).split())


def _err(prog: str, msg) -> None:
    print(f"{prog}: error: {_one_line(msg)}", file=sys.stderr, flush=True)


def _show_warning(message, category, filename, lineno, file=None, line=None):
    print(f"jaxbelt: warning: {_one_line(message)}", file=sys.stderr, flush=True)


def _check_input_file(path: str, what: str = "configuration file") -> Path:
    p = Path(path)
    if not p.exists():
        raise UsageError(f"{path}: no such {what}")
    if p.is_dir():
        raise UsageError(f"{path}: is a directory, expected a {what}")
    if not os.access(p, os.R_OK):
        raise UsageError(f"{path}: permission denied")
    return p


def _check_out_dir(out_dir: Path) -> None:
    """The output directory (or the nearest existing folder it would be made in) must accept files:
    probed by writing one, which also tells the truth for root and read-only file systems."""
    import tempfile

    if out_dir.exists() and not out_dir.is_dir():
        raise UsageError(f"--out {out_dir}: exists and is not a directory")
    base = out_dir
    while not base.exists():
        if base.is_symlink():
            raise UsageError(f"--out {out_dir}: {base} is a broken link")
        base = base.parent
    if not base.is_dir():
        raise UsageError(f"--out {out_dir}: {base} is a file, not a directory; choose another output directory")
    try:
        fd, probe = tempfile.mkstemp(prefix=".jaxbelt-probe-", dir=base)
        os.close(fd)
        os.unlink(probe)
    except OSError as err:
        where = "" if base == out_dir else f" (it would be created in {base})"
        raise UsageError(f"--out {out_dir}: cannot write there{where}: {err.strerror or err}; "
                         "choose another output directory") from None


def _enable_x64() -> None:
    import jax

    jax.config.update("jax_enable_x64", True)


def _split_cpu_into_devices() -> None:
    """For ``sweep``: present every CPU core as a JAX device, so the batch is sharded over all cores.

    One CPU device runs a batched simulation mostly on one core (measured on 2 cores: 64 variants in
    32.9 s on one device, 16.1 s on two). Only the host platform is split (GPUs are unaffected), only
    when the user has not set the count, and before JAX creates its backend.
    """
    flags = os.environ.get("XLA_FLAGS", "")
    if "xla_force_host_platform_device_count" not in flags and (os.cpu_count() or 1) > 1:
        os.environ["XLA_FLAGS"] = f"{flags} --xla_force_host_platform_device_count={os.cpu_count()}".strip()


def _fmt(x, spec=".4g") -> str:
    try:
        x = float(x)
    except (TypeError, ValueError):
        return "-"
    return format(x, spec) if math.isfinite(x) else "nan"


def _creep_comparison(result) -> dict | None:
    """Creep theory beside the simulation (two-pulley drives): {quantity: {simulation, theory}}."""
    s = result.summary
    th = s.get("creep_theory")
    if not th:
        return None
    spec = result.drive.spec
    roles = [p.role for p in spec.pulleys]
    d1, d2 = spec.pulleys[roles.index("driver")].name, spec.pulleys[roles.index("driven")].name
    names = list(result.drive.model.pulley_names)
    import numpy as np

    radii = np.asarray(result.drive.params.pulleys.radius)
    R1, R2 = radii[names.index(d1)], radii[names.index(d2)]
    p1, p2 = s["pulleys"][d1], s["pulleys"][d2]
    w1, w2 = (p["omega_mean"] * p.get("running_sense", 1) for p in (p1, p2))  # the theory's speeds are positive
    tens = [sp["tension_mean"] for sp in s["spans"]]
    sim = {
        "omega_driven": w2,
        "speed_loss": w1 * R1 / R2 - w2,
        "torque_driver": abs(p1["torque_mean"]),
        "torque_driven": abs(p2["torque_mean"]),
        "T_tight": max(tens),
        "T_slack": min(tens),
        "slip_arc_driver_deg": p1["slip_arc_deg"],
        "stick_arc_driver_deg": p1["stick_arc_deg"],
        "slip_arc_driven_deg": p2["slip_arc_deg"],
        "stick_arc_driven_deg": p2["stick_arc_deg"],
    }
    return {k: {"simulation": float(v), "theory": float(th[k])} for k, v in sim.items() if k in th}


def _laws_settle_time(spec) -> float:
    """Time of the last knot of any prescribed speed, torque or load (0 for constants)."""
    from ..config.laws import law_from_spec

    last = 0.0
    for p in spec.pulleys:
        for value in (p.speed, p.speed_rpm, p.torque, p.load, p.power_kw):
            if value is not None:
                last = max(last, float(law_from_spec(value, p.name).times[-1]))
    return last


_UNITS = {"omega_driven": "rad/s", "speed_loss": "rad/s", "torque_driver": "N m", "torque_driven": "N m",
          "T_tight": "N", "T_slack": "N"}


def _print_report(result, stem: str, files: dict, comparison, out_dir: Path) -> None:
    s, timing = result.summary, result.timing
    spec = result.drive.spec
    w = s.get("window_s", [math.nan, math.nan])
    print(f"{stem}: {len(spec.pulleys)} pulleys, {spec.belt.n_elements} elements, "
          f"t = {_fmt(float(result.ts[-1]))} s, dt = {_fmt(result.drive.dt, '.3g')} s   status: {s['status']}")
    belt = s.get("belt")
    if belt:
        spans = f"; tight span {belt['tight_span']}, slack span {belt['slack_span']}" if belt.get("tight_span") else ""
        print(f"belt runs {belt['direction']}: " + " -> ".join(belt["travel_order"]) + spans
              + ("" if belt.get("spans_in_travel_order", True) else " (spans named against the travel)"))
    print(f"means over t = {_fmt(w[0])} .. {_fmt(w[1])} s (omega, torque counter-clockwise positive; torque: "
          "exerted by the belt on the pulley)")
    width = max([len(n) for n in s["pulleys"]] + [6])
    print(f"  {'pulley':<{width}}  {'omega [rad/s]':>13}  {'torque [N m]':>12}  "
          f"{'stick [deg]':>11}  {'slip [deg]':>10}")
    for name, p in s["pulleys"].items():
        print(f"  {name:<{width}}  {_fmt(p['omega_mean'], '13.4f')}  {_fmt(p['torque_mean'], '12.3f')}  "
              f"{_fmt(p['stick_arc_deg'], '11.1f')}  {_fmt(p['slip_arc_deg'], '10.1f')}"
              + (f"   arm angle {_fmt(math.degrees(p['arm_angle_mean']), '.2f')} deg" if "arm_angle_mean" in p else ""))
    width = max([len(sp["name"]) for sp in s["spans"]] + [4])
    print(f"  {'span':<{width}}  {'tension [N]':>11}")
    for sp in s["spans"]:
        print(f"  {sp['name']:<{width}}  {_fmt(sp['tension_mean'], '11.2f')}")
    if comparison and s["status"] == "ok":
        settle = _laws_settle_time(spec)
        note = (f" (the run is not steady yet: its prescribed laws change until t = {settle:g} s)"
                if settle > w[0] else "")
        print(f"creep theory (steady state) beside the simulation{note}:")
        width = max(len(k) for k in comparison)
        print(f"  {'':<{width}}  {'simulation':>10}  {'theory':>10}")
        for k, v in comparison.items():
            unit = _UNITS.get(k, "deg" if k.endswith("_deg") else "")
            label = k[:-4] if k.endswith("_deg") else k
            print(f"  {label + (' [' + unit + ']' if unit else ''):<{width + 6}}"
                  f"{_fmt(v['simulation'], '10.5g')}  {_fmt(v['theory'], '10.5g')}")
    print(f"timing: build {timing['build_s']:.2f} s, compile {timing['compile_s']:.2f} s, run {timing['run_s']:.2f} s "
          f"({timing['num_steps']} steps, {timing['us_per_step']:.0f} us/step)")
    print(f"wrote {out_dir}/: " + ", ".join(Path(f).name for f in files.values()))


# --------------------------------------------------------------------------- commands
def _cmd_run(args) -> int:
    cfg = _check_input_file(args.config)
    from .._errors import ConfigError

    try:
        return _run_config(args, cfg)
    except ConfigError as err:  # name the file the problem is in
        msg = str(err)
        raise ConfigError(msg if msg.startswith(str(cfg)) else f"{cfg}: {msg}") from None


def _run_config(args, cfg: Path) -> int:
    from ..config.toml import load_config

    spec = load_config(cfg)
    if args.t_end is not None:
        spec.solver.t_end = args.t_end
    out_dir = Path(args.out) if args.out else Path("out") / cfg.stem
    _check_out_dir(out_dir)  # before the simulation, not after it
    from ..io import _check_not_input

    planned = ["summary.json", "signals.csv", "result.npz", "config_used.toml", "speeds.png", "tensions.png",
               "torques.png", "contact.png", "belt.png", "belt.gif"]
    for name in planned:
        _check_not_input(out_dir / name, [cfg])

    from ..config.build import build_drive
    from ..outputs.summary import contact_distribution
    from ..analysis.run import run

    t0 = time.perf_counter()
    drive = build_drive(spec)
    t_build = time.perf_counter() - t0
    progress = sys.stdout.isatty() and not args.quiet
    if not args.quiet:
        print(f"{cfg.stem}: simulating {spec.solver.t_end:g} s (dt {drive.dt:.3g} s, "
              f"{math.ceil(spec.solver.t_end / drive.dt)} steps after a {spec.solver.settle_time:g} s settle phase; "
              "compiling first) ...", flush=True)
    result = run(drive, progress=progress, window=args.window)
    _raise_if_interrupted()
    # run() got a built drive: count the build (validation, layout, stability estimate) here
    result.timing["build_s"] = t_build
    result.timing["wall_s"] = result.timing.get("wall_s", 0.0) + t_build
    result.summary["wall_time_s"] = result.timing["wall_s"]
    import jax

    from ..outputs.summary import guarded

    # The simulation is done: from here on a failing derived output (contact distribution, creep
    # comparison, plots) becomes a warning in summary.json; the raw results are written first.
    warns = result.summary.setdefault("warnings", [])
    last = jax.tree.map(lambda x: x[-1], result.trajectory.states)
    contact = guarded(warns, "final contact distribution", lambda: contact_distribution(result.drive, last))
    comparison = guarded(warns, "creep comparison", lambda: _creep_comparison(result))
    from .. import __version__
    from ..io import write_run_outputs, write_summary

    extra = {"config": str(cfg), "t_end": float(spec.solver.t_end), "window": args.window,
             "jaxbelt_version": __version__, "timing": result.timing}
    if comparison:
        extra["creep_comparison"] = comparison
    files = write_run_outputs(result, out_dir, contact=contact, extra_summary=extra, inputs=[cfg])
    n_warnings = len(warns)
    try:
        from ..config.toml import dump_toml
        from ..io import atomic_write

        with atomic_write(out_dir / "config_used.toml", "w", inputs=[cfg]) as fh:
            fh.write(f"# effective configuration of the run (from {cfg})\n" + dump_toml(spec))
        files["config_used"] = out_dir / "config_used.toml"
    except (TypeError, ValueError):
        pass  # a law without a TOML form: the input file is the record
    if not args.no_plots:
        from ..viz import plot_run

        files.update(plot_run(result, out_dir, contact=contact, animate=args.animate,
                              exaggeration=args.exaggerate, warnings_=warns))
    if len(warns) > n_warnings:  # a plot failed: the summary records it
        write_summary(out_dir / "summary.json", {**result.summary, **extra}, inputs=[cfg])
    if not args.quiet:
        guarded(warns, "report", lambda: _print_report(result, cfg.stem, files, comparison, out_dir))
    for w in warns:
        print(f"jaxbelt: warning: {_one_line(w)}", file=sys.stderr)
    status = result.summary["status"]
    if args.quiet:
        print(f"{cfg.stem}: {status}; results in {out_dir}")
    if status != "ok":
        what = "result is implausible" if status.startswith("implausible") else "simulation did not finish cleanly"
        print(f"jaxbelt run: {what}: {_one_line(status)}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _with_config_context(fn):
    def wrapped(args):
        cfg = _check_input_file(args.config)
        from .._errors import ConfigError

        try:
            return fn(args, cfg)
        except ConfigError as err:
            msg = str(err)
            raise ConfigError(msg if msg.startswith(str(cfg)) else f"{cfg}: {msg}") from None

    return wrapped


def _parse_vary(text: str):
    import numpy as np

    key, sep, grid = text.partition("=")
    parts = grid.split(":")
    if not sep or len(parts) != 3:
        raise UsageError(f"--vary {text}: expected KEY=START:STOP:N, e.g. contact.mu=0.2:0.6:5")
    try:
        a, b, n = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise UsageError(f"--vary {text}: START and STOP must be numbers and N an integer") from None
    if n < 1 or not (math.isfinite(a) and math.isfinite(b)):
        raise UsageError(f"--vary {text}: N must be >= 1 and START, STOP finite")
    return key.strip(), np.linspace(a, b, n)


@_with_config_context
def _cmd_sweep(args, cfg: Path) -> int:
    import numpy as np

    from ..config.toml import load_config
    from ..config.build import build_drive
    from ..analysis.sweep import sweep
    from ..io import atomic_write

    if not args.vary:
        raise UsageError("give at least one --vary KEY=START:STOP:N")
    grid = dict(_parse_vary(v) for v in args.vary)
    spec = load_config(cfg)
    if args.t_end is not None:
        spec.solver.t_end = args.t_end
    out_dir = Path(args.out) if args.out else Path("out") / f"{cfg.stem}_sweep"
    drive = build_drive(spec)
    n = int(np.prod([len(v) for v in grid.values()]))
    if not args.quiet:
        print(f"{cfg.stem}: sweeping {n} points ({', '.join(grid)}) in one batched run; checking every point ...",
              flush=True)
    say = None if args.quiet else (lambda msg: print(f"{cfg.stem}: {msg}", flush=True))
    from .._types import Fault

    res = sweep(drive, grid, window=args.window, progress=say)
    _raise_if_interrupted()
    header, rows = res.table()
    with atomic_write(out_dir / "sweep.csv", "w", inputs=[cfg]) as fh:
        fh.write(",".join(header) + "\n")
        for row in rows:
            fh.write(",".join(repr(float(x)) for x in row) + "\n")
    from ..viz import plot_sweep

    plot_sweep(res, out_dir / "sweep.png")
    bad = int(np.sum(res.figures["fault"] != Fault.OK))
    print(f"{cfg.stem}: {n} points on {res.timing['devices']} device(s), dt = {res.timing['dt']:.4g} s: compile "
          f"{res.timing['compile_s']:.1f} s, run {res.timing['run_s']:.1f} s; {bad} diverged; results in {out_dir}")
    return EXIT_OK if bad == 0 else EXIT_FAILED


@_with_config_context
def _cmd_identify(args, cfg: Path) -> int:
    import json

    from ..config.toml import load_config
    from ..config.build import build_drive
    from ..analysis.identify import Measurement, identify
    from ..analysis.parameters import get_parameter
    from ..io import atomic_write, read_signals_csv, to_jsonable

    if not args.measured:
        raise UsageError("give --measured FILE.csv (signals.csv layout)")
    if not args.fit:
        raise UsageError("give --fit KEYS, e.g. --fit belt.E,belt.eta,contact.mu")
    meas_path = _check_input_file(args.measured, "measured signals file")
    data = read_signals_csv(meas_path)
    spec = load_config(cfg)
    if args.t_end is not None:
        spec.solver.t_end = args.t_end
    drive = build_drive(spec)
    keys = [k.strip() for k in args.fit.split(",") if k.strip()]
    fit = {}
    for k in keys:
        v = float(get_parameter(drive, drive.params, k))
        fit[k] = (v, (v / args.bounds, v * args.bounds))
    windows = []
    for w in args.window:
        try:
            a, b = (float(x) for x in w.split(":"))
        except ValueError:
            raise UsageError(f"--window {w}: expected T0:T1 in seconds") from None
        windows.append((a, b))
    sigma = {}
    for item in args.sigma:
        col, sep, level = item.partition("=")
        try:
            sigma[col.strip()] = float(level)
        except ValueError:
            sep = ""
        if not sep:
            raise UsageError(f"--sigma {item}: expected COLUMN=LEVEL, e.g. omega:driven=0.05")
    t = data.pop("t")
    windows = windows + [(float(t[0]), float(t[-1]))] if windows else None
    out_dir = Path(args.out) if args.out else Path("out") / f"{cfg.stem}_identify"
    if not args.quiet:  # the first iteration compiles the simulation and its Jacobian: say so
        print(f"{cfg.stem}: fitting {', '.join(keys)} to {len(t)} samples of {len(data)} signal(s) "
              f"({args.method}, at most {args.iterations} iterations per window; compiling first) ...", flush=True)
    res = identify(drive, Measurement(t, data, sigma=sigma or None), fit, method=args.method,
                   iterations=args.iterations, t_end=spec.solver.t_end, windows=windows, verbose=not args.quiet)
    _raise_if_interrupted()
    with atomic_write(out_dir / "identify.json", "w", inputs=[cfg, meas_path]) as fh:
        json.dump(to_jsonable(res.as_dict()), fh, indent=2)
    for k in keys:
        err = f"at its {res.at_bound[k]} bound" if k in res.at_bound else f"+- {res.std_errors[k]:.2g}"
        print(f"  {k} = {res.values[k]:.6g} {err} (start {res.initial[k]:.6g})")
    fit_ = res.misfit
    print(f"  misfit: reduced chi^2 {fit_['reduced_chi2']:.3g} (noise {fit_['noise']}); RMS residual "
          + ", ".join(f"{n} {v:.3g}" for n, v in fit_["rms_residual"].items()))
    print(f"{cfg.stem}: identification finished in {res.iterations} iterations; results in {out_dir}")
    return EXIT_OK


_COMMANDS = {"run": _cmd_run, "sweep": _cmd_sweep, "identify": _cmd_identify}


# Ctrl-C arrives wherever the main thread happens to be: inside a host callback of the compiled run
# (JAX re-raises it as a runtime error), inside JAX's C++ pytree code (a ValueError), or inside a
# garbage-collection callback (swallowed). The flag remembers it in every case; the command checks it
# before writing anything and main() turns any error it caused into the ordinary interruption.
_INTERRUPTED = threading.Event()


def _on_sigint(signum, frame):
    _INTERRUPTED.set()
    f = frame
    while f is not None:
        if getattr(f.f_code, "co_name", "") == "_xla_gc_callback":
            # Inside JAX's garbage-collection callback: Python prints an exception raised there as
            # "Exception ignored in ..." with a traceback and drops it. Deliver the signal again a
            # moment later, when the callback has returned.
            threading.Timer(0.05, os.kill, (os.getpid(), signal.SIGINT)).start()
            return
        if f.f_code.co_filename.replace("\\", "/").endswith("jax/_src/callback.py"):
            # Inside a host callback of the compiled run (the progress bar): raising there makes JAX
            # print a traceback. The run goes on to its end and the flag stops the command before it
            # writes anything.
            return
        f = f.f_back
    raise KeyboardInterrupt


def _raise_if_interrupted() -> None:
    """Called before results are written: an interrupt that got swallowed still stops the command."""
    if _INTERRUPTED.is_set():
        raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``jaxbelt`` command; returns the exit code."""
    args = _parser().parse_args(argv)
    prog = f"jaxbelt {args.command}"
    if args.command == "sweep":
        _split_cpu_into_devices()
    _enable_x64()  # before anything creates an array: jaxbelt itself never flips global config
    from .._errors import ConfigError
    from ..io import DataError

    old_show = warnings.showwarning
    warnings.showwarning = _show_warning
    _INTERRUPTED.clear()
    in_main_thread = threading.current_thread() is threading.main_thread()
    old_sigint = signal.signal(signal.SIGINT, _on_sigint) if in_main_thread else None
    try:
        code = _COMMANDS[args.command](args)
        _raise_if_interrupted()
        return code
    except (ConfigError, DataError, UsageError) as err:
        _err(prog, err)
        return EXIT_USAGE
    except FileExistsError as err:
        _err(prog, err)
        return EXIT_USAGE
    except OSError as err:
        where = f"{err.filename}: " if getattr(err, "filename", None) else ""
        _err(prog, f"{where}{err.strerror or err}")
        return EXIT_USAGE
    except KeyboardInterrupt:
        print(f"\n{prog}: interrupted (no result file was left half-written)", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as err:  # noqa: BLE001 - an internal error: one line unless debugging
        if _INTERRUPTED.is_set():  # the error is how the interrupt surfaced (see _INTERRUPTED)
            print(f"\n{prog}: interrupted (no result file was left half-written)", file=sys.stderr)
            return EXIT_INTERRUPTED
        if os.environ.get("JAXBELT_DEBUG"):
            raise
        _err(prog, f"internal error: {type(err).__name__}: {err} (set JAXBELT_DEBUG=1 for the traceback)")
        return EXIT_FAILED
    finally:
        warnings.showwarning = old_show
        if old_sigint is not None:
            signal.signal(signal.SIGINT, old_sigint)


def script_main() -> None:
    """The installed ``jaxbelt`` command and ``python -m jaxbelt``.

    After an interrupt XLA may still be running the abandoned computation in its own threads, and
    tearing the interpreter down under it can crash (measured: SIGSEGV at exit). The output is
    flushed and the process ends at once instead.
    """
    code = main()
    if code == EXIT_INTERRUPTED:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)
