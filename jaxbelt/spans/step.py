"""One step of the spans tier, as named stages:

1. ``belt_forces``: the span tensions at the step's start on the pulleys (torque) and carriers (hub force);
2. ``free_velocities``: loads, laws, engine orders and carrier springs as in the ANCF tier
   (``pulleys.carrier.free_pulley_velocities``), the belt's forces added explicitly, the belt's mass lumped on
   the sheaves (its wrap, a third of each neighbouring span: the consistent mass's diagonal);
3. ``carrier_constraints``: pivot friction, stops and clutches by the carriers' own local solves (exact here:
   the belt's forces are already in the velocities);
4. ``belt_transport``: each wrap carries the belt at its surface speed over the arriving span's strain
   (adhesion at the entry: creep theory); the belt on each wrap is creep theory's for the adhesion arc's
   tension (which follows the arriving span's over the wrap's transit time ``R phi / |u|``) and the leaving
   span's tension (the slip arc at the exit follows it at once: a wrap with a slip arc stretches with its
   leaving span), implicit in the span lengths (per span a Newton solve; explicit it was unstable where the
   wraps are as long as the spans);
5. ``capstan_projection``: per wrap a gross-slip flux ``d`` in ``[d+, d-]``, the interval in which the
   wrap's tension ratio stays within the capstan limit; 0 (creep) when 0 is in it, else its nearer end:
   a complementarity problem per wrap, coupled through the shared spans, by Gauss-Seidel sweeps with a
   static count (differentiable in both modes);
6. the new tensions (elastic + Kelvin-Voigt, none in compression).
"""

from __future__ import annotations

from functools import partial
from typing import NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._branch import batch_cond
from .._types import DriveParams
from ..pulleys.carrier import free_pulley_velocities, pulley_inverse_mass, to_coordinates
from ..pulleys.carriers.constraints import AbstractConstrainedCarrier, CarrierVelocity
from .model import SpansModel, SpansState, entry_direction, sliding_mu, span_path, turned, wrap_contents

__all__ = ["stepped_geometry", "spans_step", "SWEEPS", "NEWTON_STEPS"]

CONTENT_ROUNDS = 2  # span lengths with the contents implicit, then the capstan limit, twice: one round held the
# limit to 4e-5 only, and on the accessory example (the crank in gross slip half of each cycle, an arm in its
# friction band) moved the mean tensions by 2 % and the arm by 0.2 deg
CONTENT_NEWTON = 2  # per round (a smooth scalar equation per span)
# Gauss-Seidel sweeps over the wraps (a wrap's slip changes its neighbours' spans only; 6 sweeps with 4 Newton
# steps gave the accessory example's figures to 1e-12 at 1.45 x the cost)
SWEEPS = 3
NEWTON_STEPS = 3  # per interval end (the tension is a smooth rational function of the slip)


def _idx(t: tuple[int, ...]):
    return jnp.asarray(np.asarray(t, dtype=int))


def centrifugal_tension(sm: SpansModel, params: DriveParams, strain, omega):
    """m' v^2 of the belt on each wrap (m' per current length, v the pulley's surface speed)."""
    mid = 0.5 * (strain[_idx(sm.arrive)] + strain[_idx(sm.leave)])
    return params.belt.mass_per_length / (1.0 + mid) * (params.pulleys.radius * omega) ** 2


def belt_forces(sm: SpansModel, params: DriveParams, st: SpansState, geometry=None):
    """Belt torque on each pulley (counter-clockwise positive), hub forces, span lengths and d(centre)/d(psi).
    The hub force is the wrap's contact pressure: the spans' tensions less the centrifugal tension m'v^2,
    which the belt's own inertia carries round the wrap (a tensioner holds T - m'v^2, so a running belt's
    spans carry m'v^2 more than at rest). ``geometry``: ``span_path`` at ``st.psi`` if already computed."""
    R = params.pulleys.radius
    path, dcenter = span_path(sm, params, st.psi) if geometry is None else geometry
    L, d, phi = path.span_length, path.span_dir, path.wrap_angle
    T = st.tension
    c = centrifugal_tension(sm, params, st.strain, st.omega)
    hub = (T - c)[:, None] * d - (jnp.roll(T, 1) - c)[:, None] * jnp.roll(d, 1, axis=0)  # spans i, i-1 on pulley i
    torque = jnp.asarray(sm.sense) * R * (T[_idx(sm.leave)] - T[_idx(sm.arrive)])
    return torque, hub, L, phi, dcenter, entry_direction(sm, path)


def lumped_inertia(sm: SpansModel, params: DriveParams, L, phi):
    """Belt inertia on each sheave [kg m^2]: its wrap and a third of each neighbouring span at radius R."""
    R, m = params.pulleys.radius, params.belt.mass_per_length
    return m * R**2 * (R * phi + (L[_idx(sm.leave)] + L[_idx(sm.arrive)]) / 3.0)


def spans_step(sm: SpansModel, params: DriveParams, st: SpansState, t, h) -> SpansState:
    """The state after one step of ``h`` from time ``t`` (module docstring)."""
    return stepped_geometry(sm, params, st, t, h)[0]


def stepped_geometry(sm: SpansModel, params: DriveParams, st: SpansState, t, h, geometry=None):
    """``spans_step`` and the belt path at the new carrier coordinates (``span_path``), which the next step
    starts from: a time loop hands it on (``geometry``) instead of computing it again (7 % of a step)."""
    model, belt = sm.model, params.belt
    R = params.pulleys.radius
    # 1-2. belt forces and free velocities
    torque, hub, L, phi, dcenter, entry0 = belt_forces(sm, params, st, geometry)
    pp = eqx.tree_at(lambda p: p.inertia, params.pulleys, params.pulleys.inertia + lumped_inertia(sm, params, L, phi))
    omega, psi_dot, _, _ = free_pulley_velocities(model, pp, st, t, h, params.gravity)
    inv_spin, inv_carrier = pulley_inverse_mass(model, pp, h)
    movable = jnp.asarray([c.movable for c in model.carriers])
    omega = omega + h * inv_spin * torque
    pushed = to_coordinates(model, jnp.sum(hub * dcenter, axis=-1))  # a pendulum's second idler pushes the arm
    psi_dot = psi_dot + h * inv_carrier * jnp.where(movable, pushed, 0.0)
    # 3. carrier constraints
    lam = jnp.zeros_like(omega)
    deflection = st.deflection
    if model.constrained:
        for k, c in enumerate(model.carriers):
            if not isinstance(c, AbstractConstrainedCarrier):
                continue
            cv = CarrierVelocity(
                omega=omega[k],
                psi_dot=psi_dot[k],
                psi=st.psi[k],
                deflection=st.deflection[k],
                inv_spin=inv_spin[k],
                inv_carrier=inv_carrier[k],
                h=jnp.asarray(h, omega.dtype),
            )
            lam_k = c.constraint_impulse(pp, k, cv)
            d_omega, d_psi_dot = c.constraint_response(pp, k, lam_k, inv_spin[k], inv_carrier[k])
            omega, psi_dot = omega.at[k].add(d_omega), psi_dot.at[k].add(d_psi_dot)
            lam, deflection = lam.at[k].set(lam_k), deflection.at[k].set(c.deflection(pp, k, lam_k, cv))
    theta1, psi1 = st.theta + h * omega, st.psi + h * psi_dot
    # 4. belt transport (creep: adhesion at each wrap's entry)
    geometry1 = span_path(sm, params, psi1)
    path1 = geometry1[0]
    L1, phi1 = path1.span_length, path1.wrap_angle
    # numpy indices: constants in the program, not values a branch would carry as operands (_branch)
    arrive, leave, source, target = (np.asarray(t, dtype=int) for t in (sm.arrive, sm.leave, sm.source, sm.target))
    travel = Travel(arrive, leave, source, target, wrap_colours(sm))
    sense = jnp.asarray(sm.sense)
    u = sense * R * omega  # surface speed along the travel
    # the belt crosses each entry at the surface speed less the entry point's own motion round the pulley (a
    # carrier moving turns its spans: the wrap grows or shrinks at that end, from or into the arriving span)
    entry_turn = turned(entry0, entry_direction(sm, path1))
    inflow = (u - sense * R * entry_turn / h) / (1.0 + st.strain[arrive])
    moved = st.free + h * (inflow[source] - inflow[target])  # each wrap passing on what it takes in
    # the adhesion arc carries the arriving tension of the belt that entered it: it follows the arriving span
    # over the wrap's transit time R phi / |u| (a wrap at rest keeps it)
    rate = jnp.minimum(h * jnp.abs(u) / (R * phi1), 1.0)
    entry = st.entry + rate * (st.tension[arrive] - st.entry)
    damp = belt.axial_damping / h
    stiff = belt.EA + damp

    def tension(free_len):
        return stiff * (L1 / free_len - 1.0) - damp * st.strain

    def contents(free_len):
        """Each span's source wrap's belt for the span's tension (its slip arc at the exit follows at once)."""
        T = jnp.maximum(tension(free_len), 0.0)
        return wrap_contents(sm, params, T[leave], phi1, entry=entry)[0][source]

    # 5. what a wrap takes up (its slip arc grew) it does not pass on: the span lengths with the contents
    # implicit (per span, Newton), alternating with the capstan limit per wrap
    limit = jnp.exp(sliding_mu(model, params) * phi1)
    centrifugal = centrifugal_tension(sm, params, st.strain, omega)
    booked = st.wrap[source]
    slip = jnp.zeros_like(omega)
    free = moved
    ones = jnp.ones_like(free)

    def balance(free, slip):  # the span lengths for this slip, every wrap's content consistent with them
        shift = h * (slip[source] - slip[target])
        for _ in range(CONTENT_NEWTON):
            held, d_held = jax.jvp(contents, (free,), (ones,))  # diagonal: span j's only
            free = free - (free - moved - shift + held - booked) / (1.0 + d_held)
        return free, shift, 1.0 / (1.0 + jax.jvp(contents, (free,), (ones,))[1])

    for _ in range(CONTENT_ROUNDS):
        free, shift, gain = balance(free, slip)
        slip = capstan_projection(
            travel,
            SpanBalance(free, shift, gain, L1, stiff, damp * st.strain),
            WrapLimits(limit, centrifugal),
            h,
            sm.batched,
        )
    free, _, _ = balance(free, slip)  # the wraps' contents booked exactly: belt is conserved to round-off
    wrap = wrap_contents(sm, params, jnp.maximum(tension(free), 0.0)[leave], phi1, entry=entry)[0]
    strain = L1 / free - 1.0
    T = jnp.maximum(stiff * strain - damp * st.strain, 0.0)
    new = SpansState(
        theta=theta1,
        omega=omega,
        psi=psi1,
        psi_dot=psi_dot,
        free=free,
        strain=strain,
        tension=T,
        wrap=wrap,
        entry=entry,
        deflection=deflection,
        slip=slip,
        belt_torque=torque,
        hub=hub,
        carrier_torque=lam / h,
    )
    return new, geometry1


class Travel(NamedTuple):
    """The belt's travel order as index arrays (``SpansModel``'s tuples): per pulley the spans it arrives from
    and leaves by, per span the pulleys it comes from and goes to; the wraps in groups that share no span
    (``wrap_colours``)."""

    arrive: np.ndarray
    leave: np.ndarray
    source: np.ndarray
    target: np.ndarray
    colours: tuple[np.ndarray, ...]


def wrap_colours(sm: SpansModel) -> tuple[np.ndarray, ...]:
    """The wraps in groups of which no two share a span (neighbours along the travel alternate; on an odd ring
    the last takes a third group): Gauss-Seidel over the groups, each group at once, is Gauss-Seidel over the
    wraps in that order (a wrap's limit involves its own two spans only), three sequential updates per sweep
    instead of one per wrap."""
    order, i = [], 0
    for _ in range(len(sm.leave)):
        order.append(i)
        i = sm.target[sm.leave[i]]
    colour = [q % 2 for q in range(len(order))]
    if len(order) % 2 and len(order) > 1:
        colour[-1] = 2
    return tuple(np.asarray([w for w, c in zip(order, colour) if c == g]) for g in sorted(set(colour)))


class SpanBalance(NamedTuple):
    """The span lengths ``free`` balanced for a slip shift ``shift``, how much of a change of shift they take
    (``gain``; the wraps' contents the rest), the spans' geometric lengths ``L`` and ``stiff`` (d T / d strain)."""

    free: jax.Array
    shift: jax.Array
    gain: jax.Array
    L: jax.Array
    stiff: jax.Array
    relaxing: jax.Array  # the Kelvin-Voigt term of the step's start: tension = stiff (L / free - 1) - relaxing

    def tension(self, free_len):
        return self.stiff * (self.L / free_len - 1.0) - self.relaxing


class WrapLimits(NamedTuple):
    """Per wrap the capstan factor ``limit`` = e^{mu phi} and the centrifugal tension m'v^2."""

    limit: jax.Array
    centrifugal: jax.Array


def capstan_projection(travel: Travel, spans: SpanBalance, wraps: WrapLimits, h, batched: bool = False):
    """Per wrap the gross-slip flux ``d`` [m/s] (positive: the belt slides from the arriving span into the
    leaving one) such that ``T_l - c <= E (T_a - c)`` and ``T_a - c <= E (T_l - c)`` (``E = e^{mu phi}``,
    ``c`` the centrifugal tension), ``d = 0`` where both hold, else the end of the interval nearest 0.
    Gauss-Seidel over the wraps (``SWEEPS`` sweeps), each end by ``NEWTON_STEPS`` Newton steps, the spans'
    response to the slip linearised in the wraps' contents (``SpanBalance``; the step's final balance is exact).
    ``batched``: the caller vmaps the run and does not reverse-differentiate it; the sweeps then run only on the
    steps where some point of the batch slips (``_branch.batch_cond``), not on every step."""
    arrive, leave, source, target, colours = travel
    T0 = spans.tension(spans.free - spans.gain * spans.shift)
    tl, ta = T0[leave], T0[arrive]
    limit, centrifugal = wraps
    within = jnp.all(
        (tl - centrifugal <= limit * (ta - centrifugal)) & (ta - centrifugal <= limit * (tl - centrifugal))
    )
    # the sweeps take the step's numbers as their operand and close over constants only
    args = (within, lambda x: jnp.zeros_like(x[1].limit), partial(_slip_sweeps, travel), (spans, wraps, h))
    if not batched:
        return jax.lax.cond(*args)
    # a whole batch in gross slip at once is common (the crank slipping in every variant at the same phase): the
    # sweeps alone there, without the select
    return batch_cond(*args, false_alone=True)


def _slip_sweeps(travel: Travel, operand):
    """``capstan_projection``'s Gauss-Seidel sweeps over the wraps, from no slip."""
    arrive, leave, source, target, colours = travel
    spans, wraps, h = operand
    free, shift, gain, L, stiff, _ = spans
    limit, centrifugal = wraps
    tension = spans.tension

    def lengths(d):
        return free + gain * (h * (d[source] - d[target]) - shift)

    def dT(free_len, i_span):  # d tension / d shift of span i_span
        return -stiff * L[i_span] / free_len[i_span] ** 2 * gain[i_span]

    def end(d, i, tight_leaves):
        """The roots in d_i of T_tight - c - E (T_slack - c) = 0 for the wraps ``i`` (sharing no span), the
        other wraps' d fixed."""

        def newton(_, x):
            fl = lengths(d.at[i].set(x))
            T = tension(fl)
            tl, ta = T[leave[i]], T[arrive[i]]
            # d free_leave / d x = h, d free_arrive / d x = -h
            dl, da = h * dT(fl, leave[i]), -h * dT(fl, arrive[i])
            g = jnp.where(tight_leaves, tl - limit[i] * ta, ta - limit[i] * tl) - centrifugal[i] * (1.0 - limit[i])
            dg = jnp.where(tight_leaves, dl - limit[i] * da, da - limit[i] * dl)
            return x - g / jnp.where(dg == 0.0, -1.0, dg)

        return jax.lax.fori_loop(0, NEWTON_STEPS, newton, d[i])  # loops, not unrolled: a small program

    def sweep(_, d):
        for i in colours:
            low = end(d, i, True)  # T_l - c <= E (T_a - c): g decreasing in d, so d >= low
            high = end(d, i, False)  # T_a - c <= E (T_l - c): d <= high
            d = d.at[i].set(jnp.clip(0.0, low, jnp.maximum(low, high)))
        return d

    # called only where some wrap exceeds its limit (the usual step has creep alone: a real branch, except under
    # vmap without ``batched``)
    return jax.lax.fori_loop(0, SWEEPS, sweep, jnp.zeros_like(limit))
