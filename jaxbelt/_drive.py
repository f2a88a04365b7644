"""Drive specification (plain Python, validated) and its translation into Model, Params and State.

A ``DriveSpec`` is what a user writes (in Python or TOML): SI units, pulleys listed in the order
the belt travels. ``build_drive`` validates everything *before* anything is traced or compiled and
raises ``ConfigError`` naming the field, the value and what is allowed.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from dataclasses import dataclass, field
from typing import Literal

import jax.numpy as jnp
import numpy as np

from . import _timelaw as tl
from ._belt import BeltParams
from ._layout import BeltPath, belt_path, check_belt_path, place_belt
from ._lcp import COULOMB, REGULARISED
from ._model import CARRIER_ARM, CARRIER_FIXED, CARRIER_SLIDER, DriveModel, DriveParams, DriveState, PulleyParams

__all__ = ["ConfigError", "BeltSpec", "PulleySpec", "TensionerSpec", "ContactSpec", "SolverSpec", "DriveSpec",
           "Drive", "build_drive", "law_from_spec"]


class ConfigError(ValueError):
    """A drive configuration that cannot be simulated; the message names the field."""


def _require(cond: bool, field_name: str, value, allowed: str):
    if not cond:
        raise ConfigError(f"{field_name} = {value!r}: {allowed}")


def _positive(field_name: str, value):
    _require(value is not None and isinstance(value, (int, float)) and math.isfinite(value) and value > 0,
             field_name, value, "must be a finite number > 0")


def _non_negative(field_name: str, value):
    _require(isinstance(value, (int, float)) and math.isfinite(value) and value >= 0,
             field_name, value, "must be a finite number >= 0")


@dataclass
class BeltSpec:
    """Belt data. Stiffness and mass refer to the *stress-free* length.

    Give either ``E`` (with ``width`` and ``thickness``) or explicit ``EA``/``EI``; either ``rho``
    or ``mass_per_length``; either ``stress_free_length`` or ``pretension`` (uniform installed
    tension, from which the stress-free length follows).
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


@dataclass
class TensionerSpec:
    """Carrier of a tensioner pulley: a pivoted arm (default) or a linear slider.

    Arm: the pulley centre at installation (``PulleySpec.center``) and ``pivot`` fix the arm length
    and the installed angle. The spring torque on the arm is
    ``preload + stiffness * (rest - angle)`` (counter-clockwise positive; ``rest`` defaults to the
    installed angle). Slider: travel ``s`` along ``direction`` from the installed centre, force
    ``preload + stiffness * (rest - s)``.
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
    torque: dict | tl.TimeLaw | float | None = None   # applied torque law (driver by torque) [N m]
    load: dict | tl.TimeLaw | float | None = None     # load torque law opposing rotation (driven) [N m]
    viscous: float = 0.0                    # viscous load [N m s/rad]
    tensioner: TensionerSpec | None = None


@dataclass
class ContactSpec:
    mu: float = 0.5
    stiffness: float = 3.2e8                # per unit belt length [N/m^2]
    damping: float = 6.4e3                  # per unit belt length [N s/m^2]
    friction_law: Literal["coulomb", "regularized"] = "coulomb"
    nu_s: float = 50.0                      # regularised-law steepness [s/m]
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


def law_from_spec(value, what: str, sign: float = 1.0) -> tl.TimeLaw:
    """A number (constant), a TimeLaw, or a dict:
    ``{ramp = [t0, t1, v0, v1]}``, ``{smooth_step = [t0, t1, v0, v1]}``,
    ``{table = [[t, v], ...], smooth = false}``, optional ``base`` added to steps/ramps."""
    if value is None:
        return tl.constant(0.0)
    if isinstance(value, tl.TimeLaw):
        return tl.TimeLaw(value.times, sign * value.values, value.smooth)
    if isinstance(value, (int, float)):
        _require(math.isfinite(value), what, value, "must be finite")
        return tl.constant(sign * float(value))
    if isinstance(value, dict):
        keys = set(value) - {"base", "smooth"}
        _require(len(keys) == 1 and keys <= {"ramp", "smooth_step", "table", "constant"}, what, value,
                 "must have exactly one of 'constant', 'ramp', 'smooth_step', 'table'")
        (kind,) = keys
        base = float(value.get("base", 0.0))
        arg = value[kind]
        try:
            if kind == "constant":
                return tl.constant(sign * (float(arg) + base))
            if kind in ("ramp", "smooth_step"):
                _require(isinstance(arg, (list, tuple)) and len(arg) == 4, f"{what}.{kind}", arg,
                         "must be [t0, t1, v0, v1]")
                t0, t1, v0, v1 = map(float, arg)
                _require(t1 > t0, f"{what}.{kind}", arg, "needs t1 > t0")
                law = (tl.ramp if kind == "ramp" else tl.smooth_step)(t0, t1, sign * (v0 + base), sign * (v1 + base))
                return law
            pts = np.asarray(arg, dtype=float)
            _require(pts.ndim == 2 and pts.shape[1] == 2, f"{what}.table", arg, "must be a list of [t, value] pairs")
            return tl.table(pts[:, 0], sign * (pts[:, 1] + base), smooth=bool(value.get("smooth", False)))
        except ValueError as err:
            if isinstance(err, ConfigError):
                raise
            raise ConfigError(f"{what}: {err}") from None
    raise ConfigError(f"{what} = {value!r}: must be a number, a TimeLaw or a table/ramp/smooth_step dict")


def _belt_numbers(b: BeltSpec) -> dict:
    _require(isinstance(b.n_elements, int) and b.n_elements >= 8, "belt.n_elements", b.n_elements,
             "must be an integer >= 8")
    _positive("belt.width", b.width)
    _positive("belt.thickness", b.thickness)
    A = b.width * b.thickness
    I = b.width * b.thickness**3 / 12.0
    if b.EA is not None:
        _positive("belt.EA", b.EA)
    else:
        _require(b.E is not None, "belt.E", b.E, "give E (Young's modulus, Pa) or EA (N)")
        _positive("belt.E", b.E)
    EA = b.EA if b.EA is not None else b.E * A
    if b.EI is not None:
        _positive("belt.EI", b.EI)
    EI = b.EI if b.EI is not None else (b.E * I if b.E is not None else None)
    _require(EI is not None, "belt.EI", b.EI, "give EI (N m^2) or E (Pa)")
    if b.mass_per_length is not None:
        _positive("belt.mass_per_length", b.mass_per_length)
        m = b.mass_per_length
    else:
        _require(b.rho is not None, "belt.rho", b.rho, "give rho (kg/m^3) or mass_per_length (kg/m)")
        _positive("belt.rho", b.rho)
        m = b.rho * A
    if b.axial_damping is not None:
        _non_negative("belt.axial_damping", b.axial_damping)
        cd = b.axial_damping
    else:
        eta = 0.0 if b.eta is None else b.eta
        _non_negative("belt.eta", eta)
        cd = eta * A
    _non_negative("belt.bending_damping", b.bending_damping)
    _non_negative("belt.mass_damping", b.mass_damping)
    _require(b.type in ("flat", "poly-v"), "belt.type", b.type, "must be 'flat' or 'poly-v'")
    _require(0 < b.groove_angle_deg < 180, "belt.groove_angle_deg", b.groove_angle_deg, "must be in (0, 180)")
    inner = b.thickness / 2 if b.inner_offset is None else b.inner_offset
    back = b.thickness / 2 if b.back_offset is None else b.back_offset
    _non_negative("belt.inner_offset", inner)
    _non_negative("belt.back_offset", back)
    return dict(EA=EA, EI=EI, m=m, cd=cd, inner=inner, back=back)


def build_drive(spec: DriveSpec) -> Drive:
    """Validate ``spec`` and build the static model, the parameters and the state at rest."""
    b = _belt_numbers(spec.belt)
    c, s = spec.contact, spec.solver
    _require(isinstance(c.mu, (int, float)) and math.isfinite(c.mu) and c.mu > 0, "contact.mu", c.mu,
             "must be a finite number > 0 (a frictionless belt cannot transmit torque)")
    _positive("contact.stiffness", c.stiffness)
    _non_negative("contact.damping", c.damping)
    _require(c.friction_law in ("coulomb", "regularized"), "contact.friction_law", c.friction_law,
             "must be 'coulomb' or 'regularized'")
    _positive("contact.nu_s", c.nu_s)
    _require(c.points_per_element in (1, 2), "contact.points_per_element", c.points_per_element,
             "must be 1 or 2 (more points than belt DOFs make the contact problem singular)")
    _require(isinstance(spec.pulleys, list) and len(spec.pulleys) >= 2, "pulleys", len(spec.pulleys or []),
             "a drive needs at least 2 pulleys")
    names = [p.name for p in spec.pulleys]
    _require(len(set(names)) == len(names), "pulleys.name", names, "names must be unique")
    g = tuple(float(x) for x in spec.gravity)
    _require(len(g) == 2 and all(math.isfinite(x) for x in g), "gravity", spec.gravity, "must be two finite numbers")

    centers, radii, sides, kinematic, carrier, ffac = [], [], [], [], [], []
    pp = dict(inertia=[], speed=[], torque=[], viscous=[], arm_length=[], direction=[], cinertia=[], cmass=[],
              spring=[], preload=[], rest=[], cdamp=[], origin=[], psi0=[])
    wedge = 1.0 / math.sin(math.radians(spec.belt.groove_angle_deg) / 2.0)
    for i, p in enumerate(spec.pulleys):
        f = f"pulleys[{i}] ({p.name})"
        _require(p.role in ("driver", "driven", "idler", "tensioner"), f + ".role", p.role,
                 "must be one of driver, driven, idler, tensioner")
        _require(p.wrap in ("inner", "back"), f + ".wrap", p.wrap, "must be 'inner' or 'back'")
        _positive(f + ".radius", p.radius)
        _positive(f + ".inertia", p.inertia)
        _non_negative(f + ".viscous", p.viscous)
        ctr = tuple(float(x) for x in p.center)
        _require(len(ctr) == 2 and all(math.isfinite(x) for x in ctr), f + ".center", p.center,
                 "must be two finite numbers (x, y) in m")
        offset = b["inner"] if p.wrap == "inner" else b["back"]
        centers.append(ctr)
        radii.append(p.radius + offset)
        sides.append(1 if p.wrap == "inner" else -1)
        grooved = p.grooved if p.grooved is not None else (spec.belt.type == "poly-v" and p.wrap == "inner")
        ffac.append(wedge if grooved else 1.0)
        is_kin = p.role == "driver" and p.speed is not None
        if p.role == "driver":
            _require((p.speed is None) != (p.torque is None), f + ".speed/torque", (p.speed, p.torque),
                     "a driver needs exactly one of 'speed' (rad/s law) or 'torque' (N m law)")
        if p.role != "driver":
            _require(p.speed is None, f + ".speed", p.speed, "only a driver has a prescribed speed")
        kinematic.append(is_kin)
        pp["inertia"].append(p.inertia)
        pp["speed"].append(law_from_spec(p.speed, f + ".speed"))
        applied = law_from_spec(p.torque, f + ".torque")
        load = law_from_spec(p.load, f + ".load", sign=-1.0)
        pp["torque"].append(applied if p.load is None else load if p.torque is None else
                            _sum_laws(applied, load, f))
        pp["viscous"].append(p.viscous)
        t = p.tensioner
        if p.role == "tensioner":
            _require(t is not None, f + ".tensioner", t, "a tensioner needs a [tensioner] table (arm or slider)")
        if t is None:
            carrier.append(CARRIER_FIXED)
            pp["origin"].append(ctr); pp["arm_length"].append(0.0); pp["direction"].append((1.0, 0.0))
            pp["psi0"].append(0.0); pp["cinertia"].append(1.0); pp["cmass"].append(0.0); pp["spring"].append(0.0)
            pp["preload"].append(0.0); pp["rest"].append(0.0); pp["cdamp"].append(0.0)
            continue
        _require(t.kind in ("arm", "slider"), f + ".tensioner.kind", t.kind, "must be 'arm' or 'slider'")
        _non_negative(f + ".tensioner.stiffness", t.stiffness)
        _non_negative(f + ".tensioner.damping", t.damping)
        _non_negative(f + ".tensioner.mass", t.mass)
        _require(math.isfinite(t.preload), f + ".tensioner.preload", t.preload, "must be finite")
        if t.kind == "arm":
            _require(t.pivot is not None and len(t.pivot) == 2, f + ".tensioner.pivot", t.pivot,
                     "an arm tensioner needs its pivot (x, y)")
            dx, dy = ctr[0] - t.pivot[0], ctr[1] - t.pivot[1]
            L = math.hypot(dx, dy)
            _require(L > 0, f + ".tensioner.pivot", t.pivot, "must differ from the pulley centre")
            psi0 = math.atan2(dy, dx)
            carrier.append(CARRIER_ARM)
            pp["origin"].append(tuple(t.pivot)); pp["arm_length"].append(L); pp["direction"].append((1.0, 0.0))
            inertia = t.inertia if t.inertia is not None else max(t.mass, 1e-3) * L * L
        else:
            d = np.asarray(t.direction if t.direction is not None else (0.0, 1.0), dtype=float)
            _require(d.shape == (2,) and np.linalg.norm(d) > 0, f + ".tensioner.direction", t.direction,
                     "must be a non-zero vector (x, y)")
            d = d / np.linalg.norm(d)
            psi0 = 0.0
            carrier.append(CARRIER_SLIDER)
            pp["origin"].append(ctr); pp["arm_length"].append(0.0); pp["direction"].append(tuple(d))
            inertia = t.inertia if t.inertia is not None else max(t.mass, 1e-2)
        _positive(f + ".tensioner.inertia", inertia)
        pp["psi0"].append(psi0); pp["cinertia"].append(inertia); pp["cmass"].append(t.mass)
        pp["spring"].append(t.stiffness); pp["preload"].append(t.preload)
        pp["rest"].append(psi0 if t.rest is None else t.rest); pp["cdamp"].append(t.damping)

    _require(any(kinematic) or any(p.role == "driver" for p in spec.pulleys), "pulleys.role",
             [p.role for p in spec.pulleys], "a drive needs one driver")
    centers_np, radii_np = np.asarray(centers), np.asarray(radii)
    try:
        check_belt_path(centers_np, radii_np, tuple(sides))
    except ValueError as err:
        raise ConfigError(f"pulleys: {err}") from None
    path = belt_path(jnp.asarray(centers_np), jnp.asarray(radii_np), tuple(sides))
    L_path = float(path.length)

    bl = spec.belt
    _require((bl.stress_free_length is None) != (bl.pretension is None), "belt.stress_free_length/pretension",
             (bl.stress_free_length, bl.pretension), "give exactly one of them")
    if bl.pretension is not None:
        _non_negative("belt.pretension", bl.pretension)
        L0 = L_path / (1.0 + bl.pretension / b["EA"])
    else:
        _positive("belt.stress_free_length", bl.stress_free_length)
        L0 = bl.stress_free_length
    stretch = L_path / L0
    _require(stretch >= 1.0, "belt.stress_free_length", L0,
             f"is longer than the belt path around the pulleys ({L_path:.6g} m): the belt would be slack "
             "(shorten it or move the pulleys apart)")
    _require(stretch < 1.2, "belt.stress_free_length", L0,
             f"needs {100 * (stretch - 1):.1f} % strain to reach the belt path ({L_path:.6g} m); "
             "a belt cannot be installed beyond 20 % strain")

    n = bl.n_elements
    element = L_path / n
    for name, radius in zip(names, radii_np):
        if element > 0.5 * radius:
            warnings.warn(
                f"pulley {name!r} (radius {radius:.4g} m at the belt axis) is wrapped by belt elements "
                f"{element:.4g} m long: expect a speed and tension ripple from the polygon effect; use at least "
                f"{math.ceil(2 * L_path / radius)} elements (element length <= radius / 2)", UserWarning, stacklevel=2)
    model = DriveModel(
        n_elements=n, pulley_names=tuple(names), kinematic=tuple(kinematic), carrier_kind=tuple(carrier),
        wrap_side=tuple(sides), friction_factor=tuple(ffac), contact_points_per_element=c.points_per_element,
        friction_law=COULOMB if c.friction_law == "coulomb" else REGULARISED,
        lcp_iterations=int(s.lcp_iterations), lcp_relaxation=float(s.relaxation))
    _require(isinstance(s.lcp_iterations, int) and s.lcp_iterations >= 1, "solver.lcp_iterations",
             s.lcp_iterations, "must be an integer >= 1")
    _require(0 < s.relaxation <= 1.0, "solver.relaxation", s.relaxation, "must be in (0, 1]")

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
                         mass_damping=f64(bl.mass_damping), settle_damping=f64(s.settle_damping))

    q0 = place_belt(path, n, L0)
    npul, nc = len(names), model.n_contacts
    z = jnp.zeros(npul)
    state0 = DriveState(q=q0, v=jnp.zeros_like(q0), theta=z, omega=z, psi=f64(pp["psi0"]), psi_dot=z,
                        lam_n=jnp.zeros(nc), lam_t=jnp.zeros(nc), contact_pulley=-jnp.ones(nc),
                        belt_torque=z, lcp_residual=f64(0.0), work=jnp.zeros(5), pulley_work=z, fault=f64(0.0),
                        fault_time=f64(jnp.inf))

    from ._stability import stable_time_step  # local import: the estimate needs the built params

    dt_limit = stable_time_step(model, params, q0)
    if s.dt is None:
        dt = 0.9 * dt_limit
    else:
        _positive("solver.dt", s.dt)
        _require(s.dt <= dt_limit, "solver.dt", s.dt,
                 f"exceeds the stability limit {dt_limit:.3g} s of this mesh ({n} elements); use dt <= "
                 f"{0.9 * dt_limit:.3g} s, or fewer elements, or less belt damping")
        dt = s.dt
    _positive("solver.t_end", s.t_end)
    _positive("solver.save_dt", s.save_dt)
    _non_negative("solver.settle_time", s.settle_time)
    return Drive(spec=spec, model=model, params=params, state0=state0, path=path, dt=float(dt))


def _sum_laws(a: tl.TimeLaw, b: tl.TimeLaw, what: str) -> tl.TimeLaw:
    """Sum of two laws, sampled on the union of their knots (exact for piecewise-linear laws)."""
    raise ConfigError(f"{what}: give either 'torque' or 'load', not both")
