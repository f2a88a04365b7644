"""``jaxbelt identify``: fit configuration keys to a measured signals file; writes identify.json. Exit code 1
(``EXIT_FAILED``) when the fit has not converged (the values are written, without standard errors).

On several processes (``--coordinator``/``--num-processes``/``--process-id`` or ``--distributed``, as for
``sweep``) every process fits, the Jacobians' columns split over them (see ``analysis.optimise``), and
process 0 alone prints and writes identify.json; the others end with exit code 0."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .common import (
    EXIT_FAILED,
    EXIT_OK,
    UsageError,
    check_input_file,
    load_spec,
    output_dir,
    start_processes,
    with_config_context,
)
from .interrupt import raise_if_interrupted

__all__ = ["command"]


def _windows(args, t) -> list[tuple[float, float]]:
    """``--window T0:T1`` fit stages: finite, increasing, and holding some of the record's samples ``t``."""
    windows = []
    lo, hi = float(t[0]), float(t[-1])
    for w in args.window:
        try:
            a, b = (float(x) for x in w.split(":"))
        except ValueError:
            raise UsageError(f"--window {w}: expected T0:T1 in seconds") from None
        if not (math.isfinite(a) and math.isfinite(b) and a < b):
            raise UsageError(f"--window {w}: need finite times T0 < T1 [s]")
        if int(((t >= a) & (t <= b)).sum()) < 2:
            raise UsageError(f"--window {w}: holds fewer than 2 of the record's samples (it spans {lo:g} ... {hi:g} s)")
        windows.append((a, b))
    return windows


def _sigma(args) -> dict[str, float]:
    sigma = {}
    for item in args.sigma:
        col, sep, level = item.partition("=")
        if col.strip() in sigma:
            raise UsageError(f"--sigma {item}: column {col.strip()!r} has a noise level already; give each column once")
        try:
            sigma[col.strip()] = float(level)
        except ValueError:
            sep = ""
        if not sep:
            raise UsageError(f"--sigma {item}: expected COLUMN=LEVEL, e.g. omega:driven=0.05")
    return sigma


def _search_box(args, drive) -> tuple[list[str], dict]:
    """``--fit`` keys and their starting values (the configuration's) and bounds (``--bounds``)."""
    from ..analysis.parameters import get_parameter

    keys = [k.strip() for k in args.fit.split(",") if k.strip()]
    twice = sorted({k for k in keys if keys.count(k) > 1})
    if twice:
        raise UsageError(f"--fit {args.fit}: {', '.join(twice)} given more than once; name each key once")
    fit = {}
    for k in keys:
        v = float(get_parameter(drive, drive.params, k))
        fit[k] = (v, (v / args.bounds, v * args.bounds))
    return keys, fit


@with_config_context
def command(args, cfg: Path) -> int:
    group = start_processes(args)  # before anything starts JAX's backend
    import warnings

    from ..config.build import build_drive
    from ..analysis.identify import Measurement, identify
    from ..io import read_signals_csv

    quiet = args.quiet or not group.writes  # the others compute silently
    if not args.measured:
        raise UsageError("give --measured FILE.csv (signals.csv layout)")
    if not args.fit:
        raise UsageError("give --fit KEYS, e.g. --fit belt.E,belt.eta,contact.mu")
    meas_path = check_input_file(args.measured, "measured signals file")
    data = read_signals_csv(meas_path)
    t = data.pop("t")
    windows, sigma = _windows(args, np.asarray(t)), _sigma(args)
    spec = load_spec(cfg, args.t_end, args.scheme)
    drive = build_drive(spec)
    keys, fit = _search_box(args, drive)
    stages = windows + [(float(t[0]), float(t[-1]))] if windows else None  # the windows, then the whole record
    out_dir = output_dir(args, cfg, "_identify")
    if not quiet:  # the first iteration compiles the simulation and its Jacobian: say so
        print(
            f"{cfg.stem}: fitting {', '.join(keys)} to {len(t)} samples of {len(data)} signal(s) "
            f"({args.method}, at most {args.iterations} iterations per window; compiling first) ...",
            flush=True,
        )
    with warnings.catch_warnings():
        if not group.writes:  # process 0 warns
            warnings.simplefilter("ignore")
        res = identify(
            drive,
            Measurement(t, data, sigma=sigma or None),
            fit,
            method=args.method,
            iterations=args.iterations,
            t_end=spec.solver.t_end,
            windows=stages,
            verbose=not quiet,
            model=args.model,
        )
    raise_if_interrupted()
    if not group.writes:
        return EXIT_OK
    _write_and_report(res, keys, cfg, meas_path, out_dir)
    return EXIT_OK if res.converged else EXIT_FAILED  # values still moving: no result to sign


def _write_and_report(res, keys: list[str], cfg: Path, meas_path: Path, out_dir: Path) -> None:
    import json

    from ..io import atomic_write, to_jsonable

    with atomic_write(out_dir / "identify.json", "w", inputs=[cfg, meas_path]) as fh:
        json.dump(to_jsonable(res.as_dict()), fh, indent=2)
    for k in keys:
        if k in res.at_bound:
            err = f"at its {res.at_bound[k]} bound"
        elif not res.converged:
            err = "(no standard error: not converged)"
        else:
            err = f"+- {res.std_errors[k]:.2g}"
            part = res.error_budget.get(k, {})
            if "time_step" in part:  # what the error is made of (docs/cli.md)
                err += f" (noise {part['noise']:.2g}, time step {part['time_step']:.2g})"
        print(f"  {k} = {res.values[k]:.6g} {err} (start {res.initial[k]:.6g})")
    fit_ = res.misfit
    print(
        f"  misfit: reduced chi^2 {fit_['reduced_chi2']:.3g} (noise {fit_['noise']}); RMS residual "
        + ", ".join(f"{n} {v:.3g}" for n, v in fit_["rms_residual"].items())
    )
    done = "converged" if res.converged else "NOT CONVERGED"
    print(
        f"{cfg.stem}: identification finished in {res.iterations} iterations, {done} ({_cost(res.timing)}); "
        f"results in {out_dir}"
    )
    print(f"  {res.convergence['reason']}")


def _cost(tm: dict) -> str:
    """What the fit evaluated; in forward-run equivalents only when a forward run was timed (their unit)."""
    import math

    parts = [f"{tm['forward_runs']} forward runs"]
    for kind in ("jacobian", "gradient"):
        if tm.get(f"{kind}s"):
            ratio = tm[f"{kind}_ratio"]
            each = f"{ratio:.2g} runs each" if math.isfinite(ratio) else f"{tm[f'{kind}_s']:.2g} s each"
            parts.append(f"{tm[f'{kind}s']} {kind}s at {each}")
    total = tm["forward_run_equivalents"]
    return ", ".join(parts) + (f": {total:.3g} forward-run equivalents" if math.isfinite(total) else "")
