"""The spans tier's time loop (one compiled program: a scan over saves of a loop over steps, static counts,
so ``jax.grad`` / ``jax.jacfwd`` / ``vmap`` go through it), its stable step, and its named signals (the ANCF
tier's names where the figure is the same)."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from .._cache import per_drive
from .._drive import Drive
from .._types import DriveParams
from ..pulleys.carrier import to_coordinates
from .model import SpansModel, SpansState, initial_spans_state, sliding_mu, span_geometry, span_path
from .step import centrifugal_tension, lumped_inertia, stepped_geometry

SPEED_FLOOR = 1e-3  # m/s: below this belt speed a wrap's slip is reported as 0 (as the ANCF tier's)

__all__ = [
    "SpansResult",
    "SpansTrajectory",
    "run_spans",
    "simulate_spans",
    "running_start",
    "spans_stick_shares",
    "spans_signal_names",
    "spans_signals",
    "spans_signals_of",
    "spans_time_step",
    "spans_time_steps",
    "STABILITY_FRACTION",
]

_STARTS: dict = {}  # per drive: the compiled installed state
_STEPS: dict = {}  # per drive: its stable step
_W2: dict = {}  # per drive: the compiled highest frequency (one variant, a batch)
STABILITY_FRACTION = 0.5  # of the explicit limit 2 / w_max of the stiffest pulley-span or carrier-span mode
MAX_STEP = 1e-4  # [s]: 40 steps per period up to 250 Hz (the engine orders of an accessory drive)


@dataclasses.dataclass(frozen=True)
class SpansTrajectory:
    """Saved states ``states`` (leading axis: time) at ``ts`` [s], and the step ``dt`` they were made with."""

    ts: jax.Array
    states: SpansState
    dt: float


def _highest_w2(drive: Drive, params: DriveParams):
    """The square of the highest pulley-span or carrier-span frequency [rad^2/s^2] (traceable): each free sheave
    on its two spans, ``R^2 (EA/L_a + EA/L_l) / J`` (belt inertia lumped), each carrier on its spans' axial
    stiffness."""
    sm = SpansModel.of(drive)
    st = initial_spans_state(drive, params)
    L, d, phi, dcenter = span_geometry(sm, params, st.psi)
    pp, EA = params.pulleys, params.belt.EA
    J = pp.inertia + lumped_inertia(sm, params, L, phi)
    la, ll = (jnp.asarray(np.asarray(x)) for x in (sm.arrive, sm.leave))
    spin = pp.radius**2 * (EA / L[la] + EA / L[ll]) / J
    along = EA / L[la] * jnp.sum(d[la] * dcenter, -1) ** 2 + EA / L[ll] * jnp.sum(d[ll] * dcenter, -1) ** 2
    along = to_coordinates(drive.model, along)  # a pendulum's arm on both its idlers' spans
    movable = jnp.asarray([c.movable for c in drive.model.carriers])
    inertia = jnp.stack([c.numbers(pp, k)["inertia"] if c.movable else 1.0 for k, c in enumerate(drive.model.carriers)])
    carrier = jnp.where(movable, along / inertia, 0.0)
    free = ~jnp.asarray(np.asarray(drive.model.kinematic))
    return jnp.maximum(jnp.max(jnp.where(free, spin, 0.0)), jnp.max(carrier))


def _step_of(w2) -> np.ndarray:
    return np.minimum(MAX_STEP, STABILITY_FRACTION * 2.0 / np.sqrt(np.asarray(w2)))


def spans_time_step(drive: Drive, params: DriveParams | None = None) -> float:
    """``STABILITY_FRACTION`` of the explicit limit 2 / w_max (``_highest_w2``); at most ``MAX_STEP``."""
    params = drive.params if params is None else params
    program = per_drive(_W2, drive, lambda: jax.jit(lambda p: _highest_w2(drive, p)))
    with jax.ensure_compile_time_eval():  # concrete numbers even when called while tracing (sweeps, gradients)
        return float(_step_of(program(params)))


# the batch ``spans_time_steps`` evaluates at once: one compiled program per drive for every sweep size (a program
# per batch size compiled again for each sweep: 4.1 of a 1,000-point sweep's 4.6 s outside its run and compile)
STEP_BLOCK = 64


def spans_time_steps(drive: Drive, params: DriveParams) -> np.ndarray:
    """``spans_time_step`` of each of a batch of parameters (leading axis: the variants of a sweep), in blocks of
    ``STEP_BLOCK`` (the last one padded with its last variant)."""
    program = per_drive(_W2, drive, lambda: jax.jit(jax.vmap(lambda p: _highest_w2(drive, p))), "batch")
    n = int(jax.tree.leaves(params)[0].shape[0])
    take = np.minimum(np.arange(-(-n // STEP_BLOCK) * STEP_BLOCK), n - 1).reshape(-1, STEP_BLOCK)
    w2 = [np.asarray(program(jax.tree.map(lambda a: a[rows], params))) for rows in take]
    return _step_of(np.concatenate(w2)[:n])


def simulate_spans(
    drive: Drive,
    params: DriveParams | None = None,
    *,
    t_end: float,
    dt: float | None = None,
    save_dt: float | None = None,
    state0: SpansState | None = None,
    running: bool = False,
    batched: bool = False,
) -> SpansTrajectory:
    """Run the spans tier of ``drive`` from its installed state (``running``: at speed) or ``state0`` to
    ``t_end``, saving every ``save_dt`` (default: the drive's save interval). Traceable in ``params``.
    ``batched``: the caller vmaps this run over many points and does not reverse-differentiate it (a sweep): a
    step then runs the gross-slip projection only where some point of the batch slips (forward mode and vmap
    only; ``step.capstan_projection``)."""
    params = drive.params if params is None else params
    if dt is None:  # the built drive's numbers (params may be traced), once per drive
        dt = per_drive(_STEPS, drive, lambda: spans_time_step(drive))
    dt = float(dt)
    save_dt = float(drive.options.save_dt if save_dt is None else save_dt)
    stride = max(1, round(save_dt / dt))
    n_saves = max(1, round(t_end / (stride * dt)))
    sm = SpansModel.of(drive)
    if batched:
        sm = dataclasses.replace(sm, batched=True)
    if state0 is None:  # the statics' Newton solve, compiled once per drive
        start = per_drive(
            _STARTS, drive, lambda: jax.jit(lambda p: initial_spans_state(drive, p, running=running)), running
        )
        state0 = start(params)
    st0 = state0
    ts, states = _run(sm, params, st0, dt, stride, n_saves)
    return SpansTrajectory(ts=ts, states=states, dt=dt)


@jax.jit(static_argnums=(0, 3, 4, 5))
def _run(sm: SpansModel, params: DriveParams, st0: SpansState, dt: float, stride: int, n_saves: int):
    def save(carry, n):
        def one(j, c):  # the state and its belt path, handed on from step to step
            st, geometry = c
            return stepped_geometry(sm, params, st, (n * stride + j).astype(st.omega.dtype) * dt, dt, geometry)

        carry = jax.lax.fori_loop(0, stride, one, carry)
        return carry, carry[0]

    _, states = jax.lax.scan(save, (st0, span_path(sm, params, st0.psi)), jnp.arange(n_saves))
    states = jax.tree.map(lambda a, b: jnp.concatenate([a[None], b]), st0, states)
    ts = jnp.arange(n_saves + 1, dtype=st0.omega.dtype) * (stride * dt)
    return ts, states


def spans_signals_of(drive: Drive, params: DriveParams, ts, states: SpansState) -> dict[str, jax.Array]:
    """Named signals of saved spans-tier states (traceable; the ANCF tier's quantities and names, see
    ``outputs.signals``): ``omega:P``, ``tension:A-B``, ``speed:A-B`` (the belt's along the travel: the flux of
    belt its source wrap passes on, stretched by the span's strain), ``hub_load:P``, ``torque:P`` (the belt's,
    counter-clockwise positive), ``hub_direction:P`` [deg, counter-clockwise from +x], ``arm_angle:P`` /
    ``travel:P``, ``rotor_omega:P``, ``slip:P`` [%] (the wrap's gross-slip flux against the belt speed on it: 0 in
    creep) and ``friction_use:P``
    (``|ln((T_1 - m'v^2) / (T_2 - m'v^2))| / (mu phi)``, the inverse of the slip safety factor; 1 at the capstan
    limit)."""
    sm = SpansModel.of(drive)
    names = list(drive.model.pulley_names)
    k = len(names)
    s = states
    out: dict[str, jax.Array] = {"t": ts}
    sense = jnp.asarray(sm.sense)
    arrive, leave, source = (jnp.asarray(np.asarray(x)) for x in (sm.arrive, sm.leave, sm.source))
    R = params.pulleys.radius
    for i, n in enumerate(names):
        out[f"omega:{n}"] = s.omega[:, i]
    for j in range(k):
        out[f"tension:{names[j]}-{names[(j + 1) % k]}"] = s.tension[:, j]
    flux = sense * R * s.omega / (1.0 + s.strain[:, arrive])  # stress-free belt each wrap takes in per second
    speed = flux[:, source] * (1.0 + s.strain)  # per span, along the travel
    for j in range(k):
        out[f"speed:{names[j]}-{names[(j + 1) % k]}"] = speed[:, j]
    phi = jax.vmap(lambda psi: span_geometry(sm, params, psi)[2])(s.psi)
    mu = sliding_mu(drive.model, params)
    cent = jax.vmap(lambda e, w: centrifugal_tension(sm, params, e, w))(s.strain, s.omega)
    ta, tl = s.tension[:, arrive] - cent, s.tension[:, leave] - cent
    hi, lo = jnp.maximum(ta, tl), jnp.minimum(ta, tl)
    safe_lo = jnp.where(lo > 0, lo, 1.0)
    # a slack side (T - m'v^2 <= 0): friction cannot hold any ratio, the use is unbounded
    use = jnp.where(lo > 0, jnp.log(jnp.maximum(hi, safe_lo) / safe_lo) / (mu * phi), jnp.inf)
    belt_speed = jnp.abs(sense * R * s.omega) + jnp.abs(s.slip)
    slip = 100.0 * s.slip / jnp.where(belt_speed > SPEED_FLOOR, belt_speed, 1.0)
    for i, n in enumerate(names):
        hx, hy = s.hub[:, i, 0], s.hub[:, i, 1]
        loaded = hx * hx + hy * hy > 0  # (guards: no NaN in the derivatives of an unloaded pulley)
        out[f"hub_load:{n}"] = jnp.where(loaded, jnp.sqrt(jnp.where(loaded, hx * hx + hy * hy, 1.0)), 0.0)
        out[f"hub_direction:{n}"] = jnp.where(loaded, jnp.degrees(jnp.arctan2(hy, jnp.where(loaded, hx, 1.0))), 0.0)
        out[f"torque:{n}"] = sense[i] * s.belt_torque[:, i]
        c = drive.model.carriers[i]
        if c.movable:
            out[f"{c.coordinate or 'coordinate'}:{n}"] = s.psi[:, i]
        if c.load_on_carrier:
            out[f"rotor_omega:{n}"] = s.psi_dot[:, i]
        out[f"slip:{n}"] = jnp.where(belt_speed[:, i] > SPEED_FLOOR, slip[:, i], 0.0)
        out[f"friction_use:{n}"] = use[:, i]
    return out


def spans_signals(drive: Drive, traj: SpansTrajectory, params: DriveParams | None = None) -> dict[str, np.ndarray]:
    """``spans_signals_of`` of a run as numpy arrays (``t`` first)."""
    params = drive.params if params is None else params
    return {k: np.asarray(v) for k, v in spans_signals_of(drive, params, traj.ts, traj.states).items()}


def slip_warnings(share: dict, found: dict) -> list[str]:
    """The spans tier's intermittent-slip warning of a steady window: each wrap's share of the window's samples
    in which it slides (``share``: pulley -> share gripping, ``spans_stick_shares``) beside ``found`` (the
    window's ``steadiness``): the check's own sentence (from mean speeds) only where this count has none, so no
    wrap is named twice."""
    partial = [f"{n} ({1.0 - c:.0%})" for n, c in share.items() if 0.0 < 1.0 - c and n not in found["gross_slip"]]
    if partial:
        return [f"intermittent gross slip (share of the window's samples): {', '.join(partial)}"]
    return [found["intermittent_slip"]] if found.get("intermittent_slip") else []


def spans_signal_names(drive: Drive) -> list[str]:
    """The names ``spans_signals`` returns for ``drive`` (without ``t``), known before a run."""
    names = list(drive.model.pulley_names)
    k = len(names)
    spans = [f"{names[j]}-{names[(j + 1) % k]}" for j in range(k)]
    out = [f"omega:{n}" for n in names] + [f"tension:{s}" for s in spans] + [f"speed:{s}" for s in spans]
    for i, n in enumerate(names):
        out += [f"hub_load:{n}", f"hub_direction:{n}", f"torque:{n}"]
        c = drive.model.carriers[i]
        if c.movable:
            out.append(f"{c.coordinate or 'coordinate'}:{n}")
        if c.load_on_carrier:
            out.append(f"rotor_omega:{n}")
        out += [f"slip:{n}", f"friction_use:{n}"]
    return out


@dataclasses.dataclass(frozen=True)
class SpansResult:
    """A spans-tier run as analyses read it: the drive, its trajectory, its named signals and a summary with
    ``status`` ("ok", or why not)."""

    drive: Drive
    trajectory: SpansTrajectory
    signals: dict
    summary: dict


def running_start(drive: Drive) -> bool:
    """Whether the drive is configured to start at speed (``solver.start = "running"``)."""
    return drive.params.start is not None


def spans_stick_shares(sig: dict, names, sel) -> dict[str, float]:
    """Each wrap's share of the window ``sel`` without gross slip (the spans tier's twin of the ANCF tier's
    share of sticking contact points, ``outputs.steadiness.stick_shares``: a wrap in creep has its adhesion arc)."""
    return {n: float(np.mean(np.asarray(sig[f"slip:{n}"])[sel] == 0.0)) for n in names}


def run_spans(
    drive: Drive,
    *,
    t_end: float | None = None,
    running: bool | None = None,
    window: float = 0.2,
    steady: bool | None = None,
) -> SpansResult:
    """Run ``drive`` on the spans tier to ``t_end`` (default: its configured end), saving at its save interval,
    from rest or (``running``; default: the drive's ``solver.start``) at speed. ``summary["status"]``: "ok"; or
    the state became non-finite; or the final ``window`` fraction is not what the ANCF tier's run would call a
    steady state without gross slip (``outputs.steadiness``, the same checks: laws done, no drift unless
    ``steady`` is False (default: the spec's ``solver.expect_steady``), no wrap in gross slip over the window).
    A wrap that slides in part of the window is a warning (intermittent slip, e.g. once per engine cycle)."""
    from ..outputs.steadiness import STICK_SHARE_MIN, steadiness
    from ..outputs.window import summary_window

    t_end = float(drive.options.t_end if t_end is None else t_end)
    running = running_start(drive) if running is None else running
    if steady is None:
        steady = bool(getattr(drive.spec.solver, "expect_steady", True)) if drive.spec is not None else True
    traj = simulate_spans(drive, t_end=t_end, save_dt=float(drive.options.save_dt), running=running)
    sig = spans_signals(drive, traj)
    finite = all(np.all(np.isfinite(v)) for k, v in sig.items() if not k.startswith("friction_use:"))
    t = sig["t"]
    late, periods = summary_window(drive, t, np.asarray(traj.states.theta), window)  # as the ANCF tier's
    names = list(drive.model.pulley_names)
    share = spans_stick_shares(sig, names, late)
    warnings: list[str] = []
    if not finite:
        status = "the spans tier's state became non-finite (a step too long for this drive?)"
    else:
        found = steadiness(drive, sig, late, check_drift=steady, stick_share=share)
        # this tier knows each wrap's gross slip: one sliding over (nearly) the whole window is gross slip even
        # where its surface speed lies between its spans' (a driver whose belt friction cannot take along)
        sliding = [n for n, c in share.items() if c <= STICK_SHARE_MIN and n not in found["gross_slip"]]
        if sliding:
            found["gross_slip"] = [*found["gross_slip"], *sliding]
            found["findings"].append(
                "the belt slides over the whole wrap of " + ", ".join(repr(n) for n in sliding) + " all the window"
            )
        ok = found["steady"] and not found["gross_slip"]
        head = "gross slip" if found["gross_slip"] else "not steady"
        status = "ok" if ok else f"{head}: " + "; ".join(found["findings"])
        # this tier knows each wrap's gross slip exactly: a wrap sliding in part of the window (once per engine
        # cycle, say) is said even where its mean speed stays within the steadiness check's 1 % of the belt speed;
        # the check's own sentence (from mean speeds) only where this count has none, so no wrap is named twice
        warnings.extend(slip_warnings(share, found))
    summary = {
        "status": status,
        "model": "spans",
        "warnings": warnings,
        "stick_share": share,
        "window_s": [float(t[late][0]), float(t[-1])],
        "window_periods": periods,
    }
    return SpansResult(drive=drive, trajectory=traj, signals=sig, summary=summary)
