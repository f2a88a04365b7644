"""Tensioner losses around any movable carrier: Coulomb pivot (guide) friction with true sticking, damping that
differs between loading and unloading, and hard stops (``LossyCarrier(inner=ArmCarrier())``; see
``constraints`` for how its impulse is solved with the contacts)."""

from __future__ import annotations

import math
import typing
from collections.abc import Mapping
from typing import Any, ClassVar

import equinox as eqx
import jax.numpy as jnp

from .arm import MAX_ARM_ANGLE
from .base import AbstractCarrier, AbstractMovableCarrier, CarrierKey, Checks, Installed, SpecKey
from .constraints import AbstractConstrainedCarrier

__all__ = ["LossyCarrier", "in_degrees"]


@typing.final
class LossyCarrier(AbstractMovableCarrier, AbstractConstrainedCarrier):
    """Pivot (guide) dry friction, loading/unloading damping and stops around any movable carrier ``inner``
    (its centre and coordinate; the spring, damper and weight every movable carrier has). One wrapper for every
    movable kind, the way diffrax wraps solvers: a new movable carrier gets these losses with no class of its own.

    ``load_sense`` (+1 or -1): the sign of ``psi_dot`` that winds the spring up (the belt pushes the
    arm away from it); ``damping`` acts then, ``damping_unload`` otherwise.
    The implicit part of the step uses the loading damping (``_m_eff``); the local solve adds the
    difference while unloading, the friction and the stops:

        m v = m b - h F sign(v) - h (c_dir - c_load) v,   psi + h v within [low, high]

    (``m`` the implicit inertia, ``b`` the velocity without ``lam``), exactly: stick when
    ``|m b| <= h F``, else slip at the band; then the stops clip ``v``.
    """

    inner: AbstractMovableCarrier
    load_sense: int = eqx.field(static=True, default=-1)
    unload_follows: bool = eqx.field(static=True, default=False)  # no damping_unload given: it is ``damping``
    name: ClassVar[str] = "lossy"
    own_keys: ClassVar[tuple[CarrierKey, ...]] = (
        CarrierKey("friction_torque", "N m (slider: N): Coulomb pivot (guide) friction", True, loss="friction"),
        CarrierKey("damping_unload", "as damping: the damping while unloading", True, loss="damping"),
        CarrierKey("stops.min", "rad (slider: m): the lower stop (-inf: none)", True),
        CarrierKey("stops.max", "rad (slider: m): the upper stop (+inf: none)", True),
    )

    # its table's keys, beside those of the carrier it wraps: any of them given wraps it
    spec_keys: ClassVar[tuple[SpecKey, ...]] = (
        SpecKey(
            "friction_torque", "N m (slider: N): Coulomb pivot (guide) friction, true sticking", check="non_negative"
        ),
        SpecKey("damping_unload", "as damping: the damping while unloading (default: damping)", check="non_negative"),
        SpecKey(
            "stops",
            "(min, max) rad (slider: m): hard stops of the arm angle (travel)",
            tuple[float, float],
            check="interval",
        ),
    )

    @classmethod
    def given(cls, values: Mapping[str, Any]) -> bool:
        """The table gives pivot friction, unloading damping or stops: its carrier is wrapped."""
        return any(values[k.name] is not None for k in cls.spec_keys)

    @classmethod
    def check_losses(cls, inner: type[AbstractCarrier], values: Mapping[str, Any], checks: Checks) -> None:
        """The stops: an interval of the coordinate, an arm's in radians (the installed coordinate inside them is
        checked after the layout)."""
        if values["stops"] is None:
            return
        lo, hi = (float(x) for x in values["stops"])
        unit = "rad" if inner.pivoted else "m"
        checks(lo < hi, "stops", values["stops"], f"must be (min, max) with min < max [{unit}]")
        if inner.pivoted:  # radians are easily given in degrees: stops = [72, 92] are 11 and 15 turns
            checks(
                max(abs(lo), abs(hi)) <= MAX_ARM_ANGLE,
                "stops",
                values["stops"],
                f"an arm's stops are arm angles in radians and must be within [-2π, 2π] ([{lo:g}, {hi:g}] rad are "
                f"[{math.degrees(lo):.4g}, {math.degrees(hi):.4g}] deg); {in_degrees(lo, hi)}",
            )

    @classmethod
    def wrap(cls, built: Installed, values: Mapping[str, Any], center) -> Installed:
        """``built`` (a movable carrier) with its losses: ``load_sense`` from the spring's installed load (winding
        the spring up moves against its torque); symmetric damping unless ``damping_unload`` is given."""
        assert isinstance(built.carrier, AbstractMovableCarrier)  # a tensioner's carrier moves
        load_sense = 1 if type(built.carrier).installed_load(values, center) < 0 else -1
        low, high = values["stops"] if values["stops"] is not None else (-math.inf, math.inf)
        losses = {
            "friction_torque": values["friction_torque"] or 0.0,
            "damping_unload": values["damping"] if values["damping_unload"] is None else values["damping_unload"],
            "stops.min": float(low),
            "stops.max": float(high),
        }
        carrier = cls(inner=built.carrier, load_sense=load_sense, unload_follows=values["damping_unload"] is None)
        return Installed(carrier, built.origin, {**built.numbers, **losses}, built.psi0)

    @property
    def coordinate(self) -> str | None:  # type: ignore[override]
        return self.inner.coordinate

    @property
    def pivoted(self) -> bool:  # type: ignore[override]
        return self.inner.pivoted

    def signals(self):
        """The inner carrier's, and its friction and stop reaction (``constraint_parts`` of the saved impulse)."""
        friction, stop = self.inner.loss_quantities

        def part(j):
            def fn(params, states, i, h):
                assert states.constraints is not None, "a constrained drive saves its ConstraintState"
                lam = states.constraints.impulse[:, i]
                return self.constraint_parts(params.pulleys, i, lam, states.psi_dot[:, i], h)[j]

            return fn

        return (*self.inner.signals(), (friction, part(0)), (stop, part(1)))

    @classmethod
    def quantities(cls):
        return ()  # its inner kind's (AbstractMovableCarrier.quantities)

    def followers(self, name):
        return ("damping_unload",) if name == "damping" and self.unload_follows else ()

    @property
    def keys(self) -> tuple[CarrierKey, ...]:  # type: ignore[override]
        return (*self.inner.keys, *self.own_keys)

    def center(self, pp, k, psi):
        return self.inner.center(pp, k, psi)

    def dcenter(self, pp, k, psi):
        return self.inner.dcenter(pp, k, psi)

    def _unclipped(self, pp, k, m, b, h):
        """The local solve without the stops: ``(p, band, slipping, sig, extra, new)`` for the implicit
        inertia ``m`` and the velocity ``b`` without ``lam``."""
        p = m * b
        n = self.numbers(pp, k)
        band = h * n["friction_torque"]
        sig = jnp.sign(p)
        # the implicit part used the loading damping: add the difference while unloading
        extra = jnp.where(sig * self.load_sense > 0, 0.0, n["damping_unload"] - n["damping"])
        slipping = jnp.abs(p) > band
        new = jnp.where(slipping, (p - band * sig) / (m + h * extra), 0.0)
        return p, band, slipping, sig, extra, new

    def constraint_impulse(self, pp, k, v):
        h, n = v.h, self.numbers(pp, k)
        m = 1.0 / v.inv_carrier
        new = self._unclipped(pp, k, m, v.psi_dot, h)[-1]
        new = jnp.clip(new, (n["stops.min"] - v.psi) / h, (n["stops.max"] - v.psi) / h)
        return m * (new - v.psi_dot)

    def constraint_parts(self, pp, k, lam, psi_dot, h):
        """The pivot friction and the stop reaction in a step's impulse ``lam`` (end-of-step carrier
        velocity ``psi_dot``): ``(friction, stop)`` torques [N m] (forces [N] on a slider) on the
        carrier, in the sense of ``psi``, with ``lam / h = friction + stop - (c_dir - c_load) psi_dot``
        (the last term: the unloading damping's excess, at the end velocity). Friction: ``-F sign(p)``
        while slipping, the whole holding torque ``-p / h`` while sticking; stop: what is left, nonzero
        only while a stop clips the velocity (on a stop at rest: the torque pushing into it beyond the
        friction band). Read from the saved state (the velocity without ``lam`` is
        ``psi_dot - lam / m``): the step computes nothing more."""
        m = 1.0 / self.inverse_mass(pp, k, h)
        p, band, slipping, sig, extra, new = self._unclipped(pp, k, m, psi_dot - lam / m, h)
        friction = jnp.where(slipping, -band * sig, -p)
        return friction / h, (m + h * extra) * (psi_dot - new) / h

    def constraint_response(self, pp, k, lam, inv_spin, inv_carrier):
        return jnp.zeros_like(lam), inv_carrier * lam

    def constraint_power(self, lam, omega_mid, psi_dot_mid):
        return lam * psi_dot_mid


def in_degrees(lo: float, hi: float) -> str:
    """The hint for arm stops given in degrees."""
    return f"these look like degrees: write stops = [{math.radians(lo):.6g}, {math.radians(hi):.6g}] (radians)"
