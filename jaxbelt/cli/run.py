"""``jaxbelt run``: simulate one drive; write summary.json, signals.csv, result.npz, config_used.toml and
plots; print a report with creep theory beside (two-pulley drives). While it simulates, checkpoint.npz
(see ``resume.py``; ``--resume DIR`` continues a killed run)."""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

from ..outputs.signals import OMEGA, TENSION, TORQUE
from .common import EXIT_FAILED, EXIT_OK, UsageError, fmt, load_spec, one_line, output_dir
from .common import print_warning, status_kind, with_config_context
from . import run_spans
from .interrupt import raise_if_interrupted
from .resume import CHECKPOINT, Checkpointer, Stored, check_layout, config_hash, prepare_resume, read_resume

__all__ = ["command"]

# the plots a run may write (plot_run's names): derived from the data files, so a rerun into the same
# directory removes those it does not write again (--no-plots, no --animate, a plot that failed)
_PLOTS = ["speeds.png", "tensions.png", "torques.png", "contact.png", "belt.png", "fead.png", "belt.gif"]
_PLANNED = ["summary.json", "signals.csv", "result.npz", "config_used.toml", *_PLOTS, CHECKPOINT]


def command(args) -> int:
    if args.model == "spans" and (args.resume is not None or args.animate):
        raise UsageError("--model spans: no --resume or --animate (the spans tier writes its data files only)")
    if args.resume is not None:
        prepare_resume(args)
    if args.config is None:
        raise UsageError("the configuration file is missing: jaxbelt run CONFIG.toml (or --resume DIR)")
    if args.model == "spans":
        return with_config_context(run_spans.command)(args)
    return _command(args)


@with_config_context
def _command(args, cfg: Path) -> int:
    spec = load_spec(cfg, args.t_end, args.scheme)
    out_dir = output_dir(args, cfg, results=_PLANNED)  # checked before the simulation, not after it
    if args.resume is None and (out_dir / CHECKPOINT).exists():  # a killed run's progress: not to be lost
        raise UsageError(
            f"--out {out_dir}: holds an unfinished run ({CHECKPOINT}): continue it with --resume {out_dir}, "
            f"or choose another --out (or delete {out_dir / CHECKPOINT} to start again)"
        )
    resume = read_resume(out_dir, spec, cfg) if args.resume is not None else None
    meta = {"config": str(cfg.resolve()), "config_hash": config_hash(spec, cfg), "t_end_option": args.t_end}
    checkpoint = Checkpointer(out_dir / CHECKPOINT, meta, args.checkpoint_every, inputs=[cfg])
    result = _simulate(spec, cfg, args, checkpoint, resume)
    # The simulation is done: from here on a failing derived output (contact distribution, creep
    # comparison, plots) becomes a warning in summary.json; the raw results are written first.
    warns = result.summary.setdefault("warnings", [])
    files, comparison = _write_outputs(result, spec, cfg, out_dir, args, warns)
    checkpoint.remove()  # the results are whole: nothing left to resume
    if not args.quiet:
        from ..outputs.summary import guarded

        guarded(warns, "report", lambda: _print_report(result, cfg.stem, files, comparison, out_dir))
    for w in warns:
        print_warning(w)
    status = result.summary["status"]
    if args.quiet:
        print(f"{cfg.stem}: {status}; results in {out_dir}")
    if status != "ok":
        print(f"jaxbelt run: {status_kind(status)}: {one_line(status)}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


def _simulate(spec, cfg: Path, args, checkpoint: Checkpointer, resume: Stored | None):
    """Build and run the drive (checkpointed; from ``resume`` if given); the build (validation, layout,
    stability estimate) counted in the timing."""
    from ..config.build import build_drive
    from ..analysis.run import run

    t0 = time.perf_counter()
    drive = build_drive(spec)
    t_build = time.perf_counter() - t0
    if resume is not None:
        check_layout(resume, drive)  # before compiling: a checkpoint of another build is refused
    progress = sys.stdout.isatty() and not args.quiet
    if not args.quiet:
        print(f"{cfg.stem}: {_announcement(drive, resume is not None)} ...", flush=True)
    arrays = None if resume is None else resume.arrays
    on_chunk = checkpoint if args.quiet or progress else _Estimate(checkpoint, cfg.stem)  # a bar shows its own
    result = run(drive, progress=progress, window=args.window, on_chunk=on_chunk, resume=arrays, model="ancf")
    raise_if_interrupted()
    # run() got a built drive: count the build here
    result.timing["build_s"] = t_build
    result.timing["wall_s"] = result.timing.get("wall_s", 0.0) + t_build
    result.summary["wall_time_s"] = result.timing["wall_s"]
    return result


def _announcement(drive, resuming: bool) -> str:
    """What the run will take: every step of the time step, the settle phase's and the whole macro
    steps' included (the count the timing reports at the end)."""
    from ..dynamics.simulate import schedule

    o = drive.options
    sch = schedule(t_end=o.t_end, dt=drive.dt, save_dt=o.save_dt, settle_time=o.settle_time)
    return (
        f"simulating {o.t_end:g} s, {drive.scheme} scheme ({drive.scheme_reason}; dt {drive.dt:.3g} s: "
        f"{drive.dt_reason}; "
        f"{sch.n_settle + sch.n_run:,} steps: {sch.n_settle:,} in the "
        f"{o.settle_time:g} s settle phase and {sch.n_run:,} after it; "
        + ("resuming from the checkpoint; " if resuming else "")
        + "compiling first)"
    )


class _Estimate:
    """``on_chunk`` of a run without a progress bar (output not a terminal): after the checkpoint, a line
    with the steps done and the time left once a chunk has been timed (the first one shares the machine
    with the post-processing program's compile), then one a minute; for runs of more than ``min_left_s``."""

    def __init__(self, checkpoint, stem: str, clock=time.monotonic, every_s: float = 60.0, min_left_s: float = 10.0):
        self.checkpoint, self.stem, self.clock = checkpoint, stem, clock
        self.every_s, self.min_left_s = every_s, min_left_s
        self.first: tuple[float, int] | None = None  # (time, macro steps) at the end of the first chunk
        self.last_line = -math.inf

    def __call__(self, chunked, progress, interrupted: bool) -> None:
        self.checkpoint(chunked, progress, interrupted)
        if interrupted or chunked.done(progress):
            return
        now = self.clock()
        if self.first is None:
            self.first = (now, progress.k)
            return
        t0, k0 = self.first
        rate = (progress.k - k0) / max(now - t0, 1e-9)  # macro steps per second
        left = (chunked.n_macro - progress.k) / max(rate, 1e-12)
        if now - self.last_line < self.every_s or (self.last_line == -math.inf and left < self.min_left_s):
            return
        self.last_line = now
        sub = chunked.schedule.substeps
        print(
            f"{self.stem}: {progress.k * sub:,} of {chunked.n_macro * sub:,} steps; about {_duration(left)} left",
            flush=True,
        )


def _duration(seconds: float) -> str:
    if seconds < 90:
        return f"{seconds:.0f} s"
    if seconds < 5400:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


def _write_outputs(result, spec, cfg: Path, out_dir: Path, args, warns: list):
    """Data files, config_used.toml and plots; a plot that fails is recorded in summary.json."""
    import jax

    from .. import __version__
    from ..io import write_run_outputs, write_summary
    from ..outputs.contact import contact_distribution
    from ..outputs.summary import guarded

    last = jax.tree.map(lambda x: x[-1], result.trajectory.states)
    # the last state's geometry comes from the run's post-processing program (no compiling here)
    known = {} if result.derived is None else result.derived.last_inputs()
    contact = guarded(warns, "final contact distribution", lambda: contact_distribution(result.drive, last, **known))
    comparison = guarded(warns, "creep comparison", lambda: _creep_comparison(result))
    extra = {
        "config": str(cfg),
        "t_end": float(spec.solver.t_end),
        "window": args.window,
        "jaxbelt_version": __version__,
        "timing": result.timing,
    }
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

        files.update(
            plot_run(
                result, out_dir, contact=contact, animate=args.animate, exaggeration=args.exaggerate, warnings_=warns
            )
        )
    if len(warns) > n_warnings:  # a plot failed: the summary records it
        write_summary(out_dir / "summary.json", {**result.summary, **extra}, inputs=[cfg])
    stale = remove_stale(out_dir, _PLOTS, files.values())
    if stale and not args.quiet:
        print(f"removed plots of an earlier run that no longer match the data: {', '.join(stale)}")
    return files, comparison


def remove_stale(out_dir: Path, names, written) -> list[str]:
    """Remove the result files ``names`` (a command's own plot names, nothing else) that this run did not
    write (``written``: paths) but an earlier run into ``out_dir`` left; returns their names."""
    kept = {Path(p).name for p in written}
    stale = [n for n in names if n not in kept and (out_dir / n).is_file()]
    for n in stale:
        (out_dir / n).unlink()
    return stale


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
    from ..config.laws import is_angle_law, law_from_spec

    last = 0.0
    for p in spec.pulleys:
        for value in (p.speed, p.speed_rpm, p.torque, p.load, p.power_kw):
            if value is not None and not is_angle_law(value):  # an angle table's knots are angles, not times
                last = max(last, float(law_from_spec(value, p.name).times[-1]))
    return last


# the compared quantities are speeds, torques and tensions: the signals' units
_UNITS = {
    "omega_driven": OMEGA.unit,
    "speed_loss": OMEGA.unit,
    "torque_driver": TORQUE.unit,
    "torque_driven": TORQUE.unit,
    "T_tight": TENSION.unit,
    "T_slack": TENSION.unit,
}


def _print_report(result, stem: str, files: dict, comparison, out_dir: Path) -> None:
    s, timing = result.summary, result.timing
    spec = result.drive.spec
    w = s.get("window_s", [math.nan, math.nan])
    print(
        f"{stem}: {len(spec.pulleys)} pulleys, {spec.belt.n_elements} elements, "
        f"t = {fmt(float(result.ts[-1]))} s, {result.drive.scheme} scheme, dt = {fmt(result.drive.dt, '.3g')} s"
        f"   status: {s['status']}"
    )
    belt = s.get("belt")
    if belt:
        spans = f"; tight span {belt['tight_span']}, slack span {belt['slack_span']}" if belt.get("tight_span") else ""
        print(
            f"belt runs {belt['direction']}: "
            + " -> ".join(belt["travel_order"])
            + spans
            + ("" if belt.get("spans_in_travel_order", True) else " (spans named against the travel)")
        )
    print(
        f"means over t = {fmt(w[0])} .. {fmt(w[1])} s (omega, torque counter-clockwise positive; torque: "
        "exerted by the belt on the pulley)"
    )
    _print_means(s)
    from .report import print_fead_table

    print_fead_table(s)
    if comparison and s["status"] == "ok":
        _print_comparison(comparison, _laws_settle_time(spec), w[0])
    print(
        f"timing: build {timing['build_s']:.2f} s, compile {timing['compile_s']:.2f} s, run {timing['run_s']:.2f} s "
        f"({timing['num_steps']} steps, {timing['us_per_step']:.0f} us/step)"
    )
    print(f"wrote {out_dir}/: " + ", ".join(Path(f).name for f in files.values()))


def _print_means(s: dict) -> None:
    width = max([len(n) for n in s["pulleys"]] + [6])
    print(
        f"  {'pulley':<{width}}  {f'omega [{OMEGA.unit}]':>13}  {f'torque [{TORQUE.unit}]':>12}  "
        f"{'stick [deg]':>11}  {'slip [deg]':>10}"
    )
    for name, p in s["pulleys"].items():
        print(
            f"  {name:<{width}}  {fmt(p['omega_mean'], '13.4f')}  {fmt(p['torque_mean'], '12.3f')}  "
            f"{fmt(p['stick_arc_deg'], '11.1f')}  {fmt(p['slip_arc_deg'], '10.1f')}"
            + (f"   arm angle {fmt(math.degrees(p['arm_angle_mean']), '.2f')} deg" if "arm_angle_mean" in p else "")
            + (f"   slider travel {fmt(1e3 * p['travel_mean'], '.2f')} mm" if "travel_mean" in p else "")
        )
    width = max([len(sp["name"]) for sp in s["spans"]] + [4])
    print(f"  {'span':<{width}}  {f'tension [{TENSION.unit}]':>11}")
    for sp in s["spans"]:
        print(f"  {sp['name']:<{width}}  {fmt(sp['tension_mean'], '11.2f')}")


def _print_comparison(comparison: dict, settle: float, window_start: float) -> None:
    note = (
        f" (the run is not steady yet: its prescribed laws change until t = {settle:g} s)"
        if settle > window_start
        else ""
    )
    print(f"creep theory (steady state) beside the simulation{note}:")
    width = max(len(k) for k in comparison)
    print(f"  {'':<{width}}  {'simulation':>10}  {'theory':>10}")
    for k, v in comparison.items():
        unit = _UNITS.get(k, "deg" if k.endswith("_deg") else "")
        label = k[:-4] if k.endswith("_deg") else k
        print(
            f"  {label + (' [' + unit + ']' if unit else ''):<{width + 6}}"
            f"{fmt(v['simulation'], '10.5g')}  {fmt(v['theory'], '10.5g')}"
        )
