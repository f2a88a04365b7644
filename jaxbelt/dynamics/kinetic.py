"""The kinetic energy of a drive: belt, pulley spins and carriers (one definition for every caller)."""

from __future__ import annotations

import typing

import equinox as eqx
import jax
import jax.numpy as jnp

from .._linalg import AbstractRingOperator, xy_components

__all__ = ["KineticEnergy", "kinetic_energy"]


@typing.final
class KineticEnergy(eqx.Module):
    belt: jax.Array  # v . M v / 2
    pulleys: jax.Array  # sum of J omega^2 / 2
    carriers: jax.Array  # sum of the carriers' kinetic energies

    @property
    def total(self):
        return self.belt + self.pulleys + self.carriers


def kinetic_energy(mass: AbstractRingOperator, v, model=None, pp=None, omega=None, psi_dot=None) -> KineticEnergy:
    """Kinetic energy of the belt (nodal velocities ``v`` ``(n, 2, 2)``) and, given a ``DriveModel``, its
    pulleys (``PulleyParams``, spins ``omega``) and carriers (``psi_dot``). Without a model: the belt alone."""
    vx, vy = xy_components(v)
    belt = 0.5 * (jnp.dot(mass.apply(vx), vx) + jnp.dot(mass.apply(vy), vy))
    if model is None:
        zero = jnp.zeros((), belt.dtype)
        return KineticEnergy(belt=belt, pulleys=zero, carriers=zero)
    pulleys = 0.5 * jnp.sum(pp.inertia * omega**2)
    carriers = sum(c.kinetic_energy(pp, k, psi_dot[k]) for k, c in enumerate(model.carriers))
    return KineticEnergy(belt=belt, pulleys=pulleys, carriers=jnp.asarray(carriers, belt.dtype))
