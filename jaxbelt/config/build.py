"""``build_drive``: a ``DriveSpec`` into a ``Drive`` (static model, differentiable parameters, the
state at rest), as a short sequence of named steps.

Validation (``config.validate``) runs first, on plain Python and numpy values, and raises a
``ConfigError`` naming the field, the value and what is allowed; only then are JAX arrays made.
Adding a friction law: one file in ``contact/`` and its line in ``contact.friction.FRICTION_LAWS``.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import numpy as np

from .._drive import Drive, PulleyInfo, RunOptions
from .._errors import ConfigError as ConfigError  # re-exported: the name's home before the split
from .._types import DriveModel, DriveParams, PulleyParams, RunningStart
from ..pulleys.carriers import Decoupler, FixedCarrier, Installed, OverrunningClutch
from .friction_keys import law_arrays, law_for
from ..belt.ring import BeltParams
from ..geometry.path import belt_path, place_belt
from ..pulleys import timelaw as tl
from .checks import _pulley_label, _warn, collected_warnings
from .direction import _direction_warnings
from .excitation import build_excitation, build_mu
from .laws import _law_sign, law_from_spec
from .resources import _initial_state
from .spec import BeltSpec as BeltSpec, ContactSpec as ContactSpec, DriveSpec  # re-exported: as ConfigError
from .spec import PulleySpec as PulleySpec, SolverSpec as SolverSpec, TensionerSpec as TensionerSpec
from .carrier_keys import check_spring_loads, rider_carrier, riders, tensioner_carrier
from ..pulleys.carriers.constraints import ConstraintState
from .belt import _effective_offset, _stress_free_length, installed_state_definition
from .validate import Checked, belt_numbers, validate_spec
from .contact_defaults import default_contact_stiffness

__all__ = ["build_drive"]


def build_drive(spec: DriveSpec) -> Drive:
    """Validate ``spec`` and build the static model, the parameters and the state at rest.

    Every check runs first, on plain Python and numpy values: a bad configuration is refused (with
    a ``ConfigError`` naming the key) before any JAX array is made or anything is compiled
    (``config.validate.check_spec`` runs those checks alone). Its warnings are also kept on the drive
    (``Drive.build_warnings``), for the summary.
    """
    with collected_warnings() as notes:
        drive = _build(spec)
    return dataclasses.replace(drive, build_warnings=tuple(notes))


def _build(spec: DriveSpec) -> Drive:
    checked = validate_spec(spec)
    _build_warnings(spec, checked)
    spec, checked = _in_model_order(spec, checked)
    sense = tuple(checked.travel * w for w in checked.sides)
    _direction_warnings(spec, checked.travel, checked.along, checked.source)

    pulleys, kinematic, carrier, psi0 = _pulley_params(spec, checked, sense)
    own_mu, mu = build_mu(spec)
    pulleys = dataclasses.replace(pulleys, mu=mu, excitation=build_excitation(spec, sense))
    path = belt_path(
        jax.device_put(np.asarray(checked.centers)),
        jax.device_put(np.asarray(checked.radii)),
        checked.sides,
        orientation=checked.orientation,
    )
    L0 = _stress_free_length(
        spec.belt, checked.belt["EA"], float(path.length), checked.installation_tension, checked.contact_shortening
    )
    brakes = tuple(
        float(sense[i]) if p.load is not None or p.power_kw is not None else 0.0 for i, p in enumerate(spec.pulleys)
    )
    model = dataclasses.replace(
        _model(spec, checked, kinematic, carrier), own_mu=own_mu, brake_sense=brakes if any(brakes) else ()
    )
    params = _params(spec, checked, pulleys, L0)
    if spec.solver.start == "running":  # settle at speed (checked: one speed driver, moving at t = 0)
        driver = next(i for i, p in enumerate(spec.pulleys) if p.role == "driver" and kinematic[i])
        along = 1.0 if int(round(float(path.orientation))) == checked.travel else -1.0
        start = RunningStart(sense=_f64(np.asarray(sense, dtype=float)), along=_f64(along), driver=driver)
        params = dataclasses.replace(params, start=start)
    q0 = place_belt(path, spec.belt.n_elements, L0)
    state0 = _initial_state(q0, _f64(psi0), len(spec.pulleys), model.n_contacts)
    if model.constrained:  # pivot friction, stops, clutches: their impulses and decoupler deflections
        state0 = dataclasses.replace(state0, constraints=ConstraintState.zeros(len(spec.pulleys)))
    return _drive(spec, model, params, state0, path, sense, checked)


def _f64(x):
    # numpy, then put on the device (in JAX's float width): no eager device conversion to compile
    return jax.device_put(np.asarray(x, dtype=float))


def _build_warnings(spec: DriveSpec, checked: Checked) -> None:
    """Warnings of a drive that passed validation: the polygon effect of long elements on small
    pulleys, a tensioner spring far beyond what the belt holds."""
    n = spec.belt.n_elements
    element = checked.L_path / n
    for p, radius in zip(spec.pulleys, checked.radii):
        if element > 0.5 * radius:
            _warn(
                f"pulley {p.name!r} (radius {radius:.4g} m at the belt axis) is wrapped by belt elements "
                f"{element:.4g} m long: expect a speed and tension ripple from the polygon effect; use at least "
                f"{math.ceil(2 * checked.L_path / radius)} elements (element length <= radius / 2)"
            )
    check_spring_loads(spec, checked.belt["EA"] * (checked.stretch - 1.0))


def _in_model_order(spec: DriveSpec, checked: Checked) -> tuple[DriveSpec, Checked]:
    """The spec and the checked layout with the pulleys in the order the belt travels (as listed
    unless ``belt.direction`` reverses the listing)."""
    order = checked.order
    if order == list(range(len(order))):
        return spec, checked
    spec = dataclasses.replace(spec, pulleys=[spec.pulleys[i] for i in order])
    checked = dataclasses.replace(
        checked,
        centers=checked.centers[order],
        radii=checked.radii[order],
        sides=tuple(checked.sides[i] for i in order),
        omega_nominal=checked.omega_nominal[order],
    )
    return spec, checked


def _pulley_params(spec: DriveSpec, checked: Checked, sense):
    """``PulleyParams`` (radii at the belt axis, laws stored counter-clockwise positive, each carrier's numbers),
    which pulleys are speed-driven, each carrier's kind and its installed coordinate."""
    kinematic, carriers, numbers, origins, psi0 = [], [], [], [], []
    pp: dict[str, list] = dict(inertia=[], speed=[], torque=[], viscous=[])
    rode = riders(spec)  # the pulleys that ride another's carrier (a pendulum's second idler)
    for i, p in enumerate(spec.pulleys):
        f = _pulley_label(i, p)
        kinematic.append(p.role == "driver" and (p.speed is not None or p.speed_rpm is not None))
        pp["inertia"].append(p.inertia)
        # laws are stored counter-clockwise positive; _law_sign turns the user's sense into that
        key = "speed_rpm" if p.speed_rpm is not None else "speed"
        pp["speed"].append(law_from_spec(getattr(p, key), f"{f}.{key}", sign=_law_sign(p, key, sense[i], spec)))
        key = next((k for k in ("torque", "load", "power_kw") if getattr(p, k) is not None), "torque")
        scale = 1e3 / checked.omega_nominal[i] if key == "power_kw" else 1.0  # kW at the nominal speed -> N m
        pp["torque"].append(
            law_from_spec(getattr(p, key), f"{f}.{key}", sign=_law_sign(p, key, sense[i], spec) * scale)
        )
        pp["viscous"].append(p.viscous)
        built = rider_carrier(spec, p.name) if p.name in rode else _carrier(p, sense[i])
        assert set(built.numbers) == {key.name for key in built.carrier.keys}, built  # what its class declares
        carriers.append(built.carrier)
        numbers.append({k: _f64(v) for k, v in built.numbers.items()})
        origins.append(built.origin)
        psi0.append(built.psi0)
    pulleys = PulleyParams(
        radius=_f64(checked.radii),
        center=_f64(origins),
        inertia=_f64(pp["inertia"]),
        speed=tl.stack_laws(pp["speed"]),
        torque=tl.stack_laws(pp["torque"]),
        viscous=_f64(pp["viscous"]),
        carrier=tuple(numbers),
    )
    return pulleys, kinematic, carriers, psi0


def _carrier(p: PulleySpec, sense: float) -> Installed:
    """The carrier of pulley ``p``: its tensioner table's, a one-way clutch (the rotor, a decoupler's spring and
    damper; ``sense`` the running sense) or a fixed centre."""
    ctr = (float(p.center[0]), float(p.center[1]))
    if p.tensioner is not None:
        return tensioner_carrier(p.tensioner, ctr)
    if p.clutch is None:
        return Installed(FixedCarrier(), ctr, {}, 0.0)
    numbers = dict(rotor_inertia=float(p.rotor_inertia or 0.0))
    if p.clutch == "decoupler":
        numbers.update(clutch_stiffness=p.clutch_stiffness or 0.0, clutch_damping=p.clutch_damping or 0.0)
    clutch = Decoupler if p.clutch == "decoupler" else OverrunningClutch
    return Installed(clutch(sense=1 if sense >= 0 else -1), ctr, numbers, 0.0)


def _model(spec: DriveSpec, checked: Checked, kinematic, carrier) -> DriveModel:
    """The static model: sizes, topology, the friction law and the contact solver's settings."""
    c, s = spec.contact, spec.solver
    wedge = 1.0 / math.sin(math.radians(spec.belt.groove_angle_deg) / 2.0)
    ffac = []
    for p in spec.pulleys:
        grooved = p.grooved if p.grooved is not None else (spec.belt.type == "poly-v" and p.wrap == "inner")
        ffac.append(wedge if grooved else 1.0)
    return DriveModel(
        n_elements=spec.belt.n_elements,
        pulley_names=tuple(p.name for p in spec.pulleys),
        kinematic=tuple(kinematic),
        carriers=tuple(carrier),
        wrap_side=checked.sides,
        friction_factor=tuple(ffac),
        contact_points_per_element=c.points_per_element,
        friction_law=law_for(c),
        lcp_iterations=int(s.lcp_iterations),
        lcp_relaxation=float(s.relaxation),
        implicit_damping=bool(s.implicit_damping) or checked.scheme == "implicit",
        implicit_stiffness=checked.scheme == "implicit",
    )


def _params(spec: DriveSpec, checked: Checked, pulleys: PulleyParams, L0) -> DriveParams:
    """The differentiable parameters: belt, pulleys, contact, gravity and damping."""
    bl, c, s = spec.belt, spec.contact, spec.solver
    belt = BeltParams(**{k: _f64(v) for k, v in belt_numbers(checked.belt, bl, L0)._asdict().items()})
    return DriveParams(
        belt=belt,
        pulleys=pulleys,
        mu=_f64(c.mu),
        contact_stiffness=_f64(default_contact_stiffness(c, bl)),
        contact_damping=_f64(c.damping),
        nu_s=_f64(c.nu_s),
        gravity=_f64(checked.gravity),
        mass_damping=_f64(bl.mass_damping),
        settle_damping=_f64(s.settle_damping),
        friction=law_arrays(c, _f64),
    )


def _drive(spec: DriveSpec, model, params, state0, path, sense, checked) -> Drive:
    """The ``Drive``: the time step (0.9 x the stability limit unless given) and the static facts
    outputs read (run settings, pulley names, roles and drawn geometry, the installed-state key)."""
    from ..dynamics.stability import stable_time_step  # the closed form validation used, on the built params
    from ..dynamics.time_step import explicit_step_reason

    bl, s = spec.belt, spec.solver
    travel = checked.travel
    if checked.dt is None:  # explicit: the limit of the built parameters (the closed form validation used)
        limit = stable_time_step(model, params, state0.q)
        dt, reason = 0.9 * limit, explicit_step_reason(limit)
    else:
        dt, reason = checked.dt, checked.dt_reason
    how = installed_state_definition(spec)
    from_E = tuple(k for k in ("EA", "EI") if bl.E is not None and getattr(bl, k) is None)
    info = tuple(
        PulleyInfo(
            name=p.name,
            role=p.role,
            center=(float(p.center[0]), float(p.center[1])),
            radius=float(p.radius),
            pivot=_drawn_pivot(p, spec),
        )
        for p in spec.pulleys
    )
    return Drive(
        spec=spec,
        model=model,
        params=params,
        state0=state0,
        path=path,
        dt=float(dt),
        dt_reason=reason,
        scheme_reason=checked.scheme_reason,
        options=RunOptions(t_end=float(s.t_end), save_dt=float(s.save_dt), settle_time=float(s.settle_time)),
        pulleys=info,
        travel=travel,
        running_sense=tuple(sense),
        installed_by=how,
        E_sets=from_E or ("EA", "EI"),
        # effective_length is given exactly when it defines the installed state (how); the offset with
        # either effective length
        effective_length=None if bl.effective_length is None else float(bl.effective_length),
        effective_offset=None
        if bl.effective_length is bl.installed_effective_length is None
        else _effective_offset(bl),
    )


def _drawn_pivot(p: PulleySpec, spec: DriveSpec) -> tuple[float, float] | None:
    """The pivot of a pulley's tensioner arm, drawn by ``viz`` (None: no arm): the anchor of a carrier that swings
    about one (a pendulum's second idler: the pendulum's)."""
    rode = riders(spec)
    if p.name in rode:
        return rider_carrier(spec, p.name).origin
    if p.tensioner is None:
        return None
    built = tensioner_carrier(p.tensioner, (float(p.center[0]), float(p.center[1])))
    return built.origin if built.carrier.pivoted else None
