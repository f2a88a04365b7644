"""The implicit scheme's contact solve: a semismooth Newton (active-set) iteration on the velocities of belt
and pulleys together.

Under ``implicit_stiffness`` the belt's step mass carries ``theta h^2 K``: an impulse at one point moves the
belt over a few elements, and the Jacobi sweeps of ``contact.sweeps`` (each point alone, the others frozen)
then resolve the impulse distribution along an arc only slowly (measured: median relative residual 3e-3
after 8 sweeps, 2e-4 after 100 on the accessory example at h = 1e-4 s; slip arcs off by up to 70 %).
Here every iteration linearises each point's law at the last iterate

* normal, compliant: closed (``u_n + b < 0``) -> ``lam_n = -(u_n + b) / eps`` (the law itself), else 0;
* tangential (``AbstractFrictionLaw.linearised``): sticking -> ``lam_t = lam_hat - rho u_t`` (augmented
  Lagrangian, ``u_t = 0`` exactly at convergence), sliding -> the law's sliding force, which follows the
  normal impulse (``mu lam_n``: ``d lam_t / d lam_n`` by a jvp of the law, taken inside the linear solve);

and solves, for the velocity changes ``dz`` of the belt nodes, pulley spins and carriers at once,

    (A + J^T kappa J) dz = J^T (g - kappa u_free)        (A: the step's W and the pulleys' inertias)

``W`` plus the points' element blocks stays cyclic block-tridiagonal (``belt.implicit.factor_cyclic``); the
few pulley coordinates border it (a Schur complement of size <= 2 x pulleys). So sticking couples belt and
pulley inside the operator, not through sweeps. Carrier constraints (pivot friction, stops, clutches) enter
the same way: each carrier's exact local law (``constraint_impulse``) is linearised about the last iterate
along its own direction (held: a penalty towards the velocity its law holds; sliding or compliant: its slope),
so a clutch engaged on a sheave the belt sticks to is one body in the solve (block Gauss-Seidel between
contacts and carriers cycled on the accessory example). Each Newton step is followed by a line search over
``LINE_SEARCH`` by the laws' residual; an iteration whose penalties are those of the last one (no point or
carrier changed its linearisation) reuses its factor. The trip count is static (``solver.lcp_iterations``;
iterations after convergence are skipped at run time).

Derivatives (both modes) are the root's, not the iterations' (``_root_of``, a custom JVP; the implicit function
theorem): the iteration runs on inputs whose derivatives are stopped, and the solution's tangent is one linear
solve of the laws linearised there (``_tangent_solve``). Measured (2026-11-28): through the iterations the
derivatives on the accessory example (arm tensioner with pivot friction, clutch) were NaN; reverse mode through
Benchmark A 60 el. costs 799 instead of 1,770 us per step, forward mode (3 tangents) 720 against 739.
"""

from __future__ import annotations

import functools
import typing
from typing import Callable

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._branch import batch_cond
from ..belt.implicit import CyclicFactor, factor_cyclic, node_blocks, point_loads, point_values, solve_factored

from ..contact.sweeps import PointProblem, SolveSettings

if typing.TYPE_CHECKING:
    from .step import ContactFrames, FreeVelocities

__all__ = [
    "newton_contact",
    "newton_system",
    "linear_solve",
    "LinearOptions",
    "CarrierLaws",
    "PulleyUnknowns",
    "STICK_PENALTY",
    "PENALTY_STEP",
    "TRIAL_PENALTY",
    "LINE_SEARCH",
    "CONVERGED",
]

# rho = STICK_PENALTY x a point's mass (1 / its plain-mass Delassus diagonal) x h / PENALTY_STEP: the augmented
# Lagrangian's sticking error shrinks by about 1 / (1 + rho G) per iteration, G a point's compliance through the step's
# operator, which falls as the step grows (G ~ 1 / h where the scaled stiffness dominates; measured G m 0.27 on
# Benchmark A 120 el. at 5e-5 s, 0.11 / 0.05 on the stiff serpentine at 5e-5 / 1.5e-4 s). Too stiff a penalty cycles:
# neighbouring points at the end of a stick arc, their friction at opposite bounds, switch stick <-> slip together and
# the Newton step comes back to the same point every 4-5 iterations; too soft a one converges slowly. Measured
# (Benchmark A 120 el., first 0.35 s, every step; steps above 1e-3 / largest): at 5e-5 s 1e4 x m (the value until
# 2026-11-29) 327 of 7,001 / 0.12, 3e3 0 / 2.5e-5, 1e3 0 / 1.0e-6, 1e2 0 / 3.8e-5; at 2.5e-5 s 3e3 0 of 14,001 /
# 8.9e-4, 1e3 and 5e2 0 / 1.0e-6 (1e4 over the whole 2.45 s: 16,740 of 98,001 / 2.4). The stiff serpentine at
# 1.5e-4 s (0.2 s): 1e3 median 1.9e-5 (8 iterations too few), 3e3 8.3e-7 / largest 8.0e-4, 1e4 5.3e-7 but 4 steps
# above 1e-3 (4.3e-3). So the penalty follows the step: 1e3 x m at 5e-5 s, 3e3 at 1.5e-4 s, 500 at 2.5e-5 s (and the
# trial penalty below with it).
STICK_PENALTY = 1e3
PENALTY_STEP = 5e-5  # s
# The laws decide stick or slip with the trial ``lam - u / d`` of a point compliance d = 1 / (TRIAL_PENALTY x its
# mass x h / PENALTY_STEP). Measured (with the line search; a fixed 30 x m until 2026-11-29) on Benchmark A 40 el. at
# 1e-4 s / 60 el. at 2e-4 s and the accessory example at 1e-4 s, largest residual of any saved step 3.5e-8 / 2.6e-7 /
# 1.4e-4 with 30, 2.3e-10 / 4.9e-11 / 2.2e-4 with 10; 1 (the Jacobi diagonal) left 2-cycles of stick and slip, 100
# stagnated (0.67). With the sticking penalty following the step (2026-11-29), every step, 0.3-0.5 s: Benchmark A 20 el.
# at 5e-5 s 30 x m: 6 steps above 1e-3 (a sliding point whose direction flipped each iteration), 10 / 3: none above
# 1e-6; 120 el. 10 / 3: none; the stiff serpentine at 1.5e-4 s 10 / 3 x m (not following the step): 7 / 22 steps above
# 1e-3, 30: none - the trial, too, follows the step. 10 instead of 30 at 5e-5 s: fewer iterations (Benchmark A 120 el.
# 221 -> 189 us per step, the accessory example 406 -> 387).
TRIAL_PENALTY = 10.0
# A solve whose laws' residual is below this fraction of the largest normal impulse has converged (the targets are
# 1e-4 median, 1e-3 at most). 1e-6, not 1e-11 (until 2026-11-28): on the accessory example at 5e-5 s 566 -> 429 us
# per step (5.7 Newton iterations per step during start-up), every figure of the run unchanged to 3 digits
# (arcs, amplitudes, tensions, energy audit); reported residual median 7.8e-8, largest 9.9e-7 (1e-11: 1.5e-12 /
# 5.1e-7). Looser gains little more: 400 us at 1e-5, 378 at 1e-4.
CONVERGED = 1e-6
# the trial steps along each Newton direction, the best by the laws' residual taken ((1, 0.5, 0.25) stalled at
# 0.04 in one step of Benchmark A 40 el.)
LINE_SEARCH = (1.0, 0.5, 0.25, 0.1)
# A sliding point's friction follows its normal impulse (mu lam_n): lagged by one iteration, that coupling alone
# made the solve converge linearly (about 7 x per iteration on the accessory example at 1e-4 s during start-up:
# median residual 9e-5 after 3 iterations, largest 4.5e-6 after 8; 7.9 iterations per step to 1e-11). Re-solving
# with the updated friction (the factor reused) takes it into the Newton step: 3e-7 after 3, 3e-9 after 8; 6.5
# iterations per step with one re-solve, 5.8 with two (measured 2026-11-28; more re-solves change nothing).
COUPLING_SWEEPS = 1
# ... but a re-solve is skipped where the friction would change by less than this fraction of the laws' residual
# the iteration is correcting (Benchmark A converged in 3 iterations with or without it: its re-solves were 16 %
# of the step)
COUPLING_SKIP = 1e-2
# The solution's tangent (``_tangent_solve``): a sticking point's velocity constraint as a stiff penalty
# (TANGENT_PENALTY x its mass, the iteration's too until 2026-11-29; 1e6 lost the linear solve's accuracy: measured
# on Benchmark A 60 el., the preconditioned error's spectral radius 3e4, against 3e-3 at 1e4), and refinements
# against the exact linearised laws (each two more solves with the same factor) that remove the error the penalty
# and the lagged friction-normal coupling leave
TANGENT_PENALTY = 1e4
TANGENT_REFINEMENTS = 2
TANGENT_COUPLING_SWEEPS = 1
# False: derivatives through the iterations instead (as before 2026-11-28), for comparison; read while tracing
IMPLICIT_TANGENT = True


def _point_vectors(cx, cy, shape):
    """Each point's belt vector ``S_i^T d`` (direction ``d = (cx, cy)`` per point) as its element's two node
    4-vectors ``(n, m, 2, 4)``."""
    m = shape.shape[0]
    dx, dy = cx.reshape(-1, m, 1), cy.reshape(-1, m, 1)
    s0, s1 = shape[None, :, 0:2], shape[None, :, 2:4]
    return jnp.stack([jnp.concatenate([s0 * dx, s0 * dy], -1), jnp.concatenate([s1 * dx, s1 * dy], -1)], axis=2)


def _point_load_columns(Px, Py, shape):
    """``S^T P`` (``belt.implicit.point_loads``) for several columns of point forces ``(nc, q)``: ``(n, 4, q)``."""
    return jax.vmap(point_loads, in_axes=(1, 1, None), out_axes=-1)(Px, Py, shape)


def _solve_small(A, b):
    """``A x = b`` (``b`` (q,) or (q, r)) for a small SPD matrix (the pulleys' Schur complement): Gauss-Jordan
    elimination without pivoting on ``[A | b]``, unrolled, one elementwise update per pivot (XLA's CPU runtime
    pays per operation; a batched LAPACK call deadlocks its CPU pool, see ``belt.ring``)."""
    q = A.shape[0]
    M = jnp.concatenate([A, b.reshape(q, -1)], axis=1)
    index = np.arange(q)[:, None]
    for i in range(q):
        row = M[i] / M[i, i]
        M = jnp.where(index == i, row[None, :], M - M[:, i : i + 1] * row[None, :])
    return M[:, q:].reshape(b.shape)


class _System(typing.NamedTuple):
    """The linear pieces that do not change between iterations. Pulley coordinates: the spins that can turn,
    then the carriers that can move (or carry a constraint), ``q`` in all."""

    an: jax.Array  # (n, m, 2, 4) belt vectors of the normal directions
    at: jax.Array  # tangential
    Ln: jax.Array  # (nc, q) pulley coordinates -> normal surface velocity at the points
    Lt: jax.Array
    mass: jax.Array  # (q,) pulley spin inertias and carrier masses (1 where a coordinate is held)
    free: jax.Array  # (q,) bool: the coordinate moves under impulses
    spins: tuple  # the pulleys whose spin is a coordinate (static)
    carriers: tuple  # the pulleys whose carrier is one

    def coordinates(self, omega, psi_dot):
        """The coordinates' values among all pulleys' spins and carriers."""
        spins, carriers = np.asarray(self.spins, dtype=int), np.asarray(self.carriers, dtype=int)
        return jnp.concatenate([omega[spins], psi_dot[carriers]])

    def pulleys(self, w, omega, psi_dot):
        """All pulleys' spins and carriers: ``omega``, ``psi_dot`` with the coordinates set to ``w``."""
        ns = len(self.spins)
        return (
            omega.at[np.asarray(self.spins, dtype=int)].set(w[:ns]),
            psi_dot.at[np.asarray(self.carriers, dtype=int)].set(w[ns:]),
        )


class CarrierLaws(typing.NamedTuple):
    """The carriers' constraints for the Newton solve: ``local(env, omega, psi_dot) -> lam_c`` (p,) each carrier's
    exact impulse given the velocities without it (``env``: what it reads besides them, an argument so that the
    iteration can stop its derivatives), ``direction`` (omega, psi_dot) the velocity change per unit impulse of
    each carrier (its ``constraint_response`` at lam = 1), and ``warm`` the last step's impulses."""

    local: Callable
    env: typing.Any
    direction: tuple
    warm: jax.Array


class PulleyUnknowns(typing.NamedTuple):
    """The pulleys whose spin / carrier can move at all (static): the others never enter the solve."""

    spins: tuple
    carriers: tuple


def newton_system(frames: ContactFrames, free: FreeVelocities, unknowns: PulleyUnknowns) -> _System:
    """The pieces of the linear solves that stay fixed over the iterations of one step."""
    spins, carriers = unknowns
    fr = frames.frame
    tx, ty = fr.tx, fr.ty
    owner = (fr.pulley[:, None] == jnp.arange(frames.n_pulleys, dtype=fr.pulley.dtype)).astype(fr.lx.dtype)
    lever_n = fr.lx * fr.ny - fr.ly * fr.nx  # spin -> surface velocity along n / t at the point
    lever_t = fr.lx * ty - fr.ly * tx
    s_idx, c_idx = np.asarray(spins, dtype=int), np.asarray(carriers, dtype=int)
    carried = owner  # point -> the carrier coordinate that moves its pulley (a pendulum's second idler: the arm's)
    if frames.carrier_of is not None:
        coordinate = jnp.asarray(np.asarray(frames.carrier_of))[fr.pulley]
        carried = (coordinate[:, None] == jnp.arange(frames.n_pulleys, dtype=coordinate.dtype)).astype(fr.lx.dtype)
    Ln = [lever_n[:, None] * owner[:, s_idx], (frames.dcx * fr.nx + frames.dcy * fr.ny)[:, None] * carried[:, c_idx]]
    Lt = [lever_t[:, None] * owner[:, s_idx], (frames.dcx * tx + frames.dcy * ty)[:, None] * carried[:, c_idx]]
    inv_all = jnp.concatenate([free.inv_spin[s_idx], free.inv_carrier[c_idx]])
    moving = inv_all > 0.0
    assert free.implicit is not None, "the Newton contact solve needs the implicit scheme's operator W"
    shape = free.implicit.shape
    return _System(
        an=_point_vectors(fr.nx, fr.ny, shape),
        at=_point_vectors(tx, ty, shape),
        Ln=jnp.concatenate(Ln, axis=1),
        Lt=jnp.concatenate(Lt, axis=1),
        mass=jnp.where(moving, 1.0 / jnp.where(moving, inv_all, 1.0), 1.0),
        free=moving,
        spins=tuple(spins),
        carriers=tuple(carriers),
    )


def _penalised(sys: _System, frames: ContactFrames, free: FreeVelocities, kn, kt, rows):
    """The linear pieces of one set of penalties: ``W + S^T kappa S`` factored, the belt-pulley coupling as nodal
    loads ``C`` (n, 4, q) and the pulley block ``P`` (q, q) (``rows``: the carriers' ``(a, kappa, g)``, their
    loads ``a^T g`` are the right-hand side's)."""
    assert free.implicit is not None
    fr, shape = frames.frame, free.implicit.shape
    tx, ty = fr.tx, fr.ty
    m = shape.shape[0]
    kn_e, kt_e = kn.reshape(-1, m), kt.reshape(-1, m)
    blocks = "em,emkx,emly->eklxy"  # each point's penalty kappa a a^T on its element's two nodes
    E = jnp.einsum(blocks, kn_e, sys.an, sys.an) + jnp.einsum(blocks, kt_e, sys.at, sys.at)
    factor = factor_cyclic(*node_blocks(free.implicit.blocks + E))
    cn, ct = -kn[:, None] * sys.Ln, -kt[:, None] * sys.Lt  # (nc, q): belt-pulley coupling as point forces
    C = _point_load_columns(cn * fr.nx[:, None] + ct * tx[:, None], cn * fr.ny[:, None] + ct * ty[:, None], shape)
    P = (sys.Ln.T * kn) @ sys.Ln + (sys.Lt.T * kt) @ sys.Lt
    if rows is not None:
        a, kc, _ = rows
        P = P + (a.T * kc) @ a
    held = ~sys.free
    C = jnp.where(held[None, None, :], 0.0, C)
    P = jnp.where(held[:, None] | held[None, :], 0.0, P) + jnp.diag(sys.mass)
    return factor, C, P


def _loads(sys: _System, frames: ContactFrames, shape, lin, u_free, g_t, rp_rows):
    """The point forces ``g - kappa u_free`` on the belt nodes (n, 4) and the pulley coordinates (q,)."""
    kn, gn, kt = lin[:3]
    un_f, ut_f = u_free
    fr = frames.frame
    rn, rt = gn - kn * un_f, g_t - kt * ut_f
    rb = point_loads(rn * fr.nx + rt * fr.tx, rn * fr.ny + rt * fr.ty, shape)  # (n, 4)
    return rb, jnp.where(~sys.free, 0.0, rp_rows - (sys.Ln.T @ rn + sys.Lt.T @ rt))


class _Border(typing.NamedTuple):
    """The belt's penalised solve bordered by the pulley coordinates: its factor, the coupling columns ``C``
    (n, 4, q), their belt solves ``YC`` and the inverse of the pulleys' Schur complement (q, q)."""

    factor: CyclicFactor
    C: jax.Array
    YC: jax.Array
    schur_inv: jax.Array


def _border(factor, C, P, YC) -> _Border:
    """The bordered system from ``_penalised``'s pieces and the belt solves of ``C``."""
    schur_inv = _solve_small(P - jnp.einsum("nxj,nxk->jk", C, YC), jnp.eye(P.shape[0], dtype=P.dtype))
    return _Border(factor, C, YC, schur_inv)


def _velocities(sys: _System, frames: ContactFrames, shape, border: _Border, u_free, y, rp):
    """Point velocities and pulley-coordinate changes from the belt solve ``y`` of the loads (the pulleys'
    Schur complement closing the bordered system)."""
    fr = frames.frame
    _, C, YC, schur_inv = border
    w = schur_inv @ (rp - jnp.einsum("nxj,nx->j", C, y))
    vx, vy = point_values(y - jnp.einsum("nxj,j->nx", YC, w), shape)
    return u_free[0] + vx * fr.nx + vy * fr.ny - sys.Ln @ w, u_free[1] + vx * fr.tx + vy * fr.ty - sys.Lt @ w, w


def _solve_loads(sys: _System, frames: ContactFrames, shape, border: _Border, lin, u_free, g_t, rp_rows):
    """``_velocities`` of the loads of ``lin`` with the tangential ``g_t``: one more solve with the factor."""
    rb, rp = _loads(sys, frames, shape, lin, u_free, g_t, rp_rows)
    return _velocities(sys, frames, shape, border, u_free, solve_factored(border.factor, rb[..., None])[..., 0], rp)


def penalised_border(sys: _System, frames: ContactFrames, free: FreeVelocities, kn, kt, rows, rb):
    """The bordered penalised system of one set of penalties (``_penalised``, ``_border``) and the belt solve of
    ``rb`` (n, 4), in the same solve as the coupling columns (one pass through the factor for all of them)."""
    factor, C, P = _penalised(sys, frames, free, kn, kt, rows)
    Y = solve_factored(factor, jnp.concatenate([rb[..., None], C], axis=-1))
    return _border(factor, C, P, Y[..., 1:]), Y[..., 0]


class LinearOptions(typing.NamedTuple):
    """How ``linear_solve`` runs: ``skip_below`` (the coupling re-solve's threshold), ``batched`` (the run is a
    sweep's vmapped program: ``batch_cond``) and ``reuse = (border, same)`` (a bordered factor of the same
    penalties, used when ``same``)."""

    skip_below: typing.Any = 0.0
    batched: bool = False
    reuse: tuple | None = None


def linear_solve(
    sys: _System,
    frames: ContactFrames,
    free: FreeVelocities,
    lin,
    u_free,
    rows=None,
    options: LinearOptions = LinearOptions(),
):
    """Point velocities ``(u_n, u_t)``, pulley-coordinate changes ``dw (q,)`` and the tangential ``g_t`` applied,
    after ``(A + J^T kappa J) dz = J^T (g - kappa u_free)``: the point impulses ``g - kappa u`` applied to belt
    (through W) and pulleys; and the bordered factor used. ``lin = (kappa_n, g_n, kappa_t, g_t, c_tn, lam_ref)`` the
    points' linearised laws, ``u_free`` their free velocities ``(u_n, u_t)``. With ``c_tn`` (a sliding point's
    ``d lam_t / d lam_n``) the tangential law follows the normal impulse, ``g_t + c_tn (lam_n - lam_ref)``: an
    unsymmetric coupling, taken by ``COUPLING_SWEEPS`` re-solves with the same (symmetric) factor, each skipped where
    the friction would change by no more than ``skip_below``; the ``g_t`` returned is the one the last solve applied,
    so impulses and velocities stay consistent (``batched``: the run is a sweep's vmapped program, ``batch_cond``).
    ``rows``: the carriers' linearised laws ``(a (p, q), kappa (p,), g (p,))``, impulses ``g - kappa a . w`` on
    the pulley coordinates ``w`` (free velocities included in ``g``). ``options.reuse = (border, same)``: a
    bordered factor of the same penalties when ``same`` (the last iteration's, unchanged where no point or carrier
    changed its linearisation), used instead of factoring again."""
    skip_below, batched, reuse = options
    kn, gn, kt, gt, c_tn, lam_ref = lin
    assert free.implicit is not None
    shape = free.implicit.shape
    rp_rows = 0.0 if rows is None else rows[0].T @ rows[2]
    rb, rp = _loads(sys, frames, shape, lin, u_free, gt, rp_rows)
    if reuse is None:
        border, y = penalised_border(sys, frames, free, kn, kt, rows, rb)
    else:
        # measured: 1.6 of 4.4 iterations per step on the accessory example change no penalty (1.0 of 2.2 on
        # Benchmark A); reusing their factor saves 6 % of the accessory example's step (nothing measurable on
        # Benchmark A's)
        last, same = reuse
        border, y = (batch_cond if batched else jax.lax.cond)(
            same,
            lambda o: (o[0], solve_factored(o[0].factor, o[1][..., None])[..., 0]),
            lambda o: penalised_border(sys, frames, free, kn, kt, rows, o[1]),
            (last, rb),
        )
    un, ut, w = _velocities(sys, frames, shape, border, u_free, y, rp)

    def resolve(carry):
        g_t = gt + c_tn * (gn - kn * carry[0] - lam_ref)
        return *_solve_loads(sys, frames, shape, border, lin, u_free, g_t, rp_rows), g_t

    out = (un, ut, w, gt)
    for _ in range(COUPLING_SWEEPS):
        # skipped at run time where the friction's change is far below what the iteration is correcting (a drive
        # that converges without it: Benchmark A); vmapped, both branches run unless the run is batched
        shift = jnp.max(jnp.abs(c_tn * (gn - kn * out[0] - lam_ref)), initial=0.0)
        out = (batch_cond if batched else jax.lax.cond)(shift > skip_below, resolve, lambda c: c, out)
    return out, border


class _Laws:
    """One step's contact and carrier laws on given inputs, and the velocities that impulses give (affine in them):
    built on the inputs with their derivatives stopped for the iteration, and on the live inputs for the
    derivative of its solution (``newton_contact``)."""

    def __init__(self, frames, free, problem: PointProblem, settings: SolveSettings, unknowns, carrier_laws):
        self.frames, self.free, self.fr = frames, free, frames.frame
        self.u_free_n, self.u_free_t = problem.u_free_n, problem.u_free_t
        self.bias, self.eps = problem.bias_n, problem.compliance_n
        assert problem.point_mass is not None, "the Newton solve scales its penalties by the points' masses"
        self.point_mass, self.friction_law = problem.point_mass, settings.friction_law
        self.params = settings.law_params(problem.mu)
        self.sys = sys = newton_system(frames, free, unknowns)
        assert problem.step is not None, "the Newton solve's penalties grow with the step"
        grow = problem.step / PENALTY_STEP  # both penalties follow the step (a point's compliance falls as it grows)
        self.stick = STICK_PENALTY * grow  # per unit mass
        self.rho = self.stick * self.point_mass
        self.point_compliance = 1.0 / (TRIAL_PENALTY * grow * self.point_mass)
        self.w_free = sys.coordinates(free.omega, free.psi_dot)
        self.carrier_laws = carrier_laws
        self.carriers = carrier_laws is not None
        if carrier_laws is not None:
            d_omega, d_psi = carrier_laws.direction  # (p,) each: velocity change per unit impulse
            self.direction = sys.coordinates(jnp.diag(d_omega).T, jnp.diag(d_psi).T).T  # (p, q)
            inv = 1.0 / sys.mass  # 1 where held: its direction entry is 0 there
            self.a = jnp.where(sys.free[None, :], self.direction / inv[None, :], 0.0)  # the constraint rows: c = a . w
            self.m_c = 1.0 / jnp.maximum(jnp.sum(self.a * self.direction, axis=1), 1e-300)  # each one's own mass
        self.inv_w = jnp.where(sys.free, 1.0 / sys.mass, 0.0)

    def normal_law(self, un):  # the compliant normal law at a normal velocity
        return jnp.maximum(0.0, -(un + self.bias) / self.eps)

    def friction(self, lam_t, ut, lam_n):  # the friction law's impulse, the others frozen
        return self.friction_law.local_update(lam_t, ut, self.point_compliance, lam_n, self.params)

    def carrier_local(self, wo):  # each carrier's exact impulse given the velocities without the carriers' own
        assert self.carrier_laws is not None
        cl = self.carrier_laws
        return cl.local(cl.env, *self.sys.pulleys(wo, self.free.omega, self.free.psi_dot))

    def linearised(self, ut, applied_t, lam_n, closed):
        """The laws about the solve's velocities (``lam_n`` the normal impulses they give), for the next solve;
        and the friction impulses there. A sliding point's friction follows its normal impulse (``c_tn``)."""
        law = lambda ln: self.friction_law.linearised(applied_t, ut, self.point_compliance, ln, self.params)
        (new_t, gt, kt, stick), (c_tn, *_) = jax.jvp(law, (lam_n,), (jnp.ones_like(lam_n),))
        lin = (
            jnp.where(closed, 1.0 / self.eps, 0.0),
            jnp.where(closed, -self.bias / self.eps, 0.0),
            jnp.where(stick, self.rho, kt),
            gt,
            jnp.where(stick, 0.0, c_tn),
            lam_n,
        )
        return new_t, lin

    def laws(self, un, ut, applied_t):
        """The contact laws at the solve's velocities and their linearisation for the next solve."""
        new_n = self.normal_law(un)
        new_t, lin = self.linearised(ut, applied_t, new_n, new_n > 0.0)
        return new_n, new_t, lin

    def carrier_lin(self, w, applied_c):
        """Each carrier's exact impulse at the solve's velocities and its law about it: impulses ``g - kappa a . w``
        (held: a penalty towards the velocity its law holds)."""
        wo = w - self.direction.T @ applied_c  # the velocities without the carriers' own impulses
        # slope: per unit impulse
        new, slope = jax.jvp(self.carrier_local, (wo,), (self.direction.T @ jnp.ones_like(applied_c),))
        c_new = self.a @ wo + new / self.m_c
        held = slope < -1.0 + 1e-9
        kc = jnp.where(held, self.stick * self.m_c, -slope * self.m_c / jnp.where(held, 1.0, 1.0 + slope))
        return new, (kc, new + kc * c_new)

    def velocities_at(self, lam):
        """Point velocities and pulley coordinates under impulses ``lam = (n, t, c)`` (affine in them)."""
        lam_n, lam_t, lam_c = lam
        fr, implicit = self.fr, self.free.implicit
        assert implicit is not None
        vx, vy = implicit.at_points(implicit.response(lam_n * fr.nx + lam_t * fr.tx, lam_n * fr.ny + lam_t * fr.ty))
        force = -(self.sys.Ln.T @ lam_n + self.sys.Lt.T @ lam_t)
        if self.carriers:
            force = force + self.a.T @ lam_c
        dw = self.inv_w * force
        un = self.u_free_n + vx * fr.nx + vy * fr.ny - self.sys.Ln @ dw
        return (un, self.u_free_t + vx * fr.tx + vy * fr.ty - self.sys.Lt @ dw), self.w_free + dw

    def residuals(self, lam, u, w):
        """Each law's residual (impulse minus the law's impulse at the velocities): zero at the solution."""
        lam_n, lam_t, lam_c = lam
        rn = lam_n - self.normal_law(u[0])
        rt = lam_t - self.friction(lam_t, u[1], jnp.maximum(lam_n, 0.0))
        if not self.carriers:
            return rn, rt, jnp.zeros(())
        return rn, rt, lam_c - self.carrier_local(w - self.direction.T @ lam_c)

    def merit(self, lam, u, w):
        return sum(jnp.sum(r * r) for r in self.residuals(lam, u, w))

    def root(self, lam):
        """The laws' residuals at the impulses ``lam`` (a carrier-free solve's placeholder ``lam[2]`` its own)."""
        rn, rt, rc = self.residuals(lam, *self.velocities_at(lam))
        return rn, rt, rc if self.carriers else lam[2]


def _iterate(L: _Laws, warm, carrier_warm, settings: SolveSettings):
    """The semismooth Newton iteration from the warm start: the laws' impulses at the last iterate's velocities
    ``(lam_n, lam_t, lam_c)`` and the relative residual."""
    fr = L.frames.frame
    lam_n0, lam_t0 = warm
    if L.carriers:
        lam_c0 = carrier_warm
        clin0 = (jnp.zeros_like(lam_c0), lam_c0)
    else:
        lam_c0, clin0 = jnp.zeros(()), (jnp.zeros(()), jnp.zeros(()))

    # the first linearisation: last step's contact set and impulses at their velocities
    lam0 = (lam_n0, lam_t0, lam_c0)
    u0, w0 = L.velocities_at(lam0)
    _, lin0 = L.linearised(u0[1], lam_t0, lam_n0, (lam_n0 > 0.0) | (fr.gap < 0.0))
    steps = jnp.asarray(LINE_SEARCH, L.u_free_n.dtype)

    def body(i, carry):
        lam, u, w, lin, (kc, gc), last_change, last, key = carry
        rows = None if not L.carriers else (L.a, kc, gc - kc * (L.a @ L.w_free))
        skip_below = COUPLING_SKIP * jnp.where(jnp.isfinite(last_change), last_change, 0.0)
        u_free = (L.u_free_n, L.u_free_t)
        kn, gn, kt = lin[:3]
        penalties = (kn, kt, kc)
        same = functools.reduce(jnp.logical_and, [jnp.all(a == b) for a, b in zip(penalties, key)])
        options = LinearOptions(skip_below, settings.batched, (last, same))
        (un, ut, dw, gt), border = linear_solve(L.sys, L.frames, L.free, lin, u_free, rows, options)
        wN = L.w_free + dw
        lamN = (gn - kn * un, gt - kt * ut, (gc - kc * (L.a @ wN)) if L.carriers else lam[2])
        # Semismooth Newton alone cycles (period 2: a point at its stick limit sticking and sliding, a contact-edge
        # point closing and opening; measured on Benchmark A and the accessory example): take the best of a few
        # steps along the Newton direction by the laws' residual. Velocities are affine in the impulses, so the
        # trial points cost no solve.
        mix = lambda x, y: x[None] + steps.reshape((-1,) + (1,) * jnp.ndim(x)) * (y - x)[None]
        trial = jax.tree.map(mix, (lam, u, w), (lamN, (un, ut), wN))
        scores = jax.vmap(L.merit)(*trial)
        best = jnp.argmin(scores)
        lam, u, w = jax.tree.map(lambda x: x[best], trial)
        new_n, new_t, lin = L.laws(u[0], u[1], lam[1])
        rn, rt, rc = L.residuals(lam, u, w)
        change = jnp.maximum(jnp.max(jnp.abs(rn)), jnp.max(jnp.abs(rt)))
        if not L.carriers:
            return lam, u, w, lin, (kc, gc), change, border, penalties
        new_c, clin = L.carrier_lin(w, lam[2])
        return lam, u, w, lin, clin, jnp.maximum(change, jnp.max(jnp.abs(rc))), border, penalties

    def converged(carry):
        return carry[5] <= CONVERGED * jnp.max(jnp.abs(carry[0][0]), initial=0.0)

    def step(i, carry):
        # through the iterations (IMPLICIT_TANGENT = False) reverse mode needs a static trip count: once converged
        # the remaining iterations are skipped at run time by a cond (under vmap both branches run, unless the run
        # says it is batched: then they are skipped once every point has converged)
        branch = batch_cond if settings.batched else jax.lax.cond
        return branch(converged(carry), lambda c: c, lambda c: body(i, c), carry)

    # no factor yet: the first iteration's penalties (NaN) match none
    rows0 = None if not L.carriers else (L.a, clin0[0], clin0[1])
    assert L.free.implicit is not None
    loads = jax.ShapeDtypeStruct((L.free.implicit.blocks.shape[0], 4), lin0[0].dtype)  # node loads (n, 4)
    shapes = jax.eval_shape(lambda rb: penalised_border(L.sys, L.frames, L.free, lin0[0], lin0[2], rows0, rb)[0], loads)
    border0 = jax.tree.map(lambda x: jnp.zeros(x.shape, x.dtype), shapes)
    key0 = jax.tree.map(lambda x: jnp.full_like(x, jnp.nan), (lin0[0], lin0[2], clin0[0]))
    init = (lam0, u0, w0, lin0, clin0, jnp.asarray(jnp.inf, L.u_free_n.dtype), border0, key0)
    if IMPLICIT_TANGENT:
        # the iteration is not differentiated (its inputs' derivatives are stopped; the root's tangent is
        # ``_root_of``'s): it stops at convergence, at most ``settings.iterations`` (vmapped: once every point has)
        _, (lam, u, w, _, _, change, _, _) = jax.lax.while_loop(
            lambda c: (c[0] < settings.iterations) & ~converged(c[1]), lambda c: (c[0] + 1, body(c[0], c[1])), (0, init)
        )
    else:
        lam, u, w, _, _, change, _, _ = jax.lax.fori_loop(0, settings.iterations, step, init)
    # what the step applies: the laws' impulses at the last iterate's velocities
    lam_n = L.normal_law(u[0])
    lam_t = L.friction(lam[1], u[1], lam_n)
    lam_c = L.carrier_local(w - L.direction.T @ lam[2]) if L.carriers else jnp.zeros(())
    scale = jnp.max(jnp.abs(lam_n), initial=0.0)
    residual = jnp.where(scale > 1e-300, change / jnp.where(scale > 1e-300, scale, 1.0), 0.0)
    return (lam_n, lam_t, lam_c), residual


def _tangent_solve(L: _Laws, solution, g, y):
    """``x`` with ``g(x) = y``, ``g`` the laws' residuals linearised at their root ``solution`` (``_root_of``):
    preconditioned by the Newton step's own linear solve, factored once with the laws' slopes at the solution
    (a sticking point's velocity constraint as a stiff penalty, ``TANGENT_PENALTY``), and refined
    ``TANGENT_REFINEMENTS`` times against ``g`` itself, so that the penalty and the lagged friction-normal coupling
    leave no error of their own. Linear in ``y`` (no branch on it): reverse mode transposes it."""
    lam_n, lam_t, lam_c = solution
    (un, ut), w = L.velocities_at(solution)
    ones = jnp.ones_like(lam_n)
    _, dn = jax.jvp(L.normal_law, (un,), (ones,))  # d lam_n / d u_n (-1 / eps where closed)
    ln = jnp.maximum(lam_n, 0.0)
    _, a = jax.jvp(lambda x: L.friction(x, ut, ln), (lam_t,), (ones,))
    _, b = jax.jvp(lambda x: L.friction(lam_t, x, ln), (ut,), (ones,))
    _, e = jax.jvp(lambda x: L.friction(lam_t, ut, jnp.maximum(x, 0.0)), (lam_n,), (ones,))
    # the friction row (1 - a) dlam_t - b du_t - e dlam_n = y_t, with (1 - a) -> (1 - a) - b / rho: a sticking
    # point (a = 1) held by the penalty rho, a sliding one (b = 0) exact
    d_t = 1.0 - a - b / (TANGENT_PENALTY * L.point_mass)
    kn, kt, c_tn = -dn, -b / d_t, e / d_t
    rows_k = None
    if L.carriers:
        ones_c = jnp.ones_like(lam_c)
        wo = w - L.direction.T @ lam_c
        _, slope = jax.jvp(L.carrier_local, (wo,), (L.direction.T @ ones_c,))  # per unit impulse, in [-1, 0]
        d_c = 1.0 + slope * (1.0 - 1.0 / TANGENT_PENALTY)  # held (slope -1): the penalty TANGENT_PENALTY m_c
        kc = -slope * L.m_c / d_c
        rows_k = (L.a, kc, jnp.zeros_like(kc))
    assert L.free.implicit is not None
    shape = L.free.implicit.shape
    factor, C, P = _penalised(L.sys, L.frames, L.free, kn, kt, rows_k)
    border = _border(factor, C, P, solve_factored(factor, C))
    zero = (jnp.zeros_like(un), jnp.zeros_like(ut))

    def precondition(r):
        rn, rt, rc = r
        rp_rows, gc = 0.0, rc
        if L.carriers:
            gc = rc / d_c
            rp_rows = L.a.T @ gc
        lin = (kn, rn, kt, rt / d_t, c_tn, jnp.zeros_like(rn))

        def solve(g_t):
            return _solve_loads(L.sys, L.frames, shape, border, lin, zero, g_t, rp_rows)

        g_t = lin[3]
        du_n, du_t, dw = solve(g_t)
        for _ in range(TANGENT_COUPLING_SWEEPS):  # the sliding friction following the normal impulse
            g_t = lin[3] + c_tn * (rn - kn * du_n)
            du_n, du_t, dw = solve(g_t)
        x_c = (gc - kc * (L.a @ dw)) if L.carriers else rc
        return rn - kn * du_n, g_t - kt * du_t, x_c

    x = precondition(y)
    for _ in range(TANGENT_REFINEMENTS):
        x = jax.tree.map(jnp.add, x, precondition(jax.tree.map(jnp.subtract, y, g(x))))
    return x


def _detached(tree):
    return jax.tree.map(lambda x: jax.lax.stop_gradient(x) if eqx.is_inexact_array(x) else x, tree)


def _laws_of(static, inputs) -> _Laws:
    """The laws on ``inputs = (frames, free, problem, settings, carriers)`` (``carriers``: the carrier laws' arrays
    ``(env, direction, warm)`` or None; ``static = (unknowns, local)``)."""
    unknowns, local = static
    frames, free, problem, settings, carriers = inputs
    carrier_laws = None if carriers is None else CarrierLaws(local, *carriers)
    return _Laws(frames, free, problem, settings, unknowns, carrier_laws)


@functools.partial(jax.custom_jvp, nondiff_argnums=(0,))
def _root_of(static, solution, inputs):
    """``solution``, the laws' root on ``inputs`` (found by ``_iterate``), with the derivatives of a root: the
    inputs' tangents through the laws linearised there (the implicit function theorem), not through the
    iterations that found it. A custom JVP, so that its tangent solve is traced only when differentiated."""
    return solution


@_root_of.defjvp
def _root_of_jvp(static, primals, tangents):
    solution, inputs = primals
    _, d_inputs = tangents
    laws = _laws_of(static, inputs)
    _, rhs = jax.jvp(lambda x: _laws_of(static, x).root(solution), (inputs,), (d_inputs,))  # the laws' own change
    _, g = jax.linearize(laws.root, solution)
    return solution, jax.tree.map(jnp.negative, _tangent_solve(laws, solution, g, rhs))


def newton_contact(
    frames: ContactFrames,
    free: FreeVelocities,
    problem: PointProblem,
    warm,
    settings: SolveSettings,
    unknowns: PulleyUnknowns,
    carrier_laws: CarrierLaws | None = None,
):
    """Return ``(lam_n, lam_t, lam_c, residual)`` from the warm start ``(lam_n, lam_t)`` (and the carriers'
    ``carrier_laws.warm``); ``residual``: the largest difference between the impulses the last linear solve
    applied and the laws' impulses at its velocities, over the largest normal impulse. ``problem.point_mass``
    (each point's share of the belt's plain mass) is the scale of the penalties; ``settings.iterations`` the
    static trip count (the relaxation is the sweeps', not used here).

    Derivatives (both modes) are those of the laws' root, not of the iterations (``_root_of``): the iteration runs
    on inputs whose derivatives are stopped, and the solution's tangent is one refined linear solve at it
    (``_tangent_solve``), whatever the number of iterations it took. ``IMPLICIT_TANGENT = False``: through the
    iterations instead (for comparison)."""
    if not IMPLICIT_TANGENT:
        live = _Laws(frames, free, problem, settings, unknowns, carrier_laws)
        c_warm = None if carrier_laws is None else carrier_laws.warm
        (lam_n, lam_t, lam_c), residual = _iterate(live, warm, c_warm, settings)
        return lam_n, lam_t, (lam_c if carrier_laws is not None else None), jax.lax.stop_gradient(residual)
    carriers = None if carrier_laws is None else (carrier_laws.env, carrier_laws.direction, carrier_laws.warm)
    static = (unknowns, None if carrier_laws is None else carrier_laws.local)
    inputs = (frames, free, problem, settings, carriers)
    fixed = _laws_of(static, _detached(inputs))
    c_warm = None if fixed.carrier_laws is None else fixed.carrier_laws.warm
    solution, residual = _iterate(fixed, _detached(warm), c_warm, settings)
    lam_n, lam_t, lam_c = _root_of(static, solution, inputs)
    return lam_n, lam_t, (lam_c if carrier_laws is not None else None), jax.lax.stop_gradient(residual)
