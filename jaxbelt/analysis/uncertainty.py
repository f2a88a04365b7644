"""Standard errors, misfit and bound report of a least-squares fit (``identify``'s last step)."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

# Reduced chi^2 above which the misfit counts as far above a given noise level (RMS residual 1.4x sigma),
# or above the level a pure-noise chi^2 reaches with 5 standard deviations (few samples).
MISFIT_WARN = 2.0
# log-space distance under which a parameter counts as at its bound (the optimisers clip onto it exactly)
AT_BOUND = 1e-9
# eigenvalues of the (column-normalised) J^T J below this fraction of the largest: a direction the
# signals do not determine
SINGULAR = 1e-12
# stretches of time the record is cut into to test that the residuals are white (_block_ratios)
BLOCKS = 20


class Fitted(NamedTuple):
    """The fitted parameters at the optimum: their ``keys``, values ``theta`` and bounds ``lo_log``, ``hi_log``
    (log space, one entry per key)."""

    keys: list[str]
    theta: np.ndarray
    lo_log: np.ndarray
    hi_log: np.ndarray


def _uncertainty(J, r, mask, fitted: Fitted, names, sigma, sigma_given):
    """Gauss–Newton covariance in log space and the misfit report (numpy, at the optimum ``fitted``).

    ``J``, ``r``: Jacobian and residuals of the weighted misfit (masked entries 0); ``sigma``: the noise
    level per column ``names`` that weighted them. Returns (covariance, misfit, at_bound, warnings).
    """
    keys, theta, lo_log, hi_log = fitted
    n_par = len(keys)
    m = int(mask.sum())
    dof = max(m - n_par, 1)
    chi2_red = float(r @ r) / dof
    rw = r.reshape(len(names), -1)
    counts = np.maximum(mask.sum(axis=1), 1)
    rms = {n: float(sigma[i] * math.sqrt(np.sum(rw[i] ** 2) / counts[i])) for i, n in enumerate(names)}
    # given noise: (J^T J)^-1 if the model fits, scaled up by chi^2_red if it does not; else each column's
    # noise level is what its residuals say (weighted units), see _column_scales
    scale = max(1.0, chi2_red) if sigma_given else chi2_red
    column_scale = None if sigma_given else _column_scales(rw, mask, n_par)
    sigma_of = {n: float(sigma[i]) for i, n in enumerate(names)}
    misfit: dict = dict(
        noise="given" if sigma_given else "estimated",
        reduced_chi2=chi2_red,
        dof=dof,
        samples=m,
        rms_residual=rms,
        sigma=sigma_of,
        covariance_scale=scale,
    )
    if column_scale is not None:
        misfit["column_scale"] = {n: float(column_scale[i]) for i, n in enumerate(names)}
    notes = []
    if sigma_given and chi2_red > max(MISFIT_WARN, 1.0 + 5.0 * math.sqrt(2.0 / dof)):
        worst = max(names, key=lambda n: rms[n] / sigma_of[n])
        notes.append(
            f"identify: the misfit is far above the given noise (reduced chi^2 = {chi2_red:.3g}; "
            f"{worst}: RMS residual {rms[worst]:.3g} = {rms[worst] / sigma_of[worst]:.3g} x sigma): "
            "the model misses part of the measurement (a parameter not fitted or wrong, or the noise "
            f"level too low); standard errors scaled by sqrt(reduced chi^2) = {math.sqrt(chi2_red):.3g}"
        )
    at_bound = {}
    for i, k in enumerate(keys):
        if theta[i] <= lo_log[i] + AT_BOUND or theta[i] >= hi_log[i] - AT_BOUND:
            side = "lower" if theta[i] <= lo_log[i] + AT_BOUND else "upper"
            at_bound[k] = side
            notes.append(
                f"identify: {k} stopped at its {side} bound {math.exp(theta[i]):.6g}: the measurement "
                "asks for a value beyond it, so it has no standard error (the others' hold it fixed); "
                "widen the bounds (--bounds) or check the model"
            )
    free = [i for i, k in enumerate(keys) if k not in at_bound]
    cov = np.full((n_par, n_par), np.nan)
    if free and not (np.all(np.isfinite(J[:, free])) and np.all(np.isfinite(r))):
        notes.append(
            "identify: the residuals or their derivatives at the fitted values are not finite (the simulation "
            "failed there, or its derivative did): no standard errors; check the run at these values "
            "(jaxbelt run) or narrow the bounds"
        )
    elif free:
        Jf = J[:, free]
        norm = np.linalg.norm(Jf, axis=0)
        Js = Jf / np.where(norm > 0, norm, 1.0)  # columns of unit length: conditioning free of units
        w, V = np.linalg.eigh(Js.T @ Js)
        good = w > SINGULAR * max(w.max(), 0.0)
        inv_s = (V[:, good] / w[good]) @ V[:, good].T
        if column_scale is None:
            middle = scale * np.eye(len(free))
        else:  # sandwich: (J^T J)^-1 (sum_c s_c^2 J_c^T J_c) (J^T J)^-1, each column at its own noise level
            rows = np.repeat(np.sqrt(column_scale), J.shape[0] // len(names))[:, None] * Js
            middle = rows.T @ rows
        c = inv_s @ middle @ inv_s
        if column_scale is None:
            s2_rows = np.full(J.shape[0], scale)
        else:
            s2_rows = np.repeat(column_scale, J.shape[0] // len(names))
        # the block check: the larger of the two errors always (for white noise that costs ~2 % on average,
        # measured below), a warning only where the excess is significant (3 standard deviations)
        ratio, block_dof = _block_ratios(Js @ inv_s, r, mask, s2_rows)
        significant = ratio > 1.0 + 3.0 * np.sqrt(2.0 / np.maximum(block_dof, 1e-300))
        grow = np.sqrt(np.maximum(ratio, 1.0))
        c = c * np.outer(grow, grow) / np.outer(np.where(norm > 0, norm, 1.0), np.where(norm > 0, norm, 1.0))
        misfit["correlation"] = {
            keys[i]: dict(
                block_ratio=float(np.sqrt(ratio[j])), dof=float(block_dof[j]), significant=bool(significant[j])
            )
            for j, i in enumerate(free)
        }
        for j in np.flatnonzero(significant):
            notes.append(
                f"identify: the residuals are correlated in time (model error, e.g. the fit's time step, or "
                f"coloured noise): the scatter between {BLOCKS} stretches of the record gives {keys[free[j]]} "
                f"{np.sqrt(ratio[j]):.3g} x the white-noise standard error; the standard error is scaled by it"
            )
        undetermined = (np.abs(V[:, ~good]) > 1e-6).any(axis=1) | (norm == 0)
        c[undetermined, :] = c[:, undetermined] = np.nan
        c[undetermined, undetermined] = np.inf
        cov[np.ix_(free, free)] = c
        for j in np.flatnonzero(undetermined):
            notes.append(
                f"identify: {keys[free[j]]} is not determined by these signals (the misfit does not "
                "change with it, alone or together with another fitted key): standard error infinite; "
                "fit fewer keys or measure more signals"
            )
    return cov, misfit, at_bound, notes


def _block_ratios(A, r, mask, s2_rows) -> tuple[np.ndarray, np.ndarray]:
    """Whether the residuals are white, as the standard errors assume: the record is cut into BLOCKS
    stretches of time, and the scatter of each parameter's share of the normal equations between them
    (``A``: the rows' influence on each parameter, (J^T J)^-1 J_i; shares G_b = sum_{i in b} A_i r_i) is
    compared with what white noise of the estimated levels (``s2_rows``) gives. Returns per parameter the
    ratio of the two variances (1 +- sqrt(2 / dof) for white noise; above it: residuals correlated within a
    stretch, so the white-noise errors are too small) and the degrees of freedom of that comparison
    (Satterthwaite's, from the blocks' white-noise shares v_b: (sum v_b)^2 / sum v_b^2). At the optimum the
    shares add up to 0, so E[sum G_b^2] = V (1 - 1 / dof) under white noise; the estimate is corrected for it."""
    C, M = mask.shape
    q = A.shape[1]
    valid = np.flatnonzero(mask.any(axis=0))
    if valid.size < 2 * BLOCKS:
        return np.ones(q), np.zeros(q)
    share = (A * r[:, None]).reshape(C, M, q).sum(axis=0)  # per sample time
    white = (A**2 * s2_rows[:, None]).reshape(C, M, q).sum(axis=0)
    parts = np.array_split(valid, BLOCKS)
    G = np.array([share[b].sum(axis=0) for b in parts])
    v = np.array([white[b].sum(axis=0) for b in parts])
    V = v.sum(axis=0)
    dof = V**2 / np.maximum(np.sum(v**2, axis=0), 1e-300)
    block = np.sum(G**2, axis=0) / np.maximum(1.0 - 1.0 / np.maximum(dof, 1.0 + 1e-12), 1e-12)
    return block / np.maximum(V, 1e-300), dof


def _column_scales(rw, mask, n_par: int) -> np.ndarray:
    """Each measured column's weighted noise variance from its own residuals, s_c^2 = RSS_c / (m_c - p m_c / m)
    (the column's share of the degrees of freedom). One pooled s^2 = RSS / (m - p) would be right only if
    every column's noise were the same multiple of its weight; columns weighted by a guess (1 % of their
    spread) are not: a quiet column then borrows its noisier neighbours' scatter (measured on the two-pulley
    benchmark, 20 noise seeds: (value - truth) / std error had an RMS of 0.64-0.82 instead of 1)."""
    counts = mask.sum(axis=1).astype(float)
    m = max(counts.sum(), 1.0)
    dof = np.maximum(counts - n_par * counts / m, 1.0)
    return np.sum(rw**2, axis=1) / dof
