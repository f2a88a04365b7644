"""The minimisers behind ``identify``: a bounded Levenberg-Marquardt in log space with Broyden updates
of its Jacobian, and optax's optimisers; and the compiled residual functions with their cost accounting.

Cost: one forward-mode Jacobian of the residuals costs several forward runs (measured 5-6 for three
parameters: one tangent ~1.2-1.7 runs, the primal once). Levenberg-Marquardt therefore computes the
exact Jacobian only where it must: at the start, when a step computed from the secant (Broyden)
approximation fails to lower the misfit, and when the fit seems converged (the stop is then judged,
and the standard errors computed, on the exact Jacobian). In between, every step costs one forward run
and refines the Jacobian by Broyden's rank-1 secant update. The stop is statistical (``SETTLE``): once
the exact Gauss-Newton step is shorter than half a standard error, the fit ends there, instead of
chasing misfit gains (``tol``) that the noise makes meaningless and the forward model's roughness at
that scale makes expensive (measured on the benchmark's noise-free fit: 25 runs and 6 Jacobians before,
10 and 4 after).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from .._export import compiled_flat
from .distributed import ProcessGroup, assemble, gather, process_group, tangent_block

# Trust region: at most a factor e^0.5 = 1.65 per iteration and parameter (a box, see _lm_step). It is
# what keeps a fit off its bounds: optimistix.LevenbergMarquardt with proposed points projected onto
# the bounds (tried, with Marquardt scaling) was 10-30 % faster on most identify tests but parked
# contact.mu on its upper bound (+60 %) in test_identify_recovers_E_eta_mu_from_noisy_signals, where the
# clipped residual is flat.
MAX_LOG_STEP = 0.5
# A step from the secant Jacobian that gains less than this fraction of the reduction its linear model
# predicted is followed by an exact Jacobian (the trust-region gain ratio's usual "poor" threshold).
POOR_GAIN = 0.25
# Converged when the exact Jacobian's Gauss-Newton step is shorter than this many standard errors (see
# _remaining): stopping there adds at most sqrt(1 + 0.5^2) - 1 = 12 % to the statistical error. Measured on
# the noisy identification benchmark (bench_identify.py): 0.3 spent 6 Jacobians and 18 runs chasing steps
# that the forward model's linearisation could not confirm at that scale; 0.5 took 4 and 13.
SETTLE: float | None = 0.5
# A step whose misfit fell by more than this multiple of what its linear model predicted is extended
# (doubled while the misfit keeps falling, at most MAX_EXTEND times): see _extend.
EXTEND_GAIN = 1.2
# Also converged when the Gauss-Newton step changes no value by more than this fraction: a record without
# noise has standard errors near 0, in whose units every step is long.
XTOL = 1e-5
# Stalled after this many iterations in a row that each gained less than settle^2 noise variances while the
# exact Jacobian still promised more (each of them costs a Jacobian). Measured on the start-up example fitted
# to all 18 columns of signals.csv (slip and hub direction among them: reduced chi^2 41): 20 such iterations
# gained 1e-5 of the misfit.
STALL = 3
MAX_EXTEND = 3


@dataclass
class Costs:
    """What a fit evaluated, and the measured time of each kind of evaluation (compilation apart)."""

    forward: list[float] = field(default_factory=list)  # seconds of each forward run
    jacobian: list[float] = field(default_factory=list)  # seconds of each (residuals, Jacobian)
    gradient: list[float] = field(default_factory=list)  # seconds of each misfit + gradient (reverse mode)
    compile_s: float = 0.0
    # after each iteration: the evaluations so far and the values reached (how the cost buys accuracy)
    path: list[dict] = field(default_factory=list)

    def mark(self, values: dict[str, float]) -> None:
        self.path.append(dict(forward_runs=len(self.forward), jacobians=len(self.jacobian), values=values))

    def report(self) -> dict:
        """Counts, mean seconds, and the total in forward-run equivalents (each kind at its measured ratio)."""
        fwd = float(np.median(self.forward)) if self.forward else math.nan
        out: dict = dict(forward_runs=len(self.forward), forward_s=fwd, compile_s=self.compile_s)
        equivalents = float(len(self.forward))
        for kind, times in (("jacobian", self.jacobian), ("gradient", self.gradient)):
            if times:
                ratio = float(np.median(times)) / fwd if self.forward else math.nan
                out.update({f"{kind}s": len(times), f"{kind}_s": float(np.median(times)), f"{kind}_ratio": ratio})
                equivalents += sum(times) / fwd if self.forward else math.nan
        out["forward_run_equivalents"] = equivalents
        ratio = out.get("jacobian_ratio", 0.0)
        out["path"] = [dict(p, forward_run_equivalents=p["forward_runs"] + ratio * p["jacobians"]) for p in self.path]
        return out


class CountedResiduals:
    """``fun(theta, *args)`` -> residuals (1-D) compiled ahead of time (on first use), once for the primal
    and once for (residuals, forward-mode Jacobian); every call timed into ``costs``. The arrays ``args`` are
    arguments, not constants of the program, so that a second fit of the same drive and sampling runs
    the same program, which the persistent compilation cache stores (diffrax's run-time checks of the save
    times hold no host callback in jaxbelt's solves: ``jaxbelt._equinox_checks``).

    Several processes (``jax.distributed``, ``group.count > 1``; ``group`` defaults to this process's): the
    Jacobian's tangents are split over them (``tangent_block``): every process runs the same compiled
    program on its block of k = ceil(p / count) tangents, and the columns are gathered (``assemble``).
    Forward runs (``evaluate``) are not split: every process runs each one itself. They are deterministic
    (the same program on the same inputs), so every process takes the same Levenberg-Marquardt decisions
    without exchanging anything but the Jacobian's columns."""

    def __init__(self, fun, args, group: ProcessGroup | None = None, closure=None):
        self.costs = Costs()
        self._fun, self._args = fun, args
        self.group = process_group() if group is None else group
        self._evaluate_fn = fun
        self._evaluate: Any = None  # compiled on first use, like linearise
        split = self.group.count > 1
        self._linearise_fn = _linearise_rows(fun) if split else _linearise_all(fun)
        self._linearise: Any = None  # compiled on first use: an optax fit never needs it
        # what ``fun`` closes over (a drive, keys, sampling): given, its programs are stored traced beside the
        # compilation cache (jaxbelt._export) and loaded by a later fit instead of traced
        self._closure = closure

    def _compile(self, fn, out_like, *lead):
        t0 = time.perf_counter()
        args = (*lead, *self._args)
        compiled: Any
        if self._closure is None:
            compiled = jax.jit(fn).lower(*args).compile()
        else:
            name = "residuals" if fn is self._evaluate_fn else "jacobian"
            compiled = compiled_flat(name, fn, args, out_like, closure=(self._closure, self.group.count))

        self.costs.compile_s += time.perf_counter() - t0
        return compiled

    def evaluate(self, theta) -> np.ndarray:
        """The residuals at ``theta`` (in every process alike: see the class)."""
        if self._evaluate is None:
            self._evaluate = self._compile(self._evaluate_fn, 0.0, jnp.asarray(theta))
        t0 = time.perf_counter()
        r = np.asarray(self._evaluate(jnp.asarray(theta), *self._args))
        self.costs.forward.append(time.perf_counter() - t0)
        return r

    def _tangents(self, theta) -> jax.Array:
        """This process's tangent block (several processes), its program compiled on first use."""
        tangents = jnp.asarray(tangent_block(theta.shape[0], self.group), dtype=theta.dtype)
        if self._linearise is None:
            self._linearise = self._compile(self._linearise_fn, (0.0, 0.0), theta, tangents)
        return tangents

    def jacobian_rows(self, theta) -> tuple[np.ndarray, np.ndarray]:
        """This process's share (several processes): the residuals (m,) and the Jacobian's transposed
        columns (k, m) of its tangent block, rows beyond p zero."""
        theta = jnp.asarray(theta)
        tangents = self._tangents(theta)  # first: it compiles self._linearise
        r, rows = self._linearise(theta, tangents, *self._args)
        return np.asarray(r), np.asarray(rows)

    def linearise(self, theta) -> tuple[np.ndarray, np.ndarray]:
        """The residuals (m,) and the exact Jacobian (m, p) at ``theta``; its time (with the gathering of
        the processes' columns) goes into ``costs.jacobian``."""
        theta = jnp.asarray(theta)
        if self.group.count > 1:
            self._tangents(theta)  # compiled outside the timing
            t0 = time.perf_counter()
            r, rows = self.jacobian_rows(theta)
            J = assemble(gather(rows, self.group), theta.shape[0])
        else:
            if self._linearise is None:
                self._linearise = self._compile(self._linearise_fn, (0.0, 0.0), theta)
            t0 = time.perf_counter()
            r, J = self._linearise(theta, *self._args)
            r, J = np.asarray(r), np.asarray(J)
        self.costs.jacobian.append(time.perf_counter() - t0)
        return r, J


def _linearise_all(fun):
    """(theta, *args) -> (residuals, Jacobian): ``_linearise_rows`` on the p identity tangents."""
    rows = _linearise_rows(fun)

    def linearise(th, *a):
        r, cols = rows(th, jnp.eye(th.shape[0], dtype=th.dtype), *a)
        return r, cols.T

    return linearise


def _linearise_rows(fun):
    """(theta, tangents (k, p), *args) -> (residuals, Jacobian-tangent products (k, m)): the primal once,
    the given tangents batched (the same program in every process, whichever block it holds)."""

    def linearise_rows(th, tangents, *a):
        jvp = lambda v: jax.jvp(lambda x: fun(x, *a), (th,), (v,))  # noqa: E731
        return jax.vmap(jvp, out_axes=(None, 0))(tangents)

    return linearise_rows


@dataclass
class Linearisation:
    """Residuals of the whole record at ``theta`` and a Jacobian: exact (``fresh``) or Broyden's."""

    theta: np.ndarray
    r: np.ndarray
    J: np.ndarray
    fresh: bool


def exact(res: CountedResiduals, theta) -> Linearisation:
    r, J = res.linearise(theta)
    return Linearisation(np.asarray(theta, dtype=float), r, J, True)


def _broyden(lin: Linearisation, theta, r) -> np.ndarray:
    """Broyden's rank-1 update of ``lin.J``: the smallest change that maps the step onto the residual change."""
    s = np.asarray(theta) - lin.theta
    ss = float(s @ s)
    if ss == 0.0 or not np.all(np.isfinite(r)):
        return lin.J
    return lin.J + np.outer(r - lin.r - lin.J @ s, s) / ss


def _lm_step(lin: Linearisation, w, lam, lo_log, hi_log):
    """The damped Gauss-Newton step (Marquardt scaling) minimised within the box: the bounds and at most
    MAX_LOG_STEP per parameter. A component that leaves the box is held on its edge and the others are
    solved again with it held (an active set, at most one pass per parameter), so that a parameter the
    window hardly determines (a tiny, free-running component) or one pressed on a bound does not shrink
    or distort the step of the others, as scaling or clipping the whole step would."""
    Jw = lin.J * w[:, None]
    g = Jw.T @ (lin.r * w)
    H = Jw.T @ Jw
    A = H + lam * np.diag(np.diag(H) + 1e-12)
    lo_s = np.maximum(np.asarray(lo_log) - lin.theta, -MAX_LOG_STEP)
    hi_s = np.minimum(np.asarray(hi_log) - lin.theta, MAX_LOG_STEP)
    step, held = np.zeros_like(lin.theta), np.zeros(lin.theta.shape, bool)
    for _ in range(lin.theta.size):
        free = ~held
        step[free] = np.linalg.solve(A[np.ix_(free, free)], -(g[free] + A[np.ix_(free, held)] @ step[held]))
        out = free & ((step < lo_s) | (step > hi_s))
        step = np.clip(step, lo_s, hi_s)
        held |= out
        if not out.any() or held.all():
            break
    return np.clip(lin.theta + step, lo_log, hi_log)


def _model_loss(lin: Linearisation, w, cand) -> float:
    return 0.5 * float(np.sum(((lin.r + lin.J @ (cand - lin.theta)) * w) ** 2))


def _chi2(lin: Linearisation, w, decrease: float) -> float:
    """A decrease of the misfit 0.5 |w r|^2 in units of the residual variance: 2 decrease / s^2."""
    m_p = max(float(np.sum(w)) - lin.J.shape[1], 1.0)
    return 2 * decrease / max(float(np.sum((lin.r * w) ** 2)) / m_p, 1e-300)


def _remaining(lin: Linearisation, w, lo_log, hi_log) -> float:
    """The decrease of the misfit that the linear model of ``lin`` still promises, in units of the noise
    variance (the squared standard errors' scale): ``2 (loss - min model) / s^2``, with ``s^2`` the
    residual variance ``|w r|^2 / (m - p)``. This is the squared length of the Gauss-Newton step in the
    metric of the parameters' covariance: < 0.01 means the optimum is within 0.1 standard errors.
    Parameters on a bound that the gradient pushes outward stay there; the step is clipped to the bounds."""
    return _gauss_newton(lin, w, lo_log, hi_log)[0]


def _gauss_newton(lin: Linearisation, w, lo_log, hi_log) -> tuple[float, np.ndarray]:
    """``_remaining`` and the Gauss-Newton step itself (log space, within the bounds)."""
    Jw, rw = lin.J * w[:, None], lin.r * w
    if not (np.all(np.isfinite(Jw)) and np.all(np.isfinite(rw))):
        return math.inf, np.full(lin.theta.shape, np.inf)
    m_p = max(float(np.sum(w)) - Jw.shape[1], 1.0)
    rss = float(rw @ rw)
    g = Jw.T @ rw
    pinned = ((lin.theta <= lo_log) & (g > 0)) | ((lin.theta >= hi_log) & (g < 0))
    step = np.zeros_like(lin.theta)
    if not np.all(pinned):
        step[~pinned] = np.linalg.lstsq(Jw[:, ~pinned], -rw, rcond=None)[0]
    step = np.clip(lin.theta + step, lo_log, hi_log) - lin.theta
    model = rw + Jw @ step
    return (rss - float(model @ model)) / max(rss / m_p, 1e-300), step


def settled_at(lin: Linearisation, w, lo_log, hi_log, settle: float) -> bool:
    """Converged at ``lin`` (an exact Jacobian): its Gauss-Newton step is shorter than ``settle`` standard
    errors, or changes no value by more than XTOL (a record without noise, whose standard errors are ~0)."""
    remaining, step = _gauss_newton(lin, w, lo_log, hi_log)
    return remaining < settle**2 or bool(np.max(np.abs(step), initial=0.0) < XTOL)


@dataclass
class LMStop:
    """Why a Levenberg-Marquardt window ended: ``"settled"`` (the exact Jacobian's Gauss-Newton step is
    shorter than ``settle`` standard errors), ``"cap"`` (the iteration cap; ``falling``: the last iteration
    still lowered the misfit), ``"stalled"`` (STALL iterations in a row gained less than settle^2 noise
    variances each), ``"tol"`` (a step gained less than ``tol`` of the misfit), ``"no_descent"`` (no
    step from the exact Jacobian lowered the misfit, the damping raised 8 times), ``"pinned"`` (every
    parameter on a bound the gradient pushes against). Whether the fit converged is judged afterwards on the
    exact Jacobian at the end (``identify``): the reason says what to change when it did not."""

    reason: str
    falling: bool = False


def _extend(res, lin: Linearisation, w, cand, r_c, loss_c, lo_log, hi_log):
    """Step extension: a step whose misfit fell by more than EXTEND_GAIN times what its linear model predicted
    was too short: the model overstated what the step costs. Measured on the issue's kind of fit (E and mu of
    a two-pulley drive from the file's values, E +10 %, mu -10 % in the record): the secant (Broyden)
    Jacobian kept the sensitivity to mu of the region the fit came from, which Broyden's rank-1 updates
    along the (mostly E) steps did not correct; each step in mu gained 1.35-1.6x its prediction, none was
    "poor" (so no exact Jacobian was called for: 2 in 10 iterations), and mu crept by 2-5 % per iteration,
    ending 7.7 % off after 10. The step is doubled while the misfit keeps falling (at most MAX_EXTEND times,
    in the bounds; one forward run each), and the Jacobian is updated by Broyden along each accepted
    segment. Returns (Linearisation at the last accepted point, its misfit)."""
    step = cand - lin.theta
    lin = Linearisation(cand, r_c, _broyden(lin, cand, r_c), False)
    for k in range(1, MAX_EXTEND + 1):
        far = np.clip(lin.theta + (2**k - 2 ** (k - 1)) * step, lo_log, hi_log)
        if np.array_equal(far, lin.theta):
            break
        r_f = res.evaluate(far)
        loss_f = 0.5 * float(np.sum((r_f * w) ** 2))
        if not (math.isfinite(loss_f) and loss_f < loss_c):
            break
        lin = Linearisation(far, r_f, _broyden(lin, far, r_f), False)
        loss_c = loss_f
    return lin, loss_c


class Stopping(NamedTuple):
    """When a minimisation window ends: after ``iterations`` (the cap), when a step gains less than ``tol`` of
    the misfit, or (``settle``, a fraction of a standard error; None: only ``tol``) when the exact Jacobian's
    Gauss-Newton step is shorter than ``settle`` standard errors (``levenberg_marquardt``; an optax window
    reads only the cap)."""

    iterations: int
    tol: float
    settle: float | None = None


def levenberg_marquardt(res: CountedResiduals, lin: Linearisation, w, lo_log, hi_log, stopping: Stopping, history, log):
    """Bounded Levenberg-Marquardt on 0.5 |w r(theta)|^2 (``w``: 0/1 per residual, the window).

    Starts from ``lin`` (whole-record residuals and a Jacobian at the start) and returns the one at the
    end (exact unless the iterations ran out), the number of iterations and why it stopped (``LMStop``).
    An iteration is one accepted step (extended while the misfit falls faster than its model said, see
    ``_extend``), or the failure that ends the fit: a failed step from a Broyden Jacobian is retried from
    the exact one, a failed one from the exact Jacobian raises the damping (8 times at most).

    Stops (``stopping``) when a step gains less than ``tol`` of the misfit, or (``settle``, a fraction of a
    standard error; None: only ``tol``) when the exact Jacobian's Gauss-Newton step is shorter than ``settle``
    standard errors (``_remaining`` < settle^2): the fit then stands where further iterations move it by
    a statistically irrelevant amount, and that exact Jacobian serves the standard errors. A step that
    gains less than settle^2 (in units of the noise variance) calls for that check; a failed step from
    the exact Jacobian whose Gauss-Newton step is shorter than one standard error ends the fit instead
    of raising the damping (the forward model is rough at that scale: more damping buys nothing)."""
    iterations, tol, settle = stopping
    lo_log, hi_log = np.asarray(lo_log), np.asarray(hi_log)
    if not lin.fresh:  # a new window weighs the residuals differently: start from the exact Jacobian
        lin = exact(res, lin.theta)
    lam = 1e-3
    loss = 0.5 * float(np.sum((lin.r * w) ** 2))
    history.append(loss)
    it, crawl = 0, 0
    stop = LMStop("cap")
    settled = lambda lin: settle is not None and settled_at(lin, w, lo_log, hi_log, settle)  # noqa: E731
    while it < iterations:
        if lin.fresh and settled(lin):  # no step from here would matter
            stop = LMStop("settled")
            break
        it += 1
        improved, rel, stepped_fresh, raised, poor, pinned = False, math.inf, lin.fresh, 0, False, False
        before = loss
        while raised < 8:
            cand = _lm_step(lin, w, lam, lo_log, hi_log)
            if np.array_equal(cand, lin.theta):  # pinned on the bounds: nothing left to try
                pinned = True
                break
            stepped_fresh = lin.fresh
            r_c = res.evaluate(cand)
            loss_c = 0.5 * float(np.sum((r_c * w) ** 2))
            if math.isfinite(loss_c) and loss_c < loss:
                predicted = loss - _model_loss(lin, w, cand)
                gain = (loss - loss_c) / max(predicted, 1e-300)
                poor = gain < POOR_GAIN  # the model promised much more
                # extended only where the gain is significant (above the noise variance): near the optimum a
                # gain ratio above 1 is the noise's, and the extra run would be wasted
                if gain > EXTEND_GAIN and _chi2(lin, w, loss - loss_c) > 1.0:
                    new, loss_c = _extend(res, lin, w, cand, r_c, loss_c, lo_log, hi_log)
                else:
                    new = Linearisation(cand, r_c, _broyden(lin, cand, r_c), False)
                rel = (loss - loss_c) / max(loss, 1e-300)
                lin, lam, loss, improved = new, max(lam / 3, 1e-9), loss_c, True
                break
            if lin.fresh and settle is not None and _remaining(lin, w, lo_log, hi_log) < 1.0:
                break  # the exact model puts the optimum within one standard error, and the step failed
            if lin.fresh:
                lam, raised = lam * 10, raised + 1
            else:  # the secant model misled the step: the exact Jacobian, same damping
                lin = exact(res, lin.theta)
                if settled(lin):  # which says that no step from here would matter
                    break
        history.append(loss)
        log(it, loss, lin.theta)
        stop = LMStop("cap", falling=improved)
        converged = not improved or rel < tol
        # a step that gained less than settle^2 (in units of the noise variance): near the optimum
        small = improved and settle is not None and _chi2(lin, w, before - loss) < settle**2
        crawl = crawl + 1 if small else 0
        if crawl >= STALL:  # each a Jacobian, each gaining nothing that matters: the exact model misleads
            stop = LMStop("stalled")
            break
        if small or (converged and not lin.fresh and not stepped_fresh):  # the exact Jacobian decides
            lin = exact(res, lin.theta)
            continue
        if converged:
            stop = LMStop("pinned" if pinned else "tol" if improved else "no_descent")
            break
        if poor and not stepped_fresh:  # the secant model has drifted: the exact Jacobian for the next step
            lin = exact(res, lin.theta)
    if stop.reason != "settled" and lin.fresh and settled(lin):
        stop = LMStop("settled")
    return lin, it, stop


class _Misfit:
    """0.5 |r(theta, window)|^2 and its reverse-mode gradient as one program, compiled once ahead of time
    and run from the host (each evaluation timed into ``costs``; the last ones remembered, so the step
    that follows a line search reuses the search's final evaluation)."""

    def __init__(self, res_rev, args, costs: Costs):
        self._vg = jax.jit(jax.value_and_grad(lambda th, w, *a: 0.5 * jnp.sum(res_rev(th, w, *a) ** 2)))
        self._args = args
        self._compiled: Any = None  # the value-and-gradient program, compiled at the first call
        self._costs = costs
        self._memo: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def __call__(self, theta, wmask):
        theta, wmask = np.asarray(theta), np.asarray(wmask)
        key = theta.tobytes() + np.packbits(wmask).tobytes()
        if key not in self._memo:
            if self._compiled is None:
                t0 = time.perf_counter()
                self._compiled = self._vg.lower(theta, wmask, *self._args).compile()
                self._costs.compile_s += time.perf_counter() - t0
            t0 = time.perf_counter()
            v, g = self._compiled(theta, wmask, *self._args)
            self._memo = {key: (np.asarray(v), np.asarray(g)), **dict(list(self._memo.items())[-3:])}
            self._costs.gradient.append(time.perf_counter() - t0)
        return self._memo[key]


def _optax_step(res_rev, args, method, learning_rate, lo_log, hi_log, costs: Costs):
    """An optax optimiser and its whole step as one compiled function of (theta, state, window mask).

    The misfit and its gradient are one separately compiled program called back from the step
    (``_Misfit``): inlined, L-BFGS's line search compiled the reverse-mode simulation a second time
    (measured: the L-BFGS test's step compiled in 108 s, under load). Run eagerly instead, the search's
    loops were recompiled every iteration (20 s each).
    """
    import optax  # here: importing optax costs 0.15 s that a plain simulation need not pay

    opt = optax.adam(learning_rate) if method == "adam" else optax.lbfgs()
    host = _Misfit(res_rev, args, costs)

    def _call(th, w):
        shapes = (jax.ShapeDtypeStruct((), th.dtype), jax.ShapeDtypeStruct(th.shape, th.dtype))
        return jax.pure_callback(host, shapes, th, w)

    @jax.custom_vjp
    def loss_fn(th, w):
        return _call(th, w)[0]

    def loss_fwd(th, w):
        v, g = _call(th, w)
        return v, g

    def loss_bwd(g, ct):
        return ct * g, None

    loss_fn.defvjp(loss_fwd, loss_bwd)

    @jax.jit
    def step(theta, state, wmask):
        loss, grad = jax.value_and_grad(loss_fn)(theta, wmask)
        # optax mixes its int32 step counts with floats and int64 indices: its update follows numpy's
        # promotion even where the caller asked for strict promotion (the tests do)
        with jax.numpy_dtype_promotion("standard"):
            if method == "lbfgs":
                value_fn = lambda th: loss_fn(th, wmask)  # noqa: E731
                updates, state = opt.update(grad, state, theta, value=loss, grad=grad, value_fn=value_fn)
            else:
                updates, state = opt.update(grad, state, theta)
        return jnp.clip(optax.apply_updates(theta, updates), lo_log, hi_log), state, loss

    return dict(opt=opt, step=step)


def optax_minimise(optimiser, w, theta, iterations, history):
    """``iterations`` steps of an optax optimiser; returns the final theta. The misfit and its gradient
    are timed where they run (``_Misfit``); the optimiser's own compiled step is cheap."""
    state = optimiser["opt"].init(theta)
    wmask = jnp.asarray(w)
    for _ in range(iterations):
        theta, state, loss = optimiser["step"](theta, state, wmask)
        history.append(float(loss))
    return theta
