"""The implicit scheme's time step, chosen for accuracy (numpy only: the configuration layer calls it before
anything is compiled).

The belt bounds no step of the implicit scheme (``belt.implicit``), so the step follows from what must be
resolved, each with ``STEPS_PER_PERIOD`` steps per period:

* ``solver.max_frequency``, the highest frequency the user wants in the results (default 250 Hz: span modes
  and the rotational modes of accessory drives);
* the highest engine order at the highest prescribed crank speed (an excitation's period);
* the travel of a belt point per step, at most ``TRAVEL_FRACTION`` of the contact-point spacing: beyond
  that the contact points skip across a pulley's entry and the numerical entry loss grows (the contact issue
  measured x2.3 at 80 elements, x8.6 at 160 once ``h v`` neared the spacing), and the step fails (measured on
  the accessory example running at 4,000 rpm, 33.5 m/s, spacing 7 mm: ``h v`` = 0.48 spacing diverged, 0.36
  ran with a contact residual of 0.04 at its worst step, 0.24 ran with 7e-3; at 3,200 rpm 0.38 left 0.09). A
  run-up through a span's resonance needs more: the example's 2,400 -> 3,000 rpm ramp, where the water pump - A/C
  span swings (the explicit reference: its tension 580 N peak-to-peak) ran away at 0.25 (7.2e-5 s, to 46 kN at
  2,680 rpm) and at 0.21 (6e-5 s), and followed the reference at 0.17 (5e-5 s: the span's peak-to-peak tension
  within 8 % window by window, its peak 1 %; contact residual 3e-2 at its worst step). It is the step's stability,
  not the contact solve's: at 0.25 with 16 contact iterations the contact converged (2e-7) and the run still ran
  away; with 80 elements (spacing 10.3 mm) the same 7.2e-5 s (0.175 of it) ran.

The smallest wins and is reported with its reason. ``solver.dt`` overrides the rule.
"""

from __future__ import annotations

import dataclasses

__all__ = ["STEPS_PER_PERIOD", "TRAVEL_FRACTION", "StepChoice", "implicit_time_step", "explicit_step_reason"]

# 80, not 40 (until 2026-11-28): at 40 per period of 250 Hz (1e-4 s) the accessory example's alternator slip arc was
# +6.8 deg from the explicit reference and Benchmark A's two span-tension amplitudes -26 / -20 % at 120 elements;
# at 80 (5e-5 s) +2.8 deg and -7.3 / -5.3 %, for +14 ... +30 % CPU. The error is the scheme's (it vanishes as h -> 0),
# not the contact solve's (converged to 1e-7 at both steps).
STEPS_PER_PERIOD = 80
TRAVEL_FRACTION = 0.17  # a belt point's travel per step, at most this fraction of the contact-point spacing


@dataclasses.dataclass(frozen=True)
class StepChoice:
    dt: float
    reason: str  # what bounds the step, for the summary and the CLI


def implicit_time_step(
    *,
    max_frequency: float,
    excitation_frequency: float | None,
    excitation_text: str = "",
    belt_speed: float | None,
    point_spacing: float,
    save_dt: float,
) -> StepChoice:
    """The accuracy step (``StepChoice``): see the module docstring. ``excitation_frequency``: the highest engine
    order's frequency at the highest crank speed [Hz] (None: no orders); ``belt_speed``: the largest belt speed
    a prescribed driver speed gives [m/s] (None: torque-driven, unknown before the run); ``point_spacing``: the
    stress-free belt length between contact points [m]."""
    n = STEPS_PER_PERIOD
    options = [(1.0 / (n * max_frequency), f"{n} steps per period of solver.max_frequency = {max_frequency:g} Hz")]
    if excitation_frequency is not None and excitation_frequency > 0:
        options.append(
            (
                1.0 / (n * excitation_frequency),
                f"{n} steps per period of {excitation_text} ({excitation_frequency:.4g} Hz)",
            )
        )
    if belt_speed is not None and belt_speed > 0:
        options.append(
            (
                TRAVEL_FRACTION * point_spacing / belt_speed,
                f"a belt point travels at most {TRAVEL_FRACTION:g} of the contact-point spacing "
                f"({1e3 * point_spacing:.3g} mm) per step "
                f"at the top belt speed {belt_speed:.3g} m/s",
            )
        )
    dt, reason = min(options)
    if save_dt < dt:
        dt, reason = save_dt, f"solver.save_dt = {save_dt:g} s (states are saved once per step at most)"
    return StepChoice(dt=float(dt), reason=reason)


def explicit_step_reason(limit: float) -> str:
    """The explicit scheme's default step (0.9 x ``limit``), in words."""
    return f"0.9 x the explicit scheme's stability limit {limit:.3g} s of this mesh"
