"""Linearised modes about steady running: the belt as an axially moving continuum, contacts held stuck.

jaxbelt's belt is material (its nodes travel with the belt), so a running drive has no equilibrium in its
own coordinates; its spatial shape, though, is stationary. So the mesh of a steady-running snapshot is read
as a spatial (Eulerian) mesh through which the material flows at the reference rate ``V`` (stress-free
metres per second; steady running carries the same mass flux ``rhoA V`` through every section). The
material at mesh coordinate ``x`` moves at ``S(x) qdot + V S'(x) q``, and its kinetic energy
``1/2 int rhoA |S qdot + V S' q|^2 dx`` adds to the installed-state model of ``modes.py`` a gyroscopic
and a centrifugal term:

    M zddot + V (G - G^T) zdot + (K - V^2 H) z = 0,   G = int rhoA S^T S' dx,   H = int rhoA S'^T S' dx,

``K`` the Hessian of the potential (belt, contacts held stuck, carriers) at the running shape: its span
tensions are the running ones (tight and slack sides, centrifugal tension included). The running shape is
not the snapshot itself (a run's snapshot carries span vibrations) but the relative equilibrium near it: the
stationary point of the amended potential ``V(z) - V^2/2 q^T H q`` with each free pulley loaded by the
torque the belt exerts on it in the snapshot (Newton's method). For a span between fixed-axis pulleys the
model is the axially moving string, ``f_n = n (c^2 - v^2) / (2 c L)``. The eigenvalues of the state-space
form come in pairs ``g +- i w`` (``g`` ~ 0 for a stable drive; a belt faster than its wave speed diverges,
``g`` > 0, with a warning); the mode shapes are complex (a running span's modes travel).

Assumptions: every contact held stuck (the slip arcs too); no damping. Sensitivities
(``running_sensitivities``) hold the belt speed and the pulley loads. A one-way clutch is linearised as it
is in the snapshot (``modes.clutch_states``): engaged (transmitting torque: an OAP locked, a decoupler
through its spring) or open; an engaged clutch's sheave carries the belt's torque as above, a decoupler's
spring is linearised about the snapshot's deflection.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from .._cache import per_drive
from .._export import StoredJit
from .._drive import Drive
from .._types import DriveParams, DriveState
from ..belt.element import gauss_legendre, shape_functions
from ..belt.ring import assemble_ring, element_coordinates
from .modes import Modes, _Layout, _mass, _potential, clutch_states, describe_modes, run_to

__all__ = ["running_state", "material_rate", "running_modes", "running_sensitivities"]


def running_state(drive: Drive, params: DriveParams | None = None, *, status: list | None = None) -> DriveState:
    """The drive's state at the end of its run (its ``t_end``): steady running if the run reaches it.
    ``status``: receives the run's summary status (whether it did: ``run_to``)."""
    state = run_to(drive, drive.options.t_end, params, status=status)
    if int(state.fault) != 0:
        from .._errors import ConfigError
        from .._types import Fault

        raise ConfigError(
            f"modes: the run to the running state failed at t = {float(state.fault_time):g} s "
            f"({Fault(int(state.fault)).message}): `jaxbelt run` on the configuration reports the cause"
        )
    return state


def material_rate(drive: Drive, state: DriveState) -> tuple[float, float]:
    """(V, v): the rate at which material flows along the belt [stress-free m/s] and the mean belt speed
    [m/s], least-squares fits of the nodal velocities to ``V r'`` over the whole loop."""
    n = drive.model.n_elements
    L = float(drive.params.belt.stress_free_length) / n
    xg, wg = gauss_legendre(4)
    s, ds, _ = (np.asarray(a) for a in shape_functions(xg, L))
    e, ed = np.asarray(element_coordinates(state.q)), np.asarray(element_coordinates(state.v))
    r_dot = np.einsum("gi,nic->ngc", s, ed)
    r_x = np.einsum("gi,nic->ngc", ds, e)
    V = float(np.einsum("g,ngc,ngc->", wg, r_dot, r_x) / np.einsum("g,ngc,ngc->", wg, r_x, r_x))
    stretch = np.sqrt(np.sum(r_x**2, -1))
    return V, V * float(np.einsum("g,ng->", wg, stretch) / (n * np.sum(wg)))


def _transport(n: int, params: DriveParams):
    """G and H (module docstring) on the belt's coordinates, ordered as ``q.ravel()`` (n, 2, 2)."""
    L = params.belt.stress_free_length / n
    xg, wg = gauss_legendre(4)  # exact: degree 5 and 4
    s, ds, _ = shape_functions(jnp.asarray(xg), L)
    w = params.belt.mass_per_length * L * jnp.asarray(wg)
    G = assemble_ring(n, jnp.einsum("g,gi,gj->ij", w, s, ds))
    H = assemble_ring(n, jnp.einsum("g,gi,gj->ij", w, ds, ds))
    eye = jnp.eye(2, dtype=G.dtype)  # x and y alike: scalar coordinate (2 j + k) -> (4 j + 2 k + c)
    return jnp.kron(G, eye), jnp.kron(H, eye)


NEWTON_STEPS = 4  # per active set, from the snapshot (residual measured below 1e-9 of the largest force)


def _amended(drive: Drive, layout: _Layout, k_contact, rate, torque):
    """(reference, A): the amended potential ``A(z, params, ref) = V(z) - V^2/2 q^T H q + loads`` (module
    docstring), each free pulley loaded by the constant torque ``-torque`` (the belt's on it in the snapshot)."""
    reference, V = _potential(drive, layout, k_contact)
    nq = 4 * layout.n
    spin = jnp.asarray(layout.spin, int)

    def amended(z, params, ref):
        _, theta, _ = layout.split(z)
        belt = z[:nq]
        centrifugal = 0.5 * rate**2 * (belt @ (_transport(layout.n, params)[1] @ belt))
        loads = jnp.sum(torque[spin] * (theta - layout.theta0)[spin])
        return V(z, params, ref) - centrifugal + loads

    return reference, amended


def _matrices(drive: Drive, params: DriveParams, state: DriveState, k_contact, rate, torque, clutch: tuple = ()):
    """M, the stiffness ``K - V^2 H``, ``G``, the relative equilibrium ``z`` near the snapshot ``state``, the
    belt nodes that chose its contacts, and the force residual there (relative to the snapshot's).

    The snapshot of a run carries its span vibrations; the steady shape is the stationary point of the
    amended potential: Newton's method from the snapshot, once with the snapshot's contacts and once more
    with the contacts re-chosen at the result."""
    layout = _Layout(drive, state, clutch)
    reference, amended = _amended(drive, layout, k_contact, rate, torque)
    hess, grad = jax.hessian(amended), jax.grad(amended)

    def newton(z, ref):  # a static trip count in a loop: one Hessian program, compiled once
        def step(_, z):
            H = hess(z, params, ref)
            # a drive with no speed-prescribed pulley turns freely as a whole: H is singular along that rigid
            # motion (steady running's torques leave no force along it); a tiny diagonal shift keeps the step
            # finite without changing it elsewhere
            shift = 1e-12 * jnp.max(jnp.abs(jnp.diag(H))) * jnp.eye(H.shape[0], dtype=H.dtype)
            return z - jnp.linalg.solve(H + shift, grad(z, params, ref))

        return jax.lax.fori_loop(0, NEWTON_STEPS, step, z)

    start = layout.join(state.q, state.theta, state.psi)
    z = newton(start, reference(params))
    active_at = layout.split(z)[0]
    ref = reference(params, active_at=active_at)
    z = newton(z, ref)
    K = hess(z, params, ref)
    residual = jnp.max(jnp.abs(grad(z, params, ref))) / jnp.max(jnp.abs(grad(start, params, ref)))
    G = _transport(drive.model.n_elements, params)[0]
    return _mass(drive, params, layout), 0.5 * (K + K.T), G, z, active_at, residual


class _RunningPoint(NamedTuple):
    """Where a running linearisation is taken: the drive's parameters, the steady-running snapshot ``state``,
    the contacts' stiffness, the material rate ``V`` (``material_rate``) and the belt's torque on each pulley
    in the snapshot (the loads held)."""

    params: DriveParams
    state: DriveState
    k_contact: jax.Array
    rate: jax.Array
    torque: jax.Array


class _Equilibrium(NamedTuple):
    """The relative equilibrium near the snapshot (``_matrices``): its coordinates ``z``, the belt nodes that
    chose its contacts, and the stiffness ``K - V^2 H`` there."""

    z: jax.Array
    active_at: jax.Array
    K: jax.Array


def _frequency_derivative(drive, point: _RunningPoint, equilibrium: _Equilibrium, key, shape, omega, clutch):
    """d omega / d(key) of one running mode (``shape`` = a + i b, the displacement part of its eigenvector)
    at the running ``point``'s belt speed and pulley loads (``equilibrium``: the running shape there):
    ``x^H (lam^2 M' + lam D' + K') x / x^H (2 lam M + D) x`` with ``lam = i omega`` (the left eigenvector of a
    conservative gyroscopic system is x itself), which for real symmetric M', K' and skew D' is
    ``(k' - omega^2 m' - 2 omega a^T D' b) / (2 (omega m + a^T D b))``; K' includes the
    equilibrium's shift ``dz = -K^-1 d(grad A)/dp`` (implicit function theorem)."""
    from .parameters import get_parameter, set_parameter

    params, state, k_contact, rate, torque = point
    z, active_at, K = equilibrium
    layout = _Layout(drive, state, clutch)
    reference, amended = _amended(drive, layout, k_contact, rate, torque)
    p0 = get_parameter(drive, params, key)
    at = lambda s: set_parameter(drive, params, key, p0 + s)  # noqa: E731
    grad_z = lambda zz, s: jax.grad(amended)(zz, at(s), reference(at(s), active_at=active_at))  # noqa: E731
    zero, one = jnp.zeros((), z.dtype), jnp.ones((), z.dtype)
    dz = -jnp.linalg.solve(K, jax.jvp(lambda s: grad_z(z, s), (zero,), (one,))[1])
    nq = 4 * layout.n

    def quadratic(u):  # u^T K'(z(p), p) u along the parameter, the equilibrium's shift included
        form = lambda zz, s: jnp.dot(jax.jvp(lambda y: grad_z(y, s), (zz,), (u,))[1], u)  # noqa: E731
        return jax.jvp(form, (z, zero), (dz, one))[1]

    def mass(u, s):
        return jnp.dot(u, _mass(drive, at(s), layout) @ u)

    def skew(s):  # a^T D b
        G = _transport(layout.n, at(s))[0]
        return rate * jnp.dot(a[:nq], (G - G.T) @ b[:nq])

    a, b = jnp.real(shape), jnp.imag(shape)
    d_mass = jax.jvp(lambda s: mass(a, s) + mass(b, s), (zero,), (one,))[1]
    d_skew = jax.jvp(skew, (zero,), (one,))[1]
    numerator = quadratic(a) + quadratic(b) - omega**2 * d_mass - 2 * omega * d_skew
    return numerator / (2 * (omega * (mass(a, zero) + mass(b, zero)) + skew(zero)))


_COMPILED: dict = {}


def _compiled(drive: Drive, clutch: tuple = ()):
    """One compiled running linearisation per drive and clutch states (parameters, state, speed and loads
    are arguments)."""

    def build():  # stored traced beside the compilation cache: a later process loads it instead of tracing it
        fn = lambda p, s, k, v, t: _matrices(drive, p, s, k, v, t, clutch)  # noqa: E731
        return StoredJit("running_matrices", fn, (drive, clutch), (0,) * 6)

    return per_drive(_COMPILED, drive, build, clutch)


def _spectrum(
    drive: Drive, params: DriveParams, state: DriveState, k: float, transport: bool = True, clutch: tuple = ()
) -> dict:
    """The running linearisation's eigenvalues (``lam``, the lowest ``g + i w``-halves in ``order``), their
    displacement shapes and what the sensitivities reuse (host arrays)."""
    V, speed = material_rate(drive, state)
    M, K, G, z, active_at, residual = (
        np.asarray(a)
        for a in _compiled(drive, clutch)(params, state, jnp.asarray(k), jnp.asarray(V), state.belt_torque)
    )
    nq = G.shape[0]
    D = np.zeros_like(M)
    if transport:
        D[:nq, :nq] = V * (G - G.T)
    else:
        H = np.asarray(_transport(drive.model.n_elements, params)[1])
        K = K.copy()
        K[:nq, :nq] += V * V * H
    size = M.shape[0]
    # state-space form y = (z, zdot): y' = A y
    A = np.block([[np.zeros((size, size)), np.eye(size)], [-np.linalg.solve(M, K), -np.linalg.solve(M, D)]])
    lam, Y = np.linalg.eig(A)
    # a drive without a speed-prescribed pulley turns freely as a whole: that rigid motion's eigenvalue pair
    # (the smallest, ~0 up to the equilibrium's accuracy) is reported as a 0 Hz mode, not as a vibration
    rigid = np.argsort(np.abs(lam))[: 0 if any(drive.model.kinematic) else 2]
    rest = np.setdiff1d(np.arange(lam.size), rigid)
    upper = rest[lam.imag[rest] > 1e-9 * max(np.max(np.abs(lam)), 1.0)]  # one of each +-i w pair
    order = np.concatenate([rigid[:1], upper[np.argsort(lam.imag[upper])]]).astype(int)
    lam_out = lam[order].copy()
    lam_out[: rigid[:1].size] = 0.0
    if not float(residual) < 1e-6:
        warnings.warn(
            f"running modes: no steady running shape near the state (force residual {float(residual):.2g} of the "
            "state's own after Newton's method): these modes are not reliable; run the drive longer (t_end) so "
            "that it reaches steady running, or linearise at another instant (under an engine-order excitation "
            "some instants of a period converge and others do not)",
            UserWarning,
            stacklevel=3,
        )
    growth = np.abs(lam[rest].real) / np.maximum(np.abs(lam[rest]), 1.0)
    if np.any((lam[rest].real > 0) & (growth > 1e-6)):
        warnings.warn(
            f"running modes: unstable at belt speed {speed:.3g} m/s (eigenvalue with real part "
            f"{float(np.max(lam[rest].real)):.3g} 1/s): a belt running faster than its transverse wave speed diverges",
            UserWarning,
            stacklevel=3,
        )
    return dict(lam=lam_out, shapes=Y[:size, order], M=M, K=K, z=z, active_at=active_at, rate=V, speed=speed)


def running_modes(
    drive: Drive,
    *,
    count: int = 12,
    contact_stiffness: float | None = None,
    state: DriveState | None = None,
    transport: bool = True,
    params: DriveParams | None = None,
    clutch="auto",
) -> Modes:
    """The lowest ``count`` modes about steady running (module docstring): ``state`` a steady-running state
    of ``drive`` (default: the end of its run). ``transport=False`` leaves out the belt's gyroscopic and
    centrifugal terms from the linearisation (same running shape and tensions): what the belt would do at
    rest with the running tensions, to show the effect of the belt's motion. ``params`` (default the
    drive's) change the drive's parameters about the same state, at its belt speed and pulley loads.
    ``clutch``: how one-way clutches are linearised (``modes.clutch_states``; by default as in ``state``)."""
    params = drive.params if params is None else params
    state = running_state(drive, params) if state is None else jax.tree.map(jnp.asarray, state)
    k = float(params.contact_stiffness) if contact_stiffness is None else float(contact_stiffness)
    how = clutch_states(drive, state, about="running", clutch=clutch)
    sp = _spectrum(drive, params, state, k, transport, how)
    layout = _Layout(drive, state, how)
    equilibrium = dataclasses.replace(state, **dict(zip(("q", "theta", "psi"), layout.split(jnp.asarray(sp["z"])))))
    lam = sp["lam"][:count]
    return describe_modes(
        drive,
        equilibrium,
        lam.imag / (2 * math.pi),
        sp["shapes"][:, :count],
        sp["M"],
        k,
        clutch=how,
        about="running",
        belt_speed=sp["speed"],
        growth_rate=lam.real,
        equilibrium=equilibrium,
    )


_SENSITIVITIES: dict = {}


def _sensitivities(drive: Drive, keys: tuple, how: tuple):
    """One program for every key, per drive, keys and clutch states, stored traced (a later process loads it)."""

    def all_keys(point: _RunningPoint, equilibrium: _Equilibrium, shapes, omega):
        one = lambda key, x, w: _frequency_derivative(drive, point, equilibrium, key, x, w, how)  # noqa: E731
        return [jax.vmap(lambda x, w, key=key: one(key, x, w), in_axes=(1, 0))(shapes, omega) for key in keys]

    build = lambda: StoredJit("running_sensitivities", all_keys, (drive, keys, how), [0] * len(keys))  # noqa: E731
    return per_drive(_SENSITIVITIES, drive, build, keys, how)


def running_sensitivities(
    drive: Drive,
    keys: list[str],
    *,
    count: int = 6,
    state: DriveState | None = None,
    contact_stiffness=None,
    clutch="auto",
) -> dict[str, np.ndarray]:
    """d f_i / d p [Hz per unit of p] of the lowest ``count`` running modes for every parameter key, at the
    same belt speed and pulley loads, the running shape's shift included (``_frequency_derivative``)."""
    from .parameters import get_parameter

    for key in keys:
        get_parameter(drive, drive.params, key)  # unknown key: ConfigError with a suggestion
    state = running_state(drive) if state is None else jax.tree.map(jnp.asarray, state)
    k = float(drive.params.contact_stiffness) if contact_stiffness is None else float(contact_stiffness)
    how = clutch_states(drive, state, about="running", clutch=clutch)
    sp = _spectrum(drive, drive.params, state, k, clutch=how)
    omega = sp["lam"][:count].imag
    shapes = sp["shapes"][:, :count]

    derivatives = _sensitivities(drive, tuple(keys), how)(
        _RunningPoint(drive.params, state, jnp.asarray(k), jnp.asarray(sp["rate"]), state.belt_torque),
        _Equilibrium(jnp.asarray(sp["z"]), jnp.asarray(sp["active_at"]), jnp.asarray(sp["K"])),
        jnp.asarray(shapes),
        jnp.asarray(omega),
    )
    # a rigid motion's 0 Hz stays 0 Hz whatever the parameters
    return {key: np.where(omega > 0, np.asarray(d), 0.0) / (2 * math.pi) for key, d in zip(keys, derivatives)}
