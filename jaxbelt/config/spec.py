"""The drive specification: plain data, as a user writes it (in Python or TOML), SI units.

A ``DriveSpec`` lists the pulleys in the order the belt travels (in either order round the loop when
``belt.direction`` is given). Nothing here checks anything: ``config.validate`` does, before
``config.build.build_drive`` makes a ``Drive``. The classes are ordinary (mutable) dataclasses: users
and tests edit a spec in place before building it; a built ``Drive`` never changes with its spec.
The TOML schema is read from these classes (``config.toml``), so a field added here is a valid key.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal

from ..contact.friction import FRICTION_LAWS
from ..pulleys import timelaw as tl
from ..pulleys.carriers import DEFAULT_TENSIONER_KIND
from .carrier_keys import carrier_keys_as_attributes
from .friction_keys import law_keys_as_attributes

__all__ = ["BeltSpec", "TensionerSpec", "PulleySpec", "ContactSpec", "SolverSpec", "DriveSpec", "FrictionLawName"]


@dataclass
class BeltSpec:
    """Belt data. Stiffness and mass refer to the *stress-free* length.

    Give either ``E`` (with ``width`` and ``thickness``) or explicit ``EA``/``EI``; either ``rho``
    or ``mass_per_length``; exactly one of ``stress_free_length`` (at the belt axis, the pitch
    line), ``effective_length`` (a poly-V belt's catalogue length, ISO 9981),
    ``installed_effective_length`` (a poly-V belt's effective length as installed on the drawn layout,
    as a drive report gives it) or ``pretension`` (uniform installed tension, from which the
    stress-free length follows).
    """

    n_elements: int = 60
    width: float = 0.02
    thickness: float = 0.005
    E: float | None = None
    EA: float | None = None
    EI: float | None = None
    rho: float | None = None
    mass_per_length: float | None = None
    eta: float | None = None  # Kelvin–Voigt viscosity [Pa s]
    axial_damping: float | None = None  # or directly eta*A [N s]
    bending_damping: float = 0.0  # Rayleigh stiffness-proportional coefficient [s]
    mass_damping: float = 0.0  # Rayleigh mass-proportional coefficient [1/s]
    stress_free_length: float | None = None
    pretension: float | None = None
    type: Literal["flat", "poly-v"] = "flat"
    ribs: int = 1
    groove_angle_deg: float = 40.0
    inner_offset: float | None = None  # pulley surface to belt axis, inner side [m] (default thickness/2)
    back_offset: float | None = None  # pulley surface to belt axis, back side [m] (default thickness/2)
    effective_length: float | None = None  # poly-V catalogue (effective) length, unstretched [m]
    # poly-V effective length at the installed layout (a drive report's belt length) [m]: the belt stretched
    # over the drawn path by the tension its tensioner holds at its drawn position
    installed_effective_length: float | None = None
    effective_offset: float | None = None  # effective line to pitch line [m] (default EFFECTIVE_OFFSET_PK)
    # Sense the belt runs round the drive, seen with z toward the viewer (the rotation sense of the
    # pulleys it wraps on its inner side). Given: pulleys may be listed in either order and drivers'
    # speed/torque are taken in that sense. None (as before the key existed): spans follow the listed
    # order, drivers' speed/torque are counter-clockwise positive and their sign sets the sense.
    direction: Literal["cw", "ccw"] | None = None


@carrier_keys_as_attributes  # the carrier kinds' keys (stiffness, pivot, direction, stops, ...) as attributes
@dataclass
class TensionerSpec:
    """Carrier of a tensioner pulley: ``kind`` names a tensioner kind of the carriers room
    (``jaxbelt.pulleys.carriers.tensioner_kinds()``: a pivoted arm, the default, a linear slider or a pendulum)
    and every other key is one its class declares (``SpecKey``; docs/config.md lists them), held in
    ``carrier_keys`` and read and written as attributes (``t.stiffness``, ``TensionerSpec(kind="slider",
    direction=(1, 0))``).

    Arm: the pulley centre at installation (``PulleySpec.center``) and ``pivot`` fix the arm length
    and the installed angle. The spring torque on the arm is
    ``preload + stiffness * (rest - angle)`` (counter-clockwise positive; ``rest`` defaults to the
    installed angle; or give ``rest_deg`` in degrees instead). Slider: travel ``s`` along
    ``direction`` from the installed centre, force ``preload + stiffness * (rest - s)``. Pendulum (the rocker
    tensioner of belt-starter-generator drives): an arm as above whose ``pivot`` is usually the
    starter-generator's axis and which carries a second idler, ``partner`` (a pulley of role "idler" without a
    table of its own); angle, spring, damper, ``inertia`` (required: the whole rocker about its pivot), pivot
    friction and stops are the arm's, its angle the one from the pivot to this pulley. Any kind: Coulomb pivot
    friction ``friction_torque``, ``damping_unload`` and hard ``stops`` (min, max).
    """

    kind: TensionerKind = DEFAULT_TENSIONER_KIND
    carrier_keys: dict = field(default_factory=dict)  # the kind's keys (SpecKey), e.g. stiffness, pivot

    if TYPE_CHECKING:  # the routed keys: attributes at run time (carrier_keys_as_attributes)

        def __getattr__(self, name: str) -> Any: ...

        def __setattr__(self, name: str, value: Any) -> None: ...


@dataclass
class PulleySpec:
    name: str
    center: tuple[float, float]
    radius: float  # radius of the surface the belt touches [m]
    role: Literal["driver", "driven", "idler", "tensioner"] = "idler"
    inertia: float = 1e-3
    wrap: Literal["inner", "back"] = "inner"
    grooved: bool | None = None  # poly-V grooves (default: inner wrap of a poly-V belt)
    speed: dict | tl.TimeLaw | float | None = None  # driver by speed: rad/s law
    torque: dict | tl.TimeLaw | float | None = None  # applied torque law, + in the running sense [N m]
    load: dict | tl.TimeLaw | float | None = None  # brake torque law opposing the running sense [N m]
    viscous: float = 0.0  # viscous load [N m s/rad]
    tensioner: TensionerSpec | None = None
    speed_rpm: dict | tl.TimeLaw | float | None = None  # driver by speed: rpm law (instead of speed)
    power_kw: dict | tl.TimeLaw | float | None = None  # load absorbing this power at the nominal speed [kW]
    mu: float | None = None  # this pulley's friction coefficient, instead of contact.mu (wedge factor still applies)
    # engine orders over the pulley's rotation angle, added to its speed (driver by speed) or torque:
    # {order: {amplitude = rad/s or N m | amplitude_deg = angular oscillation, phase_deg = 0}}
    excitation: dict | None = None
    # one-way clutch between this sheave and a rotor of rotor_inertia (the load acts on the rotor):
    # "oap" overrunning pulley, "decoupler" with a torsion spring (clutch_stiffness, clutch_damping) in series
    clutch: Literal["oap", "decoupler"] | None = None
    rotor_inertia: float | None = None  # [kg m^2]
    clutch_stiffness: float | None = None  # decoupler spring [N m/rad]
    clutch_damping: float | None = None  # decoupler damper [N m s/rad]


if TYPE_CHECKING:  # the names are a registry's keys, known only at run time (a new law adds one)
    FrictionLawName = str
else:
    FrictionLawName = Literal[tuple(FRICTION_LAWS)]  # the TOML loader checks names against the table too
TensionerKind = str  # a name of pulleys.carriers.tensioner_kinds(); the TOML loader reads the table (routed)


@law_keys_as_attributes  # the friction law's own keys (contact.mu_kinetic, ...) as attributes
@dataclass
class ContactSpec:
    mu: float = 0.5
    # Normal stiffness per unit belt length [N/m^2]; default: stiffness_per_area x belt.width
    # (config.contact_defaults.default_contact_stiffness)
    stiffness: float | None = None
    stiffness_per_area: float | None = None  # [N/m^3] (default CONTACT_STIFFNESS_PER_AREA); not with stiffness
    damping: float = 6.4e3  # per unit belt length [N s/m^2]
    friction_law: FrictionLawName = "coulomb"
    nu_s: float = 50.0  # regularised-law steepness [s/m]
    law_parameters: dict[str, float] = field(default_factory=dict)  # the law's keys (LawKey), e.g. mu_kinetic
    points_per_element: int = 2


@dataclass
class SolverSpec:
    dt: float | None = None  # default: 0.9 x the estimated stability limit
    t_end: float = 1.0
    save_dt: float = 1e-3
    lcp_iterations: int = 8
    relaxation: float = 0.9
    settle_time: float = 0.1
    settle_damping: float = 200.0
    implicit_damping: bool = False  # Kelvin-Voigt belt damping implicit: step bounded by the belt's waves only
    # belt mass scaled by theta h^2 K, contact through it: no stability bound from the belt (implies the above)
    implicit_stiffness: bool = False
    # "explicit" (dt from the belt's stability limit), "implicit" (implicit_stiffness with the Newton contact
    # solve; dt chosen for accuracy: dynamics.time_step) or "auto" (the implicit one where its step is at least
    # AUTO_STEP_RATIO x the explicit one: config.validate.resolve_scheme); solver.dt overrides the step
    scheme: str = "auto"
    max_frequency: float = 250.0  # Hz: the highest frequency the implicit scheme's automatic step resolves
    # the summary window is meant to be a steady state (checked; status "not steady" if not); false for a
    # transient on purpose (a start-up): then only faults, implausible results and gross slip set the status
    expect_steady: bool = True
    # "rest": pulleys locked while the belt settles, the run starts from standstill (a start-up);
    # "running": the settle phase brings belt and pulleys to the speed the driver has at t = 0 (a duty point)
    start: str = "rest"
    # the tier every analysis of this file runs on unless told otherwise (``--model``, ``model=``): "ancf" (the
    # ANCF belt) or "spans" (span springs, docs/spans.md)
    model: str = "ancf"


@dataclass
class DriveSpec:
    belt: BeltSpec
    pulleys: list[PulleySpec]
    contact: ContactSpec = field(default_factory=ContactSpec)
    solver: SolverSpec = field(default_factory=SolverSpec)
    gravity: tuple[float, float] = (0.0, 0.0)
