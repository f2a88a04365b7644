"""The summary window holds whole periods of the engine orders (jaxbelt/outputs/window.py).

A mean over a fractional number of periods of a forced response carries part of a period: for x = m + A sin(k phi)
over a window of n + f periods the error is up to A / (pi (n + f)) (measured on the accessory example at idle:
slack spans -6 %, the crank's mean slip safety factor -8 %). Trimmed to whole periods the mean of every harmonic of
the fundamental vanishes: closed forms on synthetic signals, and on a driven drive the window means must not depend
on the window's length once it is steady.
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import build_quietly, excited_two_pulley_spec

import jaxbelt as jb
from jaxbelt.outputs.window import excitation_period, summary_window, traced_window, window_mask

jax.config.update("jax_enable_x64", True)


def _signal(t, omega=100.0, wobble=0.02, k=2, A=30.0, m=200.0):
    """A pulley angle turning at ``omega`` with a small k-th order wobble, and a response m + A sin(k phi + 0.4)."""
    phi = omega * t + wobble * np.sin(k * omega * t)
    return phi, m + A * np.sin(k * phi + 0.4) + 0.3 * A * np.cos(2 * k * phi)


@pytest.mark.parametrize("window", [0.05, 0.08, 0.13, 0.2, 0.27])
def test_whole_periods_take_the_forced_response_out_of_the_mean(window):
    """Saves every 1 ms of a 2nd-order response at 100 rad/s (period pi in the angle, 31.4 ms): the trimmed
    window's mean equals the signal's time mean within one sample's share of the ripple (the samples cover whole
    periods less than one save: 1.3 A / N for N samples), the untrimmed one misses by up to 2 A / (k omega T); the
    kept states span whole periods, less than one save of rotation short."""
    t = np.arange(0.0, 1.0 + 5e-4, 1e-3)
    phi, x = _signal(t)
    fine = np.linspace(0.0, 30 * math.pi / 100.0, 300_001)  # 30 periods: the time mean (the wobble gives it a
    m = np.mean(_signal(fine)[1][:-1])  # DC share of J_1(0.04) A, ~0.2 N, so not exactly 200)
    sel = window_mask(t, window, phi, math.pi)
    plain = window_mask(t, window)
    assert sel[-1] and np.all(np.diff(sel.astype(int)) >= 0)  # a tail of the saves, inside the fraction
    assert sel.sum() <= plain.sum()
    turned = phi[-1] - phi[sel][0]
    periods = round(turned / math.pi)
    assert periods >= 1
    assert 0.0 <= periods * math.pi - turned < 1e-3 * 100.0 * 1.3  # within one save's rotation (wobble included)
    assert abs(np.mean(x[sel]) - m) < 1.3 * 30.0 / sel.sum()
    bound = 2 * 1.3 * 30.0 / (2 * 100.0 * (t[-1] - t[plain][0]))
    assert abs(np.mean(x[plain]) - m) < bound + 1.3 * 30.0 / plain.sum()


def test_the_traced_rule_is_the_numpy_rule():
    """``window_mask`` on jax arrays under jit gives the numpy mask (sweeps and the spans tier use it traced)."""
    t = np.arange(0.0, 0.6 + 5e-4, 1e-3)
    phi, _ = _signal(t)
    for window in (0.05, 0.2, 0.3):
        traced = jax.jit(lambda a, b: window_mask(a, window, b, math.pi))(jnp.asarray(t), jnp.asarray(phi))
        assert np.array_equal(np.asarray(traced), window_mask(t, window, phi, math.pi))


def test_a_pulley_that_stands_or_turns_back_keeps_a_contiguous_window():
    """No rotation: the fraction alone. A pulley that turns back inside the window: the kept states are still
    a tail (the largest rotation back from each state to the end counts)."""
    t = np.arange(0.0, 1.0 + 5e-4, 1e-3)
    assert np.array_equal(window_mask(t, 0.2, np.zeros_like(t), math.pi), window_mask(t, 0.2))
    phi = 40.0 * np.sin(2.0 * t)  # forwards, then back
    sel = window_mask(t, 0.3, phi, math.pi)
    assert sel[-1] and np.all(np.diff(sel.astype(int)) >= 0)


def _drive(t_end=1.0):
    orders = {2: {"amplitude_deg": 0.5}, 6: {"amplitude_deg": 0.1}}
    spec = excited_two_pulley_spec({"speed": 100.0}, orders, t_end, n_elements=26, start="running")
    return build_quietly(spec)


@pytest.fixture(scope="module")
def excited_run():
    return jb.run(_drive())


def test_window_means_of_a_steady_driven_drive_do_not_depend_on_the_windows_length(excited_run):
    """Orders 2 and 6 of 0.5 / 0.1 deg at 100 rad/s (fundamental: order 2, period pi): span tensions ripple
    by about 20 N. Summaries of the same run over 5 / 8 / 13 / 20 % of it (1.6 ... 6.4 periods, trimmed to
    1 ... 6) agree on the span tensions' means within 0.3 % (measured 0.05 / 0.10 %; untrimmed 1.1 / 1.6 %), and on
    the driven pulley's mean slip safety factor (14: lightly loaded, so it magnifies the tensions' spread by
    T / (T1 - T2) ~ 10) within 3 % (measured 1.4 %); the untrimmed means spread at least twice as far."""
    r = excited_run
    d = r.drive
    assert excitation_period(d) == (0, pytest.approx(math.pi))
    ts, states = np.asarray(r.trajectory.ts), jax.tree.map(np.asarray, r.trajectory.states)
    spans = [k for k in r.signals if k.startswith("tension:")]
    assert max(np.ptp(r.signals[k][ts > 0.8]) for k in spans) > 20.0  # the forced response is there
    trimmed, plain, sf = [], [], []
    for window in (0.05, 0.08, 0.13, 0.2):
        s = jb.outputs.summary(d, ts, states, r.trajectory.final, window=window, signals_=r.signals)
        assert s["window_periods"] == round(s["window_periods"]) >= 1
        trimmed.append([sp["tension_mean"] for sp in s["spans"]])
        sf.append(s["pulleys"]["driven"]["slip_safety_factor"])
        sel = window_mask(ts, window)
        plain.append([float(np.mean(r.signals[k][sel])) for k in spans])
        turned = abs(states.theta[-1, 0] - states.theta[ts >= s["window_s"][0], 0][0])
        assert turned == pytest.approx(s["window_periods"] * math.pi, abs=1e-3 * 100.0 * 1.2)
    trimmed, plain = np.asarray(trimmed), np.asarray(plain)
    spread = np.ptp(trimmed, axis=0) / trimmed.mean(axis=0)
    assert np.all(spread < 3e-3), spread
    assert np.max(np.ptp(plain, axis=0) / plain.mean(axis=0)) > 2 * np.max(spread)
    assert np.ptp(sf) < 0.03 * np.mean(sf), sf


def test_the_run_the_spans_tier_and_a_traced_sweep_window_agree(excited_run):
    """The run's summary window, the traced rule a sweep uses and the window's power balance (from the trimmed
    start: the stored energy's change over whole periods is small against its swing)."""
    r = excited_run
    d = r.drive
    ts, theta = np.asarray(r.trajectory.ts), np.asarray(r.trajectory.states.theta)
    sel, periods = summary_window(d, ts, theta, 0.2)
    assert r.summary["window_s"][0] == ts[sel][0] and r.summary["window_periods"] == periods
    traced = jax.jit(lambda a, b: traced_window(d, a, b, 0.2))(jnp.asarray(ts), jnp.asarray(theta))
    assert np.array_equal(np.asarray(traced) > 0, sel)
    pb = r.summary["power_balance"]
    assert pb["interval_s"][0] == r.summary["window_s"][0]
    assert abs(pb["stored_change_W"]) < 0.05 * pb["delivered_W"], pb
