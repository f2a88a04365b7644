"""The carrier-constraint part of the step (tensioner pivot friction and stops, one-way clutches;
``pulleys.carriers.constraints``): the per-pulley local solves and responses the contact solve calls, the
end-of-step constraint state and the constraints' work. Used only by drives with such carriers
(``DriveModel.constrained``, static); kept out of ``step`` so that file stays the scheme itself."""

from __future__ import annotations

from typing import TYPE_CHECKING

import jax
import jax.numpy as jnp

from .._types import DriveModel, DriveParams, DriveState
from ..pulleys.carriers.constraints import AbstractConstrainedCarrier, CarrierVelocity, ConstraintState

if TYPE_CHECKING:  # step imports this module
    from .step import FreeVelocities, Impulses

__all__ = ["constraint_state", "constraint_local", "constraint_response", "constraint_work"]


def _carrier_velocity(state: DriveState, free: FreeVelocities, k: int, omega, psi_dot, h) -> CarrierVelocity:
    return CarrierVelocity(
        omega=omega[k],
        psi_dot=psi_dot[k],
        psi=state.psi[k],
        deflection=_cs(state).deflection[k],
        inv_spin=free.inv_spin[k],
        inv_carrier=free.inv_carrier[k],
        h=jnp.asarray(h, state.psi.dtype),
    )


def constraint_local(
    model: DriveModel, params: DriveParams, state: DriveState, free: FreeVelocities, omega, psi_dot, h
):
    """Per pulley: the constraint impulse of its carrier given the velocities without it (0: none)."""
    pp = params.pulleys
    return jnp.stack(
        [
            c.constraint_impulse(pp, k, _carrier_velocity(state, free, k, omega, psi_dot, h))
            if isinstance(c, AbstractConstrainedCarrier)
            else jnp.zeros_like(omega[k])
            for k, c in enumerate(model.carriers)
        ]
    )


def constraint_response(model: DriveModel, params: DriveParams, lam_c, free: FreeVelocities):
    """Spin and carrier velocity changes ``(p,), (p,)`` from the carrier constraint impulses."""
    out = [
        c.constraint_response(params.pulleys, k, lam_c[k], free.inv_spin[k], free.inv_carrier[k])
        if isinstance(c, AbstractConstrainedCarrier)
        else (jnp.zeros_like(lam_c[k]),) * 2
        for k, c in enumerate(model.carriers)
    ]
    return jnp.stack([o[0] for o in out]), jnp.stack([o[1] for o in out])


def constraint_state(
    model: DriveModel, params: DriveParams, state: DriveState, free: FreeVelocities, imp: Impulses, h
) -> ConstraintState | None:
    """End-of-step constraint state: the impulses (next warm start) and decoupler deflections."""
    if not model.constrained:
        return state.constraints
    lam, cs = _impulse(imp), _cs(state)
    deflection = jnp.stack(
        [
            c.deflection(params.pulleys, k, lam[k], _carrier_velocity(state, free, k, free.omega, free.psi_dot, h))
            if isinstance(c, AbstractConstrainedCarrier)
            else cs.deflection[k]
            for k, c in enumerate(model.carriers)
        ]
    )
    return ConstraintState(impulse=lam, deflection=deflection)


def _cs(state: DriveState) -> ConstraintState:
    assert state.constraints is not None, "a constrained drive's state has its ConstraintState"
    return state.constraints


def _impulse(imp: Impulses) -> jax.Array:
    assert imp.carrier is not None
    return imp.carrier


def constraint_work(
    model: DriveModel, params: DriveParams, state: DriveState, imp: Impulses, new_cs, omega_mid, psi_dot_mid
):
    """Work of the carrier constraint impulses over the step: on lossy carriers (pivot friction, stops,
    unloading damping) and on clutches, the latter plus the decoupler springs' energy change, so that
    it is minus the clutches' dissipation (the springs' energy is stored energy in the audit)."""
    lam, old, new = _impulse(imp), _cs(state), new_cs
    pivot, clutch = jnp.zeros_like(lam[0]), jnp.zeros_like(lam[0])
    for k, c in enumerate(model.carriers):
        if not isinstance(c, AbstractConstrainedCarrier):
            continue
        wk = c.constraint_power(lam[k], omega_mid[k], psi_dot_mid[k])
        if c.load_on_carrier:
            spring = c.spring_energy(params.pulleys, k, new.deflection[k]) - c.spring_energy(
                params.pulleys, k, old.deflection[k]
            )
            clutch = clutch + wk + spring
        else:
            pivot = pivot + wk
    return pivot, clutch
