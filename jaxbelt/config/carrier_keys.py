"""The carriers' configuration keys (``[pulleys.tensioner]``), read generically from the carriers room, the twin of
``friction_keys``.

Each tensioner kind of ``pulleys.carriers.CARRIERS`` declares its table's keys (``SpecKey`` records: name, doc with
unit, type, default, check) and what they must satisfy together (``check_spec``), and builds itself from them
(``build``: anchor, numbers, installed coordinate); pivot friction, unloading damping and stops are the keys of the
lossy wrapper around any of them. Here they become, without naming any kind:

- ``TensionerSpec`` attributes and keyword arguments, stored in its one field ``carrier_keys``, and TOML keys of
  ``[pulleys.tensioner]`` (``carrier_keys_as_attributes``; ``kind`` one of the table's tensioner kinds);
- validation (``check_tensioner``: the kind, keys of other kinds refused, each key's own check, the kind's checks,
  the wrapper's), the riders (``riders``, ``check_riders``: a kind whose class rides another's carrier names its
  second pulley with ``partner``), the stops around the installed coordinate, and the warnings for a spring the
  belt cannot hold or one its pivot friction holds;
- the carrier, its anchor, numbers and installed coordinate (``tensioner_carrier``, ``rider_carrier``) and the
  tension the one tensioner holds at the drawn layout (``installation_tension``).

Plain Python and numpy: validation makes no JAX array.
"""

from __future__ import annotations

import math

import numpy as np

from ..pulleys.carriers import CARRIERS, AbstractCarrier, Installed, LossyCarrier, tensioner_kinds, tensioner_spec_keys
from ..pulleys.carriers.base import VALUE_CHECKS
from ..pulleys.carriers.lossy import in_degrees
from ..pulleys.carriers.pendulum import PARTNER
from .checks import _pulley_label, _require, _warn
from .routed import refuse_unknown, routed

__all__ = [
    "carrier_keys_as_attributes",
    "check_tensioner",
    "check_riders",
    "check_stops_contain_installed",
    "check_spring_loads",
    "riders",
    "tensioner_carrier",
    "rider_carrier",
    "installation_tension",
    "installed_contact_shortening",
]

FIELD = "carrier_keys"  # the one TensionerSpec field that holds the kinds' keys
SPRING_LOAD_FACTOR = 3.0  # warn when a tensioner spring's installed load exceeds this many times
# the most the belt can hold on it (2 T L on an arm, 2 T on a slider)


def _defaults() -> dict:
    return {name: key.default for name, key in tensioner_spec_keys().items()}


def _hints() -> dict:
    return {name: key.hint for name, key in tensioner_spec_keys().items()}


# Class decorator (above ``@dataclass``): every tensioner kind's keys as attributes and keyword arguments of
# ``TensionerSpec`` (``TensionerSpec(kind="slider", direction=(1, 0))``), routed into ``carrier_keys``.
carrier_keys_as_attributes = routed(FIELD, _defaults, _hints, {"kind": tensioner_kinds})


def kind_class(t) -> type[AbstractCarrier]:
    """The carriers room's class of a (checked) tensioner table's kind."""
    return CARRIERS[t.kind]


def _values(t) -> dict:
    """Every key of the table: as given, or its default."""
    return {name: getattr(t, name) for name in tensioner_spec_keys()}


def _checks(f: str):
    """The refusal of the table of pulley ``f``, as the carriers room calls it (``Checks``)."""

    def refuse(ok: bool, key: str, value, allowed: str) -> None:
        _require(ok, f"{f}.tensioner.{key}", value, allowed)

    return refuse


def check_tensioner(f: str, t, center) -> None:
    """The tensioner table of pulley ``f`` (drawn at ``center``): its kind, no key of another kind, each given key
    by its own check, then the kind's checks and, where given, the wrapper's."""
    kinds = tensioner_kinds()
    _require(
        isinstance(t.kind, str) and t.kind in kinds,
        f + ".tensioner.kind",
        t.kind,
        "must be " + " or ".join(repr(k) for k in kinds),
    )
    given = getattr(t, FIELD)
    _require(isinstance(given, dict), f"{f}.tensioner.{FIELD}", given, "must be a dict of the tensioner kinds' keys")
    table, cls = tensioner_spec_keys(), kind_class(t)
    own = {key.name for key in (*cls.spec_keys, *LossyCarrier.spec_keys)}
    refuse_unknown(given, table, f"{f}.tensioner", "tensioner kind", _require)
    checks = _checks(f)
    for name, key in table.items():
        value = given.get(name)
        if value is None or (key.default is not None and type(value) is type(key.default) and value == key.default):
            continue  # not given (a default stored by the spec: every kind that reads it has the same default)
        if key.check is not None:  # a malformed value is named as such, whichever kind it was given to
            msg = VALUE_CHECKS[key.check](value)
            checks(msg is None, name, value, msg or "")
        users = [k for k in kinds if name in {s.name for s in CARRIERS[k].spec_keys}]
        checks(name in own, name, value, key.elsewhere or "is used only with kind = " + " or ".join(map(repr, users)))
    values = _values(t)
    cls.check_spec(values, center, checks)
    if LossyCarrier.given(values):
        LossyCarrier.check_losses(cls, values, checks)


def tensioner_carrier(t, center) -> Installed:
    """The carrier of a checked tensioner table, of a pulley drawn at ``center``: its kind's, wrapped with its
    losses where the table gives any."""
    values = _values(t)
    built = kind_class(t).build(values, center)
    return LossyCarrier.wrap(built, values, center) if LossyCarrier.given(values) else built


def riders(spec) -> dict[str, int]:
    """The pulleys that ride another's carrier (their names, the ``partner`` of a kind that carries two) -> the
    index of the pulley whose table names them."""
    return {
        p.tensioner.partner: i
        for i, p in enumerate(spec.pulleys)
        if p.tensioner is not None
        and p.tensioner.kind in CARRIERS
        and CARRIERS[p.tensioner.kind].rides_another
        and p.tensioner.partner is not None
    }


def rider_carrier(spec, name: str) -> Installed:
    """The carrier of the rider ``name`` (see ``riders``), on its owner's carrier."""
    owner = riders(spec)[name]
    pulleys = {p.name: p for p in spec.pulleys}
    o = spec.pulleys[owner]
    cls = kind_class(o.tensioner)
    return cls.rider(_values(o.tensioner), owner, o.center, pulleys[name].center)  # type: ignore[attr-defined]


def check_riders(spec) -> None:
    """Each table of a kind that carries a second pulley names it: another pulley, of role "idler", without a
    carrier or clutch of its own, not another's rider, away from the pivot."""
    names = [p.name for p in spec.pulleys]
    claimed: dict[str, str] = {}
    for i, p in enumerate(spec.pulleys):
        t = p.tensioner
        if t is None or t.kind not in CARRIERS or not CARRIERS[t.kind].rides_another:
            continue  # a partner given to another kind: refused by check_tensioner
        f = _pulley_label(i, p) + f".tensioner.{PARTNER}"
        others = [n for n in names if n != p.name]
        _require(
            isinstance(t.partner, str) and t.partner in others,
            f,
            t.partner,
            f"a {t.kind} tensioner needs its second idler, the name of another pulley of this drive (one of {others})",
        )
        _require(
            t.partner not in claimed,
            f,
            t.partner,
            f"is already the second idler of {claimed.get(t.partner)!r}'s {t.kind}: each idler rides one arm",
        )
        claimed[t.partner] = p.name
        q = spec.pulleys[names.index(t.partner)]
        _require(
            q.role == "idler" and q.tensioner is None and q.clutch is None,
            f,
            t.partner,
            f"the second idler rides the {t.kind}'s arm: it must be a pulley of role 'idler' without a tensioner or "
            f"clutch of its own ({q.name!r} has role {q.role!r}"
            + (", a tensioner table" if q.tensioner is not None else "")
            + (", a clutch" if q.clutch is not None else "")
            + ")",
        )
        pivot = tuple(t.pivot)
        _require(math.dist(q.center, pivot) > 0, f, t.partner, "its centre must differ from the pendulum's pivot")


def check_stops_contain_installed(f: str, t, center) -> None:
    """The stops contain the installed coordinate; checked after the layout, which moves no pulley but
    must first be possible (an overlapping layout is the problem to report, not the stops)."""
    if t.stops is None:
        return
    lo, hi = (float(x) for x in t.stops)
    built = tensioner_carrier(t, center)
    psi0, pivoted = built.psi0, built.carrier.pivoted
    what = (
        f"the installed arm angle {psi0:.6g} rad ({math.degrees(psi0):.4g} deg, pivot to pulley centre)"
        if pivoted
        else "the installed travel 0 m"
    )
    degrees = pivoted and math.radians(lo) <= psi0 <= math.radians(hi)  # they would contain it in degrees
    _require(
        lo <= psi0 <= hi,
        f + ".tensioner.stops",
        t.stops,
        f"must contain {what} (allowed: min <= it <= max)" + (f"; {in_degrees(lo, hi)}" if degrees else ""),
    )


def _installed_load(t, center) -> float:
    """The spring's torque (force) on the carrier at installation."""
    values = _values(t)
    return type(kind_class(t).build(values, center).carrier).installed_load(values, center)  # type: ignore[attr-defined]


def _check_pivot_friction(spec) -> None:
    """Warn when a carrier's friction is at least its spring's installed torque: the spring can
    never move the arm against its pivot friction (it moves only when the belt pushes it)."""
    for i, p in enumerate(spec.pulleys):
        t = p.tensioner
        if t is None or t.friction_torque is None or not t.friction_torque > 0:
            continue
        load = _installed_load(t, p.center)
        if t.friction_torque >= abs(load):
            unit = "N m" if kind_class(t).pivoted else "N"
            _warn(
                f"{_pulley_label(i, p)}.tensioner.friction_torque = {t.friction_torque:.6g}: at least the spring's "
                f"installed load |preload + stiffness·(rest − installed)| = {abs(load):.4g} {unit} (allowed: below "
                "it): the spring can never move the carrier against its pivot friction"
            )


def check_spring_loads(spec, tension: float) -> None:
    """Warn when a tensioner spring's installed torque (force) is far beyond what the belt can hold
    on that carrier: at most 2 T L on an arm of length L (both spans pulling along the hub load,
    perpendicular to the arm; a rider's arm adds its length), 2 T on a slider, T the installed tension."""
    _check_pivot_friction(spec)
    if not tension > 0:  # a belt installed without tension: no scale to compare with
        return
    rode = riders(spec)
    for i, p in enumerate(spec.pulleys):
        t = p.tensioner
        if t is None:
            continue
        f = _pulley_label(i, p)
        built, cls = tensioner_carrier(t, p.center), kind_class(t)
        psi0, rest = built.psi0, built.numbers["rest"]
        load = _installed_load(t, p.center)
        if cls.pivoted:
            L = built.numbers["length"]
            rider = [q for q in spec.pulleys if rode.get(q.name) == i]
            L += sum(rider_carrier(spec, q.name).numbers["length"] for q in rider)
            cap = 2.0 * tension * L
            what = (
                f"the spring torque at installation, preload + stiffness·(rest − angle) = {t.preload:.4g} + "
                f"{t.stiffness:.4g}·({rest:.4g} − {psi0:.4g}) = {load:.4g} N m, is {abs(load) / cap:.3g} times the "
                f"most the belt can hold on this arm (2·T·L = 2 × {tension:.4g} N × {L:.4g} m = {cap:.4g} N m, "
                "T the installed belt tension" + (", L both idlers' arms" if rider else "") + ")"
            )
            hints = []
            if t.rest is not None:
                hints.append(
                    f"tensioner.rest is in radians ({t.rest:g} rad = {math.degrees(t.rest):.4g} deg); "
                    f"if you meant degrees write rest_deg = {t.rest:g}"
                )
            if abs(rest - psi0) > math.pi:
                hints.append(
                    f"the rest angle is {rest - psi0:.4g} rad from the installed arm angle {psi0:.4g} rad "
                    "(angles are not wrapped: 2π more is a full turn of spring wind-up)"
                )
        else:
            cap = 2.0 * tension
            what = (
                f"the spring force at installation, preload + stiffness·rest = {load:.4g} N, is "
                f"{abs(load) / cap:.3g} times the most the belt can hold on this slider (2·T = {cap:.4g} N, T the "
                "installed belt tension)"
            )
            hints = []
        if abs(load) <= SPRING_LOAD_FACTOR * cap:
            continue
        hints.append("check tensioner.preload, stiffness and rest (counter-clockwise or along direction positive)")
        _warn(f"{f}.tensioner: {what}: the carrier will swing far from its drawn position; " + "; ".join(hints))


def installation_tension(spec, centers: np.ndarray, radii: np.ndarray, sides, gravity) -> float:
    """The uniform belt tension [N] that holds the drive's one tensioner in equilibrium at its drawn
    position (at rest, no load): its spring, preload and weight against the hub load ``T (d_i - d_(i-1))``
    (d the unit directions of the spans leaving and reaching it; a rider's hub load turns the same carrier), the
    equation ``analysis.statics`` solves. For ``belt.installed_effective_length``: a drive report's installed
    length is the belt stretched by this tension over the drawn layout. ``ConfigError`` without exactly one
    tensioner or when that tensioner holds no positive tension there. Numpy, listed pulley order."""
    from ..geometry.path import _choose, _static_wrap_side

    key, value = "belt.installed_effective_length", spec.belt.installed_effective_length
    movable = [i for i, p in enumerate(spec.pulleys) if p.tensioner is not None]
    _require(
        len(movable) == 1,
        key,
        value,
        f"fixes the belt by the tension its tensioner holds at the drawn position, so the drive needs exactly one "
        f"tensioner (it has {len(movable)}); give effective_length (the catalogue length), stress_free_length or "
        "pretension instead",
    )
    i = movable[0]
    p, t = spec.pulleys[i], spec.pulleys[i].tensioner
    assert t is not None
    _, g = _choose(np.asarray(centers, float), np.asarray(radii, float), _static_wrap_side(sides), None)
    d = np.asarray(g["span_dir"])
    built = tensioner_carrier(t, p.center)
    dcenter = built.carrier.dcenter_at(built.numbers, built.psi0)  # type: ignore[attr-defined]
    spring = _installed_load(t, p.center) + t.mass * float(dcenter @ gravity)
    lever = float((d[i] - d[i - 1]) @ dcenter)  # force of the belt on the pulley per unit tension, on psi
    names = [q.name for q in spec.pulleys]
    rode = [n for n, owner in riders(spec).items() if owner == i and n in names]
    for n in rode:  # a rider's hub load turns the same carrier
        j, r = names.index(n), rider_carrier(spec, n)
        lever += float((d[j] - d[j - 1]) @ r.carrier.dcenter_at(r.numbers, built.psi0))  # type: ignore[attr-defined]
    with np.errstate(all="ignore"):
        T = -spring / lever if lever != 0 else math.nan
    unit = "N m" if built.carrier.pivoted else "N"
    _require(
        math.isfinite(T) and T > 0,
        key,
        value,
        f"needs the tension the tensioner {p.name!r} holds at its drawn position, but there its spring, preload and "
        f"weight ({spring:.4g} {unit}) do not pull the belt taut (the belt's generalised force per newton of "
        f"tension is {lever:.4g} {unit}/N): check the tensioner's preload (its sign and size) and rest"
        + (
            f"; a {t.kind} whose two idlers' hub loads balance about its pivot holds any tension there: give "
            "pretension, stress_free_length or effective_length"
            if rode
            else ""
        ),
    )
    return float(T)


def installed_contact_shortening(spec, centers: np.ndarray, radii: np.ndarray, sides, tension: float) -> float:
    """How much the contact compliance shortens the drawn belt path at a uniform ``tension`` [m]: each wrap sinks
    delta = T / (R k) into its pulley (k = ``contact.stiffness``, N/m^2), shortening the path by delta times the
    wrap angle (the statics' ``contact_path_shortening``, ``analysis.statics``). Numpy, listed pulley order."""
    from ..geometry.path import _choose, _static_wrap_side
    from .contact_defaults import default_contact_stiffness

    _, g = _choose(np.asarray(centers, float), np.asarray(radii, float), _static_wrap_side(sides), None)
    k = default_contact_stiffness(spec.contact, spec.belt)
    return float(tension * np.sum(np.asarray(g["wrap_angle"]) / np.asarray(radii, float)) / k)
