"""Validation of a ``DriveSpec``: every check ``build_drive`` makes before it builds anything.

Plain Python and numpy only: a bad configuration is refused with a ``ConfigError`` naming the key,
the value and what is allowed before any JAX array is made or anything is compiled. What the checks
compute on the way (belt numbers, the layout read in numpy, the installed length, the step limit) is
handed to the build as a :class:`Checked` record, so that nothing is worked out twice.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._errors import ConfigError
from ..contact.friction import FRICTION_LAWS
from ..geometry.check import check_belt_path
from ..geometry.path import path_reading
from .checks import _integer, _is_number, _non_negative, _pair, _positive, _pulley_label, _require, _warn
from .direction import _travel
from .laws import _RPM, _check_law, _driver_law, _law_minimum, _nominal_speeds, law_from_spec
from .resources import _check_run_size
from .spec import BeltSpec, ContactSpec, DriveSpec, PulleySpec, SolverSpec, TensionerSpec
from ..pulleys.carriers import tensioner_kinds
from .carrier_keys import check_riders, check_stops_contain_installed, check_tensioner, installation_tension
from .carrier_keys import installed_contact_shortening
from .belt import (
    _belt_numbers,
    _check_installed_effective_length,
    _check_installed_length,
    installed_state_definition,
)
from .friction_keys import check_law_keys
from .excitation import check_excitation, check_pulley_mu

__all__ = ["Checked", "validate_spec", "check_spec", "installed_state_definition"]

# Limits that catch typos (an extra zero or three) before they turn into an out-of-memory crash or a
# run that never ends. Real drives stay far below them (run size and memory: see resources.py).
MAX_LCP_ITERATIONS = 1_000  # solver.lcp_iterations (sweeps per step; 8 is typical)


@dataclass(frozen=True)
class Checked:
    """What validation found, in the listed pulley order: the build starts from it."""

    belt: dict  # EA, EI, m (mass per length), cd (axial damping), inner, back (offsets)
    gravity: tuple[float, float]
    centers: np.ndarray  # (k, 2) pulley centres [m]
    radii: np.ndarray  # (k,) radii at the belt axis [m]
    sides: tuple[int, ...]  # wrap side: +1 inner, -1 back
    travel: int  # +1 counter-clockwise, -1 clockwise
    order: list[int]  # listed pulleys in model order
    orientation: int | None  # orientation forced on the built path (None: detected)
    along: bool  # spans run in the model order
    source: str  # what set the sense of travel
    omega_nominal: np.ndarray  # nominal speeds for power_kw (nan where unused)
    L_path: float  # installed path length (numpy reading) [m]
    stretch: float  # L_path / stress-free length
    installation_tension: float | None = None  # with belt.installed_effective_length: what the tensioner holds
    contact_shortening: float = 0.0  # and the path the contact compliance takes at that tension [m]
    dt: float | None = None  # the time step (solver.dt, the implicit scheme's accuracy step, or None: the
    dt_reason: str = ""  # explicit limit, computed on the built parameters) and why it is what it is
    scheme: str = "explicit"  # the scheme that runs ("auto" resolved: resolve_scheme) and why
    scheme_reason: str = ""


def validate_spec(spec: DriveSpec) -> Checked:
    """Every check of ``spec``, in the order the messages are expected (first problem first)."""
    _check_spec_types(spec)
    b = _belt_numbers(spec.belt)
    _check_contact(spec.contact)
    _check_solver(spec.solver)
    g = _check_names(spec)
    centers, radii, sides, radii_flipped = [], [], [], []
    for i, p in enumerate(spec.pulleys):
        ctr = _check_pulley(i, p)
        offset = b["inner"] if p.wrap == "inner" else b["back"]
        centers.append(ctr)
        radii.append(p.radius + offset)
        radii_flipped.append(p.radius + (b["back"] if p.wrap == "inner" else b["inner"]))
        sides.append(1 if p.wrap == "inner" else -1)
    check_riders(spec)
    _require(
        any(p.role == "driver" for p in spec.pulleys),
        "pulleys.role",
        [p.role for p in spec.pulleys],
        "a drive needs one driver",
    )
    centers_np, radii_np = np.asarray(centers, dtype=float), np.asarray(radii, dtype=float)
    with np.errstate(all="ignore"):  # absurd coordinates overflow: refused below, not warned about
        _check_layout(spec, centers_np, radii_np, sides, radii_flipped)
        for i, p in enumerate(spec.pulleys):
            if p.tensioner is not None:
                check_stops_contain_installed(_pulley_label(i, p), p.tensioner, centers[i])
        # the sense of travel; with belt.direction the pulleys are put in travel order
        listed, L_path = path_reading(centers_np, radii_np, sides)  # the length the built path will have
        travel, order, orientation, along, source = _travel(spec, listed, sides)
    _check_span_labels([spec.pulleys[i].name for i in order])
    omega_nominal = _nominal_speeds(spec, radii_np)  # for power_kw
    _require(
        math.isfinite(L_path) and L_path > 0,
        "pulleys.center",
        [tuple(x) for x in centers],
        f"give a belt path of length {L_path!r} m; centres and radii must be of a realistic size",
    )
    tension, shortening = None, 0.0
    if spec.belt.installed_effective_length is not None:
        tension = installation_tension(spec, centers_np, radii_np, sides, np.asarray(g, dtype=float))
        shortening = installed_contact_shortening(spec, centers_np, radii_np, sides, tension)
        _check_installed_effective_length(spec.belt, L_path)
    L0, stretch = _check_installed_length(spec.belt, b["EA"], L_path, tension, shortening)
    _check_belt_speed(spec, b, radii_np, b["EA"] * (stretch - 1.0))
    _check_contact_sink(spec, radii_np, b["EA"] * (stretch - 1.0))
    _check_running_start(spec)
    scheme, scheme_reason = resolve_scheme(
        spec, _explicit_limit(spec, b, L0, spec.solver.implicit_damping is True), radii_np, L0
    )
    dt_limit = _check_time_step(spec, b, L0, scheme)
    n = spec.belt.n_elements
    dt, dt_reason = _time_step(spec, dt_limit, radii_np, L0, scheme)
    _check_run_size(
        spec,
        dt,
        n,
        len(spec.pulleys),
        n * spec.contact.points_per_element,
    )
    return Checked(
        belt=b,
        gravity=g,
        centers=centers_np,
        radii=radii_np,
        sides=tuple(sides),
        travel=travel,
        order=order,
        orientation=orientation,
        along=along,
        source=source,
        omega_nominal=omega_nominal,
        L_path=L_path,
        stretch=stretch,
        installation_tension=tension,
        contact_shortening=shortening,
        dt=dt if spec.solver.dt is not None or scheme == "implicit" else None,
        dt_reason=dt_reason,
        scheme=scheme,
        scheme_reason=scheme_reason,
    )


# "auto" runs the implicit scheme where its step is at least this many times the explicit one: its step costs
# 2-3.5 x an explicit one (measured: 0.95 / 0.26-0.53 ms on the accessory example, 0.42 / 0.13 ms on Benchmark A
# at 60 elements) and its programs take longer to compile
AUTO_STEP_RATIO = 4.0


def implicit_scheme(s: SolverSpec) -> bool:
    """The spec asks for the implicit scheme (``solver.scheme = "implicit"`` or ``solver.implicit_stiffness``);
    ``"auto"`` is resolved with the drive (``resolve_scheme``)."""
    return s.scheme == "implicit" or s.implicit_stiffness is True


def resolve_scheme(spec: DriveSpec, explicit_limit: float, radii: np.ndarray, L0: float) -> tuple[str, str]:
    """``("explicit" | "implicit", why)``: the scheme asked for, or for ``"auto"`` the implicit one where its
    accuracy step is at least ``AUTO_STEP_RATIO`` x the explicit one (0.9 x ``explicit_limit``); with a given
    ``solver.dt`` "auto" keeps the explicit scheme (the step then must be below its limit)."""
    s = spec.solver
    if implicit_scheme(s):
        return "implicit", "solver.scheme = implicit"
    if s.scheme == "explicit":
        return "explicit", "solver.scheme = explicit"
    if s.dt is not None:
        return "explicit", "solver.scheme = auto with a given solver.dt: explicit"
    explicit = 0.9 * explicit_limit
    ratio = _implicit_step(spec, radii, L0)[0] / explicit if explicit > 0 else math.inf
    if ratio >= AUTO_STEP_RATIO:
        return "implicit", f"auto: its step is {ratio:.3g} x the explicit one ({explicit:.3g} s)"
    return "explicit", (
        f"auto: the implicit step would be only {ratio:.3g} x the explicit one (< {AUTO_STEP_RATIO:g}: no faster)"
    )


def _time_step(spec: DriveSpec, dt_limit: float, radii: np.ndarray, L0: float, scheme: str) -> tuple[float, str]:
    """The step and its reason: ``solver.dt`` as given, the implicit scheme's accuracy step
    (``dynamics.time_step``), or 0.9 x the explicit stability limit."""
    s = spec.solver
    if s.dt is not None:
        return float(s.dt), "solver.dt as given"
    from ..dynamics.time_step import explicit_step_reason

    if scheme == "explicit":
        return 0.9 * dt_limit, explicit_step_reason(dt_limit)
    return _implicit_step(spec, radii, L0)


def _implicit_step(spec: DriveSpec, radii: np.ndarray, L0: float) -> tuple[float, str]:
    """The implicit scheme's accuracy step and its reason (``dynamics.time_step``)."""
    from ..dynamics.time_step import implicit_time_step
    from .excitation import order_entries

    s = spec.solver

    speed, f_exc, text = None, None, ""
    for i, p, _, omega in _driver_speeds(spec):
        speed = max(speed or 0.0, omega * float(radii[i]))
        orders = [e[0] for e in order_entries(_pulley_label(i, p), p)]
        if orders and omega > 0:
            f = max(orders) * omega / (2.0 * math.pi)
            if f_exc is None or f > f_exc:
                f_exc, text = f, f"engine order {max(orders):g} at {omega / _RPM:.4g} rpm"
    choice = implicit_time_step(
        max_frequency=float(s.max_frequency),
        excitation_frequency=f_exc,
        excitation_text=text,
        belt_speed=speed,
        point_spacing=L0 / (spec.belt.n_elements * spec.contact.points_per_element),
        save_dt=float(s.save_dt),
    )
    return choice.dt, choice.reason


def _driver_speeds(spec: DriveSpec):
    """``(index, pulley, key, largest |speed| [rad/s])`` of each driver whose speed is prescribed."""
    for i, p in enumerate(spec.pulleys):
        if p.role != "driver" or (p.speed is None and p.speed_rpm is None):
            continue
        key, values = _driver_law(p)
        if values.size:
            yield i, p, key, float(np.max(np.abs(values))) * (_RPM if key == "speed_rpm" else 1.0)


def _check_belt_speed(spec: DriveSpec, b: dict, radii: np.ndarray, T0: float) -> None:
    """A speed driver's largest prescribed belt speed below the transverse wave speed of the installed belt,
    sqrt(T0 / m'): there the centrifugal term m' v^2 eats the whole installed tension, the hub loads of a
    free-running belt 2 (T0 - m' v^2) vanish and the belt lifts off every pulley (the axial wave speed
    sqrt(EA / m') is far above). Refused here rather than after a long compile and an absurd run."""
    m = b["m"] / (1.0 + max(T0, 0.0) / b["EA"])  # per current length (outputs.theory.mass_per_current_length)
    c = math.sqrt(max(T0, 0.0) / m)
    for i, p, key, omega in _driver_speeds(spec):
        if c <= 0:
            continue
        unit = _RPM if key == "speed_rpm" else 1.0
        v = omega * float(radii[i])
        _require(
            v < c,
            f"{_pulley_label(i, p)}.{key}",
            getattr(p, key),
            f"gives a belt speed of {v:.4g} m/s, at or above the installed belt's wave speed sqrt(T0/m') = "
            f"{c:.4g} m/s (installed tension T0 {T0:.4g} N, m' {m:.4g} kg/m per installed length): the belt would "
            f"lift off every pulley; check the units (rad/s or rpm), keep the speed below "
            f"{c / float(radii[i]) / unit:.4g}, or raise the installed tension",
        )


def _check_running_start(spec: DriveSpec) -> None:
    """``solver.start = "running"`` needs one driver with a prescribed speed that moves at t = 0."""
    if spec.solver.start != "running":
        return
    drivers = [
        (i, p)
        for i, p in enumerate(spec.pulleys)
        if p.role == "driver" and (p.speed is not None or p.speed_rpm is not None)
    ]
    _require(
        len(drivers) == 1 and all(p.role != "driver" or (p.speed, p.speed_rpm) != (None, None) for p in spec.pulleys),
        "solver.start",
        spec.solver.start,
        "a running start needs exactly one driver, with a prescribed speed ('speed' or 'speed_rpm'), to set the "
        'belt speed; use start = "rest" for a torque-driven drive',
    )
    i, p = drivers[0]
    key = "speed" if p.speed is not None else "speed_rpm"
    law = law_from_spec(getattr(p, key), _pulley_label(i, p) + "." + key)
    _require(
        abs(float(np.asarray(law.values)[0])) > 0,
        f"{_pulley_label(i, p)}.{key}",
        getattr(p, key),
        'is 0 at t = 0, so a running start (solver.start = "running") would start at rest: give the '
        'operating speed from t = 0 (e.g. speed_rpm = 800) or start = "rest"',
    )


def check_spec(spec: DriveSpec) -> Checked:
    """Every check ``build_drive`` makes of ``spec``, building nothing (a sweep checks each grid point so); the
    checked facts (``Checked``: the scheme, the step and its reason among them)."""
    return validate_spec(spec)


def _check_spec_types(spec) -> None:
    """The spec's parts are the spec classes (a Python-built spec may hold anything)."""
    _require(isinstance(spec, DriveSpec), "spec", type(spec).__name__, "must be a jaxbelt.DriveSpec")
    for key, cls in (("belt", BeltSpec), ("contact", ContactSpec), ("solver", SolverSpec)):
        _require(isinstance(getattr(spec, key), cls), key, getattr(spec, key), f"must be a {cls.__name__}")
    _require(
        isinstance(spec.pulleys, (list, tuple)) and len(spec.pulleys) >= 2,
        "pulleys",
        len(spec.pulleys) if isinstance(spec.pulleys, (list, tuple)) else spec.pulleys,
        "a drive needs at least 2 pulleys",
    )
    for i, p in enumerate(spec.pulleys):
        _require(isinstance(p, PulleySpec), f"pulleys[{i}]", p, "must be a PulleySpec")
        _require(
            p.tensioner is None or isinstance(p.tensioner, TensionerSpec),
            _pulley_label(i, p) + ".tensioner",
            p.tensioner,
            "must be a TensionerSpec (or None)",
        )


# The largest friction coefficient accepted: rubber on steel grips with 0.2-1 (a poly-V wedge multiplies it by
# itself); 10 holds any wrap (e^(10 pi) ~ 4e13) and keeps exp(mu phi) of the theory finite (an audit's 1e6 did not).
MAX_MU = 10.0


def _check_contact(c: ContactSpec) -> None:
    _require(
        _is_number(c.mu) and math.isfinite(c.mu) and c.mu > 0,
        "contact.mu",
        c.mu,
        "must be a finite number > 0 (a frictionless belt cannot transmit torque)",
    )
    _require(
        c.mu <= MAX_MU,
        "contact.mu",
        c.mu,
        f"is beyond any belt's grip (rubber on steel: 0.2-1; the poly-V wedge is applied on top); at most {MAX_MU:g}",
    )
    for key in ("stiffness", "stiffness_per_area"):  # either, or neither: the default from the section
        if getattr(c, key) is not None:
            _positive(f"contact.{key}", getattr(c, key))
    _require(
        c.stiffness is None or c.stiffness_per_area is None,
        "contact.stiffness/stiffness_per_area",
        (c.stiffness, c.stiffness_per_area),
        "give one: stiffness per unit belt length [N/m^2] or per contact area [N/m^3] (times belt.width)",
    )
    _non_negative("contact.damping", c.damping)
    _require(
        isinstance(c.friction_law, str) and c.friction_law in FRICTION_LAWS,
        "contact.friction_law",
        c.friction_law,
        "must be one of " + ", ".join(map(repr, FRICTION_LAWS)),
    )
    _positive("contact.nu_s", c.nu_s)
    check_law_keys(c, _require)
    _require(
        not isinstance(c.points_per_element, bool) and c.points_per_element in (1, 2, 3),
        "contact.points_per_element",
        c.points_per_element,
        "must be 1, 2 or 3 (with 4 the points over-constrain the element's 4 coordinates per direction and the "
        "contact solve does not converge)",
    )


MODELS = ("ancf", "spans")  # the tiers (solver.model, --model, model=)


def resolve_model(drive, model: str | None, what: str) -> str:
    """The tier an analysis runs on: ``model`` if given, else the ``solver.model`` of ``drive`` (a Drive or a
    DriveSpec); refused by name if it is neither tier."""
    if model is None:
        spec = getattr(drive, "spec", drive)
        model = getattr(getattr(spec, "solver", None), "model", "ancf")
    if model not in MODELS:
        raise ConfigError(f"{what}: model = {model!r}: must be 'ancf' or 'spans'")
    return model


def _check_solver(s: SolverSpec) -> None:
    if s.dt is not None:
        _positive("solver.dt", s.dt)
    _positive("solver.t_end", s.t_end)
    _positive("solver.save_dt", s.save_dt)
    _require(
        s.save_dt <= s.t_end,
        "solver.save_dt",
        s.save_dt,
        f"is longer than solver.t_end = {s.t_end:g} s: the run would save only its initial state and every "
        f"mean would be of t = 0; use save_dt <= t_end (e.g. {s.t_end / 100:.3g} s)",
    )
    _non_negative("solver.settle_time", s.settle_time)
    _non_negative("solver.settle_damping", s.settle_damping)
    _integer("solver.lcp_iterations", s.lcp_iterations, 1, MAX_LCP_ITERATIONS)
    for key in ("implicit_damping", "implicit_stiffness", "expect_steady"):
        _require(isinstance(getattr(s, key), bool), f"solver.{key}", getattr(s, key), "must be true or false")
    _require(
        _is_number(s.relaxation) and 0 < s.relaxation <= 1.0, "solver.relaxation", s.relaxation, "must be in (0, 1]"
    )
    _require(
        s.model in MODELS,
        "solver.model",
        s.model,
        'must be "ancf" (the ANCF belt) or "spans" (span springs, creep and gross slip per wrap: docs/spans.md)',
    )
    _require(
        s.scheme in ("auto", "explicit", "implicit"),
        "solver.scheme",
        s.scheme,
        'must be "auto" (the implicit scheme where its step is several times the explicit one), "explicit" (step '
        'from the belt\'s stability limit) or "implicit" (step chosen for accuracy; docs/config.md)',
    )
    _positive("solver.max_frequency", s.max_frequency)
    _require(
        s.start in ("rest", "running"),
        "solver.start",
        s.start,
        'must be "rest" (from standstill: a start-up) or "running" (at the driver\'s speed at t = 0: a duty point)',
    )


def _check_names(spec: DriveSpec) -> tuple[float, float]:
    """Pulley names, gravity and belt.direction; returns the gravity vector."""
    names = [p.name for p in spec.pulleys]
    for i, name in enumerate(names):
        _require(
            isinstance(name, str) and name.strip() != "" and not any(ch in name for ch in ".,="),
            f"pulleys[{i}].name",
            name,
            "must be a non-empty string without '.', ',' or '=' (it is used in keys such as pulleys.<name>.load "
            "and in options such as --torque <name>=Q)",
        )
        _require(
            name == name.strip() and name.isprintable(),
            f"pulleys[{i}].name",
            name,
            f"must not start or end with spaces nor hold control characters such as a line break (the command "
            f"line strips them, and a CSV header breaks at a line break); e.g. {' '.join(name.split())!r}",
        )
    _require(len(set(names)) == len(names), "pulleys.name", names, "names must be unique")
    g = _pair("gravity", spec.gravity, "[gx, gy] in m/s^2")
    _require(
        spec.belt.direction is None or (isinstance(spec.belt.direction, str) and spec.belt.direction in ("cw", "ccw")),
        "belt.direction",
        spec.belt.direction,
        "must be 'cw' (clockwise) or 'ccw' (counter-clockwise), seen with z toward the viewer",
    )
    return g


def _check_span_labels(names: list[str]) -> None:
    """Span signals are named ``<from>-<to>``: two spans must not get one name (pulley names with '-')."""
    seen: dict[str, tuple[str, str]] = {}
    for a, b in zip(names, names[1:] + names[:1]):
        label = f"{a}-{b}"
        if label in seen:
            raise ConfigError(
                f"pulleys.name = {names!r}: the spans {seen[label][0]} -> {seen[label][1]} and {a} -> {b} would both "
                f"be named '{label}' (span signals are tension:<from>-<to>); rename a pulley, e.g. without '-'"
            )
        seen[label] = (a, b)


def _check_pulley(i: int, p: PulleySpec) -> tuple[float, float]:
    """One pulley: role, wrap, numbers, its laws and its carrier; returns its centre."""
    f = _pulley_label(i, p)
    _require(
        isinstance(p.role, str) and p.role in ("driver", "driven", "idler", "tensioner"),
        f + ".role",
        p.role,
        "must be one of driver, driven, idler, tensioner",
    )
    _require(isinstance(p.wrap, str) and p.wrap in ("inner", "back"), f + ".wrap", p.wrap, "must be 'inner' or 'back'")
    _require(
        p.grooved is None or isinstance(p.grooved, (bool, np.bool_)),
        f + ".grooved",
        p.grooved,
        "must be true, false or None",
    )
    _positive(f + ".radius", p.radius)
    _positive(f + ".inertia", p.inertia)
    _non_negative(f + ".viscous", p.viscous)
    ctr = _pair(f + ".center", p.center)
    _check_pulley_laws(f, p)
    check_pulley_mu(f, p)
    check_excitation(f, p)
    t = p.tensioner
    if p.role == "tensioner":
        kinds = tensioner_kinds()
        _require(
            t is not None,
            f + ".tensioner",
            t,
            f"a tensioner needs a [tensioner] table ({', '.join(kinds[:-1])} or {kinds[-1]})",
        )
    if t is not None:
        check_tensioner(f, t, ctr)
    _check_clutch(f, p)
    return ctr


def _check_contact_sink(spec: DriveSpec, radii: np.ndarray, tension: float) -> None:
    """The installed belt must not sink deeper into a pulley than it is thick: delta = T / (R k) at the installation
    tension (k ``contact.stiffness``; an audit's k = 1 N/m^2 diverged in the settle phase, blamed on solver.dt)."""
    from .contact_defaults import default_contact_stiffness

    k = default_contact_stiffness(spec.contact, spec.belt)
    r = float(np.min(np.abs(radii)))
    sink = tension / (r * k)
    key = "contact.stiffness" if spec.contact.stiffness is not None else "contact.stiffness_per_area"
    _require(
        sink <= spec.belt.thickness,
        key,
        getattr(spec.contact, key.split(".")[1]),
        f"the installed belt ({tension:.4g} N) would sink {1e3 * sink:.3g} mm into the smallest pulley (radius "
        f"{1e3 * r:.3g} mm), more than its thickness ({1e3 * spec.belt.thickness:.3g} mm): give a stiffer contact "
        f"(at least {tension / (r * spec.belt.thickness):.3g} N/m^2; the default follows the belt's width)",
    )


def _check_pulley_laws(f: str, p: PulleySpec) -> None:
    """Which of speed, speed_rpm, torque, load and power_kw the pulley ``f`` may have, and their laws."""
    if p.role == "driver":
        given = [k for k in ("speed", "speed_rpm", "torque") if getattr(p, k) is not None]
        _require(
            len(given) == 1,
            f + "." + ("/".join(given) if len(given) > 1 else "speed/torque"),
            tuple(getattr(p, k) for k in given) or (None, None),
            "a driver needs exactly one of 'speed' (rad/s law), 'speed_rpm' (rpm law) or 'torque' (N m law)",
        )
        _require(
            p.power_kw is None,
            f + ".power_kw",
            p.power_kw,
            "a driver delivers power; give power_kw on a driven pulley (its load)",
        )
        _require(
            p.load is None or p.torque is not None,  # with a torque: "either 'torque' or 'load'", below
            f + ".load",
            p.load,
            "a driver with a prescribed speed turns at that speed whatever loads it, so a load there does nothing; "
            "give it to a driven pulley (a torque-driven driver's brake is part of its 'torque')",
        )
    if p.role != "driver":
        _require(p.speed is None, f + ".speed", p.speed, "only a driver has a prescribed speed")
        _require(p.speed_rpm is None, f + ".speed_rpm", p.speed_rpm, "only a driver has a prescribed speed")
    for key in ("speed", "speed_rpm", "torque", "load", "power_kw"):
        _check_law(getattr(p, key), f"{f}.{key}")
    if p.torque is not None and p.load is not None:
        raise ConfigError(f"{f}: give either 'torque' or 'load', not both")
    if p.power_kw is not None and (p.torque is not None or p.load is not None):
        raise ConfigError(f"{f}: give either '{'load' if p.load is not None else 'torque'}' or 'power_kw', not both")
    for key in ("load", "power_kw"):  # braking is the meaning of these keys; driving is 'torque'
        low = _law_minimum(getattr(p, key))
        if low < 0:
            _warn(
                f"{f}.{key} reaches {low:g}: a negative {key} drives the pulley instead of braking it "
                f"({key} always opposes the pulley's running sense); for a driving torque give "
                f"{f}.torque (positive in the running sense)"
            )


def _check_layout(spec: DriveSpec, centers: np.ndarray, radii: np.ndarray, sides, radii_flipped) -> None:
    """The belt path closes around the pulleys as listed; else the layout fixes in the file's terms."""
    legend = ", ".join(f"{i} = {p.name}" for i, p in enumerate(spec.pulleys))
    try:
        check_belt_path(centers, radii, tuple(sides), radii_flipped=np.asarray(radii_flipped, dtype=float))
    except ValueError as err:
        raise ConfigError(
            f"pulleys: {err} (pulleys in the order listed: {legend})" + _named_fixes(err, spec.pulleys)
        ) from None


def _named_fixes(err: ValueError, pulleys) -> str:
    """The layout fixes of ``err`` (``LayoutError.suggestions``) in the configuration's terms."""
    out = []
    for kind, arg in getattr(err, "suggestions", ()):
        if kind == "order":
            out.append("[[pulleys]] tables in the order " + ", ".join(pulleys[i].name for i in arg))
        else:
            p = pulleys[arg]
            out.append(f'pulleys.{p.name}.wrap = "{"back" if p.wrap == "inner" else "inner"}" (a different drive)')
    return " In the configuration: " + "; or ".join(out) + "." if out else ""


def belt_numbers(b: dict, bl: BeltSpec, L0: float):
    """The belt's data as host numbers (``dynamics.stability.BeltNumbers``, ``BeltParams``' fields) from the
    checked belt ``b`` (``Checked.belt``), its spec and its stress-free length: what the stable step reads and
    ``build_drive`` puts on the device."""
    from ..dynamics.stability import BeltNumbers

    return BeltNumbers(
        EA=float(b["EA"]),
        EI=float(b["EI"]),
        axial_damping=float(b["cd"]),
        bending_damping=float(bl.bending_damping),
        mass_per_length=float(b["m"]),
        stress_free_length=float(L0),
    )


def _explicit_limit(spec: DriveSpec, b: dict, L0: float, implicit_damping: bool) -> float:
    """The stability limit of the mesh (closed form, numpy; nan where it has none); ``implicit_damping``: without
    the axial damping's bound (``solver.implicit_damping`` or the implicit scheme)."""
    from ..dynamics.stability import rate_bounds, step_limit

    n = spec.belt.n_elements
    try:
        belt = belt_numbers(b, spec.belt, L0)
        with np.errstate(all="ignore"):
            return step_limit(*rate_bounds(n, belt, implicit_damping))
    except (OverflowError, ZeroDivisionError):
        return math.nan


def _check_time_step(spec: DriveSpec, b: dict, L0: float, scheme: str) -> float:
    """The explicit stability limit of the mesh (closed form, numpy); refuses a solver.dt above it
    (inf with the implicit scheme, whose step is chosen for accuracy)."""
    s, n = spec.solver, spec.belt.n_elements
    dt_limit = _explicit_limit(spec, b, L0, s.implicit_damping is True or scheme == "implicit")
    _require(
        math.isfinite(dt_limit) and dt_limit > 0,
        "belt.EA, belt.EI, belt.mass_per_length",
        (b["EA"], b["EI"], b["m"]),
        f"gives no usable stable time step ({dt_limit!r} s): stiffness and mass per length are out of "
        "any realistic range",
    )
    if scheme == "implicit":  # the belt bounds no step: solver.dt or the accuracy rule (_time_step) sets it
        _require(
            s.dt is None or s.dt <= s.save_dt,
            "solver.dt",
            s.dt,
            f"is longer than solver.save_dt = {s.save_dt:g} s: states are saved once per step at most; use "
            "dt <= save_dt (or a longer save_dt)",
        )
        return math.inf
    if s.dt is not None:
        _require(
            s.dt <= dt_limit,
            "solver.dt",
            s.dt,
            f"exceeds the stability limit {dt_limit:.3g} s of this mesh ({n} elements); use dt <= "
            f"{0.9 * dt_limit:.3g} s, or fewer elements, or less belt damping",
        )
    return dt_limit


def _check_clutch(f: str, p: PulleySpec) -> None:
    """A one-way clutch pulley: not on a driver or a tensioner, a rotor inertia, a decoupler spring."""
    if p.clutch is None:
        return
    _require(p.clutch in ("oap", "decoupler"), f + ".clutch", p.clutch, "must be 'oap' or 'decoupler' (or absent)")
    _require(
        p.role in ("driven", "idler"),
        f + ".clutch",
        p.clutch,
        f"a one-way clutch belongs on a driven pulley (an alternator); this pulley's role is {p.role!r}",
    )
    _require(p.tensioner is None, f + ".clutch", p.clutch, "a clutch pulley cannot ride on a tensioner carrier")
    _positive(f + ".rotor_inertia", p.rotor_inertia)
    if p.clutch_damping is not None:
        _non_negative(f + ".clutch_damping", p.clutch_damping)
    if p.clutch == "decoupler":
        _positive(f + ".clutch_stiffness", p.clutch_stiffness)
