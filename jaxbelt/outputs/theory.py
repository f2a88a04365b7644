"""Analytical steady-state theory of belt drives (creep theory).

Plain numpy/math reference values for checking the dynamic model; nothing here uses JAX or
touches global configuration.

Assumptions
-----------
Extensible string (no bending stiffness), Coulomb friction with one coefficient ``mu`` on both
pulleys, rigid pulleys with fixed centres, steady operation, open belt. The driver (pulley 1)
winds on the tight span (tension ``T1``); the slack span carries ``T2``. ``EA`` is the axial
stiffness relative to the *stress-free* length, strain ``eps = T / EA``.

Formulas
--------
* Geometry (radii ``R1, R2``, centre distance ``D``): span ``l = sqrt(D^2 - (R1 - R2)^2)``,
  wrap angles ``theta1 = pi + 2 asin((R1 - R2)/D)`` (driver), ``theta2 = pi - 2 asin((R1 - R2)/D)``,
  path length ``L = 2 l + R1 theta1 + R2 theta2``.
* Centrifugal term ``c = m v^2`` with ``v = omega1 R1`` and ``m`` the mass per unit of *current*
  length (``mass_per_current_length``: ``m0 / (1 + T/EA)`` of the stress-free ``m0``; for the drive,
  at the installed tension, i.e. the belt's mass over its installed path length).
* Each pulley: a stick arc at the belt entry (tension constant, no friction) and a slip arc ``phi``
  at the exit where ``dT/dphi = +-mu (T - c)``, hence ``(T1 - c)/(T2 - c) = exp(mu phi)``
  (Euler-Eytelwein / capstan). Gross slip when ``phi`` exceeds the smaller wrap angle.
* Torques: ``M1 = (T1 - T2) R1``, ``M2 = (T1 - T2) R2 = load_torque + load_viscous * omega2``.
* Creep (mass conservation, ``v ~ 1 + eps``): ``omega2 = omega1 (R1/R2) (EA + T2)/(EA + T1)``.
* Closure for fixed centres (belt-length compatibility, linear in ``T/EA``; *not* the textbook
  ``T1 + T2 = 2 T0``): ``integral of T ds`` over the loop equals ``T0 L``, i.e.
  ``(T1+T2) l + R1(theta1-phi) T1 + R2(theta2-phi) T2 + (R1+R2)[c phi + (T1-T2)/mu] = T0 L``,
  where the bracket is the slip-arc integral ``int (c + (T2-c) e^{mu s}) ds`` over ``[0, phi]``.

Compliant contact
-----------------
With a contact stiffness ``k`` per unit length (``contact_stiffness``, N/m^2) the belt sinks
``delta = (T - c) / (R k)`` into a pulley where its tension is ``T``. The loop's path is shorter by
``D = sum_i integral (T - c) dtheta / (R_i k)`` over each wrap, so the closure becomes
``y B + EA L / L0 * D = (T0 - c) L`` (``T0 = EA (L / L0 - 1)`` the rigid pulleys' installed tension; a
``pretension`` is first turned into the stress-free length that gives it at rest on the compliant pulleys),
and the stick arcs roll at ``R - delta``: ``omega2 = omega1 (R1 - delta1(T1)) / (R2 - delta2(T2))
(EA + T2) / (EA + T1)``. On a 30 mm pulley at k = 1e8 N/m^2 and 400 N: 0.13 mm of sink, 0.4 % of the
rolling radius, which the simulation's contact has too.

Solution method
---------------
For a given slip arc ``phi`` the ratio ``r = exp(mu phi)`` is fixed and the closure is linear in
``y = T2 - c``: ``y = (T0 - c) L / B(phi)`` with
``B = (r+1) l + R1(theta1-phi) r + R2(theta2-phi) + (R1+R2)(r-1)/mu > 0``. The transmitted
``T1 - T2 = (r - 1) y`` is strictly increasing in ``phi`` on ``[0, min(theta1, theta2)]``, so the
torque balance (which carries the viscous coupling through ``omega2``) is solved by bisection on
``phi`` over that bracket; a negative residual at the upper end means gross slip.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from typing import Union

import numpy as np

ArrayLike = Union[float, np.ndarray]

__all__ = [
    "CreepTheory",
    "effective_tension",
    "mass_per_current_length",
    "capstan_tension",
    "euler_eytelwein_ratio",
    "open_belt_geometry",
    "rolling_radius_correction",
    "two_pulley_creep",
]

_ANGLE_FIELDS = (
    "wrap_driver",
    "wrap_driven",
    "slip_arc_driver",
    "slip_arc_driven",
    "stick_arc_driver",
    "stick_arc_driven",
)


def _real(name: str, value: float) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {value!r}") from None
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return x


def _positive(name: str, value: float) -> float:
    x = _real(name, value)
    if x <= 0.0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    return x


def _non_negative(name: str, value: float) -> float:
    x = _real(name, value)
    if x < 0.0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return x


def _array(name: str, value: ArrayLike, *, minimum: float | None = None) -> np.ndarray:
    a = np.asarray(value, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if minimum is not None and np.any(a < minimum):
        raise ValueError(f"{name} must be >= {minimum}, got {value!r}")
    return a


def _out(a: np.ndarray) -> ArrayLike:
    return float(a) if a.ndim == 0 else a


def euler_eytelwein_ratio(mu: ArrayLike, wrap_angle: ArrayLike, centrifugal: float = 0.0) -> ArrayLike:
    """Maximum tension ratio ``exp(mu * wrap_angle)`` a belt can hold before gross slip.

    With a centrifugal term ``c = m v^2`` the ratio applies to the effective tensions,
    ``(T1 - c)/(T2 - c) <= exp(mu * theta)``; the ratio itself does not depend on ``c``, which is
    accepted (and validated, ``c >= 0``) for symmetry with :func:`capstan_tension`.
    Vectorised over ``mu`` and ``wrap_angle`` (both ``>= 0``).
    """
    _non_negative("centrifugal", centrifugal)
    m = _array("mu", mu, minimum=0.0)
    th = _array("wrap_angle", wrap_angle, minimum=0.0)
    return _out(np.exp(m * th))


def capstan_tension(
    T_in: ArrayLike,
    mu: float,
    phi: ArrayLike,
    centrifugal: float = 0.0,
    increasing: bool = True,
) -> ArrayLike:
    """Tension along a slipping arc: ``T - c = (T_in - c) exp(+-mu phi)``.

    ``phi`` (radians, ``>= 0``) is measured from the start of the slip arc where the tension is
    ``T_in``; ``increasing`` selects the sign (True on the driven pulley, False on the driver, in
    the direction of belt travel). ``T_in >= centrifugal`` is required: below it the belt carries
    no contact pressure and the capstan law does not apply. Vectorised over ``phi`` (and ``T_in``).
    """
    c = _non_negative("centrifugal", centrifugal)
    m = _non_negative("mu", mu)
    t = _array("T_in", T_in)
    if np.any(t < c):
        raise ValueError(f"T_in must be >= centrifugal ({c!r}) so the belt presses on the pulley, got {T_in!r}")
    p = _array("phi", phi, minimum=0.0)
    sign = 1.0 if increasing else -1.0
    return _out(c + (t - c) * np.exp(sign * m * p))


def rolling_radius_correction(pressure: ArrayLike, k_normal: float) -> ArrayLike:
    """Penetration ``delta = p / k`` of a penalty contact, by which the rolling radius shrinks.

    ``pressure`` is the normal load per unit belt length (N/m, e.g. ``(T - c)/R`` in a stick arc),
    ``k_normal`` the penalty stiffness per unit length (N/m^2). Use ``R - delta`` in the creep
    formula for the pulleys' effective radii; in Benchmark A (k = 3.2e8 N/m^2) this moves the speed
    loss by about 0.002 rad/s.
    """
    k = _positive("k_normal", k_normal)
    p = _array("pressure", pressure, minimum=0.0)
    return _out(p / k)


def open_belt_geometry(
    radius_driver: float, radius_driven: float, center_distance: float
) -> tuple[float, float, float, float]:
    """Return ``(span_length, wrap_driver, wrap_driven, path_length)`` of an open belt."""
    r1 = _positive("radius_driver", radius_driver)
    r2 = _positive("radius_driven", radius_driven)
    d = _positive("center_distance", center_distance)
    if d <= abs(r1 - r2):
        raise ValueError(
            f"center_distance must be > |radius_driver - radius_driven| = {abs(r1 - r2)!r} "
            f"(one pulley would enclose the other), got {center_distance!r}"
        )
    s = (r1 - r2) / d
    span = d * math.sqrt((1.0 - s) * (1.0 + s))  # = sqrt(D^2 - (R1-R2)^2) without cancellation
    th1 = math.pi + 2.0 * math.asin(s)
    th2 = math.pi - 2.0 * math.asin(s)
    return span, th1, th2, 2.0 * span + r1 * th1 + r2 * th2


@dataclass(frozen=True)
class CreepTheory:
    """Steady state of a two-pulley drive by creep theory (SI units, angles in radians).

    When ``gross_slip`` is True no creep steady state exists: the slip arcs are capped at the
    smaller wrap angle, the tensions are those at the Euler-Eytelwein limit, the torques are the
    largest the belt can transmit (less than the load demand) and ``omega_driven`` is the creep
    value at that limit (the driven pulley actually decelerates).
    """

    T_tight: float
    T_slack: float
    centrifugal: float
    torque_driver: float
    torque_driven: float
    omega_driver: float
    omega_driven: float
    speed_loss: float
    wrap_driver: float
    wrap_driven: float
    slip_arc_driver: float
    slip_arc_driven: float
    stick_arc_driver: float
    stick_arc_driven: float
    gross_slip: bool

    def as_dict(self) -> dict[str, float | bool]:
        """Plain dict of floats (``gross_slip`` stays bool); angles also as ``<name>_deg``."""
        d: dict[str, float | bool] = {k: (bool(v) if k == "gross_slip" else float(v)) for k, v in asdict(self).items()}
        for k in _ANGLE_FIELDS:
            d[k + "_deg"] = math.degrees(d[k])
        return d

    def __str__(self) -> str:
        width = max(len(f.name) for f in fields(self))
        units = {
            "T_tight": "N",
            "T_slack": "N",
            "centrifugal": "N",
            "torque_driver": "N m",
            "torque_driven": "N m",
            "omega_driver": "rad/s",
            "omega_driven": "rad/s",
            "speed_loss": "rad/s",
        }
        lines = ["CreepTheory("]
        for f in fields(self):
            v = getattr(self, f.name)
            if f.name in _ANGLE_FIELDS:
                text = f"{v:.6g} rad ({math.degrees(v):.3f} deg)"
            elif f.name == "gross_slip":
                text = str(v)
            else:
                text = f"{v:.6g} {units[f.name]}"
            lines.append(f"  {f.name:<{width}} = {text}")
        lines.append(")")
        return "\n".join(lines)


def mass_per_current_length(mass_per_length, tension, EA):
    """Mass per unit of current length ``m0 / (1 + T/EA)`` of a belt with ``mass_per_length`` ``m0`` per
    stress-free length, stretched by the tension ``T`` (floats or arrays, numpy or JAX).

    Why: ``m' v^2`` (the centrifugal term, the string wave speed ``sqrt(T/m')``) is the momentum flux of
    the belt through a fixed cross-section, ``v`` its speed in current length per second, so ``m'`` is
    the mass per current length; with ``m0`` the term is ``T/EA`` too large (+4 % of the hub load of a
    free-running belt at v/c = 0.7, tests/test_centrifugal.py)."""
    return mass_per_length / (1.0 + tension / EA)


def effective_tension(tension, speed, mass_per_length, EA):
    """``T - m' v^2`` with ``m'`` the mass per current length at that tension (``mass_per_current_length``):
    what presses the belt onto a pulley, enters the capstan law and the hub load."""
    return tension - mass_per_current_length(mass_per_length, tension, EA) * speed**2


def two_pulley_creep(
    *,
    radius_driver: float,
    radius_driven: float,
    center_distance: float,
    EA: float,
    mass_per_length: float,
    mu: float,
    omega_driver: float,
    load_torque: float = 0.0,
    load_viscous: float = 0.0,
    pretension: float | None = None,
    stress_free_length: float | None = None,
    contact_stiffness: float | None = None,
) -> CreepTheory:
    """Creep-theory steady state of an open two-pulley drive with fixed centres.

    Exactly one of ``pretension`` (uniform installed tension at rest, ``T0``) or
    ``stress_free_length`` (``L0``, giving ``T0 = EA (L/L0 - 1)`` for path length ``L``) must be
    given. The driven load is ``load_torque + load_viscous * omega_driven``. ``mass_per_length`` is
    per *current* length (``mass_per_current_length`` at the installed tension) and may be 0 (massless
    belt, ``c = 0``). ``contact_stiffness`` [N/m^2] (None: rigid pulleys): the belt sinks ``(T - c) / (R k)``
    into each pulley (module docstring, "Compliant contact"). See the module docstring for formulas and the
    :class:`CreepTheory` docstring for what is returned under gross slip.

    Raises ``ValueError`` for non-physical input, including a pretension not above the
    centrifugal term (the belt would lift off the pulleys).

    Parameters: the eleven keyword-only inputs are the textbook formula's own (geometry, belt, friction, driver
    speed, load, pretension or stress-free length), each named after its quantity and checked by that name;
    a record of them would only rename them.
    """
    r1 = _positive("radius_driver", radius_driver)
    r2 = _positive("radius_driven", radius_driven)
    span, th1, th2, path = open_belt_geometry(r1, r2, center_distance)
    ea = _positive("EA", EA)
    m = _non_negative("mass_per_length", mass_per_length)
    mu_ = _positive("mu", mu)
    w1 = _non_negative("omega_driver", omega_driver)
    m0 = _non_negative("load_torque", load_torque)
    cv = _non_negative("load_viscous", load_viscous)

    k = math.inf if contact_stiffness is None else _positive("contact_stiffness", contact_stiffness)
    if math.isfinite(k) and pretension is not None and stress_free_length is None:
        # the pretension at rest on compliant pulleys: its stress-free length, through the sunk path
        p0 = _positive("pretension", pretension)
        pretension, stress_free_length = None, (path - p0 * (th1 / r1 + th2 / r2) / k) / (1.0 + p0 / ea)
    t0, t0_source = _installed_tension(ea, path, pretension, stress_free_length)
    # the sunk path's shortening per unit y, EA-weighted: it enters the closure beside B (0: rigid pulleys)
    g = 0.0 if math.isinf(k) else ea * (t0 / ea + 1.0) / k  # EA L / L0 / k, L / L0 = 1 + T0 / EA
    c = m * (w1 * r1) ** 2
    if t0 <= c:
        raise ValueError(
            f"pretension must exceed the centrifugal term c = m v^2 = {c!r} N, otherwise the belt "
            f"lifts off the pulleys; got {t0_source} with omega_driver={omega_driver!r}"
        )

    theta_min = min(th1, th2)
    ratio_w = w1 * r1 / r2

    def state(phi: float) -> tuple[float, float, float]:
        r = math.exp(mu_ * phi)
        b = (r + 1.0) * span + r1 * (th1 - phi) * r + r2 * (th2 - phi) + (r1 + r2) * math.expm1(mu_ * phi) / mu_
        sunk = (r * (th1 - phi) + math.expm1(mu_ * phi) / mu_) / r1 + ((th2 - phi) + math.expm1(mu_ * phi) / mu_) / r2
        y = (t0 - c) * path / (b + g * sunk)
        t1, t2 = c + r * y, c + y
        rolling = 1.0 if math.isinf(k) else (1.0 - r * y / (r1 * r1 * k)) / (1.0 - y / (r2 * r2 * k))
        return t1, t2, ratio_w * rolling * (ea + t2) / (ea + t1)

    def residual(phi: float) -> float:
        t1, t2, w2 = state(phi)
        return (t1 - t2) * r2 - (m0 + cv * w2)

    phi, gross = _slip_arc(residual, theta_min)
    t1, t2, w2 = state(phi)
    dt = t1 - t2
    return CreepTheory(
        T_tight=t1,
        T_slack=t2,
        centrifugal=c,
        torque_driver=dt * r1,
        torque_driven=dt * r2,
        omega_driver=w1,
        omega_driven=w2,
        speed_loss=ratio_w - w2,
        wrap_driver=th1,
        wrap_driven=th2,
        slip_arc_driver=phi,
        slip_arc_driven=phi,
        stick_arc_driver=th1 - phi,
        stick_arc_driven=th2 - phi,
        gross_slip=gross,
    )


def _installed_tension(
    ea: float, path: float, pretension: float | None, stress_free_length: float | None
) -> tuple[float, str]:
    """``T0`` from exactly one of ``pretension`` or ``stress_free_length`` (``EA (L/L0 - 1)``), and how
    it was given (for error messages)."""
    if pretension is not None and stress_free_length is None:
        return _positive("pretension", pretension), f"pretension={pretension!r}"
    if stress_free_length is None or pretension is not None:
        raise ValueError(
            "exactly one of pretension or stress_free_length must be given, got "
            f"pretension={pretension!r}, stress_free_length={stress_free_length!r}"
        )
    l0 = _positive("stress_free_length", stress_free_length)
    if l0 >= path:
        raise ValueError(
            f"stress_free_length must be < the belt path length {path!r} m "
            f"(otherwise the belt is slack), got {stress_free_length!r}"
        )
    t0 = ea * (path / l0 - 1.0)
    return t0, f"stress_free_length={stress_free_length!r} (pretension {t0!r} N)"


def _slip_arc(residual, theta_min: float) -> tuple[float, bool]:
    """The slip arc ``phi`` in [0, theta_min] where ``residual`` (transmitted minus demanded torque) vanishes,
    by bisection to round-off, and whether the belt slips grossly (no root: phi = theta_min)."""
    # residual(0) = -demand <= 0 and the transmitted torque rises strictly with phi, so a sign
    # change on [0, theta_min] brackets the root; without one the belt cannot carry the load.
    if residual(0.0) >= 0.0:
        return 0.0, False
    if residual(theta_min) < 0.0:
        return theta_min, True
    lo, hi = 0.0, theta_min
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            break
        if residual(mid) < 0.0:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi), False
