"""Physics checks of the single planar ANCF element (jaxbelt.belt.element) and the ring mass matrix.

Every comparison is against a closed-form result; tolerances are round-off level unless a
comment says otherwise.
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from jaxbelt.belt import (
    element_energy,
    element_forces,
    element_mass_unit,
    make_quadrature,
    ring_mass_matrix,
    shape_functions,
    strain_measures,
)

L = 0.07  # element length [m] (a belt element: ~1/20 of a 1.3 m belt)
EA = 1.0e4  # [N]
EI = 0.5  # [N m^2]
ETA = 2.0  # Kelvin-Voigt axial damping eta*A [N s]
BETA = 1.0e-3  # Rayleigh bending damping [s]
QUAD = make_quadrature(L)
ANGLES = [0.0, 0.3, 2.0, -2.9, math.pi]


def _rot(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s], [s, c]])


def _straight(stretch=1.0, angle=0.0, origin=(0.0, 0.0)):
    """Straight element of stress-free length L, uniformly stretched, at an angle."""
    t = _rot(angle) @ np.array([1.0, 0.0])
    o = np.asarray(origin, float)
    return jnp.asarray(np.stack([o, stretch * t, o + stretch * L * t, stretch * t]))


def _rigid(e, angle, shift):
    """Rigid motion of element coordinates: positions rotate and shift, slopes only rotate."""
    R = jnp.asarray(_rot(angle))
    out = e @ R.T
    return out.at[0].add(jnp.asarray(shift)).at[2].add(jnp.asarray(shift))


def _deformed(key):
    """A generic stretched and bent element (random perturbation of a straight one)."""
    return _straight(1.03) + 0.1 * jax.random.normal(key, (4, 2)) * jnp.asarray([[L], [1.0], [L], [1.0]])


# jitted once: eager op-by-op dispatch of the quadrature code is what would cost time here
_forces = jax.jit(lambda e, e_dot: element_forces(e, e_dot, L, EA, EI, ETA, BETA, QUAD))
_measures = jax.jit(lambda e: strain_measures(e, QUAD))
_energy_grad = jax.jit(jax.grad(lambda e: element_energy(e, L, EA, EI, QUAD)))
_energy_hess = jax.jit(jax.hessian(lambda e: element_energy(e, L, EA, EI, QUAD)))


# --------------------------------------------------------------------------- rigid motion / objectivity
@pytest.mark.parametrize("angle", ANGLES)
def test_stress_free_straight_element_any_pose_has_no_strain_and_no_force(angle):
    e = _straight(1.0, angle, origin=(0.3, -1.2))
    eps, eps_d, K = _measures(e)
    f, diss = _forces(e, jnp.zeros_like(e))
    # Round-off only: |r'| = 1 is formed from cos/sin of the angle (1e-16) and the
    # positions enter r'' divided by L^2 ~ 5e-3 (so K carries ~1e-13 of round-off).
    np.testing.assert_allclose(eps, 0.0, atol=1e-14)
    np.testing.assert_allclose(eps_d, 0.0, atol=1e-14)
    np.testing.assert_allclose(K, 0.0, atol=1e-12)
    # forces scale with EA ~ 1e4 N: 1e-9 N is round-off (EA * 1e-14 * O(10))
    np.testing.assert_allclose(f, 0.0, atol=1e-9)
    assert float(diss) == 0.0


@pytest.mark.parametrize("angle", ANGLES)
@pytest.mark.parametrize("stretch", [0.97, 1.05])
def test_prestretched_straight_element_exact_strain_and_rotated_force(angle, stretch):
    e = _straight(stretch, angle, origin=(-0.4, 0.9))
    eps, eps_d, K = _measures(e)
    # strain = stretch - 1 exactly (engineering strain of a uniformly stretched bar), K = 0
    np.testing.assert_allclose(eps, stretch - 1.0, rtol=0, atol=1e-14)
    np.testing.assert_allclose(eps_d, stretch - 1.0, rtol=0, atol=1e-14)
    np.testing.assert_allclose(K, 0.0, atol=1e-12)
    # closed form: generalized force = -N int S'(x) dx (x) t = N t on r0, -N t on r1, 0 on slopes
    N = EA * (stretch - 1.0)
    t = _rot(angle) @ np.array([1.0, 0.0])
    expected = np.stack([N * t, 0 * t, -N * t, 0 * t])
    f, _ = _forces(e, jnp.zeros_like(e))
    # |N| <= 500 N; 1e-9 relative is round-off through the 3-point quadrature sums
    np.testing.assert_allclose(f, expected, rtol=0, atol=1e-9 * abs(N))
    # objectivity: the force of the rotated element is the rotated force of the unrotated one
    f0, _ = _forces(_straight(stretch, 0.0), jnp.zeros_like(e))
    np.testing.assert_allclose(f, f0 @ _rot(angle).T, rtol=0, atol=1e-9 * abs(N))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_generic_element_is_objective_under_rigid_motion(seed):
    """Bent + stretched element: strains invariant, force rotates (not translates) with the body."""
    e = _deformed(jax.random.PRNGKey(seed))
    a, shift = 1.0 + seed, jnp.asarray([0.5, -2.0])
    e2 = _rigid(e, a, shift)
    m1, m2 = _measures(e), _measures(e2)
    for x1, x2 in zip(m1, m2):
        # strains O(0.1), curvatures O(10 1/m): round-off tolerances
        np.testing.assert_allclose(x2, x1, rtol=1e-11, atol=1e-12)
    f1, _ = _forces(e, jnp.zeros_like(e))
    f2, _ = _forces(e2, jnp.zeros_like(e))
    scale = float(jnp.max(jnp.abs(f1)))
    np.testing.assert_allclose(f2, f1 @ jnp.asarray(_rot(a)).T, rtol=0, atol=1e-11 * scale)
    # and the elastic force is exactly -grad(element_energy) (same quadrature rules)
    g = _energy_grad(e)
    np.testing.assert_allclose(f1, -g, rtol=0, atol=1e-11 * scale)
    # internal forces are self-equilibrated: zero resultant (translation invariance)
    np.testing.assert_allclose(f1[0] + f1[2], 0.0, atol=1e-11 * scale)


# --------------------------------------------------------------------------- mass
def test_element_mass_matrix_matches_closed_form_and_total_mass():
    M = np.asarray(element_mass_unit(L))
    ref = L * np.array(
        [
            [13 / 35, 11 * L / 210, 9 / 70, -13 * L / 420],
            [11 * L / 210, L**2 / 105, 13 * L / 420, -(L**2) / 140],
            [9 / 70, 13 * L / 420, 13 / 35, -11 * L / 210],
            [-13 * L / 420, -(L**2) / 140, -11 * L / 210, L**2 / 105],
        ]
    )
    np.testing.assert_allclose(M, ref, rtol=1e-12, atol=1e-16)  # 4-point Gauss is exact (degree 6)
    rhoA = 0.8288
    M8 = rhoA * np.kron(M, np.eye(2))
    for d in range(2):  # rigid translation in x, then y: u^T M u = rhoA L (the element's mass)
        u = np.kron(np.array([1.0, 0.0, 1.0, 0.0]), np.eye(2)[d])
        assert abs(u @ M8 @ u - rhoA * L) <= 1e-12 * rhoA * L


def test_ring_mass_matrix_total_mass():
    n, L0, rhoA = 17, 1.3, 0.8288
    M = np.asarray(ring_mass_matrix(n, L0 / n, rhoA))
    assert M.shape == (2 * n, 2 * n)
    np.testing.assert_allclose(M, M.T, rtol=0, atol=1e-15 * np.abs(M).max())  # assembly-order round-off
    pos = np.arange(0, 2 * n, 2)  # scalar DOF 2k = position of node k, 2k+1 = its slope
    total = M[np.ix_(pos, pos)].sum()
    assert abs(total - rhoA * L0) <= 1e-12 * rhoA * L0
    assert np.linalg.eigvalsh(M).min() > 0  # consistent mass of the closed loop is positive definite


# --------------------------------------------------------------------------- linearised stiffness
def _hermite_bending(L):
    return (
        EI
        / L**3
        * np.array(
            [
                [12, 6 * L, -12, 6 * L],
                [6 * L, 4 * L**2, -6 * L, 2 * L**2],
                [-12, -6 * L, 12, -6 * L],
                [6 * L, 2 * L**2, -6 * L, 4 * L**2],
            ]
        )
    )


def _cubic_axial(L):
    """EA int S'_i S'_j dx for the cubic Hermite axial interpolation, DOFs (u0, u0', u1, u1')."""
    return (
        EA
        / (30 * L)
        * np.array(
            [
                [36, 3 * L, -36, 3 * L],
                [3 * L, 4 * L**2, -3 * L, -(L**2)],
                [-36, -3 * L, 36, -3 * L],
                [3 * L, -(L**2), -3 * L, 4 * L**2],
            ]
        )
    )


@pytest.mark.parametrize("angle", [0.0, 0.7])
def test_linearised_stiffness_of_straight_element(angle):
    e0 = _straight(1.0, angle)
    H = _energy_hess(e0)  # (4, 2, 4, 2)
    t = _rot(angle) @ np.array([1.0, 0.0])
    nrm = _rot(angle) @ np.array([0.0, 1.0])
    Ktt = np.einsum("iajb,a,b->ij", H, t, t)  # axial (tangential) DOFs
    Knn = np.einsum("iajb,a,b->ij", H, nrm, nrm)  # transverse DOFs
    Ktn = np.einsum("iajb,a,b->ij", H, t, nrm)
    Kb, Ka = _hermite_bending(L), _cubic_axial(L)
    # Transverse block = classical Hermite beam stiffness EI/L^3[[12, 6L, ...]]: the axial term
    # contributes nothing at the stress-free state (eps = 0 and d eps/dy = 0) and the 3-point rule
    # integrates the quadratic (S'')^2 exactly. 1e-8 relative: round-off of a Hessian whose
    # entries span EI/L^3 ~ 1.5e3 to EA/L ~ 1.4e5.
    np.testing.assert_allclose(Knn, Kb, rtol=0, atol=1e-8 * np.abs(Kb).max())
    # Axial block: what we compare is the full 4x4 EA int S'S'^T (positions AND slopes), exact
    # for the quartic integrand with 3 Gauss points. It is not EA/L[[1,-1],[-1,1]] on the end
    # positions alone (with the slopes held that block is 36/30 EA/L, 20 % stiffer); statically
    # condensing the slope DOFs gives exactly the two-node bar EA/L[[1,-1],[-1,1]].
    np.testing.assert_allclose(Ktt, Ka, rtol=0, atol=1e-10 * np.abs(Ka).max())
    p, s = [0, 2], [1, 3]
    cond = Ktt[np.ix_(p, p)] - Ktt[np.ix_(p, s)] @ np.linalg.solve(Ktt[np.ix_(s, s)], Ktt[np.ix_(s, p)])
    np.testing.assert_allclose(cond, EA / L * np.array([[1, -1], [-1, 1]]), rtol=0, atol=1e-8 * EA / L)
    # no axial-bending coupling about the straight stress-free state
    np.testing.assert_allclose(Ktn, 0.0, atol=1e-9 * np.abs(Ka).max())


# --------------------------------------------------------------------------- damping
@pytest.mark.parametrize("seed", [0, 1])
def test_rigid_rate_gives_no_damping_force(seed):
    e = _deformed(jax.random.PRNGKey(10 + seed))
    omega, vel, centre = 3.7, jnp.asarray([1.5, -0.4]), jnp.asarray([0.02, 0.01])
    J = jnp.asarray([[0.0, -1.0], [1.0, 0.0]])
    # rigid velocity field: positions omega x (r - c) + v, slopes omega x r'
    e_dot = e @ J.T * omega
    e_dot = e_dot.at[0].add(vel - omega * (J @ centre)).at[2].add(vel - omega * (J @ centre))
    f_rate, diss = _forces(e, e_dot)
    f_static, _ = _forces(e, jnp.zeros_like(e))
    scale = float(jnp.max(jnp.abs(f_static)))
    # the strain and curvature rates of a rigid motion are zero up to round-off
    np.testing.assert_allclose(f_rate, f_static, rtol=0, atol=1e-11 * scale)
    assert abs(float(diss)) < 1e-20


def test_damping_dissipates_and_its_power_matches_the_dissipation_rate():
    key = jax.random.PRNGKey(7)
    for i in range(5):
        k1, k2, key = jax.random.split(key, 3)
        e = _deformed(k1)
        e_dot = jax.random.normal(k2, (4, 2)) * jnp.asarray([[1.0], [10.0], [1.0], [10.0]])
        f, diss = _forces(e, e_dot)
        f_el, _ = _forces(e, jnp.zeros_like(e))
        f_damp = f - f_el
        assert float(diss) > 0.0
        # the damping force does negative work equal to the reported dissipation (it is linear in
        # the rates, so f_total - f_elastic is exactly the damping force): round-off tolerance
        np.testing.assert_allclose(-jnp.sum(f_damp * e_dot), diss, rtol=1e-10)


def test_shape_functions_interpolate_nodes():
    s, ds, _ = shape_functions(jnp.asarray([0.0, 1.0]), L)
    np.testing.assert_allclose(s, [[1, 0, 0, 0], [0, 0, 1, 0]], atol=1e-15)
    np.testing.assert_allclose(ds, [[0, 1, 0, 0], [0, 0, 0, 1]], atol=1e-13)


# --------------------------------------------------------------------------- hand-written force kernel
def _autodiff_forces(e, e_dot):
    """Reference: the internal virtual work of strain_measures by jvp (rates) and vjp (back-mapping)."""
    measures = lambda x: strain_measures(x, QUAD)  # noqa: E731
    (eps, _, K), (_, eps_d_dot, K_dot) = jax.jvp(measures, (e,), (e_dot,))
    _, pullback = jax.vjp(measures, e)
    (g,) = pullback(
        (
            L * QUAD["w_axial"] * EA * eps,
            L * QUAD["w_damp"] * ETA * eps_d_dot,
            L * QUAD["w_bend"] * EI * (K + BETA * K_dot),
        )
    )
    diss = L * (ETA * jnp.sum(QUAD["w_damp"] * eps_d_dot**2) + EI * BETA * jnp.sum(QUAD["w_bend"] * K_dot**2))
    return -g, diss


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_hand_written_force_kernel_equals_autodiff_of_the_strain_measures(seed):
    """element_forces writes d(eps)/de and d(K)/de out by hand (5x fewer operations per step); it must be
    the exact derivative of strain_measures, elastic and viscous parts, and give the same dissipation."""
    k1, k2 = jax.random.split(jax.random.PRNGKey(seed))
    e = _deformed(k1)
    e_dot = jax.random.normal(k2, (4, 2)) * jnp.asarray([[1.0], [10.0], [1.0], [10.0]])
    f, diss = _forces(e, e_dot)
    f_ref, diss_ref = jax.jit(_autodiff_forces)(e, e_dot)
    scale = float(jnp.max(jnp.abs(f_ref)))
    np.testing.assert_allclose(f, f_ref, rtol=0, atol=1e-13 * scale)  # measured <= 6e-16 relative
    np.testing.assert_allclose(diss, diss_ref, rtol=1e-13)
