"""A run traced inside ``jax.jit`` (every sweep point, gradient and identification) writes every save, whatever its
step: at some steps XLA's ``iota * dt`` put the last save time one ulp past the end time, diffrax's check of the
save times (callback-free: ``jaxbelt._equinox_checks``) turned them all into NaN, and the run kept only its first
save while reporting no fault - a sweep's figures came back NaN (the accessory drive at 4,000 rpm, 5.368e-5 s)."""

import warnings

import jax
import jax.numpy as jnp
import numpy as np

import jaxbelt as jb
from jaxbelt._types import Fault
from jaxbelt.dynamics.simulate import schedule, simulate

jax.config.update("jax_enable_x64", True)

DT = 5.017543859649123e-05  # one of the steps where XLA's last save time exceeds n_run * dt (found by a search)
T_END, SAVE_DT, SETTLE = 0.01, 5e-4, 0.005


def test_a_jitted_run_writes_every_save():
    """Benchmark A (12 elements) at that step: traced inside ``jax.jit``, every save is finite and equals the eager
    run's to 1e-12, no fault. (On this machine's XLA the premise holds: the jitted last save time is past the end
    time; the assertions hold either way.)"""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the coarse mesh's polygon warning
        drive = jb.build_drive(jb.benchmark_a(n_elements=12, t_end=T_END, save_dt=SAVE_DT))
    sch = schedule(t_end=T_END, dt=DT, save_dt=SAVE_DT, settle_time=SETTLE)
    last = float(jax.jit(lambda: jnp.arange(0, sch.n_steps + 1, sch.stride, dtype=jnp.float64) * DT)()[-1])
    print(f"jitted last save time - end time: {last - sch.n_run * DT:.3g} s")

    def run(p):
        return simulate(drive.model, p, drive.state0, t_end=T_END, dt=DT, save_dt=SAVE_DT, settle_time=SETTLE)

    eager, jitted = run(drive.params), jax.jit(run)(drive.params)
    assert bool(np.all(np.asarray(jitted.valid))) and len(jitted.valid) == sch.n_saves
    assert float(jitted.final.fault) == Fault.OK
    np.testing.assert_allclose(np.asarray(jitted.states.q), np.asarray(eager.states.q), rtol=1e-12, atol=1e-12)
