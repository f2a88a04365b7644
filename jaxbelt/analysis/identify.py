"""Identify belt and contact parameters (E, eta, mu, ...) from measured signals.

Weighted least squares on named signals (``signals.csv`` layout: ``t`` plus columns such as
``omega:<pulley>``, ``tension:<from>-<to>``, ``arm_angle:<tensioner>``; any subset, any sampling
times). Parameters are fitted as ``log(value)`` (all are positive), clipped to their bounds.

Methods: ``"lm"`` Levenberg–Marquardt (the default) on forward-mode Jacobians, refined between them
by Broyden's secant updates, so that most iterations cost one forward run (see ``optimise``); or
optax ``"adam"`` / ``"lbfgs"`` on the misfit (reverse-mode gradients). ``IdentifyResult.timing``
counts the cost in forward-run equivalents. Levenberg-Marquardt's step is minimised within a box (the
bounds, and a factor e^0.5 per parameter and iteration), so that a parameter the window hardly
determines does not shrink the others' steps, and extended while the misfit falls faster than its linear
model said (``optimise._extend``); it stops when a step gains less than ``tol`` of the misfit or when the
exact Jacobian's Gauss-Newton step is shorter than half a standard error (``optimise.SETTLE``: further
iterations would change the values by a statistically irrelevant amount; that Jacobian then serves the
standard errors).
Convergence is judged at the end, alike for every method, on the exact Jacobian (``_convergence``:
``IdentifyResult.converged`` and ``convergence``, with the reason when not); a fit that has not
converged gets no standard errors (NaN) and a warning.
Standard errors come from the Gauss–Newton covariance ``s^2 (J^T J)^-1`` at the optimum (J of the
weighted residuals, mapped from log space to values). With a noise level ``sigma`` given for every
column, ``s^2 = max(1, chi^2_red)``: the given noise, or the misfit where the model misses the
measurement by more (then a warning says so); otherwise each column's noise is estimated from its own
residuals, ``s_c^2 = RSS_c / (m_c - p m_c / m)``, and the covariance is the sandwich
``(J^T J)^-1 (sum_c s_c^2 J_c^T J_c) (J^T J)^-1`` (calibrated when the columns' weights are not their
noise levels, as with the default weights). A parameter that stops at a bound has no standard error (reported "at
bound", with a warning; the others' errors hold it fixed); one the signals do not depend on has an
infinite one. ``IdentifyResult.misfit`` reports the RMS residual per column and chi^2_red.
Two more terms make the standard errors honest (``IdentifyResult.error_budget``): residuals correlated in
time scale the noise's (``uncertainty._block_ratios``), and the model's own time-step error, from one run
at half the step, is added in quadrature (``_time_step_error``).
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field
from typing import Callable, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from .._drive import Drive
from .._types import DriveParams
from .._errors import ConfigError, did_you_mean
from ..config.validate import resolve_model
from .parameters import check_together, get_parameter, set_parameters
from ..outputs.signals import simulate_signals
from . import optimise as _optimise
from .optimise import (
    CountedResiduals,
    LMStop,
    Stopping,
    _gauss_newton,
    _optax_step,
    exact,
    levenberg_marquardt,
    optax_minimise,
    settled_at,
)
from .uncertainty import Fitted, _uncertainty

__all__ = ["Measurement", "IdentifyResult", "identify", "check_measurement"]


@dataclass
class Measurement:
    """Measured signals: times ``t`` (M,) and columns name -> (M,) values (NaN = missing sample)."""

    t: np.ndarray
    columns: dict[str, np.ndarray]
    # noise level per column, in its unit; a column without one is weighted by 1 % of its spread (min 1e-12)
    # and, unless every column has one, the noise scale is estimated from the residuals
    sigma: dict[str, float] | None = None


@dataclass
class IdentifyResult:
    keys: list[str]
    values: dict[str, float]
    std_errors: dict[str, float]
    initial: dict[str, float]
    loss_history: list[float]
    covariance_log: np.ndarray
    iterations: int
    # wall_s, compile_s; forward_runs, jacobians / gradient_steps with their median seconds and cost ratio to
    # a forward run; forward_run_equivalents (everything at its measured ratio); path: after each LM
    # iteration the evaluations so far and the values reached
    timing: dict = field(default_factory=dict)
    # final misfit: noise ("given"/"estimated"), reduced_chi2, dof, samples, rms_residual and sigma per
    # column (in the column's unit), covariance_scale (the s^2 above)
    misfit: dict = field(default_factory=dict)
    at_bound: dict[str, str] = field(default_factory=dict)  # key -> "lower" / "upper" (std error NaN)
    warnings: list[str] = field(default_factory=list)
    # whether the fit converged (see _convergence); when not, every standard error is NaN
    converged: bool = True
    # converged, reason (what stopped the fit and what to change), stop (the minimiser's: "settled", "cap",
    # "stalled", "tol", "no_descent", "pinned"), gauss_newton_step_sigma (the remaining step in standard errors),
    # criterion, method, iteration_cap
    convergence: dict = field(default_factory=dict)
    # key -> noise (the noise's standard error, scaled where the residuals are correlated) and time_step (the
    # time-step error, see _time_step_error); std_errors combine them in quadrature
    error_budget: dict[str, dict] = field(default_factory=dict)

    def as_dict(self) -> dict:
        return dict(
            converged=self.converged,
            convergence=self.convergence,
            values=self.values,
            std_errors=self.std_errors,
            error_budget=self.error_budget,
            at_bound=self.at_bound,
            misfit=self.misfit,
            warnings=self.warnings,
            initial=self.initial,
            loss_history=self.loss_history,
            iterations=self.iterations,
            timing=self.timing,
        )


def check_measurement(drive: Drive, m: Measurement, t_end: float, model: str = "ancf") -> None:
    """Clear errors for measurement files that cannot be fitted (columns: the signals of ``model``'s tier)."""
    from ..outputs.signals import signal_names
    from ..spans import spans_signal_names

    t = np.asarray(m.t, dtype=float)
    if t.ndim != 1 or t.size < 2:
        raise ConfigError("measured: needs a column 't' with at least 2 samples")
    if not np.all(np.isfinite(t)):
        raise ConfigError("measured: column 't' has non-finite values")
    if np.any(np.diff(t) <= 0):
        i = int(np.argmax(np.diff(t) <= 0))
        raise ConfigError(
            f"measured: times must increase strictly (row {i + 2}: t = {float(t[i + 1]):g} after {float(t[i]):g})"
        )
    if t[0] < 0 or t[-1] > t_end + 1e-12:
        raise ConfigError(
            f"measured: times span [{t[0]:g}, {t[-1]:g}] s, outside the simulation [0, {t_end:g}] s "
            "(raise solver.t_end / --t-end or trim the file)"
        )
    valid = set(signal_names(drive) if model == "ancf" else spans_signal_names(drive))
    if not m.columns:
        raise ConfigError(f"measured: no signal columns; expected some of {sorted(valid)}")
    for name, col in m.columns.items():
        if name not in valid:
            raise ConfigError(
                f"measured: unknown column {name!r}"
                + did_you_mean(name, sorted(valid))
                + f"; this drive has {sorted(valid)}"
            )
        col = np.asarray(col, dtype=float)
        if col.shape != t.shape:
            raise ConfigError(f"measured: column {name!r} has {col.size} values for {t.size} times")
        if np.all(np.isnan(col)):
            raise ConfigError(f"measured: column {name!r} has no finite value")
        if np.any(np.isinf(col)):
            raise ConfigError(f"measured: column {name!r} has infinite values")
    for name, level in (m.sigma or {}).items():
        if name not in m.columns:
            raise ConfigError(
                f"measured: sigma given for {name!r}, which is not a measured column (columns: {sorted(m.columns)})"
            )
        try:
            level = float(level)
        except (TypeError, ValueError):
            raise ConfigError(f"measured: sigma[{name!r}] = {level!r}: must be a positive number") from None
        if not (np.isfinite(level) and level > 0):
            raise ConfigError(
                f"measured: sigma[{name!r}] = {level!r}: must be a positive, finite noise level "
                "(same unit as the column)"
            )


def _interp_signals(ts, sig, t_meas, names):
    return jnp.stack([jnp.interp(t_meas, ts, sig[n]) for n in names])


def identify(
    drive: Drive,
    measured: Measurement,
    fit: dict[str, tuple[float, tuple[float, float]]] | list[str],
    *,
    method: str = "lm",
    iterations: int = 30,
    learning_rate: float = 0.05,
    t_end: float | None = None,
    save_dt: float | None = None,
    tol: float = 1e-6,
    windows: list[tuple[float, float]] | None = None,
    verbose: bool = False,
    time_step_check: bool = True,
    model: str | None = None,
) -> IdentifyResult:
    """Fit parameters ``fit`` (key -> (initial guess, (low, high)); or a list of keys: start from the
    drive's values with bounds x/10..x*10) to ``measured``.

    ``windows``: optional continuation, a list of time windows ``(t0, t1)`` fitted one after the
    other, each starting where the previous stopped (e.g. first the quasi-static part, where the
    misfit is convex in E and mu, then the whole record, whose oscillations carry eta but would
    trap a fit that starts with the wrong frequency). Standard errors come from the last window.
    ``iterations`` is per window; with ``"lm"`` most cost one forward run (``timing`` has the counts).

    Under ``jax.distributed`` (see ``analysis.distributed``) the fit uses every process by itself: each
    Jacobian's columns are split over the processes and gathered; everything else runs in each of them.
    Every process must therefore call ``identify`` with the same inputs, and each gets the same result.

    ``model``: "ancf" (the ANCF belt) or "spans" (the spans tier, docs/spans.md: its step the smallest of its
    stable steps over the search box's corners, its signals' names; the time-step check at half that step);
    None: the drive's ``solver.model``.

    Parameters: besides the drive, the record and the keys, its ten keyword options are the user's settings of
    one fit (method, iteration cap, learning rate, sampling, tolerance, windows, verbosity, time-step check,
    tier), each with a default and passed by name; a record of them would only rename them.
    """
    if method not in ("lm", "adam", "lbfgs"):
        raise ConfigError(f"identify: method = {method!r}: must be 'lm', 'adam' or 'lbfgs'")
    model = resolve_model(drive, model, "identify")
    t_end = float(np.max(measured.t)) if t_end is None else t_end
    check_measurement(drive, measured, t_end, model)
    keys, guess, lo, hi = _search_box(drive, fit)
    drive = _drive_stable_over_bounds(drive, keys, lo, hi, model)
    problem = _FitProblem.build(drive, measured, keys, lo, hi, t_end, save_dt, model)
    history: list[float] = []
    t0 = time.perf_counter()
    stopping = Stopping(iterations, tol, settle=_optimise.SETTLE)
    theta, lin, wmask, n_iter, stop = _fit_windows(
        problem, windows, jnp.log(jnp.asarray(guess)), method, learning_rate, stopping, history, verbose
    )
    if not lin.fresh or not np.array_equal(lin.theta, theta):  # the exact Jacobian for the standard errors
        lin = exact(problem.res, theta)
    convergence = _convergence(problem, lin, wmask, stop, method, iterations, tol)
    r_half, half_s = None, None
    if convergence["converged"] and time_step_check:  # one run at half the step: the model's own error
        t_half = time.perf_counter()
        r_half = _half_step_residuals(problem, drive, t_end, save_dt, lin.theta)
        half_s = time.perf_counter() - t_half
    values, stds, cov, misfit, at_bound, notes, budget = _estimates(problem, measured, lin, theta, wmask, r_half)
    if not convergence["converged"]:  # values that are still moving have no standard error worth the name
        stds, budget = {k: math.nan for k in keys}, {}
        cov = np.full_like(cov, np.nan)
        notes = [n for n in notes if "correlated in time" not in n]  # about standard errors it has not got
        notes.insert(0, f"identify: not converged: {convergence['reason']}; no standard errors")
    for note in notes:
        warnings.warn(note, UserWarning, stacklevel=2)
    return IdentifyResult(
        keys=keys,
        values=values,
        std_errors=stds,
        initial=dict(zip(keys, guess)),
        loss_history=history,
        covariance_log=cov,
        iterations=n_iter,
        timing=dict(wall_s=time.perf_counter() - t0, **problem.res.costs.report(), time_step_check_s=half_s),
        misfit=misfit,
        at_bound=at_bound,
        warnings=notes,
        converged=bool(convergence["converged"]),
        convergence=convergence,
        error_budget=budget,
    )


def _half_step_residuals(problem: _FitProblem, drive: Drive, t_end, save_dt, theta) -> np.ndarray:
    """The residuals at ``theta`` of the same model run at half its time step (a program of its own)."""
    import dataclasses

    half = dataclasses.replace(drive, dt=drive.dt / 2)
    residuals = _residual_function(half, problem.keys, problem.names, t_end, save_dt, problem.model)
    closure = (half, tuple(problem.keys), tuple(problem.names), t_end, save_dt, problem.model)
    res = CountedResiduals(residuals, problem.args, closure=closure)
    r = res.evaluate(theta)
    problem.res.costs.compile_s += res.costs.compile_s
    return r


_REASONS = {
    "cap": "iteration cap ({n} per window) reached",
    "tol": "stalled: the last step lowered the misfit by less than tol = {tol:g} of it",
    "no_descent": "step too small: no step lowered the misfit (damping raised 8 times), gradient not zero",
    "pinned": "pinned on the bounds",
    "stalled": "stalled: {stall} iterations in a row each lowered the misfit by less than {small:g} noise "
    "variances while the exact Jacobian promised more (the misfit is rough at this scale, or the model misses the "
    "record: check rms_residual, fit fewer keys or leave out columns)",
    "settled": "stopped",
}


def _convergence(problem: _FitProblem, lin, wmask, stop: LMStop, method: str, iterations: int, tol: float) -> dict:
    """Converged when the exact Jacobian's Gauss-Newton step at the end (of the last window, within the
    bounds) is shorter than ``optimise.SETTLE`` standard errors: iterating further would move the values by
    a statistically irrelevant amount. Judged alike for every method; ``reason`` says why the fit stopped
    when it had not converged (with the remaining step, in standard errors)."""
    settle = _optimise.SETTLE if _optimise.SETTLE is not None else 0.5
    w = _flat(problem.mask, wmask)
    lo, hi = np.asarray(problem.lo_log), np.asarray(problem.hi_log)
    remaining, gn = _gauss_newton(lin, w, lo, hi)
    step = math.sqrt(max(remaining, 0.0)) if math.isfinite(remaining) else math.inf
    converged = settled_at(lin, w, lo, hi, settle)
    if converged:
        reason = (
            f"converged: the Gauss-Newton step is {step:.2g} standard errors (< {settle:g})"
            if step < settle
            else f"converged: the Gauss-Newton step changes no value by more than {_optimise.XTOL:g} (relative)"
        )
    else:
        why = _REASONS[stop.reason].format(n=iterations, tol=tol, stall=_optimise.STALL, small=settle**2)
        if stop.reason == "cap" and stop.falling:
            why += ", misfit still falling"
        if method != "lm":
            why = f"{method}: " + why
        reason = (
            f"{why}; the Gauss-Newton step is still {step:.3g} standard errors (converged: < {settle:g}): "
            "raise the iteration cap (--iterations), start closer, or fit fewer keys"
            if math.isfinite(step)
            else f"{why}; the residuals or their derivatives are not finite at the end"
        )
    return dict(
        converged=converged,
        reason=reason,
        stop=stop.reason,
        gauss_newton_step_sigma=step,
        criterion=f"Gauss-Newton step < {settle:g} standard errors, or < {_optimise.XTOL:g} of every value",
        gauss_newton_step_relative=float(np.max(np.abs(gn), initial=0.0)),
        method=method,
        iteration_cap=iterations,
    )


@dataclass
class _FitProblem:
    """What every stage of a fit shares: the parameter keys and log bounds, the measured columns as arrays
    (``data``: (columns, samples), NaN-free; ``mask``: measured samples), the residual function and its
    counted, compiled form ``res`` with its array arguments ``args`` (one ``_FitArrays``)."""

    keys: list[str]
    names: list[str]
    t: np.ndarray
    lo_log: jax.Array
    hi_log: jax.Array
    sig_scale: list[float]
    mask: np.ndarray
    residuals: Callable
    args: tuple
    res: CountedResiduals
    model: str = "ancf"

    @classmethod
    def build(cls, drive: Drive, measured: Measurement, keys, lo, hi, t_end, save_dt, model="ancf") -> _FitProblem:
        lo_log, hi_log = jnp.log(jnp.asarray(lo)), jnp.log(jnp.asarray(hi))
        names = list(measured.columns)
        data, sig_scale = _measured_data(measured, names)
        mask = np.isfinite(data)
        residuals = _residual_function(drive, keys, names, t_end, save_dt, model)
        arrays = _FitArrays(
            t=jnp.asarray(measured.t, dtype=float),
            params=drive.params,
            data=jnp.asarray(np.nan_to_num(data)),
            weight=1.0 / jnp.asarray(sig_scale),
            mask=jnp.asarray(mask),
            lo_log=lo_log,
            hi_log=hi_log,
        )
        args = (arrays,)
        # all the residuals close over, for their stored traced programs (jaxbelt._export)
        closure = (drive, tuple(keys), tuple(names), t_end, save_dt, model)
        res = CountedResiduals(residuals, args, closure=closure)
        t = np.asarray(measured.t)
        return cls(keys, names, t, lo_log, hi_log, sig_scale, mask, residuals, args, res, model)


def _estimates(problem: _FitProblem, measured: Measurement, lin, theta, wmask, r_half=None):
    """Values, standard errors, covariance (log space), misfit, parameters at a bound, warnings and the error
    budget per key, from the exact linearisation ``lin`` at ``theta`` over the last window's samples and (if
    given) the residuals ``r_half`` of a run at half the time step there (``_time_step_error``)."""
    mask = problem.mask
    r, J = lin.r * _flat(mask, wmask), lin.J * _flat(mask, wmask)[:, None]
    theta = np.asarray(theta)
    given = all(measured.sigma is not None and n in measured.sigma for n in problem.names)
    cov, misfit, at_bound, notes = _uncertainty(
        J,
        r,
        mask & wmask[None, :],  # the samples the last window fitted
        Fitted(problem.keys, theta, np.asarray(problem.lo_log), np.asarray(problem.hi_log)),
        problem.names,
        np.asarray(problem.sig_scale),
        given,
    )
    values = {k: float(np.exp(theta[i])) for i, k in enumerate(problem.keys)}
    noise_var = np.diag(cov).copy()
    step = _time_step_error(J, r, r_half, _flat(mask, wmask), noise_var) if r_half is not None else None
    budget: dict[str, dict] = {}
    for i, k in enumerate(problem.keys):
        if not np.isfinite(noise_var[i]):
            continue
        budget[k] = dict(noise=float(values[k] * math.sqrt(noise_var[i])))
        if step is not None:
            budget[k]["time_step"] = float(values[k] * step[i])
            cov[i, i] += step[i] ** 2
            if step[i] ** 2 > noise_var[i]:
                notes.append(
                    f"identify: {k}'s time-step error ({budget[k]['time_step']:.3g}: twice its change when the "
                    f"step is halved) exceeds its noise error ({budget[k]['noise']:.3g}); the standard error "
                    "includes both (a smaller solver.dt lowers the first)"
                )
    # infinite: the signals do not determine it; NaN: at a bound, or no derivative to judge by
    stds = {
        k: float(values[k] * math.sqrt(cov[i, i])) if np.isfinite(cov[i, i]) else float(cov[i, i])
        for i, k in enumerate(problem.keys)
    }
    return values, stds, cov, misfit, at_bound, notes, budget


def _time_step_error(J, r, r_half, w, noise_var) -> np.ndarray:
    """The time-step error of each fitted value (log space): twice the change that halving the step makes
    (Richardson extrapolation to dt -> 0 for a first-order scheme: the order is not known, stick/slip
    switching not being smooth in time; the changes for 2/3 and 1/2 of the step measured below were in the
    ratio 1.4-2.1, first order gives 1.5, second 1.35), linearised,
    -(J^T J)^-1 J^T (r_half - r), over the parameters that have a noise error (not at a bound,
    determined). The fit's own model error: a record made at another time step (or the real, continuous
    belt) differs from the fit's model by it, and the noise errors alone then miss the truth by several of
    themselves (measured on the two-pulley drive, 30 elements, 1.6 s, record at the drive's own step, fit at
    the box's smaller one: E 5.5 and mu 4.1 noise errors off; the linearised half-step changes 0.013 % and
    0.23 % against actual errors of 0.014 % and 0.39 %)."""
    free = np.flatnonzero(np.isfinite(noise_var))
    out = np.zeros(J.shape[1])
    d = (np.asarray(r_half) * w) - r
    if not free.size:
        return out
    if not np.all(np.isfinite(d)):
        out[free] = np.inf
        return out
    out[free] = 2.0 * np.abs(np.linalg.lstsq(J[:, free], -d, rcond=None)[0])
    return out


def _search_box(drive: Drive, fit):
    """Keys, starting values and bounds of the fit, checked (a list of keys: the drive's values, x/10..x*10)."""
    if isinstance(fit, (list, tuple)):
        twice = sorted({k for k in fit if list(fit).count(k) > 1})
        if twice:
            raise ConfigError(f"identify: {', '.join(map(str, twice))} given more than once in the keys to fit")
        fit = {k: (float(get_parameter(drive, drive.params, k)), None) for k in fit}
    keys = list(fit)
    check_together(drive, keys)
    guess, lo, hi = [], [], []
    for k, (g, bounds) in fit.items():
        get_parameter(drive, drive.params, k)  # validates the key
        if not (g > 0 and math.isfinite(g)):
            raise ConfigError(f"identify: starting value of {k} = {float(g):g}: must be a finite number > 0")
        b = (g / 10, g * 10) if bounds is None else bounds
        if not (0 < b[0] <= g <= b[1]):
            shown = f"({float(b[0]):g}, {float(b[1]):g})" if len(b) == 2 else repr(b)
            raise ConfigError(f"identify: bounds of {k} = {shown}: need 0 < low <= start ({float(g):g}) <= high")
        guess.append(g)
        lo.append(b[0])
        hi.append(b[1])
    return keys, guess, lo, hi


def _measured_data(measured: Measurement, names):
    """The measured columns as one (columns, M) array (NaN = missing) and each column's noise scale: the
    given sigma, else 1 % of the column's spread (min 1e-12)."""
    data = np.stack([np.asarray(measured.columns[n], dtype=float) for n in names])
    sig_scale = []
    for i, n in enumerate(names):
        if measured.sigma and n in measured.sigma:
            sig_scale.append(measured.sigma[n])
        else:
            col = data[i][np.isfinite(data[i])]
            sig_scale.append(max(0.01 * (np.ptp(col) if col.size > 1 else abs(col[0])), 1e-12))
    return data, sig_scale


class _FitArrays(NamedTuple):
    """The array arguments of a fit's residuals: the measured times ``t`` (M,), the drive's parameters, the
    measured columns ``data`` (columns, M; NaN-free), their weights ``weight`` (1 / noise scale), the measured
    samples ``mask`` (columns, M) and the log bounds of the fitted values. Arguments, not constants, so that the
    compiled program depends only on the drive's structure, the keys and the sampling."""

    t: jax.Array
    params: DriveParams
    data: jax.Array
    weight: jax.Array
    mask: jax.Array
    lo_log: jax.Array
    hi_log: jax.Array


def _residual_function(drive, keys, names, t_end, save_dt, model="ancf"):
    """residuals(theta, arrays, window_mask=None, adjoint): the weighted misfit of simulated and measured
    signals at log parameters ``theta`` (clipped to the bounds), flattened (column-major: one block of samples
    per column); missing samples and those outside the window 0. The measured arrays and the drive's parameters
    come as one ``_FitArrays``. ``model`` "spans": the spans tier at ``drive.dt``."""

    def simulate(p, adjoint):
        if model == "ancf":
            return simulate_signals(drive, p, t_end=t_end, save_dt=save_dt, adjoint=adjoint)
        from ..spans import simulate_spans, spans_signals_of
        from ..spans.simulate import running_start

        traj = simulate_spans(drive, p, t_end=t_end, dt=drive.dt, save_dt=save_dt, running=running_start(drive))
        sig = spans_signals_of(drive, p, traj.ts, traj.states)
        return sig.pop("t"), sig

    def residuals(theta, arrays: _FitArrays, window_mask=None, adjoint="forward"):
        th = jnp.clip(theta, arrays.lo_log, arrays.hi_log)
        p = set_parameters(drive, arrays.params, [(k, jnp.exp(th[i])) for i, k in enumerate(keys)])
        ts, sig = simulate(p, adjoint)
        r = (_interp_signals(ts, sig, arrays.t, names) - arrays.data) * arrays.weight[:, None]
        mask = arrays.mask
        keep = mask if window_mask is None else mask & window_mask[None, :]
        return jnp.where(keep, r, 0.0).ravel()

    return residuals


def _flat(mask, wmask) -> np.ndarray:
    """1.0 where a residual counts in the window (measured and inside it), else 0.0; flattened like r."""
    return (np.asarray(mask) & np.asarray(wmask)[None, :]).ravel().astype(float)


def _fit_windows(problem: _FitProblem, windows, theta, method, learning_rate, stopping: Stopping, history, verbose):
    """Minimise over each time window in turn, each starting where the previous stopped. The residuals and
    Jacobians are of the whole record (one program for all windows), masked to the window here. ``stopping``:
    when each window ends (an optax window runs its ``iterations``).

    Returns (theta, the last Linearisation (LM; else None), the last window's mask, total iterations, and
    why the last window stopped: ``LMStop``; an optax window always runs its iterations)."""
    res, args, keys, lo_log, hi_log = problem.res, problem.args, problem.keys, problem.lo_log, problem.hi_log
    t = problem.t
    windows = [(-np.inf, np.inf)] if windows is None else list(windows)
    total_iter, lin, optimiser = 0, None, None
    if method != "lm":
        res_rev = lambda th, w, *a: problem.residuals(th, *a, window_mask=w, adjoint="reverse")  # noqa: E731
        optimiser = _optax_step(res_rev, args, method, learning_rate, lo_log, hi_log, res.costs)
    mask = problem.mask
    for wi, (wa, wb) in enumerate(windows):
        wmask = (t >= wa) & (t <= wb)
        label = f"window {wi + 1}/{len(windows)}"

        def log(it, loss, th, label=label):
            res.costs.mark({k: math.exp(v) for k, v in zip(keys, th)})
            if verbose:
                print(
                    f"identify ({label}): iteration {it}, misfit {loss:.6g}, values "
                    + ", ".join(f"{k}={math.exp(v):.6g}" for k, v in zip(keys, th))
                )

        if method == "lm":
            lin = exact(res, np.asarray(theta)) if lin is None else lin
            w = _flat(mask, wmask)
            lin, n_iter, stop = levenberg_marquardt(res, lin, w, lo_log, hi_log, stopping, history, log)
            theta = lin.theta
        else:
            theta = optax_minimise(optimiser, wmask, jnp.asarray(theta), stopping.iterations, history)
            last = wi == len(windows) - 1  # there the exact Jacobian is needed anyway (standard errors)
            lin = exact(res, np.asarray(theta)) if last else None
            r = (lin.r if lin is not None else res.evaluate(theta)) * _flat(mask, wmask)
            history.append(0.5 * float(r @ r))
            n_iter, stop = stopping.iterations, LMStop("cap", falling=len(history) < 2 or history[-1] < history[-2])
        total_iter += n_iter
    return np.asarray(theta), lin, wmask, total_iter, stop


def _drive_stable_over_bounds(drive: Drive, keys, lo, hi, model: str = "ancf") -> Drive:
    """A copy of ``drive`` whose time step stays stable at every corner of the search box (``model`` "spans":
    the spans tier's step, the smallest of its stable steps at the corners)."""
    import dataclasses
    import itertools

    from ..dynamics.stability import stable_time_step

    if model == "spans":
        from ..spans import spans_time_steps

        corners = np.array(list(itertools.product(*zip(lo, hi))))
        batch = jax.vmap(lambda c: set_parameters(drive, drive.params, [(k, c[i]) for i, k in enumerate(keys)]))
        return dataclasses.replace(drive, dt=float(np.min(spans_time_steps(drive, batch(jnp.asarray(corners))))))
    dt = drive.dt
    for corner in itertools.product(*zip(lo, hi)):
        p = set_parameters(drive, drive.params, list(zip(keys, corner)))
        dt = min(dt, 0.9 * stable_time_step(drive.model, p))
    return dataclasses.replace(drive, dt=dt)
