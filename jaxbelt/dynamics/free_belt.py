"""Free belt dynamics (no pulleys, no contact): the belt model on its own, through diffrax.

Used to verify the belt model (ring release, free vibration, energy) before any contact is added,
and by users who want the belt alone. The integrator is symplectic Euler built from the drive
step's belt stages (``stages``): ``v+ = v + h M^-1 f(q, v)``, ``q+ = q + h v+``.

Energy: the scheme conserves (for linear forces, exactly; otherwise with bounded, non-drifting
error) the *discrete* energy ``E_h = T(v) + U(q) + (h/2) v . f_el(q)``, which differs from the
physical ``T + U`` by O(h). Both are returned by ``free_belt_energies``.
"""

from __future__ import annotations

import typing

import diffrax
import equinox as eqx
import jax
import jax.numpy as jnp

from .._equinox_checks import callback_free_checks
from .._linalg import xy_components
from ..belt.ring import BeltParams, belt_operators, elastic_energy, gravity_forces, internal_forces
from .kinetic import kinetic_energy
from .solver import FixedStepSolver, solve_fixed_steps
from .stages import advance_belt, belt_free_velocity, belt_smooth_forces

__all__ = ["FreeBeltState", "simulate_free_belt", "free_belt_energies"]


@typing.final
class FreeBeltState(eqx.Module):
    q: jax.Array
    v: jax.Array
    dissipated: jax.Array  # energy removed by damping so far [J]


@typing.final
class _FreeBeltEuler(FixedStepSolver):
    def advance(self, args, t0, h, y0):
        params, ops, f_ext, mass_damping = args
        forces = belt_smooth_forces(params, ops, f_ext, y0.q, y0.v)
        vx, vy = xy_components(y0.v)
        v1x, v1y = belt_free_velocity(ops.mass_inv, forces, vx, vy, h, mass_damping)
        v, q = advance_belt(y0.q, v1x, v1y, h)
        # Work of this step's damping forces over the displacement the scheme conserves energy
        # along: (h/2)(v0 + v1) . g  with g = f - f_el - c M v1 (exact balance with E_discrete).
        f_el, _ = internal_forces(y0.q, jnp.zeros_like(y0.v), params, ops)
        gx, gy = xy_components(forces.internal - f_el)
        gx, gy = gx - mass_damping * ops.mass.apply(v1x), gy - mass_damping * ops.mass.apply(v1y)
        work = jnp.dot(0.5 * (vx + v1x), gx) + jnp.dot(0.5 * (vy + v1y), gy)
        return FreeBeltState(q=q, v=v, dissipated=y0.dissipated - h * work)


@eqx.filter_jit
@callback_free_checks()  # traced without host callbacks: the program reaches the persistent cache
def simulate_free_belt(
    params: BeltParams,
    q0,
    v0,
    *,
    t_end: float,
    dt: float,
    n_save: int = 100,
    gravity=(0.0, 0.0),
    mass_damping=0.0,
    quadrature: tuple[int, int, int] = (3, 3, 2),
    adjoint: str = "reverse",
):
    """Integrate a free closed belt from ``(q0, v0)``; returns ``(ts, FreeBeltState stacked)``.

    ``params`` (and ``q0``, ``v0``, ``gravity``, ``mass_damping``) are traced arguments: jit once,
    then vmap or differentiate over them; ``adjoint="forward"`` for ``jax.jacfwd``/``jax.jvp``.

    Parameters: the three belt arrays and seven keyword options of one run; under ``eqx.filter_jit`` each option
    is traced or static by its own value (arrays traced, Python numbers part of the compilation key), which a
    record holding both kinds would blur, so they stay separate.
    """
    n = q0.shape[0]
    ops = belt_operators(n, params, *quadrature)
    f_ext = gravity_forces(n, params, ops, jnp.asarray(gravity, dtype=q0.dtype))
    n_steps = int(round(t_end / dt))
    ts = jnp.linspace(0.0, n_steps * dt, n_save)
    y0 = FreeBeltState(q=q0, v=v0, dissipated=jnp.zeros((), q0.dtype))
    sol = solve_fixed_steps(
        _FreeBeltEuler(),
        y0,
        (params, ops, f_ext, jnp.asarray(mass_damping, q0.dtype)),
        t0=0.0,
        t1=n_steps * dt,
        dt0=dt,
        saveat=diffrax.SaveAt(ts=ts),
        max_steps=n_steps + 2,
        adjoint=diffrax.ForwardMode()
        if adjoint == "forward"
        else diffrax.RecursiveCheckpointAdjoint(checkpoints=n_steps + 2),
    )
    return sol.ts, sol.ys


def free_belt_energies(params: BeltParams, states: FreeBeltState, dt: float, quadrature=(3, 3, 2)):
    """Per saved state: kinetic, elastic, and the scheme's discrete energy ``T + U + (h/2) v.f_el``."""
    n = states.q.shape[-3]
    ops = belt_operators(n, params, *quadrature)

    def one(q, v):
        f_el, _ = internal_forces(q, jnp.zeros_like(v), params, ops)
        T, U = kinetic_energy(ops.mass, v).belt, elastic_energy(q, params, ops)
        return T, U, T + U + 0.5 * dt * jnp.sum(v * f_el)

    return jax.vmap(one)(states.q, states.v)
