"""The abstract friction law and the record of a law's own configuration keys.

A law is a static, number-free ``eqx.Module`` (its instance sits in ``DriveModel`` and keys the jit
cache by type); its coefficients arrive as the ``params`` argument (a dict of arrays, per contact
point where they vary), so they stay differentiable function arguments, never closure constants.

``local_update`` is the exact solve of one point's tangential impulse with the others frozen (one
Jacobi sweep of ``contact.sweeps.solve_contact``); ``bound`` is the largest friction impulse the point
can carry (the relaxed impulse is clipped to it); ``slip_bound`` is the friction a sliding point
carries at least, which post-processing uses to classify stick and slip.

A law owns its configuration keys (``keys``: ``contact.<name>`` in the file, the same name in
``ContactSpec`` and in ``DriveParams.friction``); the configuration layer validates, stores, builds
and varies them generically from these records, so a new law touches no other module.
"""

from __future__ import annotations

import abc
import dataclasses
import typing
from collections.abc import Callable, Mapping
from typing import Any, ClassVar

import equinox as eqx
import jax.numpy as jnp

from ..._errors import is_finite_number as is_finite_number  # the friction laws' name for it

__all__ = ["AbstractFrictionLaw", "LawKey", "is_finite_number", "positive"]


def positive(value, mu) -> str | None:
    """The default check of a law key: a finite number > 0."""
    return None if is_finite_number(value) and value > 0 else "must be a finite number > 0"


@typing.final
@dataclasses.dataclass(frozen=True)
class LawKey:
    """One configuration key of a friction law (``contact.<name>``), a float coefficient.

    ``check(value, mu)`` gives the error text for a value (``contact.mu`` given, already checked) or
    None; it also sees ``None`` when a ``required`` key is missing. An optional key left out is not
    checked and is absent from ``DriveParams.friction`` (the law may then be built differently)."""

    name: str
    doc: str  # unit and meaning, e.g. "m/s: Stribeck velocity"
    required: bool = False
    check: Callable[[Any, Any], str | None] = positive


class AbstractFrictionLaw(eqx.Module):
    keys: ClassVar[tuple[LawKey, ...]] = ()  # the law's own contact.<key>s (besides mu, read by every law)

    @abc.abstractmethod
    def local_update(self, lam_t, u_t, d_t, lam_n, params):
        """New tangential impulse of each point, the others frozen (``u_t`` includes ``lam_t``)."""

    @classmethod
    def from_values(cls, values: Mapping[str, float]) -> AbstractFrictionLaw:
        """The law for its validated keys as given (static choices only, no numbers)."""
        return cls()

    def coefficients(self, params) -> dict:
        """The law's coefficients besides ``mu`` from ``DriveParams`` (traced): its keys by default."""
        return dict(params.friction)

    def linearised(self, lam_t, u_t, d_t, lam_n, params):
        """One point's step of the Newton contact solve (``dynamics.contact_newton``): ``lam_t`` the impulse
        the last linear solve applied, ``u_t`` the velocity it gave, ``d_t`` the point's own compliance.
        Returns ``(new, g, kappa, stick)``: the law's impulse (``local_update``), and the law about it for the
        next solve, which applies ``g - kappa u_t`` - or holds the point (``stick``: ``u_t = 0``, exactly at
        convergence, ``g`` its starting impulse).

        Laws with true sticking (this default): a point whose trial ``lam_t - u_t / d_t`` lies inside the
        (static) bound sticks, one outside carries the sliding force ``new``."""
        new = self.local_update(lam_t, u_t, d_t, lam_n, params)
        stick = jnp.abs(lam_t - u_t / d_t) < self.bound(lam_n, params)
        return new, new, jnp.zeros_like(new), stick

    def bound(self, lam_n, params):
        """Largest friction impulse ``|lam_t|`` a point with normal impulse ``lam_n`` can carry."""
        return params["mu"] * lam_n

    def slip_bound(self, lam_n, params):
        """Friction impulse a sliding point carries at least (stick/slip classification)."""
        return params["mu"] * lam_n
