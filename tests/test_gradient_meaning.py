"""What a derivative of a steady-state figure means (docs/gradients.md; the study: benchmarks/
bench_gradient_convergence.py). With the regularised friction law the run is smooth in E and the exact
derivative (forward mode) of a window mean equals central differences; with Coulomb friction and true sticking
the steady-state sensitivity is creep theory's, which central differences at a relative step of 1e-2 give."""

import dataclasses
import warnings

import jax
import jax.numpy as jnp
import pytest

import jaxbelt as jb
from jaxbelt.outputs.summary import creep_theory_for

E0 = 9.5e6  # Benchmark A's E [Pa]


def _drive(law: str):
    """Benchmark A, 20 elements, steady early: the speed ramp ends at 0.2 s, the load at 0.4 s; the figure is the
    driven speed averaged over 1.2-1.5 s. (Over 0.8-1.0 s, one second of running, the exact derivative of the
    regularised run still differed from central differences at h = 3e-3 ... 3e-2 by -30 %: the decaying
    start-up leaves structure in E at scales below those steps.)"""
    spec = jb.benchmark_a(n_elements=20, t_end=1.5, save_dt=2e-3, friction_law=law, nu_s=200.0)
    spec.pulleys[0].speed = {"ramp": [0.0, 0.2, 0.0, 12.0]}
    spec.pulleys[1].load = {"smooth_step": [0.2, 0.4, 0.0, 25.0]}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # 20 elements: the polygon-effect advice
        return jb.build_drive(spec)


def _window_mean(drive):
    def f(E):
        p = jb.set_parameter(drive, drive.params, "belt.E", E)
        ts, sig = jb.simulate_signals(drive, p, adjoint="forward")
        return jnp.mean(sig["omega:driven"], where=ts >= ts[-1] - 0.2 * (ts[-1] - ts[0]))

    return jax.jit(f)


def _central(f, h):
    return (f(E0 * (1 + h)) - f(E0 * (1 - h))) / (2 * h * E0)


@pytest.mark.long
def test_a_smooth_law_differentiates_a_window_mean_exactly():
    """Regularised law (nu_s 200 s/m): forward mode equals central differences at h = 1e-2 within 5 % (measured
    here +1.3 %; at 30 elements over 2.45 s: 0-10 % for windows of 10-40 % of the run)."""
    f = _window_mean(_drive("regularized"))
    ad = float(jax.jacfwd(f)(E0))
    cd = float(_central(f, 1e-2))
    assert cd > 0 and ad == pytest.approx(cd, rel=0.05)


def test_with_true_sticking_central_differences_give_creep_theorys_sensitivity():
    """Coulomb law: central differences at h = 1e-2 agree with the slope of creep theory's driven speed
    (Grashof/Firbank, smooth in E) within 15 % (measured at 30 elements: -8 ... +10 % for h = 3e-3 ... 1e-1;
    the exact derivative of the run holds its stick/slip pattern and was off by -190 ... +90 %)."""
    drive = _drive("coulomb")
    cd = float(_central(_window_mean(drive), 1e-2))

    def theory(E):
        p = jb.set_parameter(drive, drive.params, "belt.E", E)
        return creep_theory_for(dataclasses.replace(drive, params=p)).omega_driven

    slope = (theory(E0 * 1.001) - theory(E0 * 0.999)) / (0.002 * E0)
    assert slope > 0 and cd == pytest.approx(slope, rel=0.15)
