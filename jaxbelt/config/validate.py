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
from .checks import _given, _integer, _is_number, _non_negative, _pair, _positive, _pulley_label, _require, _warn
from .direction import _travel
from .laws import _check_law, _law_minimum, _nominal_speeds
from .resources import _check_run_size
from .spec import BeltSpec, ContactSpec, DriveSpec, PulleySpec, SolverSpec, TensionerSpec
from .tensioner import _check_tensioner
from .friction_keys import check_law_keys

__all__ = ["Checked", "validate_spec", "check_spec", "installed_state_definition"]

# Limits that catch typos (an extra zero or three) before they turn into an out-of-memory crash or a
# run that never ends. Real drives stay far below them (run size and memory: see resources.py).
MAX_ELEMENTS = 20_000  # belt.n_elements
MAX_LCP_ITERATIONS = 1_000  # solver.lcp_iterations (sweeps per step; 8 is typical)

# ISO 9981:2020 (PK profile) 5.4: a nominal "effective line differential" of 2 mm, read as the radial
# distance by which the belt's pitch line (tension cord) lies outside its effective line. Any closed belt
# loop turns by 2 pi, so the pitch length is L_effective + 2 pi * offset (+12.6 mm for PK).
EFFECTIVE_OFFSET_PK = 0.002  # belt.effective_offset default [m]
MAX_EFFECTIVE_OFFSET = 0.01  # [m]; more is a unit slip (mm for m), not a belt profile


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
    _require(
        any(p.role == "driver" for p in spec.pulleys),
        "pulleys.role",
        [p.role for p in spec.pulleys],
        "a drive needs one driver",
    )
    centers_np, radii_np = np.asarray(centers, dtype=float), np.asarray(radii, dtype=float)
    with np.errstate(all="ignore"):  # absurd coordinates overflow: refused below, not warned about
        _check_layout(spec, centers_np, radii_np, sides, radii_flipped)
        # the sense of travel; with belt.direction the pulleys are put in travel order
        listed, L_path = path_reading(centers_np, radii_np, sides)  # the length the built path will have
        travel, order, orientation, along, source = _travel(spec, listed, sides)
    omega_nominal = _nominal_speeds(spec, radii_np)  # for power_kw
    _require(
        math.isfinite(L_path) and L_path > 0,
        "pulleys.center",
        [tuple(x) for x in centers],
        f"give a belt path of length {L_path!r} m; centres and radii must be of a realistic size",
    )
    L0, stretch = _check_installed_length(spec.belt, b["EA"], L_path)
    dt_limit = _check_time_step(spec, b, L0)
    n = spec.belt.n_elements
    _check_run_size(
        spec,
        0.9 * dt_limit if spec.solver.dt is None else spec.solver.dt,
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
    )


def check_spec(spec: DriveSpec) -> None:
    """Every check ``build_drive`` makes of ``spec``, building nothing (a sweep checks each grid point so)."""
    validate_spec(spec)


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


def _belt_numbers(b: BeltSpec) -> dict:
    _integer("belt.n_elements", b.n_elements, 8, MAX_ELEMENTS)
    _positive("belt.width", b.width)
    _positive("belt.thickness", b.thickness)
    # every value given is checked, also one that another key overrides (EA over E, ...)
    for key in ("E", "EA", "EI", "rho", "mass_per_length", "stress_free_length", "effective_length"):
        if getattr(b, key) is not None:
            _positive(f"belt.{key}", getattr(b, key))
    for key in ("eta", "axial_damping", "pretension", "inner_offset", "back_offset"):
        if getattr(b, key) is not None:
            _non_negative(f"belt.{key}", getattr(b, key))
    A = b.width * b.thickness
    try:
        I = b.width * b.thickness**3 / 12.0
    except OverflowError:
        I = math.inf
    EA = b.EA if b.EA is not None else _given(b.E, "belt.E", "give E (Young's modulus, Pa) or EA (N)") * A
    EI = _given(
        b.EI if b.EI is not None else (b.E * I if b.E is not None else None), "belt.EI", "give EI (N m^2) or E (Pa)"
    )
    if b.mass_per_length is not None:
        m = b.mass_per_length
    else:
        m = _given(b.rho, "belt.rho", "give rho (kg/m^3) or mass_per_length (kg/m)") * A
    if b.axial_damping is not None:
        cd = b.axial_damping
    else:
        eta = 0.0 if b.eta is None else b.eta
        cd = eta * A
    for key, value in (("EA", EA), ("EI", EI), ("mass_per_length", m)):  # E*A etc. may under/overflow
        _require(
            math.isfinite(value) and value > 0,
            f"belt.{key}",
            value,
            "comes out non-finite or zero from E/rho and the section (width, thickness)",
        )
    _require(math.isfinite(cd), "belt.axial_damping", cd, "comes out non-finite from eta and the section")
    _non_negative("belt.bending_damping", b.bending_damping)
    _non_negative("belt.mass_damping", b.mass_damping)
    _require(
        isinstance(b.type, str) and b.type in ("flat", "poly-v"), "belt.type", b.type, "must be 'flat' or 'poly-v'"
    )
    _integer("belt.ribs", b.ribs, 1)
    if b.effective_length is not None:
        _require(
            b.type == "poly-v",
            "belt.effective_length",
            b.effective_length,
            "is the catalogue (effective) length of a poly-V belt (type = 'poly-v', ISO 9981); for a flat "
            "belt give stress_free_length (unstretched, at the belt axis) or pretension",
        )
    if b.effective_offset is not None:
        _require(
            b.effective_length is not None,
            "belt.effective_offset",
            b.effective_offset,
            "is used only with belt.effective_length (it converts the effective length to the pitch length)",
        )
        _require(
            _is_number(b.effective_offset) and 0 <= b.effective_offset <= MAX_EFFECTIVE_OFFSET,
            "belt.effective_offset",
            b.effective_offset,
            f"must be in [0, {MAX_EFFECTIVE_OFFSET:g}] m: the radial distance from the belt's effective line out "
            f"to its pitch line (tension cord), {EFFECTIVE_OFFSET_PK:g} m nominal for PK (ISO 9981)",
        )
    _require(
        _is_number(b.groove_angle_deg) and 0 < b.groove_angle_deg < 180,
        "belt.groove_angle_deg",
        b.groove_angle_deg,
        "must be in (0, 180)",
    )
    inner = b.thickness / 2 if b.inner_offset is None else b.inner_offset
    back = b.thickness / 2 if b.back_offset is None else b.back_offset
    _non_negative("belt.inner_offset", inner)
    _non_negative("belt.back_offset", back)
    return dict(EA=EA, EI=EI, m=m, cd=cd, inner=inner, back=back)


_INSTALLED_KEYS = ("stress_free_length", "effective_length", "pretension")


def installed_state_definition(spec) -> str:
    """The belt key that defines the installed state of ``spec`` (a ``DriveSpec`` or ``BeltSpec``):
    ``"stress_free_length"``, ``"effective_length"`` or ``"pretension"``. ``ConfigError`` unless
    exactly one of them is given."""
    b = spec.belt if isinstance(spec, DriveSpec) else spec
    given = [k for k in _INSTALLED_KEYS if getattr(b, k, None) is not None]
    _require(
        len(given) == 1,
        "belt." + "/".join(_INSTALLED_KEYS),
        tuple(getattr(b, k, None) for k in _INSTALLED_KEYS),
        "give exactly one of them",
    )
    return given[0]


def _effective_offset(b: BeltSpec) -> float:
    return EFFECTIVE_OFFSET_PK if b.effective_offset is None else float(b.effective_offset)


def _stress_free_length(b: BeltSpec, EA: float, L_path):
    """Stress-free length at the belt axis (the pitch line) from the key that defines the installed
    state; ``L_path`` is the installed path length (a float or a JAX scalar)."""
    installed_state_definition(b)  # exactly one of the three keys is given
    if b.pretension is not None:
        return L_path / (1.0 + b.pretension / EA)
    if b.effective_length is not None:
        return b.effective_length + 2.0 * math.pi * _effective_offset(b)
    return b.stress_free_length


def _check_contact(c: ContactSpec) -> None:
    _require(
        _is_number(c.mu) and math.isfinite(c.mu) and c.mu > 0,
        "contact.mu",
        c.mu,
        "must be a finite number > 0 (a frictionless belt cannot transmit torque)",
    )
    _positive("contact.stiffness", c.stiffness)
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
        not isinstance(c.points_per_element, bool) and c.points_per_element in (1, 2),
        "contact.points_per_element",
        c.points_per_element,
        "must be 1 or 2 (more points than belt DOFs make the contact problem singular)",
    )


def _check_solver(s: SolverSpec) -> None:
    if s.dt is not None:
        _positive("solver.dt", s.dt)
    _positive("solver.t_end", s.t_end)
    _positive("solver.save_dt", s.save_dt)
    _non_negative("solver.settle_time", s.settle_time)
    _non_negative("solver.settle_damping", s.settle_damping)
    _integer("solver.lcp_iterations", s.lcp_iterations, 1, MAX_LCP_ITERATIONS)
    _require(
        _is_number(s.relaxation) and 0 < s.relaxation <= 1.0, "solver.relaxation", s.relaxation, "must be in (0, 1]"
    )


def _check_names(spec: DriveSpec) -> tuple[float, float]:
    """Pulley names, gravity and belt.direction; returns the gravity vector."""
    names = [p.name for p in spec.pulleys]
    for i, name in enumerate(names):
        _require(
            isinstance(name, str) and name.strip() != "" and not any(ch in name for ch in ".,"),
            f"pulleys[{i}].name",
            name,
            "must be a non-empty string without '.' or ',' (it is used in keys such as pulleys.<name>.load)",
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
    t = p.tensioner
    if p.role == "tensioner":
        _require(t is not None, f + ".tensioner", t, "a tensioner needs a [tensioner] table (arm or slider)")
    if t is not None:
        _check_tensioner(f, t, ctr)
    return ctr


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


def _check_installed_length(bl: BeltSpec, EA: float, L_path: float) -> tuple[float, float]:
    """The stress-free length and the installed stretch; refuses a slack belt or one beyond 20 % strain."""
    how = installed_state_definition(bl)
    L0 = _stress_free_length(bl, EA, L_path)
    stretch = L_path / L0
    key, value = f"belt.{how}", getattr(bl, how)
    pitch = (
        f" (at the pitch line: effective length + 2π × effective_offset {_effective_offset(bl):g} m)"
        if how == "effective_length"
        else ""
    )
    _require(
        stretch >= 1.0,
        key,
        value,
        f"the stress-free length {L0:.6g} m{pitch} is longer than the belt path around the pulleys "
        f"({L_path:.6g} m): the belt would be slack (shorten it or move the pulleys apart)",
    )
    _require(
        stretch < 1.2,
        key,
        value,
        f"the stress-free length {L0:.6g} m{pitch} needs {100 * (stretch - 1):.1f} % strain to reach the belt "
        f"path ({L_path:.6g} m); a belt cannot be installed beyond 20 % strain",
    )
    return L0, stretch


def _check_time_step(spec: DriveSpec, b: dict, L0: float) -> float:
    """The explicit stability limit of the mesh (closed form, numpy); refuses a solver.dt above it."""
    from ..dynamics.stability import rate_bounds, step_limit

    bl, s, n = spec.belt, spec.solver, spec.belt.n_elements
    try:
        with np.errstate(all="ignore"):
            dt_limit = step_limit(
                *rate_bounds(
                    n,
                    float(b["EA"]),
                    float(b["EI"]),
                    float(b["cd"]),
                    float(bl.bending_damping),
                    float(b["m"]),
                    float(L0),
                )
            )
    except (OverflowError, ZeroDivisionError):
        dt_limit = math.nan
    _require(
        math.isfinite(dt_limit) and dt_limit > 0,
        "belt.EA, belt.EI, belt.mass_per_length",
        (b["EA"], b["EI"], b["m"]),
        f"gives no usable stable time step ({dt_limit!r} s): stiffness and mass per length are out of "
        "any realistic range",
    )
    if s.dt is not None:
        _require(
            s.dt <= dt_limit,
            "solver.dt",
            s.dt,
            f"exceeds the stability limit {dt_limit:.3g} s of this mesh ({n} elements); use dt <= "
            f"{0.9 * dt_limit:.3g} s, or fewer elements, or less belt damping",
        )
    return dt_limit
