"""The minimisers behind ``identify``: a bounded Levenberg-Marquardt in log space and optax's optimisers."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp

# Trust region: at most a factor e^0.5 = 1.65 per iteration and parameter. It is what keeps a fit off
# its bounds: optimistix.LevenbergMarquardt with proposed points projected onto the bounds (tried, with
# Marquardt scaling) was 10-30 % faster on most identify tests but parked contact.mu on its upper bound
# (+60 %) in test_identify_recovers_E_eta_mu_from_noisy_signals, where the clipped residual is flat.
MAX_LOG_STEP = 0.5


def _optax_step(res_rev, method, learning_rate, lo_log, hi_log):
    """An optax optimiser and its whole step as one compiled function of (theta, state, window mask).

    Compiled once for all windows (the mask is an argument). L-BFGS's line search evaluates the misfit
    inside the step; run eagerly, the search's loops were recompiled every iteration (20 s each).
    """
    import optax  # here: importing optax costs 0.15 s that a plain simulation need not pay

    opt = optax.adam(learning_rate) if method == "adam" else optax.lbfgs()

    @jax.jit
    def step(theta, state, wmask):
        def loss_fn(th):  # reverse-mode gradients of the misfit
            return 0.5 * jnp.sum(res_rev(th, wmask) ** 2)

        loss, grad = jax.value_and_grad(loss_fn)(theta)
        # optax mixes its int32 step counts with floats and int64 indices: its update follows numpy's
        # promotion even where the caller asked for strict promotion (the tests do)
        with jax.numpy_dtype_promotion("standard"):
            if method == "lbfgs":
                updates, state = opt.update(grad, state, theta, value=loss, grad=grad, value_fn=loss_fn)
            else:
                updates, state = opt.update(grad, state, theta)
        return jnp.clip(optax.apply_updates(theta, updates), lo_log, hi_log), state, loss

    return opt, step


def _minimise(res_jit, jac_jit, optimiser, wmask, theta, lo_log, hi_log, method, iterations, tol, history, keys, label):
    """Levenberg–Marquardt (or an optax optimiser) on 0.5 |r(theta)|^2; returns (theta, r, iterations)."""
    verbose = bool(label)
    if method == "lm":
        lam = 1e-3
        r = res_jit(theta)
        loss = float(0.5 * r @ r)
        history.append(loss)
        for it in range(iterations):
            J = jac_jit(theta)
            g = J.T @ r
            H = J.T @ J
            improved = False
            for _ in range(8):
                step = jnp.linalg.solve(H + lam * jnp.diag(jnp.diag(H) + 1e-12), -g)
                step = step * jnp.minimum(1.0, MAX_LOG_STEP / jnp.max(jnp.abs(step)))
                cand = jnp.clip(theta + step, lo_log, hi_log)
                r_c = res_jit(cand)
                loss_c = float(0.5 * r_c @ r_c)
                if math.isfinite(loss_c) and loss_c < loss:
                    theta, r, lam, improved = cand, r_c, max(lam / 3, 1e-9), True
                    rel = (loss - loss_c) / max(loss, 1e-300)
                    loss = loss_c
                    break
                lam *= 10
            history.append(loss)
            if verbose:
                print(
                    f"identify ({label}): iteration {it + 1}, misfit {loss:.6g}, values "
                    + ", ".join(f"{k}={float(jnp.exp(v)):.6g}" for k, v in zip(keys, theta))
                )
            if not improved or rel < tol:
                break
        n_iter = it + 1
    else:
        opt, step = optimiser
        state = opt.init(theta)
        for it in range(iterations):
            theta, state, loss = step(theta, state, wmask)
            history.append(float(loss))
        r = res_jit(theta)
        history.append(float(0.5 * r @ r))
        n_iter = iterations
    return theta, r, n_iter
