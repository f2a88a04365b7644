"""The static-kinetic friction law (contact.friction_law = "static-kinetic"): sticking up to mu_s = contact.mu,
sliding with mu_k = contact.mu_kinetic (or a Stribeck curve from mu_s down to mu_k)."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import assert_trees_close, build_quietly, capstan_belt, central_difference, normalised_error

import jaxbelt as jb
from jaxbelt.contact.friction import Coulomb, StaticKinetic
from jaxbelt.contact import Delassus, PointProblem, SolveSettings, solve_contact
from jaxbelt import get_parameter, set_parameter, simulate_signals


def _one_point(u_t, mu_s, mu_k, law=None, **extra):
    """One unit-mass block approaching a rigid plane at speed 1 (normal impulse 1), sliding at u_t."""

    def apply_G(ln, lt):
        return ln, lt

    one, z = jnp.ones(1), jnp.zeros(1)
    law = StaticKinetic() if law is None else law
    problem = PointProblem(u_free_n=-one, u_free_t=jnp.full(1, u_t), bias_n=z, compliance_n=z, mu=jnp.full(1, mu_s))
    settings = SolveSettings(
        iterations=50, relaxation=1.0, friction_law=law, friction_params={"kinetic_ratio": mu_k / mu_s, **extra}
    )
    ln, lt, res = solve_contact(Delassus(apply_G, one, one), problem, (z, z), settings)
    return float(ln[0]), float(lt[0]), float(res)


def test_single_point_sticks_below_mu_s_and_slides_with_mu_k_above():
    # Stopping the block needs impulse u_t; it may take up to mu_s * 1 = 0.5.
    ln, lt, res = _one_point(0.45, 0.5, 0.3)  # 0.45 > mu_k but < mu_s: still sticks
    assert ln == pytest.approx(1.0, rel=1e-12) and lt == pytest.approx(-0.45, rel=1e-12)
    assert abs(0.45 + lt) < 1e-12 and res < 1e-12  # zero slip velocity after the step
    ln, lt, _ = _one_point(0.8, 0.5, 0.3)  # above mu_s: slides, carrying only mu_k * N
    assert lt == pytest.approx(-0.3, rel=1e-12)
    assert 0.8 + lt == pytest.approx(0.5, rel=1e-12)  # slip velocity left after the step
    # With a Stribeck velocity the sliding coefficient follows mu(v) at the slip speed v after the step.
    v_s = 0.4
    _, lt, _ = _one_point(0.8, 0.5, 0.3, law=StaticKinetic(stribeck=True), stribeck_velocity=v_s)
    v = 0.8 + lt
    assert -lt == pytest.approx(0.3 + 0.2 * math.exp(-((v / v_s) ** 2)), rel=1e-12)
    assert 0.3 < -lt < 0.5


def test_single_point_with_equal_coefficients_is_coulomb_bit_for_bit():
    for u_t in (0.2, 0.5, 0.8, -0.7):
        assert _one_point(u_t, 0.5, 0.5) == _one_point(u_t, 0.5, 0.5, law=Coulomb())


@pytest.mark.long
def test_equal_coefficients_reproduce_coulomb_on_benchmark_a():
    def run(**kw):
        spec = jb.benchmark_a(n_elements=26, t_end=0.05)
        for k, v in kw.items():
            setattr(spec.contact, k, v)
        d = build_quietly(spec)
        return jb.simulate(d.model, d.params, d.state0, t_end=0.05, dt=d.dt, save_dt=spec.solver.save_dt)

    a = run()
    b = run(friction_law="static-kinetic", mu_kinetic=0.5)
    assert_trees_close(a, b, what="static-kinetic with mu_k = mu_s vs Coulomb")


def test_config_checks_name_the_key_the_value_and_what_is_allowed():
    def build(**kw):
        spec = jb.benchmark_a(n_elements=26, t_end=0.05)
        for k, v in kw.items():
            setattr(spec.contact, k, v)
        jb.build_drive(spec)

    with pytest.raises(
        jb.ConfigError, match=r"contact.friction_law = 'dry'.*'coulomb', 'regularized', 'static-kinetic'"
    ):
        build(friction_law="dry")
    with pytest.raises(
        jb.ConfigError, match=r"contact.mu_kinetic = 0.6: must be a finite number > 0 and <= contact.mu"
    ):
        build(friction_law="static-kinetic", mu_kinetic=0.6)
    with pytest.raises(jb.ConfigError, match=r"contact.mu_kinetic = None: .*required with friction_law"):
        build(friction_law="static-kinetic")
    with pytest.raises(jb.ConfigError, match=r"contact.mu_kinetic = 0.3: is used only with .*'static-kinetic'"):
        build(mu_kinetic=0.3)
    with pytest.raises(jb.ConfigError, match=r"contact.stribeck_velocity = -0.1: must be a finite number > 0"):
        build(friction_law="static-kinetic", mu_kinetic=0.3, stribeck_velocity=-0.1)


def test_capstan_holds_beyond_kinetic_and_slides_at_the_kinetic_euler_eytelwein_ratio():
    """The capstan of test_drive_cases (pulley A locked, a torque ramp on grooved B pulls the belt) with
    mu_s = 0.3, mu_k = 0.2. Before gross slip the ratio stays below exp(mu_s pi) = 2.57 and rises above
    what kinetic friction alone could hold, exp(mu_k pi) = 1.87 (measured max 2.05: an elastic belt
    creeps near the span ends, and creeping points re-stick while their stopping force is within
    mu_s). Sliding, the ratio averages exp(mu_k pi): measured 1.4 % above it over 0.12 s after the
    onset (single samples ripple +-10 % with the belt's dynamics), asserted within 3 %."""
    mu_s, mu_k = 0.3, 0.2
    spec = jb.DriveSpec(
        belt=capstan_belt(),
        pulleys=[
            jb.PulleySpec("A", (0, 0), 0.1, role="driver", inertia=0.1, speed=0.0),
            jb.PulleySpec(
                "B", (0.3, 0), 0.1, role="driver", inertia=0.01, grooved=True, torque={"ramp": [0.0, 1.0, 0.0, 40.0]}
            ),
        ],
        contact=jb.ContactSpec(mu=mu_s, stiffness=1e8, damping=2e3, friction_law="static-kinetic", mu_kinetic=mu_k),
        solver=jb.SolverSpec(t_end=0.52, save_dt=2e-3),
    )
    s = jb.run(spec).signals
    hi, lo = np.maximum(s["tension:A-B"], s["tension:B-A"]), np.minimum(s["tension:A-B"], s["tension:B-A"])
    ratio = hi / lo
    slipping = np.abs(s["omega:B"]) > 2.0  # B spins up only when the belt slides on A
    assert slipping.any() and not slipping[s["t"] < 0.2].any()
    onset = np.argmax(slipping)
    static_limit, kinetic_limit = math.exp(mu_s * math.pi), math.exp(mu_k * math.pi)
    assert kinetic_limit * 1.05 < ratio[:onset].max() < static_limit * 1.005
    t_on = s["t"][onset]
    sliding = (s["t"] >= t_on + 0.02) & (s["t"] < t_on + 0.14)
    assert slipping[sliding].all()
    assert ratio[sliding].mean() == pytest.approx(kinetic_limit, rel=0.03)


@pytest.mark.long
def test_gradient_wrt_mu_kinetic_matches_central_differences_and_forward_equals_reverse():
    """A short Benchmark A start-up (20 elements, 0.12 s, load brought in at 0.04-0.1 s) with mu_s = 0.5,
    mu_k = 0.4 and a Stribeck velocity of 0.1 m/s: the law is then continuous across stick/slip (the
    sliding coefficient starts at mu_s), so central differences (step 1e-5 relative) apply as in
    test_gradients. Measured: 1.5e-6 (speed) and 6.9e-6 (tension) relative to each output's normalised
    sensitivity; forward vs reverse 2e-10."""
    spec = jb.benchmark_a(n_elements=20, t_end=0.12, save_dt=0.01, friction_law="static-kinetic")
    spec.contact.mu_kinetic, spec.contact.stribeck_velocity = 0.4, 0.1
    spec.pulleys[1].load = {"smooth_step": [0.04, 0.1, 0.0, 10.0]}
    drive = build_quietly(spec)  # coarse mesh on purpose (speed)

    def outputs(x, adjoint):
        p = set_parameter(drive, drive.params, "contact.mu_kinetic", x)
        _, s = simulate_signals(drive, p, adjoint=adjoint)
        return jnp.stack([s["omega:driven"][-1], s["tension:driven-driver"][-1]])

    x0 = float(get_parameter(drive, drive.params, "contact.mu_kinetic"))
    # One forward-mode program gives the values (for the differences) and the forward derivative.
    jvp = jax.jit(lambda x: jax.jvp(lambda x: outputs(x, "forward"), (x,), (jnp.ones_like(x),)))
    _, d_fwd = jvp(jnp.asarray(x0))
    h = 1e-5 * x0
    d_fd = central_difference(lambda x: jvp(jnp.asarray(x))[0], x0, h)
    d_rev = np.asarray(jax.jit(jax.jacrev(lambda x: outputs(x, "reverse")))(jnp.asarray(x0)))
    d_fwd = np.asarray(d_fwd)
    assert np.all(np.isfinite(d_rev)) and np.all(np.abs(d_rev) > 0)
    np.testing.assert_allclose(d_fwd, d_rev, rtol=1e-8)
    err = normalised_error(np.array([x0]), d_rev[:, None], d_fd[:, None])  # one input: as in test_gradients
    assert np.all(err <= 1e-4), (d_rev, d_fd)
