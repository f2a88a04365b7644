"""Drive specification (plain Python, validated) and its translation into Model, Params and State.

A ``DriveSpec`` is what a user writes (in Python or TOML): SI units, pulleys listed in the order
the belt travels (in either order round the loop when ``belt.direction`` is given). ``build_drive``
validates everything *before* anything is traced or compiled and raises ``ConfigError`` naming the
field, the value and what is allowed.
"""

from __future__ import annotations

import dataclasses
import math
import os
import warnings
from dataclasses import dataclass, field
from typing import Literal

import jax.numpy as jnp
import numpy as np

from ..pulleys import timelaw as tl
from ..belt.ring import BeltParams
from ..geometry.path import BeltPath, belt_path, check_belt_path, place_belt
from ..contact.friction import FRICTION_LAWS
from .friction_keys import check_law_keys, law_arrays, law_for, law_keys_as_attributes
from .._types import DriveModel, DriveParams, DriveState, PulleyParams, WorkTerms
from ..pulleys import ArmCarrier, FixedCarrier, SliderCarrier
from .._types import Fault

__all__ = ["ConfigError", "BeltSpec", "PulleySpec", "TensionerSpec", "ContactSpec", "SolverSpec", "DriveSpec",
           "Drive", "build_drive", "law_from_spec", "installed_state_definition"]


class ConfigError(ValueError):
    """A drive configuration that cannot be simulated; the message names the field."""


# Limits that catch typos (an extra zero or three) before they turn into an out-of-memory crash or a
# run that never ends. Real drives stay far below them.
MAX_ELEMENTS = 20_000               # belt.n_elements
MAX_LCP_ITERATIONS = 1_000          # solver.lcp_iterations (sweeps per step; 8 is typical)
MAX_STEPS = 10**9                   # settle + run steps of one simulation
MAX_SAVED_BYTES = 4 * 1024**3       # saved states of one simulation (the trajectory kept in memory)
# Memory of a run, checked against what this machine has free (see _check_memory): a run may plan
# to use this fraction of it.
MEMORY_SAFETY = 0.8
# Peak copies of the saved trajectory (diffrax's buffer, the sliced states, the host copy and the
# post-processing vmapped over all states): measured 3.8 x at 240 elements, 8001 saves.
TRAJECTORY_COPIES = 4

# ISO 9981:2020 (PK profile) 5.4: a nominal "effective line differential" of 2 mm, read as the radial
# distance by which the belt's pitch line (tension cord) lies outside its effective line. Any closed belt
# loop turns by 2 pi, so the pitch length is L_effective + 2 pi * offset (+12.6 mm for PK).
EFFECTIVE_OFFSET_PK = 0.002         # belt.effective_offset default [m]
MAX_EFFECTIVE_OFFSET = 0.01         # [m]; more is a unit slip (mm for m), not a belt profile
MAX_ARM_ANGLE = 2 * math.pi         # |tensioner.rest| of an arm [rad]; beyond a full turn it was meant in degrees
SPRING_LOAD_FACTOR = 3.0            # warn when a tensioner spring's installed load exceeds this many times
                                    # the most the belt can hold on it (2 T L on an arm, 2 T on a slider)


def _require(cond: bool, field_name: str, value, allowed: str):
    if not cond:
        shown = repr(value)
        if len(shown) > 160:  # a 400-digit integer or a long table: enough to recognise it
            shown = shown[:120] + " ... " + shown[-20:]
        raise ConfigError(f"{field_name} = {shown}: {allowed}")


def _is_number(x) -> bool:
    """A real number (not a bool, not a string); huge ints that overflow a float are not."""
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)):
        return False
    try:
        float(x)
    except OverflowError:
        return False
    return True


def _finite(field_name: str, value, allowed: str = "must be a finite number"):
    _require(_is_number(value) and math.isfinite(float(value)), field_name, value, allowed)


def _positive(field_name: str, value):
    _require(value is not None and _is_number(value) and math.isfinite(float(value)) and value > 0,
             field_name, value, "must be a finite number > 0")


def _non_negative(field_name: str, value):
    _require(_is_number(value) and math.isfinite(float(value)) and value >= 0,
             field_name, value, "must be a finite number >= 0")


def _integer(field_name: str, value, lo: int, hi: int | None = None):
    ok = isinstance(value, (int, np.integer)) and not isinstance(value, bool) and value >= lo
    ok = ok and (hi is None or value <= hi)
    _require(ok, field_name, value, f"must be an integer >= {lo}" + (f" and <= {hi}" if hi is not None else ""))


def _pair(field_name: str, value, what: str = "(x, y) in m") -> tuple[float, float]:
    """Two finite numbers (a list or tuple), as floats."""
    ok = (isinstance(value, (list, tuple, np.ndarray)) and len(value) == 2
          and all(_is_number(x) and math.isfinite(float(x)) for x in value))
    _require(ok, field_name, value, f"must be two finite numbers {what}")
    return float(value[0]), float(value[1])


@dataclass
class BeltSpec:
    """Belt data. Stiffness and mass refer to the *stress-free* length.

    Give either ``E`` (with ``width`` and ``thickness``) or explicit ``EA``/``EI``; either ``rho``
    or ``mass_per_length``; exactly one of ``stress_free_length`` (at the belt axis, the pitch
    line), ``effective_length`` (a poly-V belt's catalogue length, ISO 9981) or ``pretension``
    (uniform installed tension, from which the stress-free length follows).
    """

    n_elements: int = 60
    width: float = 0.02
    thickness: float = 0.005
    E: float | None = None
    EA: float | None = None
    EI: float | None = None
    rho: float | None = None
    mass_per_length: float | None = None
    eta: float | None = None               # Kelvin–Voigt viscosity [Pa s]
    axial_damping: float | None = None     # or directly eta*A [N s]
    bending_damping: float = 0.0           # Rayleigh stiffness-proportional coefficient [s]
    mass_damping: float = 0.0              # Rayleigh mass-proportional coefficient [1/s]
    stress_free_length: float | None = None
    pretension: float | None = None
    type: Literal["flat", "poly-v"] = "flat"
    ribs: int = 1
    groove_angle_deg: float = 40.0
    inner_offset: float | None = None      # pulley surface to belt axis, inner side [m] (default thickness/2)
    back_offset: float | None = None       # pulley surface to belt axis, back side [m] (default thickness/2)
    effective_length: float | None = None  # poly-V catalogue (effective) length, unstretched [m]
    effective_offset: float | None = None  # effective line to pitch line [m] (default EFFECTIVE_OFFSET_PK)
    # Sense the belt runs round the drive, seen with z toward the viewer (the rotation sense of the
    # pulleys it wraps on its inner side). Given: pulleys may be listed in either order and drivers'
    # speed/torque are taken in that sense. None (as before the key existed): spans follow the listed
    # order, drivers' speed/torque are counter-clockwise positive and their sign sets the sense.
    direction: Literal["cw", "ccw"] | None = None


@dataclass
class TensionerSpec:
    """Carrier of a tensioner pulley: a pivoted arm (default) or a linear slider.

    Arm: the pulley centre at installation (``PulleySpec.center``) and ``pivot`` fix the arm length
    and the installed angle. The spring torque on the arm is
    ``preload + stiffness * (rest - angle)`` (counter-clockwise positive; ``rest`` defaults to the
    installed angle; or give ``rest_deg`` in degrees instead). Slider: travel ``s`` along
    ``direction`` from the installed centre, force ``preload + stiffness * (rest - s)``.
    """

    kind: Literal["arm", "slider"] = "arm"
    pivot: tuple[float, float] | None = None
    direction: tuple[float, float] | None = None
    stiffness: float = 0.0
    preload: float = 0.0
    rest: float | None = None
    damping: float = 0.0
    inertia: float | None = None           # arm inertia about the pivot [kg m^2] or slider mass [kg]
    mass: float = 0.0                      # pulley + arm mass pulled by gravity [kg]
    rest_deg: float | None = None          # an arm's rest angle in degrees (instead of rest)


@dataclass
class PulleySpec:
    name: str
    center: tuple[float, float]
    radius: float                           # radius of the surface the belt touches [m]
    role: Literal["driver", "driven", "idler", "tensioner"] = "idler"
    inertia: float = 1e-3
    wrap: Literal["inner", "back"] = "inner"
    grooved: bool | None = None             # poly-V grooves (default: inner wrap of a poly-V belt)
    speed: dict | tl.TimeLaw | float | None = None    # driver by speed: rad/s law
    torque: dict | tl.TimeLaw | float | None = None   # applied torque law, + in the running sense [N m]
    load: dict | tl.TimeLaw | float | None = None     # brake torque law opposing the running sense [N m]
    viscous: float = 0.0                    # viscous load [N m s/rad]
    tensioner: TensionerSpec | None = None
    speed_rpm: dict | tl.TimeLaw | float | None = None  # driver by speed: rpm law (instead of speed)
    power_kw: dict | tl.TimeLaw | float | None = None   # load absorbing this power at the nominal speed [kW]


FrictionLawName = Literal[tuple(FRICTION_LAWS)]  # the TOML loader checks names against the table too


@law_keys_as_attributes  # the friction law's own keys (contact.mu_kinetic, ...) as attributes
@dataclass
class ContactSpec:
    mu: float = 0.5
    stiffness: float = 3.2e8                # per unit belt length [N/m^2]
    damping: float = 6.4e3                  # per unit belt length [N s/m^2]
    friction_law: FrictionLawName = "coulomb"
    nu_s: float = 50.0                      # regularised-law steepness [s/m]
    law_parameters: dict[str, float] = field(default_factory=dict)  # the law's keys (LawKey), e.g. mu_kinetic
    points_per_element: int = 2


@dataclass
class SolverSpec:
    dt: float | None = None                 # default: 0.9 x the estimated stability limit
    t_end: float = 1.0
    save_dt: float = 1e-3
    lcp_iterations: int = 8
    relaxation: float = 0.9
    settle_time: float = 0.1
    settle_damping: float = 200.0


@dataclass
class DriveSpec:
    belt: BeltSpec
    pulleys: list[PulleySpec]
    contact: ContactSpec = field(default_factory=ContactSpec)
    solver: SolverSpec = field(default_factory=SolverSpec)
    gravity: tuple[float, float] = (0.0, 0.0)


@dataclass
class Drive:
    """A built drive: everything ``simulate`` needs plus geometry for outputs."""

    spec: DriveSpec
    model: DriveModel
    params: DriveParams
    state0: DriveState
    path: BeltPath
    dt: float
    travel: int = 1                         # sense the belt runs round the loop: +1 counter-clockwise, -1 clockwise
    running_sense: tuple[int, ...] = ()     # each pulley's rotation sense while the belt runs (travel x wrap side)
    # What the spec fixed (static, read by set_parameter so that a changed key gives the drive a file
    # edit of that key would build): "pretension" keeps the installed tension when EA or the path
    # change, "stress_free_length"/"effective_length" keep the length; and which stiffnesses the spec
    # derived from E.
    installed_by: str = "stress_free_length"
    E_sets: tuple[str, ...] = ("EA", "EI")


_LAW_FORMS = ("constant", "ramp", "smooth_step", "table")


def _law_points(t: np.ndarray, v: np.ndarray, what: str):
    _require(t.ndim == 1 and t.shape == v.shape and t.size > 0, what, (t.tolist(), v.tolist()),
             "needs as many times as values, at least one")
    _require(bool(np.all(np.isfinite(t))), what, t.tolist(), "times must be finite numbers")
    _require(bool(np.all(np.isfinite(v))), what, v.tolist(), "values must be finite numbers")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        k = int(bad[0])
        raise ConfigError(f"{what}: times must increase strictly: t = {t[k + 1]:g} at point {k + 1} follows "
                          f"t = {t[k]:g} at point {k} (times {t.tolist()})")


def _check_law(value, what: str) -> None:
    """Validate a time law (numbers, shapes, strictly increasing times) with numpy only: no JAX
    array is made, nothing is traced or compiled. Raises ``ConfigError`` naming ``what``."""
    if value is None:
        return
    if isinstance(value, tl.TimeLaw):
        try:
            t, v = np.asarray(value.times, dtype=float), np.asarray(value.values, dtype=float)
        except Exception:  # noqa: BLE001 - traced values: whoever traced them checks them
            return
        _law_points(t, v, what)
        return
    if _is_number(value):
        _require(math.isfinite(float(value)), what, value, "must be finite")
        return
    if not isinstance(value, dict):
        raise ConfigError(f"{what} = {value!r}: must be a number, a TimeLaw or a table/ramp/smooth_step dict")
    keys = set(value) - {"base", "smooth"}
    _require(len(keys) == 1 and keys <= set(_LAW_FORMS), what, value,
             "must have exactly one of 'constant', 'ramp', 'smooth_step', 'table'")
    (kind,) = keys
    base = value.get("base", 0.0)
    _finite(f"{what}.base", base)
    if "smooth" in value:
        _require(isinstance(value["smooth"], (bool, np.bool_)), f"{what}.smooth", value["smooth"],
                 "must be true or false")
    arg = value[kind]
    if kind == "constant":
        _finite(f"{what}.constant", arg)
        _require(math.isfinite(float(arg) + float(base)), f"{what}.constant", arg, "plus base must be finite")
        return
    if kind in ("ramp", "smooth_step"):
        ok = (isinstance(arg, (list, tuple, np.ndarray)) and len(arg) == 4
              and all(_is_number(x) and math.isfinite(float(x)) for x in arg))
        _require(ok, f"{what}.{kind}", arg, "must be [t0, t1, v0, v1], four finite numbers")
        t0, t1, v0, v1 = map(float, arg)
        _require(t1 > t0, f"{what}.{kind}", arg, "needs t1 > t0")
        _law_points(np.array([t0, t1]), np.array([v0, v1]) + float(base), f"{what}.{kind}")
        return
    ok = (isinstance(arg, (list, tuple, np.ndarray)) and len(arg) >= 1
          and all(isinstance(r, (list, tuple, np.ndarray)) and len(r) == 2 and all(_is_number(x) for x in r)
                  for r in arg))
    _require(ok, f"{what}.table", arg, "must be a non-empty list of [t, value] pairs of numbers")
    pts = np.asarray(arg, dtype=float)
    _law_points(pts[:, 0], pts[:, 1] + float(base), f"{what}.table")


def _law_minimum(value) -> float:
    """The smallest value a validated law takes, as written (numpy only: validation compiles nothing);
    +inf for no law or a traced one."""
    try:
        if value is None:
            return math.inf
        if isinstance(value, tl.TimeLaw):
            return float(np.min(np.asarray(value.values, dtype=float)))
        if _is_number(value):
            return float(value)
        (kind,) = set(value) - {"base", "smooth"}
        arg = value[kind]
        values = [arg] if kind == "constant" else arg[2:] if kind in ("ramp", "smooth_step") else [r[1] for r in arg]
        return float(min(float(v) for v in values)) + float(value.get("base", 0.0))
    except Exception:  # noqa: BLE001 - traced laws: nothing to say before tracing
        return math.inf


def law_from_spec(value, what: str, sign: float = 1.0) -> tl.TimeLaw:
    """A number (constant), a TimeLaw, or a dict:
    ``{ramp = [t0, t1, v0, v1]}``, ``{smooth_step = [t0, t1, v0, v1]}``,
    ``{table = [[t, v], ...], smooth = false}``, optional ``base`` added to steps/ramps."""
    _check_law(value, what)
    if value is None:
        return tl.constant(0.0)
    if isinstance(value, tl.TimeLaw):
        return tl.TimeLaw(value.times, sign * value.values, value.smooth)
    try:
        if _is_number(value):
            return tl.constant(sign * float(value))
        (kind,) = set(value) - {"base", "smooth"}
        base = float(value.get("base", 0.0))
        arg = value[kind]
        if kind == "constant":
            return tl.constant(sign * (float(arg) + base))
        if kind in ("ramp", "smooth_step"):
            t0, t1, v0, v1 = map(float, arg)
            return (tl.ramp if kind == "ramp" else tl.smooth_step)(t0, t1, sign * (v0 + base), sign * (v1 + base))
        pts = np.asarray(arg, dtype=float)
        return tl.table(pts[:, 0], sign * (pts[:, 1] + base), smooth=bool(value.get("smooth", False)))
    except (TypeError, ValueError) as err:  # not expected after _check_law; still never an obscure error
        raise ConfigError(f"{what}: {err}") from None


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
    if b.EA is None:
        _require(b.E is not None, "belt.E", b.E, "give E (Young's modulus, Pa) or EA (N)")
    EA = b.EA if b.EA is not None else b.E * A
    EI = b.EI if b.EI is not None else (b.E * I if b.E is not None else None)
    _require(EI is not None, "belt.EI", b.EI, "give EI (N m^2) or E (Pa)")
    if b.mass_per_length is not None:
        m = b.mass_per_length
    else:
        _require(b.rho is not None, "belt.rho", b.rho, "give rho (kg/m^3) or mass_per_length (kg/m)")
        m = b.rho * A
    if b.axial_damping is not None:
        cd = b.axial_damping
    else:
        eta = 0.0 if b.eta is None else b.eta
        cd = eta * A
    for key, value in (("EA", EA), ("EI", EI), ("mass_per_length", m)):  # E*A etc. may under/overflow
        _require(math.isfinite(value) and value > 0, f"belt.{key}", value,
                 "comes out non-finite or zero from E/rho and the section (width, thickness)")
    _require(math.isfinite(cd), "belt.axial_damping", cd, "comes out non-finite from eta and the section")
    _non_negative("belt.bending_damping", b.bending_damping)
    _non_negative("belt.mass_damping", b.mass_damping)
    _require(isinstance(b.type, str) and b.type in ("flat", "poly-v"), "belt.type", b.type,
             "must be 'flat' or 'poly-v'")
    _integer("belt.ribs", b.ribs, 1)
    if b.effective_length is not None:
        _require(b.type == "poly-v", "belt.effective_length", b.effective_length,
                 "is the catalogue (effective) length of a poly-V belt (type = 'poly-v', ISO 9981); for a flat "
                 "belt give stress_free_length (unstretched, at the belt axis) or pretension")
    if b.effective_offset is not None:
        _require(b.effective_length is not None, "belt.effective_offset", b.effective_offset,
                 "is used only with belt.effective_length (it converts the effective length to the pitch length)")
        _require(_is_number(b.effective_offset) and 0 <= b.effective_offset <= MAX_EFFECTIVE_OFFSET,
                 "belt.effective_offset", b.effective_offset,
                 f"must be in [0, {MAX_EFFECTIVE_OFFSET:g}] m: the radial distance from the belt's effective line out "
                 f"to its pitch line (tension cord), {EFFECTIVE_OFFSET_PK:g} m nominal for PK (ISO 9981)")
    _require(_is_number(b.groove_angle_deg) and 0 < b.groove_angle_deg < 180, "belt.groove_angle_deg",
             b.groove_angle_deg, "must be in (0, 180)")
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
    _require(len(given) == 1, "belt." + "/".join(_INSTALLED_KEYS), tuple(getattr(b, k, None) for k in _INSTALLED_KEYS),
             "give exactly one of them")
    return given[0]


def _effective_offset(b: BeltSpec) -> float:
    return EFFECTIVE_OFFSET_PK if b.effective_offset is None else float(b.effective_offset)


def _stress_free_length(b: BeltSpec, EA: float, L_path):
    """Stress-free length at the belt axis (the pitch line) from the key that defines the installed
    state; ``L_path`` is the installed path length (a float or a JAX scalar)."""
    how = installed_state_definition(b)
    if how == "pretension":
        return L_path / (1.0 + b.pretension / EA)
    if how == "effective_length":
        return b.effective_length + 2.0 * math.pi * _effective_offset(b)
    return b.stress_free_length


def _tensioner_rest(f: str, t: TensionerSpec) -> float | None:
    """The carrier's rest coordinate in model units (rad for an arm, m for a slider), None for the
    default. Refuses ``rest`` with ``rest_deg``, ``rest_deg`` on a slider and an arm angle beyond a
    full turn (radians are easily given in degrees: ``rest = 12`` is 688 deg)."""
    if t.rest_deg is not None:
        _finite(f + ".tensioner.rest_deg", t.rest_deg)
        _require(t.rest is None, f + ".tensioner.rest/rest_deg", (t.rest, t.rest_deg),
                 "give the rest angle once: rest in rad or rest_deg in degrees")
        _require(t.kind == "arm", f + ".tensioner.rest_deg", t.rest_deg,
                 "is an arm's rest angle in degrees; a slider's rest is a travel: give rest in m")
        _require(abs(t.rest_deg) <= 360.0, f + ".tensioner.rest_deg", t.rest_deg,
                 "must be within [-360, 360] deg (an arm angle; a wound-up spring is given by preload)")
        return math.radians(t.rest_deg)
    if t.rest is None:
        return None
    _finite(f + ".tensioner.rest", t.rest, "must be a finite number (rad for an arm, m for a slider)")
    if t.kind == "arm":
        _require(abs(t.rest) <= MAX_ARM_ANGLE, f + ".tensioner.rest", t.rest,
                 f"an arm's rest angle is in radians and must be within [-2π, 2π] ({t.rest:g} rad is "
                 f"{math.degrees(t.rest):.4g} deg); for degrees write rest_deg = {t.rest:g} "
                 f"({math.radians(t.rest):.4g} rad)")
    return float(t.rest)


def _check_spring_loads(spec: DriveSpec, tension: float) -> None:
    """Warn when a tensioner spring's installed torque (force) is far beyond what the belt can hold
    on that carrier: at most 2 T L on an arm of length L (both spans pulling along the hub load,
    perpendicular to the arm), 2 T on a slider, T the installed tension."""
    if not tension > 0:  # a belt installed without tension: no scale to compare with
        return
    for i, p in enumerate(spec.pulleys):
        t = p.tensioner
        if t is None:
            continue
        f = _pulley_label(i, p)
        rest = _tensioner_rest(f, t)
        if t.kind == "arm":
            dx, dy = p.center[0] - t.pivot[0], p.center[1] - t.pivot[1]
            L, psi0 = math.hypot(dx, dy), math.atan2(dy, dx)
            r = psi0 if rest is None else rest
            load, cap = t.preload + t.stiffness * (r - psi0), 2.0 * tension * L
            what = (f"the spring torque at installation, preload + stiffness·(rest − angle) = {t.preload:.4g} + "
                    f"{t.stiffness:.4g}·({r:.4g} − {psi0:.4g}) = {load:.4g} N m, is {abs(load) / cap:.3g} times the "
                    f"most the belt can hold on this arm (2·T·L = 2 × {tension:.4g} N × {L:.4g} m = {cap:.4g} N m, "
                    "T the installed belt tension)")
            hints = []
            if t.rest is not None:
                hints.append(f"tensioner.rest is in radians ({t.rest:g} rad = {math.degrees(t.rest):.4g} deg); "
                             f"if you meant degrees write rest_deg = {t.rest:g}")
            if abs(r - psi0) > math.pi:
                hints.append(f"the rest angle is {r - psi0:.4g} rad from the installed arm angle {psi0:.4g} rad "
                             "(angles are not wrapped: 2π more is a full turn of spring wind-up)")
        else:
            r = 0.0 if rest is None else rest
            load, cap = t.preload + t.stiffness * r, 2.0 * tension
            what = (f"the spring force at installation, preload + stiffness·rest = {load:.4g} N, is "
                    f"{abs(load) / cap:.3g} times the most the belt can hold on this slider (2·T = {cap:.4g} N, T the "
                    "installed belt tension)")
            hints = []
        if abs(load) <= SPRING_LOAD_FACTOR * cap:
            continue
        hints.append("check tensioner.preload, stiffness and rest (counter-clockwise or along direction positive)")
        warnings.warn(f"{f}.tensioner: {what}: the carrier will swing far from its drawn position; "
                      + "; ".join(hints), UserWarning, stacklevel=3)


def _named_fixes(err: ValueError, pulleys) -> str:
    """The layout fixes of ``err`` (``LayoutError.suggestions``) in the configuration's terms."""
    out = []
    for kind, arg in getattr(err, "suggestions", ()):
        if kind == "order":
            out.append("[[pulleys]] tables in the order " + ", ".join(pulleys[i].name for i in arg))
        else:
            p = pulleys[arg]
            out.append(f"pulleys.{p.name}.wrap = \"{'back' if p.wrap == 'inner' else 'inner'}\" (a different drive)")
    return " In the configuration: " + "; or ".join(out) + "." if out else ""


def _pulley_label(i: int, p) -> str:
    """How messages name pulley ``i``: ``pulleys.<name>`` (the dotted key), else ``pulleys[i]``."""
    name = getattr(p, "name", None)
    return f"pulleys.{name}" if isinstance(name, str) and name.strip() else f"pulleys[{i}]"


def _check_spec_types(spec) -> None:
    """The spec's parts are the spec classes (a Python-built spec may hold anything)."""
    _require(isinstance(spec, DriveSpec), "spec", type(spec).__name__, "must be a jaxbelt.DriveSpec")
    for key, cls in (("belt", BeltSpec), ("contact", ContactSpec), ("solver", SolverSpec)):
        _require(isinstance(getattr(spec, key), cls), key, getattr(spec, key), f"must be a {cls.__name__}")
    _require(isinstance(spec.pulleys, (list, tuple)) and len(spec.pulleys) >= 2, "pulleys",
             len(spec.pulleys) if isinstance(spec.pulleys, (list, tuple)) else spec.pulleys,
             "a drive needs at least 2 pulleys")
    for i, p in enumerate(spec.pulleys):
        _require(isinstance(p, PulleySpec), f"pulleys[{i}]", p, "must be a PulleySpec")
        _require(p.tensioner is None or isinstance(p.tensioner, TensionerSpec), _pulley_label(i, p) + ".tensioner",
                 p.tensioner, "must be a TensionerSpec (or None)")


def _path_length(centers: np.ndarray, radii: np.ndarray, sides) -> float:
    """Length of the installed belt path (numpy, the reading ``belt_path`` takes; nothing compiled)."""
    from ..geometry.path import _choose

    g = _choose(centers, radii, np.asarray(sides), None)[1]
    return float(np.sum(radii * g["wrap_angle"]) + np.sum(g["span_length"]))


_SENSE_WORDS = {1: "counter-clockwise", -1: "clockwise"}
_SENSE_KEYS = {1: "ccw", -1: "cw"}
_RPM = 2.0 * math.pi / 60.0


def _law_values(value) -> np.ndarray:
    """Values of a checked time law (base included), numpy only; empty for traced values."""
    if isinstance(value, tl.TimeLaw):
        try:
            return np.asarray(value.values, dtype=float).ravel()
        except Exception:  # noqa: BLE001 - traced: no value to read
            return np.zeros(0)
    if _is_number(value):
        return np.array([float(value)])
    (kind,) = set(value) - {"base", "smooth"}
    base, arg = float(value.get("base", 0.0)), value[kind]
    if kind == "constant":
        return np.array([float(arg) + base])
    if kind in ("ramp", "smooth_step"):
        return np.array([float(arg[2]), float(arg[3])]) + base
    return np.asarray(arg, dtype=float)[:, 1] + base


def _law_sign(p: PulleySpec, key: str, sense: int, spec: DriveSpec) -> float:
    """Factor from a law as written (``key`` of pulley ``p``, running sense ``sense``) to the stored
    law (SI, counter-clockwise positive). ``load``/``power_kw`` brake: they oppose the running sense;
    ``torque`` and a driver's speed count in the running sense, except a driver's without
    ``belt.direction``: counter-clockwise positive (as before the key existed; its sign sets the sense)."""
    if key in ("load", "power_kw"):
        return -float(sense)
    unit = _RPM if key == "speed_rpm" else 1.0
    if p.role == "driver" and spec.belt.direction is None:
        return unit
    return unit * float(sense)


def _driver_law(p: PulleySpec) -> tuple[str, np.ndarray]:
    key = next(k for k in ("speed", "speed_rpm", "torque") if getattr(p, k) is not None)
    return key, _law_values(getattr(p, key))


def _travel(spec: DriveSpec, centers: np.ndarray, radii: np.ndarray, sides):
    """Sense of travel (+1 counter-clockwise, -1 clockwise) and how the path is built from it:
    (travel, order of the listed pulleys in the model, orientation to force on the path or None,
    whether spans run in path order, what set the sense)."""
    from ..geometry.path import _choose

    listed = _choose(centers, radii, np.asarray(sides), None)[0]
    k = len(sides)
    if spec.belt.direction is not None:
        travel = 1 if spec.belt.direction == "ccw" else -1
        # the reverse listing keeps pulley 0 first (s = 0 stays where it was); two pulleys read
        # either way, so the orientation is forced as well
        order = list(range(k)) if listed == travel else [0, *range(k - 1, 0, -1)]
        return travel, order, travel, True, f'belt.direction = "{spec.belt.direction}"'
    travel, source = 1, "default (no driver with a non-zero speed or torque)"
    for i, (p, w) in enumerate(zip(spec.pulleys, sides)):
        if p.role == "driver":
            key, v = _driver_law(p)
            peak = float(v[np.argmax(np.abs(v))]) if v.size else 0.0
            if peak != 0.0:  # a driver on its back side turns against the loop
                travel, source = (1 if peak > 0 else -1) * w, f"the sign of {_pulley_label(i, p)}.{key}"
                break
    return travel, list(range(k)), None, listed == travel, source


def _nominal_speeds(spec: DriveSpec, radii: np.ndarray) -> np.ndarray:
    """Each pulley's nominal speed [rad/s]: the speed driver's final speed times its radius over the
    pulley's (both at the belt axis); needed (and checked) only where ``power_kw`` is given."""
    users = [i for i, p in enumerate(spec.pulleys) if p.power_kw is not None]
    out = np.full(len(spec.pulleys), np.nan)
    if not users:
        return out
    first = _pulley_label(users[0], spec.pulleys[users[0]]) + ".power_kw"
    drivers = [i for i, p in enumerate(spec.pulleys) if p.role == "driver"
               and (p.speed is not None or p.speed_rpm is not None)]
    _require(len(drivers) == 1, first, spec.pulleys[users[0]].power_kw,
             "needs exactly one driver with a prescribed speed ('speed' or 'speed_rpm') to set the nominal "
             f"speed; found {len(drivers)}: give 'load' (N m) instead")
    d = spec.pulleys[drivers[0]]
    key, v = _driver_law(d)
    w = abs(float(v[-1])) * (_RPM if key == "speed_rpm" else 1.0) if v.size else 0.0
    _require(w > 0, first, spec.pulleys[users[0]].power_kw,
             f"needs a non-zero final speed of the driver ({_pulley_label(drivers[0], d)}.{key}) to convert the "
             "power into a torque; give 'load' (N m) instead")
    return w * radii[drivers[0]] / radii


def _direction_warnings(spec: DriveSpec, travel: int, along: bool, source: str) -> None:
    """One-line warnings where the sense of travel is probably not what the file means
    (``spec.pulleys`` in model order; ``along``: spans run in that order)."""
    k, word, other = len(spec.pulleys), _SENSE_WORDS[travel], _SENSE_KEYS[-travel]
    if not along:
        warnings.warn(
            f"the pulleys are listed {_SENSE_WORDS[-travel]} but the belt runs {word} (set by {source}): spans "
            f"are named and contact angles measured against the travel; set belt.direction = "
            f'"{_SENSE_KEYS[travel]}" to keep this sense (spans then named in travel order), or belt.direction = '
            f'"{other}" to run the belt in the listed order', UserWarning, stacklevel=3)
    if spec.belt.direction is not None:
        for i, p in enumerate(spec.pulleys):
            if p.role == "driver":
                key, v = _driver_law(p)
                if v.size and float(v[np.argmax(np.abs(v))]) < 0:
                    warnings.warn(
                        f"{_pulley_label(i, p)}.{key} is negative: with belt.direction = \"{spec.belt.direction}\" "
                        f"a driver's {key} counts in that sense, so it drives the belt {_SENSE_WORDS[-travel]} and "
                        f"loads then drive the pulleys; give a positive {key} (and belt.direction = \"{other}\" if "
                        f"the belt should run {_SENSE_WORDS[-travel]})", UserWarning, stacklevel=3)
    seq = list(range(k)) if along else [0, *range(k - 1, 0, -1)]  # model indices in travel order
    pl = [spec.pulleys[i] for i in seq]
    for i, p in enumerate(pl):
        if p.role != "driver":
            continue
        # walk against the travel from the driver to the pulley that takes power off the belt: that
        # stretch is the tight side
        tens, j = [], (i - 1) % k
        while j != i and pl[j].role != "driver":
            if pl[j].role == "driven" or pl[j].load is not None or pl[j].power_kw is not None:
                if tens:
                    fix = (f'set belt.direction = "{other}"' if spec.belt.direction is not None
                           else f'set belt.direction = "{other}" (pulleys may then be listed in either order)')
                    warnings.warn(
                        f"pulley {tens[0]!r} (a tensioner) sits on the tight side of the belt, between {pl[j].name!r} "
                        f"and the driver {p.name!r} with the belt running {word} ({source}); a tensioner belongs on "
                        f"the slack side, after the driver: if the belt should run the other way, {fix}",
                        UserWarning, stacklevel=3)
                break
            if pl[j].tensioner is not None or pl[j].role == "tensioner":
                tens.append(pl[j].name)
            j = (j - 1) % k


def _initial_state(q0, psi0, npul: int, nc: int) -> DriveState:
    """The drive at rest on its installed path (also evaluated abstractly for the memory estimate)."""
    z = jnp.zeros(npul)
    f64 = lambda x: jnp.asarray(x, dtype=float)
    return DriveState(q=q0, v=jnp.zeros_like(q0), theta=z, omega=z, psi=psi0, psi_dot=z,
                      lam_n=jnp.zeros(nc), lam_t=jnp.zeros(nc), contact_pulley=-jnp.ones(nc),
                      belt_torque=z, lcp_residual=f64(0.0), work=WorkTerms.zeros(), pulley_work=z, angular_impulse=z,
                      fault=f64(float(Fault.OK)),
                      fault_time=f64(jnp.inf))


def _state_bytes(n: int, npul: int, nc: int) -> int:
    """Bytes of one ``DriveState`` (traced abstractly with ``jax.eval_shape``: nothing runs or compiles)."""
    import functools

    import jax

    dtype = jnp.result_type(float)
    shapes = jax.eval_shape(functools.partial(_initial_state, npul=npul, nc=nc),
                            jax.ShapeDtypeStruct((n, 2, 2), dtype), jax.ShapeDtypeStruct((npul,), dtype))
    return int(sum(math.prod(x.shape) * np.dtype(x.dtype).itemsize for x in jax.tree.leaves(shapes)))


def _check_run_size(spec: DriveSpec, dt: float, n: int, npul: int, nc: int) -> None:
    """Refuse runs whose step count or saved trajectory is beyond reason (a typo in t_end, save_dt ...)."""
    s = spec.solver
    n_settle = int(round(s.settle_time / dt))
    n_run = int(math.ceil(s.t_end / dt - 1e-9))
    key, value = ("solver.settle_time", s.settle_time) if n_settle > n_run else ("solver.t_end", s.t_end)
    _require(n_settle + n_run <= MAX_STEPS, key, value,
             f"with the time step {dt:.3g} s, settling {s.settle_time:g} s and running {s.t_end:g} s take "
             f"{n_settle + n_run:.3g} steps, more than the {MAX_STEPS:.0e} allowed; shorten {key} "
             "(or coarsen the mesh, belt.n_elements, for a larger stable step)")
    stride = max(1, int(round(s.save_dt / dt)))
    n_saves = n_run // stride + 2          # the saved times 0, save_dt, ... and the final state
    per_state = _state_bytes(n, npul, nc)
    need = n_saves * per_state
    gib = 1024**3
    if need > MAX_SAVED_BYTES:
        _require(2 * per_state <= MAX_SAVED_BYTES, "belt.n_elements", n,
                 f"one saved state takes {per_state / gib:.3g} GiB; the limit for all saved states is "
                 f"{MAX_SAVED_BYTES / gib:g} GiB")
        min_save_dt = s.t_end / (MAX_SAVED_BYTES // per_state - 2)
        raise ConfigError(
            f"solver.save_dt = {s.save_dt!r}: saving {n_saves} states ({per_state / 1024:.4g} KiB each) until "
            f"t_end = {s.t_end:g} s needs {need / gib:.3g} GiB of memory, more than the {MAX_SAVED_BYTES / gib:g} GiB "
            f"allowed; raise solver.save_dt to at least {min_save_dt:.3g} s or shorten solver.t_end "
            f"(saves are at most one per time step, dt = {dt:.3g} s)")
    _check_memory(spec, n, npul, nc, n_saves, per_state, dt=dt, n_run=n_run)


def _operator_bytes(n: int, points_per_element: int, itemsize: int) -> int:
    """Peak bytes of the dense operators one simulation builds (``drive_operators``).

    With ``N = 2 n`` scalar belt DOFs and ``nc`` contact points: the mass matrix, its inverse and
    one ``N x N`` work array of the inversion (3 N^2); S^T, [S; dS]^T (two) and S M^-1 (4 N nc); the
    Delassus matrix S M^-1 S^T (nc^2). Measured peak RSS growth of a short run (float64): 8.1 N^2 at
    1920 and 2880 elements with 2 points (this count: 8 N^2), 5.36 N^2 at 1920 with 1 point (5.25 N^2).
    """
    N, nc = 2 * n, n * points_per_element
    return itemsize * (3 * N * N + 4 * N * nc + nc * nc)


def _available_memory() -> tuple[int, str]:
    """Bytes this process can still allocate without swapping: MemAvailable of /proc/meminfo
    (else the free pages of os.sysconf), capped by a cgroup (container) memory limit."""
    avail = None
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    avail = int(line.split()[1]) * 1024
                    break
    except (OSError, ValueError, IndexError):
        pass
    if avail is None:
        try:
            avail = os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
        except (ValueError, OSError, AttributeError):
            return 0, "memory"  # unknown: no check
    try:
        with open("/sys/fs/cgroup/memory.max") as fh:
            limit = fh.read().strip()
        with open("/sys/fs/cgroup/memory.current") as fh:
            used = int(fh.read().strip())
        if limit != "max":
            avail = min(avail, int(limit) - used)
    except (OSError, ValueError):
        pass
    return max(int(avail), 0), "memory"


def _device_memory() -> int | None:
    """Free memory of the first accelerator (None on a CPU-only JAX): the operators live there."""
    import jax

    if jax.default_backend() == "cpu":
        return None
    try:
        stats = jax.devices()[0].memory_stats() or {}
        return int(stats["bytes_limit"]) - int(stats.get("bytes_in_use", 0))
    except (KeyError, TypeError, ValueError, RuntimeError):
        return None


def _check_memory(spec: DriveSpec, n: int, npul: int, nc: int, n_saves: int, per_state: int, *,
                  dt: float | None = None, n_run: int | None = None) -> None:
    """Refuse a run whose operators and saved states need more memory than this machine has free."""
    m = nc // n
    itemsize = np.dtype(jnp.result_type(float)).itemsize
    ops = _operator_bytes(n, m, itemsize)
    traj = TRAJECTORY_COPIES * n_saves * per_state
    avail, where = _available_memory()
    if ops + traj > 2**30:  # only a large run asks JAX for its platform (initialising the backend)
        dev = _device_memory()  # operators and saved states live there, the host keeps copies of the states
        if dev is not None and (avail <= 0 or dev < avail):
            avail, where = dev, "accelerator memory"
    budget = MEMORY_SAFETY * avail
    if avail <= 0 or ops + traj <= budget:
        return
    gb = 1e9
    # per saved state bytes grow linearly with n (eval_shape of one more element gives the slope)
    slope = _state_bytes(n + 1, npul, nc + m) - per_state
    need = lambda k: _operator_bytes(k, m, itemsize) + TRAJECTORY_COPIES * n_saves * (per_state + (k - n) * slope)
    lo, hi = 0, n  # need(lo) fits (or lo = 0: none does), need(hi) does not
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if need(mid) <= budget else (lo, mid)
    what = (f"needs about {(ops + traj) / gb:.3g} GB of {where} (dense belt and contact operators "
            f"{ops / gb:.3g} GB, {n_saves} saved states {traj / gb:.3g} GB), more than {MEMORY_SAFETY:.0%} of the "
            f"{avail / gb:.3g} GB this machine has free")
    if lo >= 8 and ops >= traj:
        raise ConfigError(f"belt.n_elements = {n}: the run {what}; at most {lo} elements fit")
    s = spec.solver
    max_saves = int((budget - ops) // (TRAJECTORY_COPIES * per_state))
    if dt is not None and n_run is not None and max_saves > 2:
        stride = math.ceil(n_run / (max_saves - 2))  # saves fall every stride steps (save_dt is rounded to that)
        raise ConfigError(f"solver.save_dt = {s.save_dt!r}: the run {what}; raise solver.save_dt to at least "
                          f"{stride * dt:.6g} s, shorten solver.t_end or use fewer elements")
    raise ConfigError(f"belt.n_elements = {n}: the run {what}; use fewer elements"
                      + (f" (at most {lo})" if lo >= 8 else ""))


def build_drive(spec: DriveSpec, *, _check_only: bool = False) -> Drive | None:
    """Validate ``spec`` and build the static model, the parameters and the state at rest.

    Every check runs first, on plain Python and numpy values: a bad configuration is refused (with
    a ``ConfigError`` naming the key) before any JAX array is made or anything is compiled.
    ``_check_only``: run every check, build nothing, return None (sweeps check each grid point so).
    """
    # ------------------------------------------------------------------ validation (no JAX)
    _check_spec_types(spec)
    b = _belt_numbers(spec.belt)
    c, s = spec.contact, spec.solver
    _require(_is_number(c.mu) and math.isfinite(c.mu) and c.mu > 0, "contact.mu", c.mu,
             "must be a finite number > 0 (a frictionless belt cannot transmit torque)")
    _positive("contact.stiffness", c.stiffness)
    _non_negative("contact.damping", c.damping)
    _require(isinstance(c.friction_law, str) and c.friction_law in FRICTION_LAWS,
             "contact.friction_law", c.friction_law, "must be one of " + ", ".join(map(repr, FRICTION_LAWS)))
    _positive("contact.nu_s", c.nu_s)
    check_law_keys(c, _require)
    _require(not isinstance(c.points_per_element, bool) and c.points_per_element in (1, 2),
             "contact.points_per_element", c.points_per_element,
             "must be 1 or 2 (more points than belt DOFs make the contact problem singular)")
    if s.dt is not None:
        _positive("solver.dt", s.dt)
    _positive("solver.t_end", s.t_end)
    _positive("solver.save_dt", s.save_dt)
    _non_negative("solver.settle_time", s.settle_time)
    _non_negative("solver.settle_damping", s.settle_damping)
    _integer("solver.lcp_iterations", s.lcp_iterations, 1, MAX_LCP_ITERATIONS)
    _require(_is_number(s.relaxation) and 0 < s.relaxation <= 1.0, "solver.relaxation", s.relaxation,
             "must be in (0, 1]")

    names = [p.name for p in spec.pulleys]
    for i, name in enumerate(names):
        _require(isinstance(name, str) and name.strip() != "" and not any(ch in name for ch in ".,"),
                 f"pulleys[{i}].name", name,
                 "must be a non-empty string without '.' or ',' (it is used in keys such as pulleys.<name>.load)")
    _require(len(set(names)) == len(names), "pulleys.name", names, "names must be unique")
    g = _pair("gravity", spec.gravity, "[gx, gy] in m/s^2")
    _require(spec.belt.direction is None or (isinstance(spec.belt.direction, str)
                                             and spec.belt.direction in ("cw", "ccw")),
             "belt.direction", spec.belt.direction,
             "must be 'cw' (clockwise) or 'ccw' (counter-clockwise), seen with z toward the viewer")

    centers, radii, sides, radii_flipped = [], [], [], []
    for i, p in enumerate(spec.pulleys):
        f = _pulley_label(i, p)
        _require(isinstance(p.role, str) and p.role in ("driver", "driven", "idler", "tensioner"), f + ".role",
                 p.role, "must be one of driver, driven, idler, tensioner")
        _require(isinstance(p.wrap, str) and p.wrap in ("inner", "back"), f + ".wrap", p.wrap,
                 "must be 'inner' or 'back'")
        _require(p.grooved is None or isinstance(p.grooved, (bool, np.bool_)), f + ".grooved", p.grooved,
                 "must be true, false or None")
        _positive(f + ".radius", p.radius)
        _positive(f + ".inertia", p.inertia)
        _non_negative(f + ".viscous", p.viscous)
        ctr = _pair(f + ".center", p.center)
        offset = b["inner"] if p.wrap == "inner" else b["back"]
        centers.append(ctr)
        radii.append(p.radius + offset)
        radii_flipped.append(p.radius + (b["back"] if p.wrap == "inner" else b["inner"]))
        sides.append(1 if p.wrap == "inner" else -1)
        if p.role == "driver":
            given = [k for k in ("speed", "speed_rpm", "torque") if getattr(p, k) is not None]
            _require(len(given) == 1, f + "." + ("/".join(given) if len(given) > 1 else "speed/torque"),
                     tuple(getattr(p, k) for k in given) or (None, None),
                     "a driver needs exactly one of 'speed' (rad/s law), 'speed_rpm' (rpm law) or 'torque' (N m law)")
            _require(p.power_kw is None, f + ".power_kw", p.power_kw,
                     "a driver delivers power; give power_kw on a driven pulley (its load)")
        if p.role != "driver":
            _require(p.speed is None, f + ".speed", p.speed, "only a driver has a prescribed speed")
            _require(p.speed_rpm is None, f + ".speed_rpm", p.speed_rpm, "only a driver has a prescribed speed")
        for key in ("speed", "speed_rpm", "torque", "load", "power_kw"):
            _check_law(getattr(p, key), f"{f}.{key}")
        if p.torque is not None and p.load is not None:
            raise ConfigError(f"{f}: give either 'torque' or 'load', not both")
        if p.power_kw is not None and (p.torque is not None or p.load is not None):
            raise ConfigError(f"{f}: give either '{'load' if p.load is not None else 'torque'}' or 'power_kw', "
                              "not both")
        for key in ("load", "power_kw"):  # braking is the meaning of these keys; driving is 'torque'
            low = _law_minimum(getattr(p, key))
            if low < 0:
                warnings.warn(f"{f}.{key} reaches {low:g}: a negative {key} drives the pulley instead of braking it "
                              f"({key} always opposes the pulley's running sense); for a driving torque give "
                              f"{f}.torque (positive in the running sense)", UserWarning, stacklevel=2)
        t = p.tensioner
        if p.role == "tensioner":
            _require(t is not None, f + ".tensioner", t, "a tensioner needs a [tensioner] table (arm or slider)")
        if t is None:
            continue
        _require(isinstance(t.kind, str) and t.kind in ("arm", "slider"), f + ".tensioner.kind", t.kind,
                 "must be 'arm' or 'slider'")
        _non_negative(f + ".tensioner.stiffness", t.stiffness)
        _non_negative(f + ".tensioner.damping", t.damping)
        _non_negative(f + ".tensioner.mass", t.mass)
        _finite(f + ".tensioner.preload", t.preload, "must be finite")
        if t.inertia is not None:
            _positive(f + ".tensioner.inertia", t.inertia)
        if t.pivot is not None:
            pivot = _pair(f + ".tensioner.pivot", t.pivot)
        if t.direction is not None:
            d = _pair(f + ".tensioner.direction", t.direction, "(x, y)")
            _require(math.hypot(*d) > 0, f + ".tensioner.direction", t.direction, "must be a non-zero vector (x, y)")
        if t.kind == "arm":
            _require(t.pivot is not None, f + ".tensioner.pivot", t.pivot, "an arm tensioner needs its pivot (x, y)")
            L = math.hypot(ctr[0] - pivot[0], ctr[1] - pivot[1])
            _require(L > 0, f + ".tensioner.pivot", t.pivot, "must differ from the pulley centre")
            inertia = t.inertia if t.inertia is not None else max(t.mass, 1e-3) * L * L
        else:
            inertia = t.inertia if t.inertia is not None else max(t.mass, 1e-2)
        _positive(f + ".tensioner.inertia", inertia)
        _tensioner_rest(f, t)

    _require(any(p.role == "driver" for p in spec.pulleys), "pulleys.role",
             [p.role for p in spec.pulleys], "a drive needs one driver")
    centers_np, radii_np = np.asarray(centers, dtype=float), np.asarray(radii, dtype=float)
    legend = ", ".join(f"{i} = {name}" for i, name in enumerate(names))
    with np.errstate(all="ignore"):  # absurd coordinates overflow: refused below, not warned about
        try:
            check_belt_path(centers_np, radii_np, tuple(sides), radii_flipped=np.asarray(radii_flipped, dtype=float))
        except ValueError as err:
            raise ConfigError(f"pulleys: {err} (pulleys in the order listed: {legend})"
                              + _named_fixes(err, spec.pulleys)) from None
        # the sense of travel; with belt.direction the pulleys are put in travel order
        travel, order, orientation, along, source = _travel(spec, centers_np, radii_np, sides)
        L_path = _path_length(centers_np, radii_np, sides)  # numpy; the built path gives the same length
    omega_nominal = _nominal_speeds(spec, radii_np)  # for power_kw
    _require(math.isfinite(L_path) and L_path > 0, "pulleys.center", [tuple(x) for x in centers],
             f"give a belt path of length {L_path!r} m; centres and radii must be of a realistic size")

    bl = spec.belt
    how = installed_state_definition(bl)
    L0 = _stress_free_length(bl, b["EA"], L_path)
    stretch = L_path / L0
    key, value = f"belt.{how}", getattr(bl, how)
    pitch = (f" (at the pitch line: effective length + 2π × effective_offset {_effective_offset(bl):g} m)"
             if how == "effective_length" else "")
    _require(stretch >= 1.0, key, value,
             f"the stress-free length {L0:.6g} m{pitch} is longer than the belt path around the pulleys "
             f"({L_path:.6g} m): the belt would be slack (shorten it or move the pulleys apart)")
    _require(stretch < 1.2, key, value,
             f"the stress-free length {L0:.6g} m{pitch} needs {100 * (stretch - 1):.1f} % strain to reach the belt "
             f"path ({L_path:.6g} m); a belt cannot be installed beyond 20 % strain")

    n = bl.n_elements
    from ..dynamics.stability import rate_bounds, step_limit

    try:
        with np.errstate(all="ignore"):
            dt_limit = step_limit(*rate_bounds(n, float(b["EA"]), float(b["EI"]), float(b["cd"]),
                                               float(bl.bending_damping), float(b["m"]), float(L0)))
    except (OverflowError, ZeroDivisionError):
        dt_limit = math.nan
    _require(math.isfinite(dt_limit) and dt_limit > 0, "belt.EA, belt.EI, belt.mass_per_length",
             (b["EA"], b["EI"], b["m"]),
             f"gives no usable stable time step ({dt_limit!r} s): stiffness and mass per length are out of "
             "any realistic range")
    if s.dt is not None:
        _require(s.dt <= dt_limit, "solver.dt", s.dt,
                 f"exceeds the stability limit {dt_limit:.3g} s of this mesh ({n} elements); use dt <= "
                 f"{0.9 * dt_limit:.3g} s, or fewer elements, or less belt damping")
    _check_run_size(spec, 0.9 * dt_limit if s.dt is None else s.dt, n, len(names), n * c.points_per_element)
    if _check_only:
        return None

    element = L_path / n
    for name, radius in zip(names, radii_np):
        if element > 0.5 * radius:
            warnings.warn(
                f"pulley {name!r} (radius {radius:.4g} m at the belt axis) is wrapped by belt elements "
                f"{element:.4g} m long: expect a speed and tension ripple from the polygon effect; use at least "
                f"{math.ceil(2 * L_path / radius)} elements (element length <= radius / 2)", UserWarning, stacklevel=2)
    _check_spring_loads(spec, b["EA"] * (stretch - 1.0))

    if order != list(range(len(names))):
        spec = dataclasses.replace(spec, pulleys=[spec.pulleys[i] for i in order])
        names, centers_np, radii_np = [names[i] for i in order], centers_np[order], radii_np[order]
        sides, omega_nominal = [sides[i] for i in order], omega_nominal[order]
    sense = [travel * w for w in sides]
    _direction_warnings(spec, travel, along, source)

    # ------------------------------------------------------------------ construction
    kinematic, carrier, ffac = [], [], []
    pp = dict(inertia=[], speed=[], torque=[], viscous=[], arm_length=[], direction=[], cinertia=[], cmass=[],
              spring=[], preload=[], rest=[], cdamp=[], origin=[], psi0=[])
    wedge = 1.0 / math.sin(math.radians(spec.belt.groove_angle_deg) / 2.0)
    for i, p in enumerate(spec.pulleys):
        f = _pulley_label(i, p)
        ctr = (float(p.center[0]), float(p.center[1]))
        grooved = p.grooved if p.grooved is not None else (spec.belt.type == "poly-v" and p.wrap == "inner")
        ffac.append(wedge if grooved else 1.0)
        kinematic.append(p.role == "driver" and (p.speed is not None or p.speed_rpm is not None))
        pp["inertia"].append(p.inertia)
        # laws are stored counter-clockwise positive; _law_sign turns the user's sense into that
        key = "speed_rpm" if p.speed_rpm is not None else "speed"
        pp["speed"].append(law_from_spec(getattr(p, key), f"{f}.{key}", sign=_law_sign(p, key, sense[i], spec)))
        key = next((k for k in ("torque", "load", "power_kw") if getattr(p, k) is not None), "torque")
        scale = 1e3 / omega_nominal[i] if key == "power_kw" else 1.0  # kW at the nominal speed -> N m
        pp["torque"].append(law_from_spec(getattr(p, key), f"{f}.{key}",
                                          sign=_law_sign(p, key, sense[i], spec) * scale))
        pp["viscous"].append(p.viscous)
        t = p.tensioner
        if t is None:
            carrier.append(FixedCarrier())
            pp["origin"].append(ctr); pp["arm_length"].append(0.0); pp["direction"].append((1.0, 0.0))
            pp["psi0"].append(0.0); pp["cinertia"].append(1.0); pp["cmass"].append(0.0); pp["spring"].append(0.0)
            pp["preload"].append(0.0); pp["rest"].append(0.0); pp["cdamp"].append(0.0)
            continue
        if t.kind == "arm":
            dx, dy = ctr[0] - t.pivot[0], ctr[1] - t.pivot[1]
            L = math.hypot(dx, dy)
            psi0 = math.atan2(dy, dx)
            carrier.append(ArmCarrier())
            pp["origin"].append(tuple(t.pivot)); pp["arm_length"].append(L); pp["direction"].append((1.0, 0.0))
            inertia = t.inertia if t.inertia is not None else max(t.mass, 1e-3) * L * L
        else:
            d = np.asarray(t.direction if t.direction is not None else (0.0, 1.0), dtype=float)
            d = d / np.linalg.norm(d)
            psi0 = 0.0
            carrier.append(SliderCarrier())
            pp["origin"].append(ctr); pp["arm_length"].append(0.0); pp["direction"].append(tuple(d))
            inertia = t.inertia if t.inertia is not None else max(t.mass, 1e-2)
        pp["psi0"].append(psi0); pp["cinertia"].append(inertia); pp["cmass"].append(t.mass)
        pp["spring"].append(t.stiffness); pp["preload"].append(t.preload)
        rest = _tensioner_rest(f, t)
        pp["rest"].append(psi0 if rest is None else rest); pp["cdamp"].append(t.damping)

    path = belt_path(jnp.asarray(centers_np), jnp.asarray(radii_np), tuple(sides), orientation=orientation)
    L_path = float(path.length)
    L0 = _stress_free_length(bl, b["EA"], L_path)

    model = DriveModel(
        n_elements=n, pulley_names=tuple(names), kinematic=tuple(kinematic), carriers=tuple(carrier),
        wrap_side=tuple(sides), friction_factor=tuple(ffac), contact_points_per_element=c.points_per_element,
        friction_law=law_for(c),
        lcp_iterations=int(s.lcp_iterations), lcp_relaxation=float(s.relaxation))

    f64 = lambda x: jnp.asarray(x, dtype=float)
    belt = BeltParams(EA=f64(b["EA"]), EI=f64(b["EI"]), axial_damping=f64(b["cd"]),
                      bending_damping=f64(bl.bending_damping), mass_per_length=f64(b["m"]),
                      stress_free_length=f64(L0))
    pulleys = PulleyParams(
        radius=f64(radii_np), center=f64(pp["origin"]), inertia=f64(pp["inertia"]),
        speed=tl.stack_laws(pp["speed"]), torque=tl.stack_laws(pp["torque"]), viscous=f64(pp["viscous"]),
        arm_length=f64(pp["arm_length"]), slider_direction=f64(pp["direction"]),
        carrier_inertia=f64(pp["cinertia"]), carrier_mass=f64(pp["cmass"]), spring=f64(pp["spring"]),
        preload=f64(pp["preload"]), rest=f64(pp["rest"]), carrier_damping=f64(pp["cdamp"]))
    params = DriveParams(belt=belt, pulleys=pulleys, mu=f64(c.mu), contact_stiffness=f64(c.stiffness),
                         contact_damping=f64(c.damping), nu_s=f64(c.nu_s), gravity=f64(g),
                         mass_damping=f64(bl.mass_damping), settle_damping=f64(s.settle_damping),
                         friction=law_arrays(c, f64))

    q0 = place_belt(path, n, L0)
    state0 = _initial_state(q0, f64(pp["psi0"]), len(names), model.n_contacts)

    from ..dynamics.stability import stable_time_step  # the same closed form as above, on the built params

    dt = 0.9 * stable_time_step(model, params, q0) if s.dt is None else s.dt
    from_E = tuple(k for k in ("EA", "EI") if bl.E is not None and getattr(bl, k) is None)
    return Drive(spec=spec, model=model, params=params, state0=state0, path=path, dt=float(dt), travel=travel,
                 running_sense=tuple(sense), installed_by=installed_state_definition(spec),
                 E_sets=from_E or ("EA", "EI"))

