"""``jaxbelt span-tension``: a span's tension from its measured transverse frequency (sonic tension meter),
or its frequencies at a given tension; prints the figures, writes span_tension.json."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

from .common import EXIT_FAILED, EXIT_OK, UsageError, fmt, load_spec, output_dir, with_config_context

__all__ = ["command"]


def belt_speed(drive, args) -> float:
    """The belt speed [m/s]: ``--belt-speed``, or ``--speed`` (driver rpm) times the speed driver's radius."""
    if args.belt_speed is not None:
        return float(args.belt_speed)
    if not args.speed:
        return 0.0
    drivers = [i for i, k in enumerate(drive.model.kinematic) if k]
    if len(drivers) != 1:
        raise UsageError("--speed needs exactly one pulley with a prescribed speed; give --belt-speed [m/s] instead")
    return float(args.speed) * 2 * math.pi / 60 * float(drive.params.pulleys.radius[drivers[0]])


@with_config_context
def command(args, cfg: Path) -> int:
    from ..analysis.span_tension import span_frequency, span_of, span_tension
    from ..config.build import build_drive
    from ..io import atomic_write, to_jsonable

    if (args.spectrum is None) != (args.fit is None):
        raise UsageError("--spectrum and --fit go together: the measured modes and the parameter they identify")
    if args.spectrum is not None:
        return _fit(args, cfg)
    if (args.frequency is None) == (args.tension is None):
        raise UsageError("give either --frequency F (Hz, measured) or --tension T (N), or --spectrum with --fit")
    spec = load_spec(cfg, args.t_end, args.scheme)
    out_dir = output_dir(args, cfg, "_span_tension", results=("span_tension.json",))
    drive = build_drive(spec)
    length = None if args.span_length is None else args.span_length / 1000
    span = span_of(drive, args.span, length=length, speed=belt_speed(drive, args))
    where = "given" if length is not None else "installation statics"
    moving = f"belt at {span.speed:.3g} m/s" if span.speed else "belt at rest"
    head = f"{cfg.stem}: span {span.name}, {1000 * span.length:.2f} mm ({where}), {moving}"
    if args.frequency is not None:
        r = span_tension(
            span,
            args.frequency,
            args.mode,
            frequency_uncertainty=args.frequency_uncertainty,
            length_uncertainty=args.length_uncertainty / 1000,
        )
        result = dict(kind="tension from frequency", **r.as_dict())
        strain = r.tension / float(drive.params.belt.EA)
        if not 0.0 < strain <= MAX_STRAIN:  # no belt carries it: a frequency, mode or span that is not this one's
            result["status"] = (
                f"implausible: a tension of {r.tension:.4g} N is a strain of {strain:.3g} on this belt (EA "
                f"{float(drive.params.belt.EA):.4g} N; a belt is installed below {MAX_STRAIN:.0%}): check the "
                "frequency (Hz), the mode number and the span"
            )
        plus = f" +- {fmt(r.uncertainty, '.3g')} N" if r.uncertainty > 0 else ""
        print(f"  mode {r.mode} at {fmt(r.frequency, '.5g')} Hz: tension {fmt(r.tension, '.5g')} N{plus}")
        if not args.quiet:
            print(
                f"  plain string 4 m0 L^2 f^2 / n^2: {fmt(r.string_tension, '.5g')} N; with the mass per current "
                f"length: {fmt(r.current_mass_tension, '.5g')} N; with bending and the ends' contact compliance: "
                f"{fmt(r.static_tension, '.5g')} N"
                + (f"; at the belt speed: {fmt(r.tension, '.5g')} N" if span.speed else "")
            )
            print(
                f"  1 % of frequency is {fmt(r.dT_df * 0.01 * r.frequency / r.tension * 100, '.3g')} % of tension, "
                f"1 mm of span length {fmt(r.dT_dL * 1e-3 / r.tension * 100, '.3g')} %"
            )
    else:
        modes = sorted({1, 2, 3, args.mode})
        freqs = {n: span_frequency(span, args.tension, n) for n in modes}
        result = dict(
            kind="frequency from tension",
            span=span.name,
            tension=float(args.tension),
            length=span.length,
            speed=span.speed,
            mode=args.mode,
            frequency=freqs[args.mode],
            frequencies={str(n): f for n, f in freqs.items()},
        )
        print(head)
        listed = ", ".join(f"f{n} {fmt(f, '.5g')} Hz" for n, f in freqs.items())
        print(f"  at {fmt(args.tension, '.5g')} N: {listed}")
    result.update(config=str(cfg), length_from=where)
    out_dir.mkdir(parents=True, exist_ok=True)
    with atomic_write(out_dir / "span_tension.json", "w", inputs=[cfg]) as fh:
        json.dump(to_jsonable(result), fh, indent=1)
    if not args.quiet:
        print(f"{cfg.stem}: written to {out_dir / 'span_tension.json'}")
    if "status" in result:
        print(f"jaxbelt span-tension: {result['status']}", file=sys.stderr)
        return EXIT_FAILED
    return EXIT_OK


# The largest strain a belt is installed at (the configuration refuses more, config/belt.py).
MAX_STRAIN = 0.2


def _spectrum(text: str) -> dict[int, float]:
    """``1=80.2,2=161`` -> {1: 80.2, 2: 161.0}; a malformed entry refused, named."""
    out: dict[int, float] = {}
    for item in text.split(","):
        n, sep, f = item.partition("=")
        try:
            mode, freq = int(n), float(f)
        except ValueError:
            mode, freq = 0, math.nan
        if not sep or mode < 1 or not (math.isfinite(freq) and freq > 0) or mode in out:
            raise UsageError(f"--spectrum {text!r}: {item!r} must be MODE=HZ (mode a whole number >= 1, once each)")
        out[mode] = freq
    return out


def _fit(args, cfg: Path) -> int:
    """``--spectrum ... --fit KEY``: the parameter from the span's measured modes (``analysis.span_spectrum``)."""
    from ..analysis.span_spectrum import fit_span_spectrum
    from ..config.build import build_drive
    from ..io import atomic_write, to_jsonable

    measured = _spectrum(args.spectrum)
    if args.frequency is not None or args.tension is not None or args.speed or args.belt_speed:
        raise UsageError("--spectrum fits the belt at rest: no --frequency, --tension, --speed or --belt-speed with it")
    spec = load_spec(cfg, args.t_end, args.scheme)
    out_dir = output_dir(args, cfg, "_span_tension", results=("span_fit.json",))
    drive = build_drive(spec)
    sigma = args.frequency_uncertainty if args.frequency_uncertainty > 0 else 0.1
    r = fit_span_spectrum(drive, args.span, measured, args.fit, frequency_uncertainty=sigma)
    print(
        f"{cfg.stem}: span {r.span} ({1000 * r.length:.2f} mm at the fit), {len(measured)} mode(s) at rest, "
        f"each +- {sigma:g} Hz"
    )
    for n, m in r.modes.items():
        print(f"  mode {n} at {fmt(m['frequency'], '.5g')} Hz: tension {fmt(m['tension'], '.5g')} N")
    print(f"  span tension {fmt(r.tension, '.5g')} +- {fmt(r.tension_uncertainty, '.3g')} N")
    print(f"  {r.key} = {fmt(r.value, '.6g')} +- {fmt(r.uncertainty, '.3g')} (from {fmt(r.initial, '.6g')})")
    if not r.consistent:
        print(
            f"jaxbelt span-tension: warning: the modes' tensions disagree (chi2 {r.chi2:.3g} for {len(measured) - 1} "
            "degree(s) of freedom): check the span length, the belt's EI, or the mode numbers",
            file=sys.stderr,
        )
    out_dir.mkdir(parents=True, exist_ok=True)
    with atomic_write(out_dir / "span_fit.json", "w", inputs=[cfg]) as fh:
        json.dump(to_jsonable(dict(r.as_dict(), config=str(cfg))), fh, indent=1)
    if not r.converged:
        print(f"jaxbelt span-tension: the fit did not converge in {r.iterations} Newton steps", file=sys.stderr)
    return EXIT_OK if r.converged else EXIT_FAILED
