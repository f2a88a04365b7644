"""Installation statics: span tensions, hub loads and tensioner positions without a dynamic run.

The belt is a string (no bending stiffness, no sag, no centrifugal tension: the drive at rest or at
low speed) on rigid pulleys with the layout's tangent geometry. Unknowns: the tension ``T0`` of the
span leaving the first driver (its slack side) and the coordinate of every movable carrier
(tensioner arm angle or slider travel). Equations:

* the tension chain: walking in the direction of travel, ``T_leave = T_arrive + Q_i / R_i`` across
  pulley ``i`` that absorbs the torque ``Q_i`` (its accessory load; the driver supplies the tension steps'
  sum, ``sum Q_i R_driver / R_i``);
* belt length: the stress-free lengths of all spans and arcs add up to the belt's stress-free
  length, with strain ``T / EA``. On an arc the tension changes over the slip arc at the exit only
  (creep theory, Euler-Eytelwein with the pulley's effective friction coefficient); the adhesion arc
  keeps the arriving tension;
* every movable carrier in equilibrium: its spring, preload and weight against the hub load,
  ``Q_spring(psi) + H . d(centre)/d(psi) = 0``.

Solved by Newton's method with a static iteration count (differentiable in forward and reverse mode
with respect to every parameter: ``jax.jacfwd`` of a figure gives its sensitivities).
The contact compliance is included: on each wrap the belt axis runs ``delta = T / (R k)`` inside the
pulley's radius (k = ``contact.stiffness``, as in the run), shortening the path by ``int delta dphi``
(``belt.contact_path_shortening`` [m]), which the tensioner or the belt's strain takes up.
Not included: gravity sag, and tensioner dry friction (a band of equilibria; this is its centre).
"""

from __future__ import annotations

import dataclasses
import math
import typing

import jax
import jax.numpy as jnp
import numpy as np

from .._cache import per_drive
from .._drive import Drive
from .._errors import ConfigError
from .._export import StoredJit
from .._types import DriveParams
from ..geometry.installed import arc_stress_free as _arc_stress_free, travel_chain as _travel_chain
from ..geometry.path import belt_path
from ..pulleys.carrier import carrier_centers, to_coordinates
from ..pulleys.carriers import AbstractMovableCarrier

__all__ = ["Statics", "statics", "statics_table", "solve_statics"]

NEWTON_ITERATIONS = 40
MAX_CARRIER_STEP = 0.05  # [rad or m] per Newton iteration: keeps an arm from jumping over its equilibrium


@dataclasses.dataclass
class Statics:
    """Result of :func:`statics` (plain numbers; ``as_dict`` for JSON)."""

    pulleys: dict  # name -> wrap_deg, torque (absorbed, N m), tension_in/out, hub_load, hub_load_deg, slip_arc_deg,
    #                slip_safety, and coordinate (arm angle [rad] / travel [m]) for movable carriers
    spans: list  # {name, from, to, length, tension}
    belt: dict  # path_length, stress_free_length, EA, max_tension, min_tension, length_change, contact_path_shortening
    gross_slip: list  # pulleys whose slip arc would exceed the wrap (the torques cannot be carried)

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


def solve_statics(drive: Drive, params: DriveParams, torques, length_change=0.0) -> dict:
    """The traceable core of :func:`statics`: Newton on (T0, movable carrier coordinates).

    ``torques`` (p,) absorbed torque per pulley in model order (the driver's entry is ignored). Returns
    arrays: ``T`` span tensions (span j from pulley j to j+1), ``psi`` carrier coordinates, ``hub`` (p, 2)
    belt force on each pulley, ``slip`` slip arcs [rad], ``path`` (BeltPath), ``residual``, ``L0``.
    Differentiable with respect to ``params`` (forward and reverse mode)."""
    model, pp, belt = drive.model, params.pulleys, params.belt
    leave, arrive, order, start = _travel_chain(drive)
    movable = [i for i, c in enumerate(model.carriers) if c.movable]
    mu_eff = _sliding_mu(model, params)
    torques = jnp.asarray(torques)
    L0 = belt.stress_free_length + length_change
    psi_base = jnp.zeros(model.n_pulleys, dtype=L0.dtype)
    orientation = int(round(float(drive.path.orientation)))

    def figures(x):
        T0, psi = x[0], psi_base.at[jnp.asarray(movable, dtype=int)].set(x[1:]) if movable else psi_base
        centers, dcenter = carrier_centers(model, pp, psi)
        path = belt_path(centers, pp.radius, model.wrap_side, orientation=orientation)
        T: list = [None] * model.n_pulleys
        T[leave[start]] = T0
        for i in order[:-1]:  # tension chain in the direction of travel
            T[leave[i]] = T[arrive[i]] + torques[i] / pp.radius[i]
        T_span = jnp.stack(T)
        free = jnp.sum(path.span_length / (1.0 + T_span / belt.EA))
        slip_arcs: list = []
        shortening = 0.0
        for i in range(model.n_pulleys):
            arc, phi_s, dl = _arc_stress_free(
                pp.radius[i],
                path.wrap_angle[i],
                T_span[arrive[i]],
                T_span[leave[i]],
                mu_eff[i],
                belt.EA,
                params.contact_stiffness,
            )
            free, slip_arcs, shortening = free + arc, slip_arcs + [phi_s], shortening + dl
        d = path.span_dir
        hub = jnp.stack(
            [
                T_span[i] * d[i] - T_span[(i - 1) % model.n_pulleys] * d[(i - 1) % model.n_pulleys]
                for i in range(model.n_pulleys)
            ]
        )
        pushed = to_coordinates(model, jnp.sum(hub * dcenter, axis=-1))  # a pendulum's idlers both push its arm
        carrier_eq = [
            typing.cast(AbstractMovableCarrier, model.carriers[i]).generalised_force(pp, i, psi[i], params.gravity)
            + pushed[i]
            for i in movable
        ]
        residual = jnp.stack([(free - L0) * belt.EA / L0, *carrier_eq])
        return residual, dict(T=T_span, path=path, hub=hub, slip=jnp.stack(slip_arcs), psi=psi, shortening=shortening)

    def newton(_, x):
        r, jac = figures(x)[0], jax.jacfwd(lambda y: figures(y)[0])(x)
        dx = -jnp.linalg.solve(jac, r)
        limit = jnp.concatenate([jnp.full((1,), jnp.inf), jnp.full((len(movable),), MAX_CARRIER_STEP)])
        return x + jnp.clip(dx, -limit, limit)

    T_guess = belt.EA * (drive.path.length / L0 - 1.0)
    x0 = jnp.concatenate([jnp.atleast_1d(jnp.maximum(T_guess, 1.0)), drive.state0.psi[jnp.asarray(movable, int)]])
    x = jax.lax.fori_loop(0, NEWTON_ITERATIONS, newton, x0)
    residual, out = figures(x)
    return dict(out, residual=residual, L0=L0)


def _check_torques(drive: Drive, torques: dict | None) -> np.ndarray:
    names = list(drive.model.pulley_names)
    torques = dict(torques or {})
    q = np.zeros(len(names))
    for name, value in torques.items():
        if name not in names:
            from .._errors import did_you_mean

            raise ConfigError(f"statics: torques[{name!r}]: no such pulley{did_you_mean(name, names)}")
        i = names.index(name)
        if drive.pulleys[i].role == "driver":
            raise ConfigError(
                f"statics: torques[{name!r}] = {value!r}: {name} is the driver; it supplies what the others absorb "
                "(sum Q_i R_driver / R_i)"
            )
        if not (isinstance(value, (int, float)) and math.isfinite(value)):
            raise ConfigError(f"statics: torques[{name!r}] = {value!r}: must be a finite number [N m]")
        q[i] = float(value)
    return q


def statics(
    drive: Drive, torques: dict | None = None, *, params: DriveParams | None = None, length_change: float = 0.0
) -> Statics:
    """Installation (``torques`` None) or loaded statics of ``drive``.

    ``torques``: pulley name -> torque it absorbs [N m] (positive takes power from the belt: an
    accessory's load; the driver is left out, it supplies sum Q_i R_driver / R_i). ``length_change`` [m] is added to
    the belt's stress-free length (a belt at the end of its length tolerance, or stretched by wear).
    """
    q = _check_torques(drive, torques)
    _check_length_change(drive, "length_change", length_change)
    params = drive.params if params is None else params
    out = _stored_solve(drive, "statics", lambda p, qq, dl: solve_statics(drive, p, qq, dl))(
        params, jnp.asarray(q, dtype=jnp.result_type(float)), jnp.asarray(length_change, dtype=jnp.result_type(float))
    )
    return _report(drive, jax.tree.map(np.asarray, out), q, length_change)


# A length change beyond this share of the stress-free length is no tolerance or wear (the run refuses
# installation strains above 20 % as well): a typo, e.g. metres given where millimetres are meant.
MAX_LENGTH_CHANGE = 0.2


def _check_length_change(drive: Drive, what: str, dl) -> None:
    if isinstance(dl, bool) or not (isinstance(dl, (int, float)) and math.isfinite(dl)):
        raise ConfigError(f"statics: {what} = {dl!r}: must be a finite length [m]")
    L0 = float(drive.params.belt.stress_free_length)
    if abs(dl) > MAX_LENGTH_CHANGE * L0:
        raise ConfigError(
            f"statics: {what} = {dl!r} m: more than {MAX_LENGTH_CHANGE:.0%} of the belt's stress-free length "
            f"{L0:.4g} m; a length tolerance or wear is a few millimetres (--length-tolerance and --wear are in mm)"
        )


_COMPILED: dict = {}


def _stored_solve(drive: Drive, name: str, fn):
    """``jax.jit(fn)`` stored traced beside the compilation cache (``_export.StoredJit``), one per drive and ``name``
    in this process: a later call or process neither traces nor keys the solve again. ``fn(params, torques,
    length_change)`` returns ``solve_statics``' dict and may close over ``drive`` alone."""
    like = dict(T=0, path=drive.path, hub=0, slip=0, psi=0, shortening=0, residual=0, L0=0)
    return per_drive(_COMPILED, drive, lambda: StoredJit(name, fn, (drive,), like), name)


def statics_table(drive: Drive, torques: dict | None = None, cases: dict | None = None) -> dict[str, Statics]:
    """:func:`statics` for several belt lengths at once (one batched solve): ``cases`` maps a label to a
    length change [m], by default nominal only. E.g. ``{"nominal": 0, "shortest": -0.004, "longest": 0.004,
    "worn": 0.012}`` for a +-4 mm length tolerance and 12 mm of wear stretch."""
    cases = {"nominal": 0.0} if cases is None else dict(cases)
    for label, dl in cases.items():
        _check_length_change(drive, f"length change of case {label!r}", dl)
    q = _check_torques(drive, torques)
    dls = jnp.asarray([float(v) for v in cases.values()])
    solve = _stored_solve(
        drive, "statics_table", lambda p, qq, dl: jax.vmap(lambda x: solve_statics(drive, p, qq, x))(dl)
    )
    batched = solve(drive.params, jnp.asarray(q, dtype=jnp.result_type(float)), dls)
    batched = jax.tree.map(np.asarray, batched)
    return {
        label: _report(drive, jax.tree.map(lambda a: a[j], batched), q, float(dl))
        for j, (label, dl) in enumerate(cases.items())
    }


def _report(drive: Drive, out: dict, q: np.ndarray, length_change: float) -> Statics:
    model = drive.model
    names = list(model.pulley_names)
    k = len(names)
    leave, arrive, _, start = _travel_chain(drive)
    T, path, hub, slip = out["T"], out["path"], out["hub"], out["slip"]
    if not np.all(np.isfinite(out["residual"])) or np.max(np.abs(out["residual"])) > 1e-6 * max(np.max(np.abs(T)), 1):
        raise ConfigError(
            "statics: no equilibrium found (residual "
            f"{np.max(np.abs(out['residual'])):.3g}): a tensioner beyond its travel or a belt too short or long "
            "for the layout; check the tensioner's rest, preload and spring, and the belt length"
            + (
                ""
                if jax.config.read("jax_enable_x64")
                else " (or float32: the solve needs float64, jax.config.update('jax_enable_x64', True))"
            )
        )
    driver_torque = -float(model_radius(drive)[start] * (T[leave[start]] - T[arrive[start]]))
    pulleys, gross = {}, []
    for i, name in enumerate(names):
        phi = float(path.wrap_angle[i])
        lo, hi = sorted((float(T[arrive[i]]), float(T[leave[i]])))
        used = math.log(hi / lo) if lo > 0 else math.inf
        mu_eff = float(np.asarray(_sliding_mu(model, drive.params))[i])
        safety = mu_eff * phi / used if used > 0 else math.inf
        if safety < 1:
            gross.append(name)
        entry = dict(
            wrap_deg=math.degrees(phi),
            torque=float(q[i]) if i != start else driver_torque,
            tension_in=float(T[arrive[i]]),
            tension_out=float(T[leave[i]]),
            hub_load=float(np.hypot(*hub[i])),
            hub_load_deg=math.degrees(math.atan2(hub[i][1], hub[i][0])),
            slip_arc_deg=math.degrees(float(slip[i])),
            slip_safety=safety,
        )
        c = model.carriers[i]
        if c.movable:
            entry[c.coordinate or "coordinate"] = float(out["psi"][i])
        pulleys[name] = entry
    spans = [
        dict(name=f"{names[j]}-{names[(j + 1) % k]}", length=float(path.span_length[j]), tension=float(T[j]))
        for j in range(k)
    ]
    belt = dict(
        path_length=float(path.length),
        stress_free_length=float(out["L0"]),
        length_change=length_change,
        EA=float(drive.params.belt.EA),
        max_tension=float(np.max(T)),
        min_tension=float(np.min(T)),
        contact_path_shortening=float(out["shortening"]),
    )
    return Statics(pulleys=pulleys, spans=spans, belt=belt, gross_slip=gross)


def _sliding_mu(model, params: DriveParams):
    """Per pulley the coefficient of the sliding arcs: its own or contact.mu, times its wedge factor, times
    mu_kinetic / mu under the static-kinetic law (sliding carries the kinetic coefficient)."""
    from ..contact.coefficients import pulley_mu

    ratio = params.friction["mu_kinetic"] / params.mu if "mu_kinetic" in params.friction else 1.0
    return pulley_mu(model, params) * ratio


def model_radius(drive: Drive) -> np.ndarray:
    return np.asarray(drive.params.pulleys.radius)
