"""Angles that wrap are averaged on the circle: ``outputs.fead.circular_mean`` against closed forms, the
sweep's window means of ``hub_direction`` (a load pointing at 180 deg reads 180, not a number between
-180 and 180), and a sweep of a drive whose driven pulley is pulled towards -x."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import build_quietly

import jaxbelt as jb
from jaxbelt.analysis.sweep import steady_figures
from jaxbelt.outputs.fead import circular_mean


def _gap(a: float, b: float) -> float:
    """Distance of two angles [deg] on the circle."""
    return abs((a - b + 180.0) % 360.0 - 180.0)


def test_circular_mean_closed_forms():
    # around 180 deg: 179 and -179 are 2 deg apart; the mean is 180 (the numbers' mean is 0)
    assert _gap(float(circular_mean(np.array([179.0, -179.0]))), 180.0) < 1e-12
    # deviations -1, +1, -2, +3 deg from 180: the mean points at 180 + atan2(sum sin, sum cos) of them
    d = np.radians([-1.0, 1.0, -2.0, 3.0])
    ref = 180.0 + math.degrees(math.atan2(np.sin(d).sum(), np.cos(d).sum()))  # 180.2501 deg = -179.7499
    assert float(circular_mean(np.array([179.0, -179.0, 178.0, -177.0]))) == pytest.approx(ref - 360.0, abs=1e-12)
    assert float(circular_mean(np.array([350.0, 10.0]))) == pytest.approx(0.0, abs=1e-12)
    assert float(circular_mean(np.array([10.0, 20.0]))) == pytest.approx(15.0, abs=1e-12)
    # weighted: the direction of the mean vector, 1 at 170 deg and 3 at -170 deg
    x, y = math.cos(math.radians(170)) * 4, math.sin(math.radians(170)) * (1 - 3)
    got = circular_mean(np.array([170.0, -170.0]), weights=np.array([1.0, 3.0]))
    assert float(got) == pytest.approx(math.degrees(math.atan2(y, x)), abs=1e-12)
    # another period (radians); along an axis
    assert float(circular_mean(np.array([math.pi - 0.1, -math.pi + 0.3]), period=2 * math.pi)) == pytest.approx(
        -math.pi + 0.1, abs=1e-12
    )
    rows = circular_mean(np.array([[179.0, -179.0], [10.0, 30.0]]), axis=1)
    assert _gap(float(rows[0]), 180.0) < 1e-12 and float(rows[1]) == pytest.approx(20.0, abs=1e-12)
    # vectors that cancel have no direction: 0, as the hub direction of an unloaded pulley
    assert float(circular_mean(np.array([0.0, 180.0]))) == 0.0
    assert float(circular_mean(np.array([30.0, 60.0]), weights=np.zeros(2))) == 0.0


def test_circular_mean_is_traceable_with_finite_derivatives():
    f = jax.jit(lambda x, w: circular_mean(x, weights=w))
    x = jnp.asarray([179.0, -179.0])
    assert _gap(float(f(x, jnp.ones(2))), 180.0) < 1e-12
    # two angles of equal weight: each moves the mean by half its own move
    g = jax.grad(lambda x: circular_mean(x, weights=jnp.ones(2)))(x)
    np.testing.assert_allclose(np.asarray(g), [0.5, 0.5], rtol=1e-12)
    assert np.all(np.isfinite(np.asarray(jax.grad(lambda x: circular_mean(x))(jnp.asarray([0.0, 180.0])))))


def test_steady_figures_average_hub_directions_on_the_circle():
    """A hub load of 800 N at 180 deg that wobbles by 0.5 deg either side (the signal reads 179.5 and
    -179.5): the sweep figure is about 180, the load-weighted circular mean (the direction of the mean load
    vector, as the run summary's ``hub_load_direction_deg``); other signals keep their plain mean."""
    ts = jnp.linspace(0.0, 1.0, 101)
    wobble = jnp.where(jnp.arange(101) % 2 == 0, 179.5, -179.5)
    load = 800.0 + 10.0 * jnp.sin(ts * 40.0)
    sig = {"hub_direction:driven": wobble, "hub_load:driven": load, "omega:driven": 10.0 + ts}
    fig = jax.jit(lambda ts, sig: steady_figures(None, ts, sig, 0.2))(ts, sig)
    assert _gap(float(fig["hub_direction:driven:mean"]), 180.0) < 0.5  # within the wobble (the numbers' mean: ~0)
    last = np.asarray(ts) >= 0.8
    a, H = np.radians(np.asarray(wobble)[last]), np.asarray(load)[last]
    by_hand = math.degrees(math.atan2(np.mean(H * np.sin(a)), np.mean(H * np.cos(a))))
    assert float(fig["hub_direction:driven:mean"]) == pytest.approx(by_hand, abs=1e-9)
    assert float(fig["omega:driven:mean"]) == pytest.approx(10.0 + np.mean(np.asarray(ts)[last]), rel=1e-12)


@pytest.mark.long
def test_sweep_hub_direction_of_a_pulley_pulled_towards_minus_x():
    """Two equal pulleys on the x axis, the driver held, no gravity: by symmetry the belt pulls the driven
    pulley (at +x) towards -x, 180 deg, with its two installed span tensions (2 x 400 N), and the driver
    towards +x, 0 deg. The y-component is round-off of either sign, so the saved directions straddle
    +-180 deg: their plain mean read -36 deg."""
    spec = jb.benchmark_a(n_elements=20, t_end=0.05, save_dt=2e-3)
    spec.gravity = (0.0, 0.0)
    spec.pulleys[0].speed = {"constant": 0.0}
    drive = build_quietly(spec)  # 20 elements: coarse on purpose (polygon-effect warning)
    res = jb.sweep(drive, {"contact.mu": [0.5]})
    fig = {k: float(v[0]) for k, v in res.figures.items()}
    assert fig["fault"] == 0
    assert _gap(fig["hub_direction:driven:mean"], 180.0) < 1e-6
    assert _gap(fig["hub_direction:driver:mean"], 0.0) < 1e-6
    assert fig["hub_load:driven:mean"] == pytest.approx(800.0, rel=0.01)  # measured 798.7 N (20 elements)


def test_the_mean_hub_load_is_the_mean_vectors_magnitude():
    """A hub load of constant magnitude H0 whose direction swings +-35 deg sinusoidally (a pulley wrapped by about
    one element): the mean vector has the magnitude H0 J0(35 deg) = 0.9093 H0 (Bessel; the mean of cos(a sin x)),
    which balances an arm's spring; the mean magnitude stays H0. The run summary's ``hub_load_mean`` and the
    sweep's ``hub_load:P:vector_mean`` (the duty table's hub load) are the former, to 1e-9."""
    from jaxbelt.outputs.fead import _vector_mean

    def j0(a: float) -> float:  # Bessel J0 by its series
        return sum((-1) ** k * (a / 2) ** (2 * k) / math.factorial(k) ** 2 for k in range(20))

    x = np.linspace(0.0, 2 * math.pi, 2001)[:-1]  # whole periods of the swing
    direction = 30.0 + 35.0 * np.sin(x)
    H0 = 150.0
    H = np.full_like(x, H0)
    expected = H0 * float(j0(math.radians(35.0)))
    assert _vector_mean(H, direction) == pytest.approx(expected, rel=1e-9)
    ts = jnp.linspace(0.0, 1.0, x.size)
    sig = {"hub_direction:p": jnp.asarray(direction), "hub_load:p": jnp.asarray(H)}
    fig = jax.jit(lambda ts, sig: steady_figures(None, ts, sig, mask=jnp.ones_like(ts)))(ts, sig)
    assert float(fig["hub_load:p:vector_mean"]) == pytest.approx(expected, rel=1e-9)
    assert float(fig["hub_load:p:mean"]) == pytest.approx(H0, rel=1e-12)
