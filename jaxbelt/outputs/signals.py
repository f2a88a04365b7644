"""The signal registry: every output signal defined once, with its name, unit and traced function.

A signal is a column ``<prefix>:<member>`` of ``signals.csv`` (``omega:driver``,
``tension:driver-driven``, ``arm_angle:idler``); its ``Quantity`` gives the unit and plot labels,
its group the traced function of ``(drive, params, states)`` that computes it. Everything that
names or computes signals reads this module: ``signal_names``, ``signals_of`` (traced, for
gradients, identification and sweeps), ``signals`` (numpy, the run's ``signals.csv``), ``io``,
``viz`` and the CLI. Adding an output = one ``Quantity`` and one ``SignalGroup`` here; a carrier
kind declares its own (``AbstractCarrier.signals``, its quantities in its class's file).

``simulate_signals(drive, params)`` runs a drive from its parameters (the installed state is
rebuilt from them, so pretension and geometry are differentiable too) and returns the named
signals. It is the one function that gradients, identification and sweeps are built on.
"""

from __future__ import annotations

import dataclasses
import typing
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np

from ..belt.tension import tension_at
from .._drive import Drive
from ..geometry.path import BeltPath, place_belt, span_midpoints
from .._types import DriveParams, DriveState
from ..geometry.installed import installed_path
from ..dynamics.simulate import Trajectory, simulate
from .._quantity import Quantity
from ..pulleys.carriers import carrier_quantities
from ..pulleys.carriers.arm import ARM_ANGLE, PIVOT_FRICTION, STOP_TORQUE
from ..pulleys.carriers.base import CarrierSignal
from ..pulleys.carriers.constraints import CLUTCH_TORQUE, ROTOR_OMEGA
from ..pulleys.carriers.slider import GUIDE_FRICTION, STOP_FORCE, TRAVEL
from .fead import fead_columns, fead_values

__all__ = [
    "Quantity",
    "SignalGroup",
    "SIGNALS",
    "QUANTITIES",
    "TIME",
    "OMEGA",
    "TORQUE",
    "TENSION",
    "ARM_ANGLE",
    "TRAVEL",
    "SLIP",
    "FRICTION_USE",
    "HUB_LOAD",
    "HUB_DIRECTION",
    "SPEED",
    "DEFLECTION",
    "ROTOR_OMEGA",
    "CLUTCH_TORQUE",
    "PIVOT_FRICTION",
    "STOP_TORQUE",
    "GUIDE_FRICTION",
    "STOP_FORCE",
    "carrier_signals",
    "span_names",
    "signal_columns",
    "signal_names",
    "signal_units",
    "quantity_of",
    "signals_of",
    "signals",
    "span_tensions",
    "initial_state",
    "simulate_signals",
]


TIME = Quantity("t", "s", "", "t", "Time")
OMEGA = Quantity("omega", "rad/s", "pulley", r"$\omega$", "Pulley angular velocities")  # counter-clockwise +
TORQUE = Quantity("torque", "N m", "pulley", "belt torque on pulley", "Belt torques")  # over the last step
TENSION = Quantity("tension", "N", "from>-<to", "span tension", "Span tensions")  # at the middle of the span
# accessory-drive outputs (fead.py): definitions in its docstring and docs/outputs.md
SLIP = Quantity("slip", "%", "pulley", "slip (belt vs surface speed)", "Pulley slip")
FRICTION_USE = Quantity("friction_use", "1", "pulley", "friction use (1 / slip safety factor)", "Friction use")
HUB_LOAD = Quantity("hub_load", "N", "pulley", "hub load", "Hub loads")  # force of the belt on the pulley
HUB_DIRECTION = Quantity(
    "hub_direction", "deg", "pulley", "hub load direction", "Hub load directions", period=360.0, magnitude="hub_load"
)
SPEED = Quantity("speed", "m/s", "from>-<to", "belt speed", "Belt speeds")  # at the middle of the span
DEFLECTION = Quantity("deflection", "m", "from>-<to", "mid-span deflection", "Span deflections")
# the carriers' quantities (arm angle, travel, pivot friction, clutch torque, ...) are their classes'
QUANTITIES = (
    OMEGA,
    TORQUE,
    TENSION,
    SLIP,
    FRICTION_USE,
    HUB_LOAD,
    HUB_DIRECTION,
    SPEED,
    DEFLECTION,
    *carrier_quantities(),
)

Column = tuple[str, Quantity]  # (name, quantity)
# one (T,) array per column from (drive, params, states, the belt path of params); traceable
Values = Callable[[Drive, DriveParams, DriveState, BeltPath], list]


@typing.final
@dataclasses.dataclass(frozen=True)
class SignalGroup:
    """Signals computed together: their columns for a drive (in ``signals.csv`` order) and one
    traced function giving all of them from stacked states."""

    columns: Callable[[Drive], list[Column]]
    values: Values


def span_names(drive: Drive) -> list[tuple[str, str]]:
    """``(from, to)`` pulley names of each span: span ``i`` runs from pulley ``i`` to pulley ``i + 1``."""
    names = drive.model.pulley_names
    return [(names[i], names[(i + 1) % len(names)]) for i in range(len(names))]


def _per_pulley(quantity: Quantity, field: str) -> SignalGroup:
    """One column per pulley: ``states.<field>[:, i]``."""
    return SignalGroup(
        columns=lambda drive: [(f"{quantity.prefix}:{p}", quantity) for p in drive.model.pulley_names],
        values=lambda drive, params, states, path: list(jnp.moveaxis(getattr(states, field), -1, 0)),
    )


def _span_tensions(drive: Drive, params: DriveParams, states: DriveState, path: BeltPath) -> list:
    """Axial force at the middle of each span (the element whose midpoint lies nearest)."""
    mid, _ = span_midpoints(path)
    T = tension_at(drive.model.n_elements, params.belt, mid, states.q, states.v)
    return list(jnp.moveaxis(T, -1, 0))


def carrier_signals(carrier) -> tuple[CarrierSignal, ...]:
    """The signals a carrier contributes, as its class declares them (``AbstractCarrier.signals``): a movable one
    its coordinate (arm angle, travel), a lossy one also its pivot (guide) friction and stop reaction, a one-way
    clutch pulley its rotor speed and clutch torque."""
    return carrier.signals()


def _carriers(drive: Drive):
    """(pulley name, index, quantity, function) of every carrier signal, in pulley order."""
    return [
        (p, i, q, fn)
        for i, (p, carrier) in enumerate(zip(drive.model.pulley_names, drive.model.carriers))
        for q, fn in carrier_signals(carrier)
    ]


SIGNALS: tuple[SignalGroup, ...] = (
    _per_pulley(OMEGA, "omega"),
    _per_pulley(TORQUE, "belt_torque"),
    SignalGroup(
        columns=lambda drive: [(f"{TENSION.prefix}:{a}-{b}", TENSION) for a, b in span_names(drive)],
        values=_span_tensions,
    ),
    SignalGroup(
        columns=lambda drive: [(f"{q.prefix}:{p}", q) for p, _, q, _ in _carriers(drive)],
        values=lambda drive, params, states, path: [
            fn(params, states, i, drive.dt) for _, i, _, fn in _carriers(drive)
        ],
    ),
    SignalGroup(
        columns=lambda drive: fead_columns(drive, (SLIP, FRICTION_USE, HUB_LOAD, HUB_DIRECTION), (SPEED, DEFLECTION)),
        values=fead_values,
    ),
)


def signal_columns(drive: Drive) -> list[Column]:
    """``(name, quantity)`` of every signal of this drive, in ``signals.csv`` order (without ``t``)."""
    return [col for group in SIGNALS for col in group.columns(drive)]


def signal_names(drive: Drive) -> list[str]:
    return [name for name, _ in signal_columns(drive)]


def signal_units(drive: Drive) -> dict[str, str]:
    """``{name: unit}`` of ``t`` and every signal of this drive."""
    return {"t": TIME.unit, **{name: q.unit for name, q in signal_columns(drive)}}


def quantity_of(name: str) -> Quantity:
    """The quantity of a signal name (``"omega:driver"`` -> ``OMEGA``)."""
    prefix = name.partition(":")[0]
    for q in (TIME, *QUANTITIES):
        if q.prefix == prefix:
            return q
    raise KeyError(f"no signal quantity {prefix!r}; known: {[q.prefix for q in QUANTITIES]}")


def signals_of(
    drive: Drive, params: DriveParams, states: DriveState, path: BeltPath | None = None
) -> dict[str, jax.Array]:
    """Every named signal of stacked saved states (traceable). ``path``: the installed belt path of
    ``params`` (default: rebuilt from them, so that geometry parameters act on the span middles)."""
    path = installed_path(drive, params) if path is None else path
    out: dict[str, jax.Array] = {}
    for group in SIGNALS:
        names = [name for name, _ in group.columns(drive)]
        out.update(zip(names, group.values(drive, params, states, path), strict=True))
    return out


def signals(drive: Drive, ts, states: DriveState) -> dict[str, np.ndarray]:
    """Time histories as numpy arrays, named as in ``signals.csv``: ``t`` then ``signal_names(drive)``
    (the traced ``signals_of`` applied to the saved states, on the drive's installed path)."""
    sig = signals_of(drive, drive.params, states, drive.path)
    return {"t": np.asarray(ts), **{k: np.asarray(v) for k, v in sig.items()}}


def span_tensions(drive: Drive, states: DriveState) -> np.ndarray:
    """Tension ``(T, k)`` at the middle of each span (the element whose midpoint lies nearest)."""
    return np.stack([np.asarray(x) for x in _span_tensions(drive, drive.params, states, drive.path)], axis=-1)


def initial_state(drive: Drive, params: DriveParams) -> DriveState:
    """The belt at rest on the path given by ``params`` (traceable)."""
    path = installed_path(drive, params)
    q0 = place_belt(path, drive.model.n_elements, params.belt.stress_free_length)
    return DriveState(
        q=q0,
        v=jnp.zeros_like(q0),
        **{
            k: getattr(drive.state0, k)
            for k in (
                "theta",
                "omega",
                "psi",
                "psi_dot",
                "lam_n",
                "lam_t",
                "contact_pulley",
                "belt_torque",
                "lcp_residual",
                "work",
                "pulley_work",
                "angular_impulse",
                "fault",
                "fault_time",
                "constraints",
            )
        },
    )


def simulate_signals(
    drive: Drive,
    params: DriveParams | None = None,
    *,
    t_end: float | None = None,
    save_dt: float | None = None,
    adjoint: str = "reverse",
    return_trajectory: bool = False,
):
    """Simulate from ``params`` and return ``(ts, {name: array})`` (and the Trajectory if asked)."""
    params = drive.params if params is None else params
    s = drive.options
    traj: Trajectory = simulate(
        drive.model,
        params,
        initial_state(drive, params),
        t_end=s.t_end if t_end is None else t_end,
        dt=drive.dt,
        save_dt=s.save_dt if save_dt is None else save_dt,
        settle_time=s.settle_time,
        adjoint=adjoint,
    )
    sig = signals_of(drive, params, traj.states)
    return (traj.ts, sig, traj) if return_trajectory else (traj.ts, sig)
