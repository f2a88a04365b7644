"""A drive parameter (the installed tension, EA, a tensioner's spring or preload) identified from a measured span
spectrum: the frequencies of one or more transverse modes of one span, the belt at rest.

Each measured mode gives the span's tension by the span model of ``span_tension`` (bending, compliant ends, mass
per current length); their weighted mean (weights ``1 / (dT/df sigma_f)^2``) is the measured tension, and the
scatter of the modes' tensions about it is a check of the span model and its numbers (EI, the span length): a
spectrum whose modes disagree beyond their uncertainty says so. The parameter is then the value at which the
installation statics (``statics.solve_statics``, differentiable: its derivative by ``jax.jacfwd``) give the
span that tension: Newton's method on one scalar, the span length re-read from the statics at every iterate
(a tensioner moves with the parameter). Its uncertainty: the tension's over ``dT_span / dp``.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np

from .._cache import per_drive
from .._drive import Drive
from .._errors import ConfigError
from .parameters import get_parameter, set_parameter
from .span_tension import span_of, span_tension

__all__ = ["SpanFit", "fit_span_spectrum"]

NEWTON_STEPS = 8  # on one scalar; the statics' tension is smooth in every parameter it depends on
_PROGRAMS: dict = {}  # per drive, key and span: the statics' tension and its derivative, compiled
SPREAD_FACTOR = 3.0  # modes whose tensions scatter more than this many standard errors: the model is off


@dataclasses.dataclass(frozen=True)
class SpanFit:
    """Result of :func:`fit_span_spectrum`: the fitted ``key`` and ``value`` with its ``uncertainty``, the span's
    measured ``tension`` [N] (weighted over the modes) and its uncertainty, per mode the frequency and the
    tension it gives, ``chi2`` of the modes' tensions about their mean (``modes - 1`` degrees of freedom),
    ``consistent`` (the modes agree within ``SPREAD_FACTOR`` standard errors) and ``converged``."""

    span: str
    key: str
    value: float
    uncertainty: float
    initial: float
    tension: float
    tension_uncertainty: float
    modes: dict
    chi2: float
    consistent: bool
    converged: bool
    iterations: int
    length: float

    def as_dict(self) -> dict:
        return dataclasses.asdict(self)


def _span_index(drive: Drive, name: str) -> int:
    names = list(drive.model.pulley_names)
    return [f"{a}-{names[(i + 1) % len(names)]}" for i, a in enumerate(names)].index(name)


def fit_span_spectrum(
    drive: Drive,
    span: str,
    frequencies: dict,
    key: str = "belt.pretension",
    *,
    frequency_uncertainty: float = 0.1,
    tol: float = 1e-10,
) -> SpanFit:
    """Identify the drive parameter ``key`` from the measured transverse frequencies of ``span`` (``"A-B"``) at
    rest: ``frequencies`` maps a mode number (1, 2, ...) to its frequency [Hz], each known to
    ``frequency_uncertainty`` [Hz] (module docstring)."""
    from .statics import solve_statics

    if not frequencies:
        raise ConfigError("span spectrum: give at least one mode's frequency (mode -> Hz)")
    if not (math.isfinite(frequency_uncertainty) and frequency_uncertainty > 0):
        raise ConfigError(f"frequency_uncertainty = {frequency_uncertainty!r}: must be a positive number [Hz]")
    # the span's name checked and its numbers; its length comes from the statics' program below at every iterate
    # (span_of's own statics would compile another program per call)
    first = span_of(drive, span, length=1.0)
    j = _span_index(drive, first.name)
    p0 = float(get_parameter(drive, drive.params, key))  # an unknown key is refused here
    zeros = jnp.zeros(drive.model.n_pulleys)

    def statics_at(v):  # the span's tension and (aux) its tangent-to-tangent length at the parameter value
        st = solve_statics(drive, set_parameter(drive, drive.params, key, v), zeros)
        return st["T"][j], st["path"].span_length[j]

    # compiled once per drive, key and span (a second spectrum of the same span costs no compile)
    build = lambda: jax.jit(jax.value_and_grad(statics_at, has_aux=True))  # noqa: E731
    tension_and_slope = per_drive(_PROGRAMS, drive, build, key, j)
    measured = {int(n): float(f) for n, f in frequencies.items()}
    value, converged, it = p0, False, 0
    T_hat = sigma_T = chi2 = math.nan
    per_mode: dict = {}
    length = first.length
    for it in range(1, NEWTON_STEPS + 1):
        (T_model, length), slope = tension_and_slope(jnp.asarray(value, dtype=float))
        T_model, length, slope = float(T_model), float(length), float(slope)
        sp = dataclasses.replace(first, length=length)
        fits = {n: span_tension(sp, f, n, frequency_uncertainty=frequency_uncertainty) for n, f in measured.items()}
        w = np.array([1.0 / r.uncertainty**2 for r in fits.values()])
        Ts = np.array([r.tension for r in fits.values()])
        T_hat = float(np.sum(w * Ts) / np.sum(w))
        sigma_T = float(1.0 / math.sqrt(np.sum(w)))
        chi2 = float(np.sum(w * (Ts - T_hat) ** 2))
        per_mode = {
            n: dict(frequency=measured[n], tension=r.tension, uncertainty=r.uncertainty) for n, r in fits.items()
        }
        if not (math.isfinite(slope) and slope != 0.0):
            raise ConfigError(
                f"span spectrum: the statics' tension of span {first.name} does not depend on {key} "
                "(choose a parameter that sets the installed tension: belt.pretension, belt.EA, a tensioner's spring "
                "or preload)"
            )
        step = (T_hat - T_model) / slope
        value = value + step
        if abs(step) <= tol * max(abs(value), 1e-300):
            converged = True
            break
    slope = float(tension_and_slope(jnp.asarray(value, dtype=float))[1])  # at the fitted value
    dof = max(len(measured) - 1, 0)
    consistent = dof == 0 or chi2 <= dof + SPREAD_FACTOR * math.sqrt(2.0 * dof)
    return SpanFit(
        span=first.name,
        key=key,
        value=float(value),
        uncertainty=abs(sigma_T / slope),
        initial=p0,
        tension=T_hat,
        tension_uncertainty=sigma_T,
        modes=per_mode,
        chi2=chi2,
        consistent=bool(consistent),
        converged=converged,
        iterations=it,
        length=length,
    )
