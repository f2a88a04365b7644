"""Planar ANCF cable/beam element: one element, written for a single item and vmapped by callers.

An element has 8 absolute nodal coordinates, stored as ``e`` with shape ``(4, 2)``:
rows ``[r0, r0', r1, r1']`` (position and slope at both nodes), columns ``(x, y)``.
``x`` is the *stress-free* material coordinate, so ``|r'| = 1 + strain`` and pre-stretch
is simply a slope longer than one.

Measures used (they stay exact under pre-stretch and arbitrary rigid motion):

* axial strain, engineering:  ``eps = |r'| - 1``
* bending, material curvature: ``K = (r' x r'') / |r'|^2``  (= d(tangent angle)/dx)

``K`` makes a circle of stress-free length ``L0`` stress-free in bending-axial coupling: its
bending energy does not depend on stretch, so a released ring has zero axial force. The plain
``r' x r''`` overstates curvature by ``|r'|^3`` and must not be used on a pre-stretched belt.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float
from .._linalg import safe_norm

__all__ = [
    "gauss_legendre",
    "shape_functions",
    "element_mass_unit",
    "strain_measures",
    "element_forces",
    "element_energy",
]


def gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre points and weights on [0, 1] (numpy, static)."""
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


def shape_functions(xi, length):
    """Cubic Hermite shape functions and their first two x-derivatives at ``xi`` in [0, 1].

    Returns three arrays of shape ``xi.shape + (4,)``: S, dS/dx, d2S/dx2.
    """
    xi = jnp.asarray(xi)
    L = length
    s = jnp.stack(
        [1 - 3 * xi**2 + 2 * xi**3, L * (xi - 2 * xi**2 + xi**3), 3 * xi**2 - 2 * xi**3, L * (xi**3 - xi**2)],
        axis=-1,
    )
    ds = jnp.stack(
        [(-6 * xi + 6 * xi**2) / L, 1 - 4 * xi + 3 * xi**2, (6 * xi - 6 * xi**2) / L, 3 * xi**2 - 2 * xi],
        axis=-1,
    )
    dds = jnp.stack([(-6 + 12 * xi) / L**2, (-4 + 6 * xi) / L, (6 - 12 * xi) / L**2, (6 * xi - 2) / L], axis=-1)
    return s, ds, dds


def element_mass_unit(length) -> Float[Array, "4 4"]:
    """Scalar consistent mass matrix of one element per unit mass-per-length: ``L * int S S^T dxi``.

    The element's full 8x8 mass matrix is ``rhoA * kron(this, I2)``; it is constant (no
    velocity-dependent inertia terms in ANCF).
    """
    xg, wg = gauss_legendre(4)  # exact for degree 6
    s, _, _ = shape_functions(jnp.asarray(xg), length)
    return length * jnp.einsum("g,gi,gj->ij", jnp.asarray(wg), s, s)


def strain_measures(e: Float[Array, "4 2"], quad: dict):
    """Axial strain at the elastic and damping quadrature points, material curvature at the bending points."""

    def stretch_strain(dS):
        r = dS @ e
        return safe_norm(r[:, 0], r[:, 1]) - 1.0

    rpb = quad["dS_bend"] @ e
    rppb = quad["ddS_bend"] @ e
    cross = rpb[:, 0] * rppb[:, 1] - rpb[:, 1] * rppb[:, 0]
    stretch_sq = jnp.sum(rpb * rpb, axis=-1)
    curvature = cross / jnp.where(stretch_sq > 0, stretch_sq, 1.0)
    return stretch_strain(quad["dS_axial"]), stretch_strain(quad["dS_damp"]), curvature


def element_energy(e, length, EA, EI, quad):
    """Elastic strain energy of one element (used by tests and energy audits)."""
    eps, _, K = strain_measures(e, quad)
    return 0.5 * length * (EA * jnp.sum(quad["w_axial"] * eps**2) + EI * jnp.sum(quad["w_bend"] * K**2))


def element_forces(e, e_dot, length, EA, EI, axial_damping, bending_damping, quad):
    """Generalised internal force (elastic + Kelvin–Voigt axial + Rayleigh bending) on one element.

    Axial force ``N = EA eps + axial_damping * d(eps)/dt`` (Kelvin–Voigt, ``axial_damping = eta A``);
    bending moment ``M = EI (K + bending_damping * dK/dt)``, stiffness-proportional (Rayleigh)
    damping of the bending part. The force is the element's internal virtual work,
    ``-sum_g L w_g [N_g d(eps_g)/de + M_g d(K_g)/de]``, with the strain derivatives written out by
    hand: one product with the stacked shape-function derivatives ``D`` gives every slope and
    curvature vector, one product with ``D^T`` maps the section forces back (autodiff of
    ``strain_measures`` gives the same numbers with five times the operations; tests compare the two).

    The viscous axial stress is integrated with its own (2-point) rule: with the elastic 3-point
    rule the explicit damping bound is dt < 2 EA / (omega_max^2 eta A), about 1.7e-5 s for
    Benchmark A at 60 elements; the 2-point rule leaves the sub-element mode undamped and lifts
    the bound to about 4.5e-5 s, while converging to the same continuum damping.

    Returns the force acting ON the element's coordinates ``(4, 2)`` and the dissipation rate [W].
    """
    na, nd, nb = quad["w_axial"].shape[0], quad["w_damp"].shape[0], quad["w_bend"].shape[0]
    g = quad["D"] @ jnp.concatenate([e, e_dot], axis=1)  # (na + nd + 2 nb, 4): columns x, y, x_dot, y_dot
    x, y, xd, yd = g[:, 0], g[:, 1], g[:, 2], g[:, 3]
    ia, id_, ib, ibb = slice(0, na), slice(na, na + nd), slice(na + nd, na + nd + nb), slice(na + nd + nb, None)

    # axial: eps = |r'| - 1, d(eps)/d(r') = r'/|r'|
    s_a = safe_norm(x[ia], y[ia])
    ca = length * quad["w_axial"] * EA * (s_a - 1.0) / jnp.where(s_a > 0, s_a, 1.0)
    # Kelvin–Voigt: eps_dot = r'.r'_dot / |r'| at the damping points
    s_d = safe_norm(x[id_], y[id_])
    inv_d = 1.0 / jnp.where(s_d > 0, s_d, 1.0)
    eps_dot = (x[id_] * xd[id_] + y[id_] * yd[id_]) * inv_d
    cd = length * quad["w_damp"] * axial_damping * eps_dot * inv_d
    # bending: K = (r' x r'') / |r'|^2 and its derivatives with respect to r' (c) and r'' (d)
    cx, cy, dx, dy = x[ib], y[ib], x[ibb], y[ibb]
    cross = cx * dy - cy * dx
    sq = cx * cx + cy * cy
    inv_sq = 1.0 / jnp.where(sq > 0, sq, 1.0)
    K = cross * inv_sq
    dK_cx, dK_cy = (dy - 2.0 * K * cx) * inv_sq, (-dx - 2.0 * K * cy) * inv_sq
    dK_dx, dK_dy = -cy * inv_sq, cx * inv_sq
    K_dot = dK_cx * xd[ib] + dK_cy * yd[ib] + dK_dx * xd[ibb] + dK_dy * yd[ibb]
    cb = length * quad["w_bend"] * EI * (K + bending_damping * K_dot)

    section = jnp.stack(
        [
            jnp.concatenate([ca * x[ia], cd * x[id_], cb * dK_cx, cb * dK_dx]),
            jnp.concatenate([ca * y[ia], cd * y[id_], cb * dK_cy, cb * dK_dy]),
        ],
        axis=-1,
    )  # (rows of D, 2)
    dissipation = length * (
        axial_damping * jnp.sum(quad["w_damp"] * eps_dot**2) + EI * bending_damping * jnp.sum(quad["w_bend"] * K_dot**2)
    )
    return -(quad["D"].T @ section), dissipation


def make_quadrature(length, n_axial: int = 3, n_bend: int = 3, n_damp: int = 2) -> dict:
    """Shape-function derivatives at the quadrature points of one element (arrays, traceable in length)."""
    xa, wa = gauss_legendre(n_axial)
    xb, wb = gauss_legendre(n_bend)
    xd, wd = gauss_legendre(n_damp)
    _, dSa, _ = shape_functions(jnp.asarray(xa), length)
    _, dSb, ddSb = shape_functions(jnp.asarray(xb), length)
    _, dSd, _ = shape_functions(jnp.asarray(xd), length)
    return dict(
        dS_axial=dSa,
        w_axial=jnp.asarray(wa),
        dS_damp=dSd,
        w_damp=jnp.asarray(wd),
        dS_bend=dSb,
        ddS_bend=ddSb,
        w_bend=jnp.asarray(wb),
        D=jnp.concatenate([dSa, dSd, dSb, ddSb]),
    )  # every row the force kernel needs, stacked
