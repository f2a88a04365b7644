"""Linearised modes of a drive about its installed static state, and their parameter sensitivities.

The model is jaxbelt's own: the ANCF belt (elastic energy with its prestress, so span tensions give
the strings' geometric stiffness), the compliant normal contact law as a penalty energy on the points
in contact, and the contacts *held stuck* by stiff tangential springs (``STICK_FACTOR`` times the contact
stiffness) anchored on the pulley surfaces: the runs' Coulomb law sticks exactly, with no tangential
compliance, and so do the modes (springs of the contact stiffness itself gave each span end a shear lag of
sqrt(EA / k), 20 mm on the accessory example, and its first modes 5 % below the runs' own ring-down). Pulleys whose
speed is prescribed (the driver) are held; the others rotate; tensioner carriers move with their
springs. Stiffness ``K`` is the Hessian of the total potential energy at the equilibrium, mass ``M``
the Hessian of the kinetic energy; ``K x = w^2 M x`` is solved by a Cholesky reduction and ``eigh``.

The equilibrium comes from a short settle run (pulleys locked, friction off: the belt finds its
installed state) refined by Newton's method on the potential (a fixed number of steps, so that the
whole chain is differentiable: ``mode_frequencies`` is a function of ``DriveParams`` and ``jax.jacfwd``
gives every frequency's sensitivity to every parameter, the equilibrium's shift included).
Not included: damping; belt speed (gyroscopic and centrifugal terms) — the modes about steady running,
with them, are in ``running_modes.py`` (``linear_modes(drive, about="running")``).

One-way clutch pulleys (``pulleys/carriers/clutch.py``) are linearised in the state their clutch is in
(``clutch_states``): an engaged overrunning pulley (OAP) as *locked*, sheave and rotor one body (the rotor
angle follows the sheave's); an engaged decoupler through its torsion spring (the rotor a coordinate of its
own, ``1/2 k (dtheta - dpsi)^2``); an open clutch as *open*, the rotor left out (it overruns: no torque
reaches it). Engaged about the installed state: the rotor's load brakes it (its torque at the end of the
run opposes the running sense, or it has a viscous load) — the running drive then drives the rotor through
the clutch; about running: the clutch transmits torque in the state linearised about (its impulse > 0).
The linearisation of an engaged clutch holds while the vibration's clutch torque stays below its mean
(larger swings overrun part of each cycle: not linear). ``clutch="locked"`` / ``"open"`` overrides.
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np

from .._cache import per_drive
from .._drive import Drive
from .._export import StoredJit
from .._types import DriveParams, DriveState
from ..belt.ring import elastic_energy
from ..contact.kinematics import nearest_pulley, point_kinematics
from ..dynamics.kinetic import kinetic_energy
from ..dynamics.step import drive_operators
from ..pulleys.carrier import carrier_centers, carrier_stored_energy
from ..pulleys.carriers.constraints import AbstractClutchCarrier

__all__ = [
    "CLUTCH_LABELS",
    "Modes",
    "clutch_states",
    "describe_modes",
    "linear_modes",
    "mode_frequencies",
    "mode_sensitivities",
    "settled_state",
]

# the stuck contacts' tangential springs over the normal contact stiffness: exact sticking as a penalty. The
# accessory example's first two modes at 1 / 10 / 1e3 / 1e4: 17.62 / 18.40 / 18.69 / 18.69 Hz and 63.75 / 66.20 /
# 67.30 / 67.32 Hz; its runs' own ring-down 18.55 / 66.54 Hz; at 1e6 the eigensolve loses digits (18.85 Hz)
STICK_FACTOR = 1e3
NEWTON_STEPS = 3  # from the settled state: measured residual force 1e-10 of the largest after 2

# how a one-way clutch enters the linearisation (``clutch_states``) -> what the output says
CLUTCH_LABELS = {"locked": "engaged (locked)", "spring": "decoupler spring", "open": "open"}


@dataclasses.dataclass
class Modes:
    frequencies: np.ndarray  # (k,) [Hz], ascending
    kinds: list  # per mode "rotational" or "transverse"
    span: list  # per mode: the span whose transverse motion dominates (None for rotational modes)
    rotational_share: np.ndarray  # (k,) fraction of the kinetic energy in pulley spins and carriers
    shapes: dict  # "belt" (k, n, 2) nodal displacements, "theta" (k, p) spins, "psi" (k, p) carriers (unit max)
    contact_stiffness: float
    about: str = "installed"  # or "running" (steady running, running_modes.py)
    belt_speed: float = 0.0  # mean belt speed of the state linearised about [m/s]
    growth_rate: np.ndarray | None = None  # (k,) [1/s] real parts of the eigenvalues (running: ~0 if stable)
    equilibrium: DriveState | None = None  # the (relative) equilibrium linearised about
    # per one-way clutch pulley: how it is linearised, a value of CLUTCH_LABELS (e.g. "engaged (locked)")
    clutches: dict = dataclasses.field(default_factory=dict)

    def table(self) -> list[dict]:
        rows = [
            dict(mode=i + 1, frequency_hz=float(f), kind=k, span=s, rotational_share=float(r))
            for i, (f, k, s, r) in enumerate(zip(self.frequencies, self.kinds, self.span, self.rotational_share))
        ]
        if self.growth_rate is not None:  # running: the eigenvalue's real part (> 0: the mode grows)
            for row, g in zip(rows, self.growth_rate):
                row["growth_rate_per_s"] = float(g)
        return rows


def settled_state(drive: Drive, params: DriveParams | None = None) -> DriveState:
    """The drive's installed state: the end of the settle phase (one step into the run)."""
    return run_to(drive, drive.dt, params)


def run_to(drive: Drive, t_end: float, params: DriveParams | None = None, *, status: list | None = None) -> DriveState:
    """The drive's state at ``t_end`` of its run (settle phase first), by the run's own chunk program (same
    step, save stride and buffer as ``run``; the clock is an argument), so that a later run of the drive,
    in this process or another, finds it compiled (persistent cache). ``status``: a list that receives the
    run's summary status (``run``'s checks of its final window: "ok", "gross slip: ...", "not steady: ...")."""
    from ..dynamics.chunked import ChunkedRun

    chunked = ChunkedRun(
        drive.model,
        drive.params if params is None else params,
        drive.state0,
        t_end=t_end,
        dt=drive.dt,
        save_dt=drive.options.save_dt,
        settle_time=drive.options.settle_time,
    )
    at = chunked.start()
    while not chunked.done(at):
        at = chunked.advance(at)
    if status is not None:
        from .run import _postprocess

        _, summ, _ = _postprocess(drive, chunked.trajectory(at), 0.2)
        status.append(summ["status"])
    return at.state


def clutch_states(
    drive: Drive, state: DriveState | None = None, *, about: str = "installed", clutch="auto"
) -> tuple[str | None, ...]:
    """Per pulley how its one-way clutch enters the linearisation (module docstring): ``None`` (no clutch),
    ``"locked"`` (an engaged OAP: sheave and rotor one body), ``"spring"`` (an engaged decoupler: the rotor on
    its spring) or ``"open"`` (the rotor left out). ``clutch``: ``"auto"`` (engaged by the rule: installed,
    the rotor's load brakes it; running, the clutch transmits torque in ``state``), ``"locked"`` (every
    clutch engaged), ``"open"``, or a mapping pulley name -> one of these. Decided on the drive's own
    (concrete) parameters and state: the result is static (it sets the coordinates)."""
    from .._errors import ConfigError

    model = drive.model
    names = model.pulley_names
    clutches = [i for i, c in enumerate(model.carriers) if isinstance(c, AbstractClutchCarrier)]
    if isinstance(clutch, str):
        wanted = {names[i]: clutch for i in clutches}
    else:
        wanted = dict(clutch)
        unknown = [n for n in wanted if n not in {names[i] for i in clutches}]
        if unknown:
            have = ", ".join(names[i] for i in clutches) or "none"
            raise ConfigError(f"modes: clutch {unknown[0]!r}: not a one-way clutch pulley of this drive ({have})")
        wanted = {names[i]: wanted.get(names[i], "auto") for i in clutches}
    for name, how in wanted.items():
        if how not in ("auto", "locked", "open"):
            raise ConfigError(f"modes: clutch {name} = {how!r}: must be 'auto', 'locked' or 'open'")
    out: list[str | None] = [None] * model.n_pulleys
    for k in clutches:
        how = wanted[names[k]]
        if how == "auto":
            engaged = _engaged(drive, k, state, about)
        else:
            engaged = how == "locked"
        carrier = model.carriers[k]
        assert isinstance(carrier, AbstractClutchCarrier)
        out[k] = carrier.engaged if engaged else "open"
    return tuple(out)


def _engaged(drive: Drive, k: int, state: DriveState | None, about: str) -> bool:
    """The rule of ``clutch_states``: about running, the clutch's impulse in ``state`` (> 0: it transmits
    torque); installed, the rotor's load at the end of the run (a law over crank angle: the mean of its
    table) or a viscous load brakes the rotor in its running sense."""
    if about == "running":
        if state is None or state.constraints is None:
            return False
        return float(np.asarray(state.constraints.impulse)[k]) > 0.0
    pp = drive.params.pulleys
    # numpy only: this decides coordinates, also while a design loop traces the parameters
    tk, vk, smooth = (np.asarray(a)[k] for a in (pp.torque.times, pp.torque.values, pp.torque.smooth))
    over_angle = pp.excitation is not None and float(np.asarray(pp.excitation.over_angle)[k]) > 0.5
    load = float(np.mean(vk)) if over_angle else _law_value(tk, vk, smooth, drive.options.t_end)
    carrier = drive.model.carriers[k]
    assert isinstance(carrier, AbstractClutchCarrier)
    return carrier.sense * load < 0.0 or float(np.asarray(pp.viscous)[k]) > 0.0


def _law_value(tk, vk, smooth, t: float) -> float:
    """``pulleys.timelaw.evaluate`` in numpy (one law at one time)."""
    if t <= tk[0]:
        return float(vk[0])
    if t >= tk[-1]:
        return float(vk[-1])
    i = int(np.clip(np.searchsorted(tk, t, side="right"), 1, tk.size - 1))
    s = min(max((t - tk[i - 1]) / (tk[i] - tk[i - 1]), 0.0), 1.0)
    s = s * s * (3.0 - 2.0 * s) if smooth[i] > 0.5 else s
    return float(vk[i - 1] + (vk[i] - vk[i - 1]) * s)


class _Layout:
    """Which coordinates are free: belt nodes, spins of pulleys not speed-prescribed, movable carriers and
    the rotors of engaged decouplers (``clutch``: per pulley as ``clutch_states``; an engaged OAP's rotor
    turns with its sheave, an open clutch's rotor is left out)."""

    def __init__(self, drive: Drive, state: DriveState, clutch: tuple = ()):
        model = drive.model
        clutch = tuple(clutch) or (None,) * model.n_pulleys
        self.n = model.n_elements
        self.carriers = model.carriers
        self.spin = [i for i in range(model.n_pulleys) if not model.kinematic[i]]
        self.carrier = [i for i, c in enumerate(model.carriers) if c.movable or clutch[i] == "spring"]
        self.rotor = [i for i in range(model.n_pulleys) if clutch[i] == "spring"]  # psi on a spring
        self.locked = [i for i in range(model.n_pulleys) if clutch[i] == "locked"]  # psi follows theta
        self.q0, self.theta0, self.psi0 = state.q, state.theta, state.psi

    @property
    def size(self) -> int:
        return 4 * self.n + len(self.spin) + len(self.carrier)

    def split(self, z, velocities: bool = False):
        """(q, theta, psi) of a coordinate vector; held entries at the reference (0 for velocities)."""
        nq = 4 * self.n
        q = z[:nq].reshape(self.n, 2, 2)
        theta0, psi0 = (
            (jnp.zeros_like(self.theta0), jnp.zeros_like(self.psi0)) if velocities else (self.theta0, self.psi0)
        )
        theta = theta0.at[jnp.asarray(self.spin, int)].set(z[nq : nq + len(self.spin)])
        psi = psi0.at[jnp.asarray(self.carrier, int)].set(z[nq + len(self.spin) :])
        if self.locked:  # an engaged OAP's rotor turns with its sheave
            lk = jnp.asarray(self.locked, int)
            psi = psi.at[lk].set(psi0[lk] + theta[lk] - theta0[lk])
        return q, theta, psi

    def decoupler_energy(self, params: DriveParams, theta, psi):
        """The engaged decouplers' springs about the reference: ``1/2 k (dtheta - dpsi)^2`` (the reference's
        deflection and its torque are part of the equilibrium linearised about)."""
        if not self.rotor:
            return 0.0
        r = jnp.asarray(self.rotor, int)
        twist = (theta - self.theta0)[r] - (psi - self.psi0)[r]
        return sum(
            _spring(self.carriers[k]).spring_energy(params.pulleys, k, twist[j]) for j, k in enumerate(self.rotor)
        )

    def join(self, q, theta, psi):
        return jnp.concatenate([q.ravel(), theta[jnp.asarray(self.spin, int)], psi[jnp.asarray(self.carrier, int)]])


def _spring(carrier) -> AbstractClutchCarrier:
    assert isinstance(carrier, AbstractClutchCarrier)  # an engaged decoupler's rotor
    return carrier


def _potential(drive: Drive, layout: _Layout, k_contact):
    """Total potential energy V(z, params) with contacts held at the reference (settled) state."""
    model = drive.model

    def reference(params, active_at=None):
        """Contact frames, anchors and active set at the reference state (the active set, with
        ``active_at`` given, from those belt nodes instead: contacts re-chosen at a refined state)."""
        ops = drive_operators(model, params)
        centers, _ = carrier_centers(model, params.pulleys, layout.psi0)
        rx, ry, stretch = point_kinematics(layout.q0, ops.contact)
        fr = nearest_pulley(rx, ry, centers, params.pulleys.radius)
        seg = jnp.tile(ops.contact.length, model.n_elements) * stretch
        gap = fr.gap
        if active_at is not None:
            ax, ay, _ = point_kinematics(active_at, ops.contact)
            gap = nearest_pulley(ax, ay, centers, params.pulleys.radius).gap
        active = jax.lax.stop_gradient(gap < 0.0)
        return ops, fr, seg, active, jnp.stack([rx, ry], -1), centers

    def V(z, params, ref):
        ops, fr, seg, active, x0, c0 = ref
        q, theta, psi = layout.split(z)
        centers, _ = carrier_centers(model, params.pulleys, psi)
        rx, ry, _ = point_kinematics(q, ops.contact)
        x = jnp.stack([rx, ry], -1)
        c = centers[fr.pulley]
        d = x - c
        gap = jnp.sqrt(jnp.sum(d * d, -1)) - params.pulleys.radius[fr.pulley]
        k = k_contact * seg * active.astype(seg.dtype)
        # the anchor: the reference contact point carried along by the pulley's rotation and carrier
        dth = (theta - layout.theta0)[fr.pulley]
        lever = x0 - c0[fr.pulley]
        cs, sn = jnp.cos(dth), jnp.sin(dth)
        anchor = c + jnp.stack([cs * lever[:, 0] - sn * lever[:, 1], sn * lever[:, 0] + cs * lever[:, 1]], -1)
        slide = (x - anchor)[:, 0] * fr.tx + (x - anchor)[:, 1] * fr.ty
        contact = 0.5 * jnp.sum(k * (gap**2 + STICK_FACTOR * slide**2))
        gravity = -jnp.sum(ops.gravity * q)
        carriers = jnp.sum(
            carrier_stored_energy(model, params.pulleys, psi, params.gravity)[np.asarray(layout.carrier, int)]
        )
        spring = layout.decoupler_energy(params, theta, psi)
        return elastic_energy(q, params.belt, ops.belt) + contact + gravity + carriers + spring

    return reference, V


def _mass(drive: Drive, params: DriveParams, layout: _Layout):
    ops = drive_operators(drive.model, params)

    def T(zdot):
        v, omega, psi_dot = layout.split(zdot, velocities=True)
        return kinetic_energy(ops.belt.mass, v, drive.model, params.pulleys, omega, psi_dot).total

    return jax.hessian(T)(jnp.zeros(layout.size, params.belt.EA.dtype))


def _spectrum(drive: Drive, params: DriveParams, state: DriveState, k_contact, clutch: tuple = ()):
    """(w^2 ascending, shapes (size, size) as columns, M) about the equilibrium near ``state``."""
    layout = _Layout(drive, state, clutch)
    reference, V = _potential(drive, layout, k_contact)
    ref = reference(params)
    z = layout.join(state.q, state.theta, state.psi)
    grad = jax.grad(V)
    hess = jax.hessian(V)
    z = jax.lax.fori_loop(  # one Hessian program in a loop (compiled once), static trip count
        0, NEWTON_STEPS, lambda _, z: z - jnp.linalg.solve(hess(z, params, ref), grad(z, params, ref)), z
    )
    K = hess(z, params, ref)
    K = 0.5 * (K + K.T)
    M = _mass(drive, params, layout)
    L = jnp.linalg.cholesky(M)
    A = jax.scipy.linalg.solve_triangular(L, jax.scipy.linalg.solve_triangular(L, K, lower=True).T, lower=True)
    w2, y = jnp.linalg.eigh(0.5 * (A + A.T))
    x = jax.scipy.linalg.solve_triangular(L.T, y, lower=False)  # M-orthonormal mode shapes
    return w2, x, M, z, K


def _eigen_derivative(
    drive: Drive, params: DriveParams, state: DriveState, k_contact, key: str, spectrum, clutch: tuple = ()
):
    """d(w^2)/d(key) of the lowest ``count`` modes: Hellmann-Feynman, x^T (dK/dp - w^2 dM/dp) x with x
    M-normalised, where dK/dp includes the equilibrium's shift dz/dp = -K^-1 d(grad V)/dp (implicit function
    theorem). Forward mode only, a few energy evaluations per mode (no derivative of eigh)."""
    from .parameters import get_parameter, set_parameter

    w2, x, z, K = spectrum
    layout = _Layout(drive, state, clutch)
    reference, V = _potential(drive, layout, k_contact)
    p0 = get_parameter(drive, params, key)

    def energy(zz, s):
        p = set_parameter(drive, params, key, p0 + s)
        return V(zz, p, reference(p))

    def grad_z(zz, s):
        return jax.grad(energy)(zz, s)

    zero = jnp.zeros((), z.dtype)
    dg_ds = jax.jvp(lambda s: grad_z(z, s), (zero,), (jnp.ones_like(zero),))[1]
    dz = -jnp.linalg.solve(K, dg_ds)

    def quadratic(zz, s, v):  # v^T K(z, p(s)) v
        return jnp.dot(jax.jvp(lambda y: grad_z(y, s), (zz,), (v,))[1], v)

    def mass_quadratic(s, v):  # v^T M(p(s)) v
        return jnp.dot(v, _mass(drive, set_parameter(drive, params, key, p0 + s), layout) @ v)

    def one(v, lam):
        dK = jax.jvp(lambda zz, s: quadratic(zz, s, v), (z, zero), (dz, jnp.ones_like(zero)))[1]
        dM = jax.jvp(lambda s: mass_quadratic(s, v), (zero,), (jnp.ones_like(zero),))[1]
        return dK - lam * dM

    return jax.vmap(one, in_axes=(1, 0))(x, w2)


def mode_sensitivities(
    drive: Drive,
    keys: list[str],
    *,
    count: int = 6,
    state: DriveState | None = None,
    contact_stiffness=None,
    about: str = "installed",
    clutch="auto",
) -> dict[str, np.ndarray]:
    """d f_i / d p [Hz per unit of p] of the lowest ``count`` natural frequencies for every parameter key
    (``jaxbelt.parameter_keys``), the equilibrium's shift included; ``about="running"``: of the modes about
    steady running, at the same belt speed and pulley loads (``running_modes.running_sensitivities``).
    ``clutch``: as ``clutch_states`` (an engaged clutch's rotor inertia and decoupler spring then count)."""
    from .parameters import get_parameter

    state = None if state is None else jax.tree.map(jnp.asarray, state)  # e.g. a saved state (numpy)
    if about == "running":
        from .running_modes import running_sensitivities

        return running_sensitivities(
            drive, keys, count=count, state=state, contact_stiffness=contact_stiffness, clutch=clutch
        )
    if about != "installed":
        from .._errors import ConfigError

        raise ConfigError(f"modes: about = {about!r}: must be 'installed' or 'running'")

    for key in keys:
        get_parameter(drive, drive.params, key)  # unknown key: ConfigError with a suggestion
    how = clutch_states(drive, clutch=clutch)
    state = settled_state(drive) if state is None else state
    k = _stiffness(drive.params.contact_stiffness if contact_stiffness is None else float(contact_stiffness))
    w2, x, _, z, K = _compiled(drive, how)(drive.params, state, k)
    spectrum = (w2[:count], x[:, :count], z, K)
    f = np.sqrt(np.maximum(np.asarray(spectrum[0]), 0.0)) / (2 * math.pi)
    derivatives = _sensitivities(drive, tuple(keys), how)(drive.params, state, k, spectrum)
    scale = np.where(f > 0, 8 * math.pi**2 * f, np.inf)  # d f = d(w^2) / (8 pi^2 f)
    return {key: np.asarray(dw2) / scale for key, dw2 in zip(keys, derivatives)}


def mode_frequencies(
    drive: Drive, params: DriveParams, state: DriveState, k_contact=None, count: int = 12, clutch="auto"
):
    """The lowest ``count`` natural frequencies [Hz] at ``params`` (one compiled program per drive; for
    their derivatives use :func:`mode_sensitivities`). ``clutch``: as ``clutch_states``, decided on the
    drive's own parameters (``params`` may be traced)."""
    k_contact = params.contact_stiffness if k_contact is None else k_contact
    w2 = _compiled(drive, clutch_states(drive, clutch=clutch))(params, state, _stiffness(k_contact))[0]
    return jnp.sqrt(jnp.maximum(w2[:count], 0.0)) / (2 * math.pi)


_COMPILED: dict = {}


def _stiffness(k):
    """The contact stiffness as the spectrum program's argument: one dtype, never weakly typed (a Python number
    and the parameters' array would otherwise make two programs of one spectrum)."""
    return jnp.asarray(k, dtype=jnp.result_type(float))


def _compiled(drive: Drive, clutch: tuple = ()):
    """One compiled spectrum per drive and clutch states (parameters, state and contact stiffness are
    arguments)."""

    def build():  # stored traced beside the compilation cache: a later process loads it instead of tracing it
        return StoredJit("spectrum", lambda p, s, k: _spectrum(drive, p, s, k, clutch), (drive, clutch), (0,) * 5)

    return per_drive(_COMPILED, drive, build, clutch)


_SENSITIVITIES: dict = {}


def _sensitivities(drive: Drive, keys: tuple, clutch: tuple):
    """One program for every key, per drive, keys and clutch states, stored traced (a later process loads it)."""

    def build():
        fn = lambda p, s, kk, sp: [_eigen_derivative(drive, p, s, kk, key, sp, clutch) for key in keys]  # noqa: E731
        return StoredJit("mode_sensitivities", fn, (drive, keys, clutch), [0] * len(keys))

    return per_drive(_SENSITIVITIES, drive, build, keys, clutch)


def linear_modes(
    drive: Drive,
    *,
    count: int = 12,
    contact_stiffness: float | None = None,
    state: DriveState | None = None,
    about: str = "installed",
    transport: bool = True,
    params: DriveParams | None = None,
    clutch="auto",
) -> Modes:
    """Natural frequencies and mode shapes of ``drive`` about its installed state (see the module docstring),
    or with ``about="running"`` about steady running: the state at the end of the drive's run (``state`` if
    given), with the belt's gyroscopic and centrifugal terms (``transport=False``: without them; see
    ``running_modes``). ``params``: the drive's parameters changed (default: the drive's own). ``clutch``:
    how one-way clutch pulleys are linearised (``clutch_states``; ``Modes.clutches`` says which)."""
    if about not in ("installed", "running"):
        from .._errors import ConfigError

        raise ConfigError(f"modes: about = {about!r}: must be 'installed' or 'running'")
    k = _checked_stiffness(drive.params if params is None else params, contact_stiffness)
    state = None if state is None else jax.tree.map(jnp.asarray, state)  # e.g. a saved state (numpy)
    if about == "running":
        from .running_modes import running_modes

        modes = running_modes(
            drive, count=count, contact_stiffness=k, state=state, transport=transport, params=params, clutch=clutch
        )
    else:
        how = clutch_states(drive, clutch=clutch)
        params = drive.params if params is None else params
        state = settled_state(drive, params) if state is None else state
        w2, x, M, _, _ = _compiled(drive, how)(params, state, _stiffness(k))
        w2, x = np.asarray(w2), np.asarray(x)
        freqs = np.sqrt(np.maximum(w2[:count], 0.0)) / (2 * math.pi)
        modes = describe_modes(drive, state, freqs, x[:, :count], np.asarray(M), k, clutch=how)
    if len(modes.frequencies) < count:
        import warnings

        warnings.warn(
            f"modes: {count} asked for, the model has {len(modes.frequencies)} (one per coordinate of the belt "
            "mesh and the free bodies): all of them returned; refine belt.n_elements for more",
            UserWarning,
            stacklevel=2,
        )
    return modes


def _checked_stiffness(params: DriveParams, contact_stiffness) -> float:
    k = float(params.contact_stiffness) if contact_stiffness is None else float(contact_stiffness)
    if not (math.isfinite(k) and k > 0):
        from .._errors import ConfigError

        raise ConfigError(f"modes: contact_stiffness = {contact_stiffness!r}: must be a finite number > 0 [N/m^2]")
    return k


def describe_modes(drive: Drive, state: DriveState, freqs, x, M, k: float, clutch: tuple = (), **extra) -> Modes:
    """A ``Modes`` from frequencies and mode shapes ``x`` (coordinates x modes, real or complex): kind,
    span and rotational share of each, shapes scaled to a largest entry of 1 (complex ones turned so
    that their largest belt entry is real: the shape at the instant of its largest deflection); ``clutch``
    as ``clutch_states`` (the coordinates' layout; named in ``Modes.clutches``)."""
    layout = _Layout(drive, state, clutch)
    nq = 4 * layout.n
    kinds, spans, shares, belts, thetas, psis = [], [], [], [], [], []
    for j in range(len(freqs)):
        v = x[:, j]
        energy = np.real(np.conj(v) * (M @ v))
        share = float(np.sum(energy[nq:]) / max(np.sum(energy), 1e-300))
        if np.iscomplexobj(v):
            big = np.argmax(np.abs(v))
            v = np.real(v * np.exp(-1j * np.angle(v[big])))
        q, theta, psi = (np.asarray(a) for a in layout.split(jnp.asarray(v), velocities=True))
        belt = q[:, 0, :]
        scale = max(np.max(np.abs(belt)), np.max(np.abs(theta), initial=0.0), 1e-300)
        kind, span = _classify(drive, state, np.asarray(x[:nq, j]).reshape(layout.n, 2, 2)[:, 0, :], share)
        kinds.append(kind)
        spans.append(span)
        shares.append(share)
        belts.append(belt / scale)
        thetas.append(theta / scale)
        psis.append(psi / scale)
    return Modes(
        frequencies=np.asarray(freqs),
        kinds=kinds,
        span=spans,
        rotational_share=np.asarray(shares),
        shapes=dict(belt=np.asarray(belts), theta=np.asarray(thetas), psi=np.asarray(psis)),
        contact_stiffness=k,
        clutches={drive.model.pulley_names[i]: CLUTCH_LABELS[c] for i, c in enumerate(clutch) if c is not None},
        **extra,
    )


def _classify(drive: Drive, state: DriveState, belt_disp: np.ndarray, rotational_share: float):
    """ "transverse" when the belt's motion normal to its free spans carries most of the belt's motion, with
    the name of the span that carries most (spans of equal length and tension vibrate together: their
    modes mix); else "rotational" (pulleys, carriers and the spans' stretching)."""
    from ..outputs.signals import span_names

    path = drive.path
    pos = np.asarray(state.q)[:, 0, :]
    names = [f"{a}-{b}" for a, b in span_names(drive)]
    start, end = np.asarray(path.span_start), np.asarray(path.span_end)
    best, best_share, transverse = None, 0.0, 0.0
    total = float(np.sum(np.abs(belt_disp) ** 2)) or 1e-300
    for j, name in enumerate(names):
        d = end[j] - start[j]
        length = float(np.hypot(*d))
        if length <= 0:
            continue
        u = d / length
        s = (pos - start[j]) @ u
        off = np.abs((pos - start[j]) @ np.array([-u[1], u[0]]))
        inside = (s > 0.02 * length) & (s < 0.98 * length) & (off < 0.05 * length + 1e-3)
        normal = belt_disp[inside] @ np.array([-u[1], u[0]])
        share = float(np.sum(np.abs(normal) ** 2)) / total
        transverse += share
        if share > best_share:
            best, best_share = name, share
    if transverse > 0.5 and rotational_share < 0.5:
        return "transverse", best
    return "rotational", None
