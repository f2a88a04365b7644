"""Accessory-drive (FEAD) outputs: what a belt supplier's report lists, per pulley, span and tensioner.

Time signals (traced; registered in ``signals.py``) and their summary over the final window:

* per pulley: ``slip`` [%] = 100 (v_b - v_s) / v_b at the place of the contact arc where the belt slides
  least (see ``_grip_slip``): v_b the belt's speed along its travel there, v_s the pulley surface's.
  0 while part of the arc sticks (creep: the belt moves with the surface where it grips); the sliding
  speed at the arc's entry once the belt slides over the whole arc (gross slip). The ``friction_use``
  ln((T1 - m'v1^2)/(T2 - m'v2^2)) / (mu_eff phi) of its two spans (mu_eff = mu x wedge factor, phi the
  current wrap), whose inverse is the slip safety factor (> 1: no gross slip); the hub load, the force
  of the belt on the pulley summed from the contact impulses (magnitude ``hub_load`` [N] and direction
  ``hub_direction`` [deg, counter-clockwise from +x]).
* per span: the belt ``speed`` [m/s] along the span at its middle (signed: + along the travel) and the
  transverse ``deflection`` [m] of the belt at mid-span from the straight tangent line between the
  current tangent points (+ outward of the loop: to the right of a counter-clockwise path).

Tensions: ``tension:<span>`` is the total axial force T; the effective tension T - m'v^2 (what
supplier reports print, and what enters the capstan law and the hub loads) is in the summary, m' the
mass per current length ``m0 / (1 + T/EA)`` (``theory.mass_per_current_length``).
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._drive import Drive
from .._types import DriveModel, DriveParams, DriveState
from ..belt.element import gauss_legendre, shape_functions
from ..belt.ring import element_coordinates
from ..belt.tension import tension_at
from ..geometry.path import BeltPath, belt_path, span_midpoints
from ..pulleys.carrier import at_coordinates, carrier_centers
from .theory import effective_tension

__all__ = [
    "fead_columns",
    "fead_values",
    "fead_summary",
    "mu_effective",
    "arriving_span",
    "circular_mean",
    "moving_mean_peak",
    "SPEED_FLOOR",
]

SPEED_FLOOR = 1e-3  # m/s: below this belt speed (where it slides least) the slip of a pulley is reported as 0
_PER_ELEMENT = 8  # belt samples per element for the mid-span deflection (spacing L/8: error 2nd order)


def mu_effective(model: DriveModel, params: DriveParams) -> jax.Array:
    """Friction coefficient of each pulley's contact: mu x its wedge factor (1/sin(beta/2) on poly-V
    grooves, 1 on a flat back side)."""
    from ..contact.coefficients import pulley_mu

    return pulley_mu(model, params)


def _along(drive: Drive) -> bool:
    """Does the belt run along the path's span order (pulley i -> i + 1)?"""
    return int(round(float(drive.path.orientation))) == drive.travel


def arriving_span(drive: Drive, i: int) -> int:
    """Index of the span on which the belt arrives at pulley ``i`` (span j runs from pulley j to j+1)."""
    k = drive.model.n_pulleys
    return (i - 1) % k if _along(drive) else i


def fead_columns(drive: Drive, pulley_q: tuple, span_q: tuple) -> list:
    """``(name, quantity)`` of the FEAD signals in ``fead_values`` order: ``pulley_q`` (slip, friction
    use, hub load, hub direction) per pulley, then ``span_q`` (speed, deflection) per span."""
    names = drive.model.pulley_names
    spans = [f"{a}-{names[(i + 1) % len(names)]}" for i, a in enumerate(names)]
    return [(f"{q.prefix}:{p}", q) for q in pulley_q for p in names] + [
        (f"{q.prefix}:{s}", q) for q in span_q for s in spans
    ]


def fead_values(drive: Drive, params: DriveParams, states: DriveState, path: BeltPath) -> list:
    """The FEAD signals (traceable), one ``(T,)`` array per column of ``fead_columns``."""
    static = (_along(drive), tuple(drive.running_sense), 1 if float(drive.path.orientation) > 0 else -1, drive.dt)
    out = _fead_core(drive.model, params, states, path, static)
    return [x for block in out for x in jnp.moveaxis(block, -1, 0)]


@eqx.filter_jit  # post-processing calls it eagerly (numpy signals): compile once per drive shape
def _fead_core(model: DriveModel, params: DriveParams, states: DriveState, path: BeltPath, static) -> tuple:
    along, sense, orientation, dt = static
    k = model.n_pulleys
    mid, _ = span_midpoints(path)
    tension = tension_at(model.n_elements, params.belt, mid, states.q, states.v)  # (T, k)
    speed = _span_speeds(states, path, along)  # (T, k)
    cur = _current_spans(model, params, states, path, orientation)  # start, end (T, k, 2), wrap (T, k)
    slip = _grip_slip(model, params, states, sense)
    # effective tensions of the two spans at each pulley: span i - 1 (arriving or leaving) and span i
    t_eff = effective_tension(tension, speed, params.belt.mass_per_length, params.belt.EA)
    floor = 1e-9 * params.belt.EA  # a slack span: the ratio is huge, the friction use too (no log of <= 0)
    t_eff = jnp.maximum(t_eff, floor)
    ratio = jnp.abs(jnp.log(t_eff[:, np.arange(k) - 1] / t_eff))
    use = ratio / (mu_effective(model, params) * cur[2])
    hx, hy = _hub_loads(model, params, states, dt)
    # A pulley without contact (before the first step) has no load and no direction: the where-guards
    # keep the derivatives finite there (a NaN there would poison every gradient of a traced run).
    h2 = hx * hx + hy * hy
    loaded = h2 > 0
    magnitude = jnp.where(loaded, jnp.sqrt(jnp.where(loaded, h2, 1.0)), 0.0)
    direction = jnp.where(loaded, jnp.degrees(jnp.arctan2(hy, jnp.where(loaded, hx, 1.0))), 0.0)
    defl = _deflections(model, params, states, cur[0], cur[1], orientation)
    return slip, use, magnitude, direction, speed, defl


def _grip_slip(model: DriveModel, params: DriveParams, states: DriveState, sense: tuple) -> jax.Array:
    """Slip ``(T, k)`` [%] of each pulley: 100 w / v_b at the contact point of the pulley where the belt
    slides least, w = v_b - v_s its sliding speed along the travel (v_b the belt's velocity there, v_s
    the surface's, both along the pulley's tangent and the running sense: the relative velocity of the
    contact solve).

    Why there: creep theory puts a stick arc at the belt's entry (tension constant, the belt moving with
    the surface) and the strain change in the slip arc after it, so in steady creep the belt grips
    where it sticks and the slip is 0 (the speed loss from pulley to pulley is creep, read from the
    pulleys' speeds); once no point sticks the belt slides over the whole arc, least at the entry (its
    creep adds to the sliding downstream), and that is the slip. The span speed at one node (this
    signal before) carries the span's axial vibration (Benchmark A: peaks of 7 % against 0). Points
    with no normal impulse do not count; no contact, or a belt slower than ``SPEED_FLOOR`` there: 0.
    """
    n, m, k = model.n_elements, model.contact_points_per_element, model.n_pulleys
    xg, _ = gauss_legendre(m)
    s, _, _ = shape_functions(jnp.asarray(xg), params.belt.stress_free_length / n)
    run = jnp.asarray(sense, states.omega.dtype)

    def one(q, v, psi, psi_dot, omega, owner, lam_n):
        r = jnp.einsum("gk,jkd->jgd", s, element_coordinates(q)).reshape(n * m, 2)
        vel = jnp.einsum("gk,jkd->jgd", s, element_coordinates(v)).reshape(n * m, 2)
        centers, dcenter = carrier_centers(model, params.pulleys, psi)
        lever = r - centers[owner]  # the contact solve's frame: normal along r - c, tangent +90 deg
        turned = jnp.stack([-lever[:, 1], lever[:, 0]], -1)  # lever turned +90 deg
        tangent = turned / jnp.linalg.norm(lever, axis=-1, keepdims=True)
        carried = at_coordinates(model, psi_dot)[owner, None]  # the coordinate that moves the pulley (pendulum)
        surface = omega[owner, None] * turned + dcenter[owner] * carried  # spin and carrier motion
        belt = run[owner] * jnp.sum(vel * tangent, -1)
        w = belt - run[owner] * jnp.sum(surface * tangent, -1)
        mine = (owner[:, None] == jnp.arange(k, dtype=owner.dtype)[None]) & (lam_n[:, None] > 0)  # (nc, k)
        j = jnp.argmin(jnp.where(mine, jnp.abs(w)[:, None], jnp.inf), axis=0)  # (k,): no gradient through the choice
        wj, bj = w[j], belt[j]
        moving = jnp.any(mine, axis=0) & (jnp.abs(bj) > SPEED_FLOOR)
        return jnp.where(moving, 100.0 * wj / jnp.where(moving, bj, 1.0), 0.0)

    owner = jnp.clip(states.contact_pulley, 0, None).astype(jnp.int32)  # -1 before the first step (no impulse)
    return jax.vmap(one)(states.q, states.v, states.psi, states.psi_dot, states.omega, owner, states.lam_n)


def _span_speeds(states: DriveState, path: BeltPath, along: bool) -> jax.Array:
    """Belt speed along each span at its middle ``(T, k)``: velocity of the node nearest the middle,
    projected on the span direction (+ along the travel)."""
    mid, u = span_midpoints(path)
    d = jnp.sum((states.q[:, :, None, 0, :] - mid[None, None]) ** 2, -1)  # (T, n, k)
    idx = jnp.argmin(d, axis=1)  # (T, k)
    vel = jnp.take_along_axis(states.v[:, :, 0, :], idx[..., None], axis=1)  # (T, k, 2)
    return (1.0 if along else -1.0) * jnp.sum(vel * u[None], -1)


def _current_spans(model: DriveModel, params: DriveParams, states: DriveState, path: BeltPath, orientation: int):
    """Span tangent points and wrap angles of the current pulley positions (a tensioner moves them)."""
    T = states.q.shape[0]
    if not model.any_movable:
        return (
            jnp.broadcast_to(path.span_start, (T, *path.span_start.shape)),
            jnp.broadcast_to(path.span_end, (T, *path.span_end.shape)),
            jnp.broadcast_to(path.wrap_angle, (T, *path.wrap_angle.shape)),
        )
    centers, _ = carrier_centers(model, params.pulleys, states.psi)  # (T, k, 2)
    side = np.asarray(model.wrap_side)
    paths = jax.vmap(lambda c: belt_path(c, params.pulleys.radius, side, orientation=orientation))(centers)
    return paths.span_start, paths.span_end, paths.wrap_angle


def _hub_loads(model: DriveModel, params: DriveParams, states: DriveState, dt: float):
    """Force of the belt on each pulley ``(T, k)`` x and y: minus the contact impulses on the belt
    (normal along r - c, friction along the normal turned +90 deg) over one step."""
    n, m = model.n_elements, model.contact_points_per_element
    xg, _ = gauss_legendre(m)
    s, _, _ = shape_functions(jnp.asarray(xg), params.belt.stress_free_length / n)

    def one(q, psi, owner, lam_n, lam_t):
        r = jnp.einsum("gk,jkd->jgd", s, element_coordinates(q)).reshape(n * m, 2)
        centers, _ = carrier_centers(model, params.pulleys, psi)
        lever = r - centers[owner]
        nrm = lever / jnp.linalg.norm(lever, axis=-1, keepdims=True)
        px = lam_n * nrm[:, 0] - lam_t * nrm[:, 1]
        py = lam_n * nrm[:, 1] + lam_t * nrm[:, 0]
        mine = owner[:, None] == jnp.arange(model.n_pulleys, dtype=owner.dtype)[None]  # (nc, k)
        return -jnp.sum(jnp.where(mine, px[:, None], 0.0), 0) / dt, -jnp.sum(jnp.where(mine, py[:, None], 0.0), 0) / dt

    owner = jnp.clip(states.contact_pulley, 0, None).astype(jnp.int32)  # -1 before the first step
    return jax.vmap(one)(states.q, states.psi, owner, states.lam_n, states.lam_t)


def _deflections(model: DriveModel, params: DriveParams, states: DriveState, start, end, orientation: int):
    """Transverse offset ``(T, k)`` of the belt sample nearest each span's middle from the straight
    line between the span's tangent points (+ outward: to the right of a counter-clockwise path)."""
    n = model.n_elements
    xi = jnp.arange(_PER_ELEMENT) / _PER_ELEMENT
    s, _, _ = shape_functions(xi, params.belt.stress_free_length / n)

    def one(q, a, b):
        r = jnp.einsum("gk,jkd->jgd", s, element_coordinates(q)).reshape(-1, 2)
        mid = 0.5 * (a + b)
        u = (b - a) / jnp.linalg.norm(b - a, axis=-1, keepdims=True)
        out = orientation * jnp.stack([u[:, 1], -u[:, 0]], -1)  # (k, 2)
        d = jnp.sum((r[:, None] - mid[None]) ** 2, -1)  # (samples, k)
        near = r[jnp.argmin(d, axis=0)]  # (k, 2)
        return jnp.sum((near - mid) * out, -1)

    return jax.vmap(one)(states.q, start, end)


def _vector_mean(magnitude, direction_deg) -> float:
    """Magnitude of the mean of the vectors (``magnitude``, ``direction_deg``) (numpy)."""
    a = np.radians(np.asarray(direction_deg, dtype=float))
    H = np.asarray(magnitude, dtype=float)
    return float(np.hypot(np.mean(H * np.cos(a)), np.mean(H * np.sin(a)))) if H.size else math.nan


def circular_mean(x, period: float = 360.0, weights=None, axis=None):
    """Mean of angles ``x`` (``period`` one turn in their unit: 360 for degrees) as the direction of the
    mean of their unit vectors, each scaled by ``weights`` (a magnitude: then the direction of the mean
    vector), in [-period/2, period/2]. Angles are points on a circle: 179 and -179 deg average to 180,
    not to 0. 0 where the vectors cancel (to round-off: no direction). Traceable (numpy in, numpy
    out); finite derivatives everywhere."""
    xp = jnp if isinstance(x, jax.Array) or isinstance(weights, jax.Array) else np
    a = (2.0 * math.pi / period) * xp.asarray(x)
    w = xp.ones_like(a) if weights is None else xp.asarray(weights)
    c, s = xp.sum(w * xp.cos(a), axis=axis), xp.sum(w * xp.sin(a), axis=axis)
    some = c * c + s * s > (1e-12 * xp.sum(xp.abs(w), axis=axis)) ** 2  # cancelled to round-off: no direction
    return xp.where(some, xp.arctan2(s, xp.where(some, c, 1.0)), 0.0) * (period / (2.0 * math.pi))


def moving_mean_peak(t, x, duration: float) -> float:
    """Largest |mean of x| over ``duration`` seconds of the evenly spaced samples ``(t, x)`` (a moving
    mean); over all of them when they cover less than ``duration`` (nan for none)."""
    t, x = np.asarray(t, dtype=float), np.asarray(x, dtype=float)
    if x.size == 0:
        return math.nan
    span = float(t[-1] - t[0]) if x.size > 1 else 0.0
    if not duration < span:  # also a NaN or infinite duration
        return float(abs(x.mean()))
    k = max(1, int(round(duration / (span / (x.size - 1)))))  # samples per duration
    c = np.concatenate([[0.0], np.cumsum(x)])
    return float(np.abs((c[k:] - c[:-k]) / k).max())


def _amplitude(x: np.ndarray) -> float:
    return float(0.5 * (x.max() - x.min())) if x.size else math.nan


def _slip_peak(slip: np.ndarray, t, omega: np.ndarray) -> float:
    """Largest |slip| of its moving mean over one revolution of the pulley (at its mean speed in the
    window; the whole window when that is shorter): the slip a once-per-revolution speed pickup would
    read. Without the sample times, the largest single |slip|."""
    if t is None:
        return float(np.abs(slip).max()) if slip.size else math.nan
    turn = 2.0 * math.pi / abs(float(np.mean(omega))) if omega.size and np.mean(omega) != 0 else math.inf
    return moving_mean_peak(t, slip, turn)


def fead_summary(drive: Drive, sig: dict, sel, *, mu=None) -> dict:
    """Window statistics of the FEAD signals: ``{"pulleys": {name: {...}}, "spans": {name: {...}}}``
    (numpy; ``sig`` the run's named signals, ``sel`` the window mask of the saved states, ``mu`` the
    pulleys' ``mu_effective`` if already computed)."""
    names = drive.model.pulley_names
    k = len(names)
    spans = [f"{a}-{names[(i + 1) % k]}" for i, a in enumerate(names)]
    m, EA = float(drive.params.belt.mass_per_length), float(drive.params.belt.EA)
    span_out = {}
    for s in spans:
        T, v = sig[f"tension:{s}"][sel], sig[f"speed:{s}"][sel]
        t_eff = effective_tension(T, v, m, EA)  # m' per current length, at each sample's tension
        span_out[s] = dict(
            tension_eff_mean=float(t_eff.mean()),
            tension_amplitude=_amplitude(T),
            tension_rms=float(np.sqrt(np.mean((T - T.mean()) ** 2))),
            speed_mean=float(v.mean()),
        )
        if f"deflection:{s}" in sig:  # (the spans tier's spans stay straight: it has none)
            d = sig[f"deflection:{s}"][sel]
            span_out[s].update(deflection_mean_mm=1e3 * float(d.mean()), deflection_amplitude_mm=1e3 * _amplitude(d))
    mu = np.asarray(mu_effective(drive.model, drive.params) if mu is None else mu)
    wrap = np.asarray(drive.path.wrap_angle)
    t = sig.get("t")
    pulley_out = {}
    for i, p in enumerate(names):
        slip, use = sig[f"slip:{p}"][sel], sig[f"friction_use:{p}"][sel]
        H = sig[f"hub_load:{p}"][sel]
        t1, t2 = (span_out[spans[j]]["tension_eff_mean"] for j in ((i - 1) % k, i))
        log = abs(math.log(t1 / t2)) if t1 > 0 and t2 > 0 else math.inf
        pulley_out[p] = dict(
            slip_mean_pct=float(slip.mean()),
            slip_peak_pct=_slip_peak(slip, None if t is None else t[sel], sig[f"omega:{p}"][sel]),
            mu_eff=float(mu[i]),
            slip_safety_factor=float(mu[i] * wrap[i] / log) if log > 0 else math.inf,
            slip_safety_factor_min=1.0 / float(use.max()) if use.max() > 0 else math.inf,
            # the mean hub-load vector's magnitude (with hub_load_direction_deg: the load that balances an arm's
            # spring, the statics' hub load); the mean magnitude exceeds it where the direction swings (measured
            # +13 % on a tensioner pulley wrapped by about one element, the direction swinging +-35 deg)
            hub_load_mean=_vector_mean(H, sig[f"hub_direction:{p}"][sel]),
            hub_load_magnitude_mean=float(H.mean()),
            hub_load_peak=float(H.max()),
            # the direction of the mean hub-load vector (a circular mean: the load may point at +-180 deg)
            hub_load_direction_deg=float(circular_mean(sig[f"hub_direction:{p}"][sel], 360.0, H)),
        )
        if f"arm_angle:{p}" in sig:
            a = np.degrees(sig[f"arm_angle:{p}"][sel])
            pulley_out[p].update(arm_angle_mean_deg=float(a.mean()), arm_angle_p2p_deg=float(a.max() - a.min()))
        if f"travel:{p}" in sig:  # a slider tensioner
            x = 1e3 * sig[f"travel:{p}"][sel]
            pulley_out[p].update(travel_mean_mm=float(x.mean()), travel_p2p_mm=float(x.max() - x.min()))
    return dict(pulleys=pulley_out, spans=span_out)
