"""Traceable simulation outputs: the same signals as ``signals.csv``, as JAX arrays.

``simulate_signals(drive, params)`` runs a drive from its parameters (the installed state is
rebuilt from them, so pretension and geometry are differentiable too) and returns the named
signals. It is the one function that gradients, identification and sweeps are built on.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from .._drive import Drive
from ..geometry.path import place_belt, span_midpoints
from .._types import CARRIER_ARM, DriveParams, DriveState
from .summary import belt_tension_profile, span_names
from ..analysis.parameters import installed_path
from ..dynamics.simulate import Trajectory, simulate

__all__ = ["initial_state", "signals_of", "simulate_signals", "signal_names"]


def initial_state(drive: Drive, params: DriveParams) -> DriveState:
    """The belt at rest on the path given by ``params`` (traceable)."""
    path = installed_path(drive, params)
    q0 = place_belt(path, drive.model.n_elements, params.belt.stress_free_length)
    return DriveState(q=q0, v=jnp.zeros_like(q0), **{k: getattr(drive.state0, k) for k in (
        "theta", "omega", "psi", "psi_dot", "lam_n", "lam_t", "contact_pulley", "belt_torque", "lcp_residual",
        "work", "pulley_work", "angular_impulse", "fault", "fault_time")})


def signal_names(drive: Drive) -> list[str]:
    names = drive.model.pulley_names
    out = [f"omega:{p}" for p in names] + [f"torque:{p}" for p in names]
    out += [f"tension:{a}-{b}" for a, b in span_names(drive)]
    out += [f"arm_angle:{p}" for p, k in zip(names, drive.model.carrier_kind) if k == CARRIER_ARM]
    out += [f"travel:{p}" for p, k in zip(names, drive.model.carrier_kind) if k not in (0, CARRIER_ARM)]
    return out


def signals_of(drive: Drive, params: DriveParams, states: DriveState) -> dict[str, jax.Array]:
    """Named signals of saved states (traceable; tensions at the middle of each span)."""
    mid, _ = span_midpoints(installed_path(drive, params))

    def tensions(q, v):
        N, r = belt_tension_profile(drive, q, v, params)
        d = jnp.sum((r[:, None, :] - mid[None]) ** 2, -1)
        return N[jnp.argmin(d, axis=0)]

    T = jax.vmap(tensions)(states.q, states.v)
    out = {}
    names = drive.model.pulley_names
    for i, p in enumerate(names):
        out[f"omega:{p}"] = states.omega[:, i]
    for i, p in enumerate(names):
        out[f"torque:{p}"] = states.belt_torque[:, i]
    for k, (a, b) in enumerate(span_names(drive)):
        out[f"tension:{a}-{b}"] = T[:, k]
    for i, (p, kind) in enumerate(zip(names, drive.model.carrier_kind)):
        if kind == CARRIER_ARM:
            out[f"arm_angle:{p}"] = states.psi[:, i]
        elif kind != 0:
            out[f"travel:{p}"] = states.psi[:, i]
    return out


def simulate_signals(drive: Drive, params: DriveParams | None = None, *, t_end: float | None = None,
                     save_dt: float | None = None, adjoint: str = "reverse",
                     return_trajectory: bool = False):
    """Simulate from ``params`` and return ``(ts, {name: array})`` (and the Trajectory if asked)."""
    params = drive.params if params is None else params
    s = drive.options
    traj: Trajectory = simulate(drive.model, params, initial_state(drive, params),
                                t_end=s.t_end if t_end is None else t_end, dt=drive.dt,
                                save_dt=s.save_dt if save_dt is None else save_dt, settle_time=s.settle_time,
                                adjoint=adjoint)
    sig = signals_of(drive, params, traj.states)
    return (traj.ts, sig, traj) if return_trajectory else (traj.ts, sig)
