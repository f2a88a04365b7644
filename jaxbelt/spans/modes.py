"""The spans tier's natural frequencies and their parameter sensitivities, from the eigenvalues of its one-step
map about the installed state at rest (a step ``h`` much shorter than the periods: ``lambda = e^{(-zeta w +- i
w_d) h}``).

Free vibration: no loads, orders or viscous loads, the driver held; wraps stuck, pivot friction left out (a band
of equilibria, as the ANCF tier's modes), engaged one-way clutches locked. The sensitivities are exact: the
eigenvalues' forward-mode derivative through the one-step map's Jacobian and the installed state (the statics'
Newton solve), one compiled program for every parameter at once."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np
from jax.flatten_util import ravel_pytree

from .._cache import per_drive
from .._drive import Drive
from .._types import DriveParams
from ..pulleys.carrier import without_losses
from .model import SpansModel, initial_spans_state
from .step import spans_step

__all__ = ["spans_campbell_modes", "spans_modes", "spans_mode_sensitivities", "spans_span_modes", "MODE_STEP"]

MODE_STEP = 1e-5  # [s] the one-step map's step: a 1 kHz mode turns 0.06 rad per step
_PROGRAMS: dict = {}  # per drive: the compiled eigenvalues
MIN_HZ = 0.5  # oscillating eigenvalues below this are no modes (the band of equilibria, numerical drift)


def _free_vibration(drive: Drive, params: DriveParams, damped: bool = True) -> DriveParams:
    """The parameters of free vibration: no applied or viscous loads, no orders, the driver held, no pivot
    friction; not ``damped``: no belt, carrier or clutch damping either."""
    pp = params.pulleys
    pp = dataclasses.replace(
        pp,
        torque=dataclasses.replace(pp.torque, values=0.0 * pp.torque.values),
        speed=dataclasses.replace(pp.speed, values=0.0 * pp.speed.values),
        viscous=0.0 * pp.viscous,
        excitation=None,
    )
    pp = without_losses(drive.model, pp, ("friction",) if damped else ("friction", "damping"))
    if not damped:
        params = dataclasses.replace(
            params, belt=dataclasses.replace(params.belt, axial_damping=0.0 * params.belt.axial_damping)
        )
    return dataclasses.replace(params, pulleys=pp)


def _eigenvalues(drive: Drive, params: DriveParams, h: float, damped: bool = True):
    """Eigenvalues of the one-step map's Jacobian about the installed state (traceable in ``params``)."""
    params = _free_vibration(drive, params, damped)
    sm = SpansModel.of(drive)
    st = initial_spans_state(drive, params)
    # a hair of motion puts each carrier's local solve on a smooth side: a clutch's rotor slower than its sheave
    # (engaged), a lossy arm moving (with no friction band it slides: at rest exactly it would read as stuck)
    clutch = jnp.asarray([c.load_on_carrier for c in drive.model.carriers])
    lossy = jnp.asarray([c.movable and c.constrained for c in drive.model.carriers])
    hair = jnp.where(clutch, -jnp.asarray(sm.sense) * 1e-9, jnp.where(lossy, 1e-9, 0.0))
    st = dataclasses.replace(st, psi_dot=st.psi_dot + hair)
    x0, unravel = ravel_pytree(st)
    step = lambda x: ravel_pytree(spans_step(sm, params, unravel(x), jnp.zeros((), x.dtype), h))[0]  # noqa: E731
    return jnp.linalg.eigvals(jax.jacfwd(step)(x0))


def _modes_of(lam: np.ndarray, h: float, count: int) -> np.ndarray:
    """Indices of the oscillating eigenvalues above ``MIN_HZ`` (one of each pair), by frequency, at most ``count``."""
    keep = np.flatnonzero((np.abs(lam) > 0.5) & (np.angle(lam) > 2 * np.pi * h * MIN_HZ))
    return keep[np.argsort(np.angle(lam[keep]))][:count]


def spans_modes(
    drive: Drive, params: DriveParams | None = None, count: int = 6, h: float = MODE_STEP, *, damped: bool = True
) -> list[dict]:
    """Natural frequencies [Hz] and damping ratios of the spans tier about its installed state at rest (module
    docstring): one dict per mode (``mode``, ``frequency_hz``, ``damping_ratio``, ``kind`` "rotational").
    ``damped=False``: without the belt's, carriers' and clutches' damping (the undamped model `jaxbelt modes`
    solves on the ANCF tier: a heavily damped arm stiffens its mode, so compare like with like)."""
    params = drive.params if params is None else params
    program = per_drive(
        _PROGRAMS, drive, lambda: jax.jit(lambda p, h, d: _eigenvalues(drive, p, h, d), static_argnums=(1, 2))
    )
    lam = np.asarray(program(params, h, damped))
    out = []
    for j, i in enumerate(_modes_of(lam, h, count)):
        w, sigma = np.angle(lam[i]) / h, np.log(np.abs(lam[i])) / h
        out.append(
            dict(
                mode=j + 1,
                frequency_hz=float(w / (2 * np.pi)),
                damping_ratio=float(-sigma / np.hypot(sigma, w)),
                kind="rotational",
                span=None,
            )
        )
    return out


def spans_mode_sensitivities(
    drive: Drive, params_of: Callable, values, count: int = 6, h: float = MODE_STEP, key=None
) -> tuple[np.ndarray, np.ndarray]:
    """The frequencies [Hz] ``(count,)`` of ``spans_modes`` at the parameters ``params_of(values)`` and their
    derivatives d f / d value ``(count, len(values))`` [Hz per unit], exact (forward mode through the eigenvalues,
    the one-step map and the installed state), every value in one program. ``params_of``: values -> ``DriveParams``
    (e.g. ``analysis.parameters.set_parameters`` over the keys); ``key``: a hashable name of ``params_of`` (e.g.
    the parameter keys) under which the compiled program is kept for the drive (None: compiled for this call)."""
    values = jnp.asarray(values, dtype=float)

    def lam(v):
        return _eigenvalues(drive, params_of(v), h)

    def build():
        return jax.jit(lambda v: (lam(v), jax.jacfwd(lam)(v)))

    program = build() if key is None else per_drive(_PROGRAMS, drive, build, "sensitivities", key, h)
    lam0, dlam = (np.asarray(x) for x in program(values))
    idx = _modes_of(lam0, h, count)
    # f = arg(lambda) / (2 pi h): d f = Im(d lambda / lambda) / (2 pi h)
    freq = np.angle(lam0[idx]) / (2 * np.pi * h)
    return freq, np.imag(dlam[idx] / lam0[idx, None]) / (2 * np.pi * h)


def spans_span_modes(drive: Drive, params: DriveParams | None = None, per_span: int = 1) -> list[dict]:
    """The spans' transverse modes at the installed state, from the span model of ``jaxbelt span-tension``
    (``analysis.span_tension``: a tensioned beam between the tangent points on the contact's foundation, mass per
    current length; belt at rest): per span its first ``per_span`` frequencies at the span's installed tension
    and length, ascending (``mode``, ``frequency_hz``, ``kind`` "transverse", ``span``, ``order``; no damping
    ratio: NaN). This tier's runs have no transverse motion; these modes say where the ANCF tier's spans ring
    (a run-up's crossings)."""
    import math

    from ..analysis.span_tension import span_frequency, span_of
    from .model import span_geometry

    params = drive.params if params is None else params
    st = initial_spans_state(drive, params)
    length = np.asarray(span_geometry(SpansModel.of(drive), params, st.psi)[0])
    names = list(drive.model.pulley_names)
    k = len(names)
    found: list[dict] = []
    for j in range(k):
        span = span_of(drive, f"{names[j]}-{names[(j + 1) % k]}", length=float(length[j]))
        for n in range(1, per_span + 1):
            f = float(span_frequency(span, float(st.tension[j]), n))
            found.append(dict(frequency_hz=f, damping_ratio=math.nan, kind="transverse", span=span.name, order=n))
    found.sort(key=lambda m: m["frequency_hz"])
    return [dict(mode=i + 1, **m) for i, m in enumerate(found)]


def spans_campbell_modes(drive: Drive, count: int = 6) -> list[dict]:
    """The lowest ``count`` of this tier's undamped rotational modes and the spans' first transverse ones, by
    frequency: the natural frequencies a run-up's crossings and the report's resonance map use (the ANCF tier's
    modes have no damping either)."""
    rotational = spans_modes(drive, count=count, damped=False)
    return sorted(rotational + spans_span_modes(drive), key=lambda m: m["frequency_hz"])[:count]
