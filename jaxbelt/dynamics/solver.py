"""Base of jaxbelt's diffrax solvers: a fixed-step map ``y1 = advance(args, t0, h, y0)``.

diffrax drives the loop (saving, progress meter, events, adjoints); the physics of one step lives
in ``advance``. Steps are fixed (``diffrax.ConstantStepSize``): a stick/slip switch inside a step
is invisible to adaptive error control, and the contact solve is what makes sticking exact.
"""

from __future__ import annotations

import abc
from typing import ClassVar

import diffrax
import jax
import jax.numpy as jnp

__all__ = ["FixedStepSolver", "solve_fixed_steps"]


class FixedStepSolver(diffrax.AbstractSolver):
    term_structure: ClassVar = diffrax.AbstractTerm
    interpolation_cls: ClassVar = diffrax.LocalLinearInterpolation

    @abc.abstractmethod
    def advance(self, args, t0, h, y0):
        """The state at ``t0 + h`` from the state at ``t0``."""

    def order(self, terms):
        return 1

    def init(self, terms, t0, t1, y0, args):
        return None

    def step(self, terms, t0, t1, y0, args, solver_state, made_jump):
        y1 = self.advance(args, t0, t1 - t0, y0)
        return y1, None, dict(y0=y0, y1=y1), None, diffrax.RESULTS.successful

    def func(self, terms, t0, y0, args):
        return terms.vf(t0, y0, args)


def _no_field(t, y, args):
    return jax.tree.map(jnp.zeros_like, y)


def solve_fixed_steps(solver: FixedStepSolver, y0, args, *, t0, t1, dt0, saveat, max_steps, adjoint, **options):
    """The one diffrax loop of jaxbelt's solvers (the drive in ``simulate``, the free belt): ``solver`` from ``t0``
    to ``t1`` in fixed steps of ``dt0`` with ``args``, saving at ``saveat``; ``options`` (an event, ``throw``, a
    progress meter) pass to ``diffrax.diffeqsolve``. Returns its solution. Parameters: ``diffeqsolve``'s own,
    named as there (the chunked run reproduces this loop's steps and saves, ``chunked.py``)."""
    return diffrax.diffeqsolve(
        diffrax.ODETerm(_no_field),
        solver,
        t0=t0,
        t1=t1,
        dt0=dt0,
        y0=y0,
        args=args,
        saveat=saveat,
        stepsize_controller=diffrax.ConstantStepSize(),
        max_steps=max_steps,
        adjoint=adjoint,
        **options,
    )
