"""The drive step's stages and the carrier types, each checked alone, and the staged step against a
reference written out in one piece (the step as it was before it was split into stages)."""

from __future__ import annotations

import warnings
from pathlib import Path

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt._linalg import DenseRingOperator, from_xy, operator_bytes, safe_norm, xy_components
from jaxbelt import load_config
from jaxbelt.dynamics import PulleyParams
from jaxbelt.contact import Delassus, PointProblem, SolveSettings, nearest_pulley, point_kinematics, solve_contact
from jaxbelt.dynamics import kinetic_energy, step as st
from jaxbelt.pulleys import ArmCarrier, CARRIERS, FixedCarrier, SliderCarrier, carrier_centers
from jaxbelt.pulleys.carriers import PendulumCarrier

jax.config.update("jax_enable_x64", True)

ROOT = Path(__file__).resolve().parents[1]
H = 1e-3
GRAVITY = jnp.asarray([0.3, -9.81])


def _pulleys(p=3):
    f = lambda *x: jnp.asarray(x, dtype=float)  # noqa: E731
    mover = lambda **n: {k: jnp.asarray(v, dtype=float) for k, v in n.items()}  # noqa: E731
    return PulleyParams(
        radius=f(0.05, 0.04, 0.03),
        center=f([0.0, 0.0], [0.3, 0.1], [0.1, -0.2]),
        inertia=f(1e-3, 2e-3, 3e-3),
        speed=None,
        torque=None,
        viscous=f(0.0, 0.0, 0.0),
        carrier=(
            {},  # fixed
            # an arm; the same pulley as a pendulum's second idler (length and offset)
            mover(inertia=4e-3, mass=0.5, stiffness=30.0, preload=4.0, rest=0.9, damping=0.2, length=0.08, offset=0.4),
            mover(inertia=0.2, mass=0.7, stiffness=2e3, preload=50.0, rest=0.01, damping=5.0, direction=[0.6, 0.8]),
        ),
    )


CASES = [(FixedCarrier(), 0), (ArmCarrier(), 1), (SliderCarrier(), 2)]
RIDER = (PendulumCarrier(owner=0), 1)  # a pendulum's second idler: pulley 1 on pulley 0's arm, 0.4 rad further


def test_carrier_table_names_every_kind():
    assert {k: CARRIERS[k] for k in ("fixed", "arm", "slider")} == {
        "fixed": FixedCarrier,
        "arm": ArmCarrier,
        "slider": SliderCarrier,
    }
    assert all(name == cls.name for name, cls in CARRIERS.items())
    assert [c.movable for c, _ in CASES] == [False, True, True]
    assert FixedCarrier() == FixedCarrier() and hash(ArmCarrier()) == hash(ArmCarrier())  # static model fields


@pytest.mark.parametrize("carrier,k", [*CASES, RIDER])
def test_centre_derivative_is_the_jacobian_of_the_centre(carrier, k):
    pp = _pulleys()
    for psi in (0.0, 0.37, -1.2):
        jac = jax.jacfwd(lambda s: carrier.center(pp, k, s))(jnp.asarray(psi))
        np.testing.assert_allclose(carrier.dcenter(pp, k, jnp.asarray(psi)), jac, rtol=0, atol=1e-15)
    # batched coordinates: (..., 2)
    psi = jnp.linspace(-0.5, 0.5, 4)
    assert carrier.center(pp, k, psi).shape == (4, 2) and carrier.dcenter(pp, k, psi).shape == (4, 2)


@pytest.mark.parametrize("carrier,k", CASES[1:])
def test_stored_energy_derivative_is_minus_the_generalised_force(carrier, k):
    pp = _pulleys()
    for psi in (0.0, 0.37, -1.2):
        dV = jax.grad(lambda s: carrier.stored_energy(pp, k, s, GRAVITY))(jnp.asarray(psi))
        F = carrier.generalised_force(pp, k, jnp.asarray(psi), GRAVITY)
        assert abs(float(dV + F)) <= 1e-12 * max(1.0, abs(float(F)))


@pytest.mark.parametrize("carrier,k", CASES[1:])
def test_free_velocity_solves_the_implicit_spring_damper_step(carrier, k):
    pp = _pulleys()
    psi, pd = jnp.asarray(0.2), jnp.asarray(-0.7)
    pd1 = carrier.free_velocity(pp, k, psi, pd, H, GRAVITY)
    F = carrier.generalised_force(pp, k, psi, GRAVITY)
    # I (pd+ - pd) = h [F - k h pd+ - c pd+]
    n = pp.carrier[k]
    lhs = n["inertia"] * (pd1 - pd)
    rhs = H * (F - n["stiffness"] * H * pd1 - n["damping"] * pd1)
    assert abs(float(lhs - rhs)) < 1e-14
    m_eff = n["inertia"] + H * n["damping"] + H * H * n["stiffness"]
    assert float(carrier.inverse_mass(pp, k, H)) == pytest.approx(1.0 / float(m_eff), rel=1e-15)


def test_fixed_carrier_is_inert():
    pp, c = _pulleys(), FixedCarrier()
    np.testing.assert_array_equal(c.center(pp, 0, jnp.asarray(0.4)), pp.center[0])
    for value in (
        c.inverse_mass(pp, 0, H),
        c.free_velocity(pp, 0, 0.4, 2.0, H, GRAVITY),
        c.stored_energy(pp, 0, jnp.asarray(0.4), GRAVITY),
        c.kinetic_energy(pp, 0, jnp.asarray(2.0)),
    ):
        assert float(value) == 0.0


def test_a_pendulum_rider_moves_with_its_owners_coordinate_and_has_none_of_its_own():
    """The second idler of a pendulum sits on the owner's arm at its own length, turned by its ``offset`` from the
    owner's arm; it has no inertia, spring or energy of its own (those are the arm's, on the owner's coordinate)."""
    pp, (c, k) = _pulleys(), RIDER
    assert c.coordinate_of(k) == 0 and ArmCarrier().coordinate_of(k) == k and c.rides_another and not c.movable
    psi = 0.3
    expected = pp.center[k] + 0.08 * jnp.asarray([np.cos(psi + 0.4), np.sin(psi + 0.4)])
    np.testing.assert_allclose(c.center(pp, k, jnp.asarray(psi)), expected, rtol=0, atol=1e-15)
    for value in (
        c.inverse_mass(pp, k, H),
        c.free_velocity(pp, k, 0.4, 2.0, H, GRAVITY),
        c.stored_energy(pp, k, jnp.asarray(0.4), GRAVITY),
        c.kinetic_energy(pp, k, jnp.asarray(2.0)),
    ):
        assert float(value) == 0.0


def test_linalg_conventions():
    q = jnp.arange(24.0).reshape(6, 2, 2)
    x, y = xy_components(q)
    np.testing.assert_array_equal(from_xy(x, y), q)
    np.testing.assert_array_equal(x, q[:, :, 0].ravel())
    assert float(safe_norm(3.0, 4.0)) == 5.0 and float(safe_norm(0.0, 0.0)) == 0.0
    g = jax.grad(lambda a: safe_norm(a, 0.0))(0.0)
    assert float(g) == 0.0  # no NaN at the origin
    A = jnp.asarray(np.random.default_rng(0).normal(size=(5, 5)))
    op = DenseRingOperator(A)
    v = jnp.arange(5.0)
    np.testing.assert_array_equal(op.apply(v), v @ A)
    np.testing.assert_array_equal(op.diagonal(), jnp.diagonal(A))
    assert op.nbytes == 25 * 8 and op.shape == (5, 5)


@pytest.fixture(scope="module")
def serpentine():
    spec = load_config(ROOT / "examples" / "serpentine_tensioner.toml")
    spec.belt.n_elements = 32  # coarse on purpose (speed): the polygon-effect warning is expected
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return jb.build_drive(spec)


def test_operator_bytes_counts_the_stored_operators(serpentine):
    d = serpentine
    ops = jb.dynamics.drive_operators(d.model, d.params)
    mats = [
        ops.belt.mass,
        ops.belt.mass_inv,
        ops.contact.positions,
        ops.contact.positions_and_slopes,
        ops.contact.impulse_response,
        ops.contact.coupling,
    ]
    expected = sum(np.asarray(m.matrix).nbytes for m in mats)
    assert operator_bytes(ops) == expected
    assert operator_bytes(jax.eval_shape(jb.dynamics.drive_operators, d.model, d.params)) == expected


def test_kinetic_energy_sums_belt_pulleys_and_carriers(serpentine):
    d = serpentine
    ops = jb.dynamics.drive_operators(d.model, d.params)
    pp = d.params.pulleys
    rng = np.random.default_rng(1)
    v = jnp.asarray(rng.normal(size=d.state0.v.shape))
    omega, psi_dot = (jnp.asarray(rng.normal(size=d.model.n_pulleys)) for _ in range(2))
    T = kinetic_energy(ops.belt.mass, v, d.model, pp, omega, psi_dot)
    vf = np.asarray(v).reshape(-1, 2)
    assert float(T.belt) == pytest.approx(0.5 * np.sum(vf * (np.asarray(ops.belt.mass.matrix) @ vf)), rel=1e-13)
    assert float(T.pulleys) == pytest.approx(0.5 * float(jnp.sum(pp.inertia * omega**2)), rel=1e-14)
    movable = np.asarray(d.model.movable)
    assert any(movable)
    inertia = np.array([float(n["inertia"]) if m else 0.0 for n, m in zip(pp.carrier, movable)])
    expected = 0.5 * np.sum(inertia * np.asarray(psi_dot) ** 2)
    assert float(T.carriers) == pytest.approx(expected, rel=1e-14)
    assert float(T.total) == pytest.approx(float(T.belt + T.pulleys + T.carriers), rel=1e-15)


def _reference_step(model, params, ops, state, t, h):
    """The drive step in one piece, from the same formulas (no fault check): the stages must chain to it."""
    pp, cops, n_p = params.pulleys, ops.contact, model.n_pulleys
    settling = t < -0.5 * h
    md = jnp.where(settling, params.settle_damping, params.mass_damping)
    f_int, _ = jb.belt.internal_forces(state.q, state.v, params.belt, ops.belt)
    fx, fy = xy_components(f_int + ops.gravity)
    vx, vy = xy_components(state.v)
    Minv = ops.belt.mass_inv.matrix
    vfx, vfy = (vx + h * (fx @ Minv)) / (1.0 + h * md), (vy + h * (fy @ Minv)) / (1.0 + h * md)
    om_f, pd_f, _, _ = jb.pulleys.free_pulley_velocities(model, pp, state, t, h, params.gravity)
    inv_spin, inv_car = jb.pulleys.pulley_inverse_mass(model, pp, h)
    om_f, inv_spin = jnp.where(settling, 0.0, om_f), jnp.where(settling, 0.0, inv_spin)
    centers, dcenter = carrier_centers(model, pp, state.psi)
    rx, ry, stretch = point_kinematics(state.q, cops)
    fr = nearest_pulley(rx, ry, centers, pp.radius)
    own = (fr.pulley[:, None] == jnp.arange(n_p, dtype=fr.pulley.dtype)).astype(float)  # (nc, p) ownership as a matrix
    at = lambda x: own @ x  # noqa: E731
    dcx, dcy = at(dcenter[:, 0]), at(dcenter[:, 1])

    def response(Px, Py):
        torque = -((fr.lx * Py - fr.ly * Px) @ own)
        return inv_spin * torque, inv_car * -((dcx * Px + dcy * Py) @ own), torque

    def rel(wx, wy, om, pd):  # belt (nodal x, y) minus pulley velocity at the points, normal and tangential
        ux = wx @ cops.positions.matrix - (-at(om) * fr.ly + dcx * at(pd))
        uy = wy @ cops.positions.matrix - (at(om) * fr.lx + dcy * at(pd))
        return ux * fr.nx + uy * fr.ny, ux * fr.tx + uy * fr.ty

    def apply_G(ln, lt):
        Px, Py = ln * fr.nx + lt * fr.tx, ln * fr.ny + lt * fr.ty
        dom, dpd, _ = response(Px, Py)
        dux = Px @ cops.coupling.matrix - (-at(dom) * fr.ly + dcx * at(dpd))
        duy = Py @ cops.coupling.matrix - (at(dom) * fr.lx + dcy * at(dpd))
        return dux * fr.nx + duy * fr.ny, dux * fr.tx + duy * fr.ty

    active = (fr.gap < 0.0) | (state.lam_n > 0.0)
    split = at(jnp.maximum(active.astype(float) @ own, 1.0))
    diag = [
        cops.coupling_diag
        + split * at(inv_spin) * (fr.lx * d1 - fr.ly * d0) ** 2
        + split * at(inv_car) * (dcx * d0 + dcy * d1) ** 2
        for d0, d1 in ((fr.nx, fr.ny), (fr.tx, fr.ty))
    ]
    seg = jnp.tile(cops.length, model.n_elements) * stretch
    k_pt, d_pt = params.contact_stiffness * seg, params.contact_damping * seg
    mu = jnp.where(settling, 0.0, params.mu) * at(jnp.asarray(model.friction_factor))
    same = state.contact_pulley == fr.pulley.astype(state.contact_pulley.dtype)
    un, ut = rel(vfx, vfy, om_f, pd_f)
    problem = PointProblem(
        u_free_n=un,
        u_free_t=ut,
        bias_n=k_pt * fr.gap / (h * k_pt + d_pt),
        compliance_n=1.0 / (h * h * k_pt + h * d_pt),
        mu=mu,
    )
    settings = SolveSettings(
        iterations=model.lcp_iterations,
        relaxation=model.lcp_relaxation,
        friction_law=model.friction_law,
        friction_params=model.friction_law.coefficients(params),
    )
    warm = (jnp.where(same, state.lam_n, 0.0), jnp.where(same, state.lam_t, 0.0))
    ln, lt, _ = solve_contact(Delassus(apply_G, diag[0], diag[1]), problem, warm, settings)
    Px, Py = ln * fr.nx + lt * fr.tx, ln * fr.ny + lt * fr.ty
    B = cops.impulse_response.matrix
    v = from_xy(vfx + Px @ B, vfy + Py @ B)
    dom, dpd, _ = response(Px, Py)
    return dict(q=state.q + h * v, v=v, omega=om_f + dom, psi_dot=pd_f + dpd, lam_n=ln, lam_t=lt)


@pytest.mark.parametrize("t", [-1.0, 0.0])  # settling, then running
def test_staged_step_equals_the_reference_step(serpentine, t):
    d = serpentine
    ops = jb.dynamics.drive_operators(d.model, d.params)
    staged = eqx.filter_jit(st.drive_step)
    reference = eqx.filter_jit(_reference_step)
    s = d.state0
    for i in range(5):  # a few steps: warm starts and contact switch on
        ti = jnp.asarray(t + i * d.dt)  # an array: a Python float would be static and recompile each step
        ref = reference(d.model, d.params, ops, s, ti, d.dt)
        s = staged(d.model, d.params, ops, s, ti, d.dt)
        for name, value in ref.items():
            got = np.asarray(getattr(s, name))
            scale = max(float(np.max(np.abs(value))), 1e-300)
            assert np.max(np.abs(got - np.asarray(value))) <= 1e-9 * scale, (i, name)
    assert float(s.fault) == jb.dynamics.Fault.OK
    assert np.all(np.asarray(s.lam_n) >= 0.0) and np.any(np.asarray(s.lam_n) > 0.0)


def test_delassus_diagonal_bounds_the_operator_diagonal(serpentine):
    """With mass splitting the stage's diagonal is at least G's own diagonal, equal where no body is shared."""
    d = serpentine
    ops = jb.dynamics.drive_operators(d.model, d.params)
    s = d.state0
    phase = st.step_phase(d.params, 0.0, d.dt)
    forces = st.smooth_forces(d.params, ops, s)
    free = st.free_velocities(d.model, d.params, ops, s, forces, phase, 0.0, d.dt)
    frames = st.contact_frames(d.model, d.params, ops, s)
    diag = st.delassus_diagonal(ops, s, frames, free)
    nc = d.model.n_contacts
    fr = frames.frame
    G_nn = []
    for a in range(nc):  # G e_a, normal part at a
        e = jnp.zeros(nc).at[a].set(1.0)
        Px, Py = e * fr.nx, e * fr.ny
        dom, dpd, _ = frames.pulley_response(free, Px, Py)
        wx, wy = frames.pulley_velocity(dom, dpd)
        dux, duy = ops.contact.coupling.apply(Px) - wx, ops.contact.coupling.apply(Py) - wy
        G_nn.append(float((dux * fr.nx + duy * fr.ny)[a]))
    G_nn = np.asarray(G_nn)
    assert np.all(np.asarray(diag.n) >= G_nn * (1 - 1e-12))
    free_pts = np.asarray(fr.gap >= 0.0) & np.asarray(s.lam_n <= 0.0)
    active_per_pulley = np.bincount(np.asarray(fr.pulley)[~free_pts], minlength=d.model.n_pulleys)
    alone = active_per_pulley[np.asarray(fr.pulley)] <= 1
    np.testing.assert_allclose(np.asarray(diag.n)[alone], G_nn[alone], rtol=1e-12)


@pytest.mark.long
def test_a_saved_contact_residual_is_the_largest_of_the_steps_since_the_last_save():
    """``MoreauJean`` with ``substeps`` contact steps per saved step keeps the largest relative contact residual of
    them, not the last step's: a summary's ``lcp_residual_max`` is then every step's (until 2026-11-29 one step in a
    save interval's 10-30; measured on Benchmark A at 120 elements, implicit: 5.3e-4 from the saved steps, 1.2e-2
    from all). Benchmark A at 20 elements during the driver's ramp, 2 Jacobi sweeps so that the residuals differ
    from step to step: the same ``drive_step`` calls, one by one and as one macro step."""
    spec = jb.benchmark_a(n_elements=20, t_end=0.3)
    spec.solver.lcp_iterations = 2
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = jb.run(spec)
    d, state = run.drive, run.trajectory.final
    ops = st.drive_operators(d.model, d.params)
    k, t0 = 6, 0.3
    hs = (k * d.dt) / k  # MoreauJean's substep

    @jax.jit
    def both(y0):
        def one(i, c):
            y, res = c
            y1 = st.drive_step(d.model, d.params, ops, y, t0 + i * hs, hs)
            return y1, res.at[i].set(y1.lcp_residual)

        last, res = jax.lax.fori_loop(0, k, one, (y0, jnp.zeros(k)))
        macro = st.MoreauJean(substeps=k).advance((d.model, d.params, ops), t0, k * d.dt, y0)
        return res, last.lcp_residual, macro.lcp_residual, macro.q, last.q

    res, last, saved, q_macro, q_steps = (np.asarray(x) for x in both(state))
    assert np.all(res > 0.0) and res.max() > 1.2 * res[-1], res  # not the last step (measured: 1.41 x it)
    np.testing.assert_allclose(q_macro, q_steps, rtol=0, atol=1e-12)  # the same steps
    assert saved == pytest.approx(res.max(), rel=1e-6)
    assert last == res[-1]
