"""Helpers shared by the test files (importable as ``from helpers import ...``: conftest.py puts tests/ on
sys.path): central differences, the normalised derivative error, tree comparison, quiet builds and states
picked out of a trajectory, and a run-time check of jaxtyping shape annotations."""

import contextlib
import dataclasses
import math
import typing
import warnings
from pathlib import Path
from types import UnionType

import equinox as eqx
import jax
import jaxtyping
import numpy as np

import jaxbelt as jb


def end_of_run_outputs(drive, keys):
    """``outputs(x, adjoint)``: the driven speed and the tight-span tension at the end of ``drive``'s run with
    the parameters ``keys`` set to ``x`` (the gradient tests' outputs)."""

    def outputs(x, adjoint):
        p = drive.params
        for i, k in enumerate(keys):
            p = jb.set_parameter(drive, p, k, x[i])
        _, s = jb.simulate_signals(drive, p, adjoint=adjoint)
        return jax.numpy.stack([s["omega:driven"][-1], s["tension:driven-driver"][-1]])

    return outputs


def central_difference(f, x, h):
    """``(f(x + h) - f(x - h)) / (2 h)`` for any pytree output of ``f`` (leaves as numpy arrays).

    Truncation error ~ h^2 |f'''| / 6, round-off ~ eps |f| / h: a relative step of 1e-5..1e-4 balances them
    in float64. ``h`` may be an array broadcasting against the outputs."""
    plus, minus = f(x + h), f(x - h)
    return jax.tree.map(lambda p, m: (np.asarray(p) - np.asarray(m)) / (2 * h), plus, minus)


def central_jacobian(f_batched, x0, rel_step):
    """Jacobian (outputs, inputs) of ``f`` at ``x0`` (n,) by central differences with step ``rel_step * x0``.

    ``f_batched`` maps a batch (2n, n) of inputs to a batch (2n, outputs): all 2n runs in one call
    (e.g. a jitted ``vmap``), the n forward points first."""
    x0 = np.asarray(x0)
    h = rel_step * x0
    pert = np.concatenate([x0 + np.diag(h), x0 - np.diag(h)])
    y = np.asarray(f_batched(pert))
    n = len(x0)
    return ((y[:n] - y[n:]) / (2 * h[:, None])).T


def forward_jacobian_and_differences(fn, x0, rel_step, batched=True, primal=False):
    """``(J_fwd, J_fd)`` of ``fn`` (n,) -> (outputs,) at ``x0`` from ONE compiled ``jax.jvp`` program: tangents
    ``e_k`` at ``x0`` give the forward-mode Jacobian, zero tangents at ``x0 +- rel_step x0_k e_k`` the central
    differences' values. Compiling is what these tests spend: one program instead of a Jacobian program and a
    second, primal one. ``batched``: the program is ``vmap``-ed over the 2n points (one call per use); else one
    point per call (for a scheme whose step is slow under ``vmap``, the implicit one's Newton solve).
    ``primal`` (with ``batched=False``): the differences' 2n values from a second program, ``fn`` alone, worth
    its compile where a run is long: test_implicit_stiffness's 1,000 implicit steps run in 1.0 s without the
    tangents against 3.5 s with them (compile 9.5 s; measured with ``quick_compile``)."""
    x0 = np.asarray(x0, dtype=float)
    n = len(x0)

    def jvp(x, dx):
        return jax.jvp(fn, (x,), (dx,))

    if batched:
        program = jax.jit(jax.vmap(jvp))
        rows = 2 * n  # the differences' batch size: the Jacobian's call pads to it (one program, one shape)
    else:
        one, rows = jax.jit(jvp), n

        def program(xs, dxs):
            outs = [one(x, dx) for x, dx in zip(xs, dxs)]
            return tuple(np.stack([np.asarray(o[i]) for o in outs]) for i in range(2))

    tangents = np.concatenate([np.eye(n), np.zeros((n, n))])[:rows]
    J_fwd = np.asarray(program(np.repeat(x0[None], rows, axis=0), tangents)[1][:n]).T
    if primal and not batched:
        value = jax.jit(fn)
        J_fd = central_jacobian(lambda pert: np.stack([np.asarray(value(x)) for x in pert]), x0, rel_step)
    else:
        J_fd = central_jacobian(lambda pert: program(pert, np.zeros_like(pert))[0], x0, rel_step)
    return J_fwd, J_fd


def reverse_projection(fn, x0, J_fwd, seed=0):
    """``(w, w^T J_rev)``: one pullback of ``fn`` at ``x0`` with a random cotangent ``w`` (each output weighted by
    a random factor in +-[0.5, 1.5] over its largest normalised sensitivity in ``J_fwd``, so that every output
    counts at its own scale), for the dot-product test ``w^T J_rev = w^T J_fwd``: one reverse run instead of one
    per output (a wrong row of J_rev changes the product, bar a measure-zero choice of w)."""
    x0 = np.asarray(x0, dtype=float)
    rng = np.random.default_rng(seed)
    scale = np.abs(J_fwd * x0[None, :]).max(axis=1)
    w = rng.uniform(0.5, 1.5, len(scale)) * rng.choice([-1.0, 1.0], len(scale)) / np.where(scale > 0, scale, 1.0)
    x = jax.numpy.asarray(x0)
    return w, np.asarray(jax.jit(lambda x, ct: jax.vjp(fn, x)[1](ct)[0])(x, jax.numpy.asarray(w)))


def reverse_jacobian(fn, x0, n_outputs):
    """Reverse-mode Jacobian (outputs, inputs) of ``fn`` at ``x0``: one compiled pullback program, called once
    per output with a unit cotangent (``jacrev``'s rows; tracing the pullback under ``vmap`` as ``jacrev``
    does costs ~25 % more tracing of the whole-run reverse program)."""
    x = jax.numpy.asarray(x0)
    pullback = jax.jit(lambda x, ct: jax.vjp(fn, x)[1](ct)[0])
    return np.stack([np.asarray(pullback(x, jax.numpy.asarray(e))) for e in np.eye(n_outputs)])


@contextlib.contextmanager
def quick_compile():
    """Programs compiled inside this block compile with XLA's backend optimisations off
    (``jax_disable_most_optimizations``: LLVM at -O0, no expensive passes; the same arithmetic, no fast-math),
    for a derivative program a test compiles once and runs once or a few times: test_spans_tier's reverse-mode
    gradient of a 0.4 s run compiled in 12 instead of 20 s (CPU) and ran in 2.3 instead of 1.6 s. Programs
    compiled outside the block (and those only loaded from the persistent cache) are not affected."""
    before = jax.config.read("jax_disable_most_optimizations")
    jax.config.update("jax_disable_most_optimizations", True)
    try:
        yield
    finally:
        jax.config.update("jax_disable_most_optimizations", before)


def normalised_error(x0, J, J_ref):
    """|J - J_ref| x_k relative to each output's largest normalised sensitivity max_k |J_ref x_k|: a derivative
    that barely matters is not judged by its own tiny size. ``J``, ``J_ref``: (outputs, inputs)."""
    scale = np.abs(J_ref * x0[None, :]).max(axis=1, keepdims=True)
    return np.abs((J - J_ref) * x0[None, :]) / scale


def assert_trees_close(a, b, rtol=0.0, atol=0.0, what=""):
    """Two pytrees with the same structure and leaves equal to ``rtol``/``atol`` (both 0: exactly equal, NaN
    equal to NaN); a failure names the leaf by its path."""
    flat_a, tree_a = jax.tree_util.tree_flatten_with_path(a)
    flat_b, tree_b = jax.tree_util.tree_flatten_with_path(b)
    assert tree_a == tree_b, f"{what}: tree structures differ:\n{tree_a}\n{tree_b}"
    for (path, x), (_, y) in zip(flat_a, flat_b):
        x, y, msg = np.asarray(x), np.asarray(y), f"{what}: leaf {jax.tree_util.keystr(path)}"
        if (rtol == 0 and atol == 0) or x.dtype == bool:  # allclose cannot subtract booleans
            np.testing.assert_array_equal(x, y, err_msg=msg)
        else:
            np.testing.assert_allclose(x, y, rtol=rtol, atol=atol, err_msg=msg)


def build_quietly(spec):
    """``jb.build_drive`` with its warnings silenced (tests use coarse meshes on purpose, for speed)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return jb.build_drive(spec)


def state_at(states, i):
    """The state at save index ``i`` of a saved trajectory's stacked states."""
    return jax.tree.map(lambda x: x[i], states)


def check_shapes(module, dims=None, what="", allow_unannotated=()) -> list[str]:
    """Check every array field of an ``eqx.Module`` (and of the modules inside it) against its jaxtyping
    annotation, at run time and without a type checker (jaxtyping's own ``isinstance`` inside its
    ``jaxtyped("context")``, which shares dimension names between the checks made in it).

    ``dims``: dimension sizes known from outside (e.g. ``n``, ``p``, ``nc`` of the model), bound first in
    every module's context, so that a name means the same size in every module of the tree; other names
    (``k`` knots of a time law) are bound per module instance. ``X | None`` fields may be None. Every array
    leaf must be covered by an array annotation, except inside the fields named (by path) in
    ``allow_unannotated`` (e.g. a dict of quadrature tables). Returns the checked paths (``what.field.sub``)."""
    checked, unannotated = [], []
    _check_module(module, dict(dims or {}), what or type(module).__name__, checked, unannotated)
    n_leaves = sum(isinstance(x, (jax.Array, np.ndarray)) for x in jax.tree.leaves(module))
    n_free = sum(n for _, n in unannotated)
    assert n_leaves == len(checked) + n_free, f"{what}: {n_leaves} array leaves, {len(checked)} checked: {checked}"
    bare = [w for w, _ in unannotated if w not in allow_unannotated]
    assert not bare, f"{what}: arrays without a shape annotation in {bare}"
    return checked


def _check_module(module, dims, path, checked, unannotated):
    hints = typing.get_type_hints(type(module), include_extras=True)
    with jaxtyping.jaxtyped("context"):
        if dims:  # bind the outside dimensions in this context first
            bound = jaxtyping.Shaped[jax.Array, " ".join(dims)]
            assert isinstance(jax.numpy.zeros(tuple(dims.values())), bound), dims
        seen = []
        for f in dataclasses.fields(module):
            value, ann, where = getattr(module, f.name), hints[f.name], f"{path}.{f.name}"
            options = typing.get_args(ann) if typing.get_origin(ann) in (typing.Union, UnionType) else (ann,)
            arrays = [a for a in options if isinstance(a, type) and issubclass(a, jaxtyping.AbstractArray)]
            if value is None:
                assert type(None) in options, f"{where}: None, annotated {ann}"
            elif arrays:
                (a,) = arrays
                shape, dtype = getattr(value, "shape", None), getattr(value, "dtype", None)
                assert isinstance(value, a), (
                    f"{where}: {type(value).__name__} {dtype}{list(shape or ())} does not "
                    f"match {a.__name__}; bound {dims}, checked before: {seen}"
                )
                seen.append(f"{f.name} {list(shape)} ~ '{a.dim_str}'")
                checked.append(where)
            elif isinstance(value, eqx.Module):
                _check_module(value, dims, where, checked, unannotated)
            elif isinstance(value, (jax.Array, np.ndarray)):
                assert jax.Array in options, f"{where}: an array annotated {ann}"
                checked.append(where)
            else:  # a container (dict, tuple) of arrays: no shape annotation to check against
                n = sum(isinstance(x, (jax.Array, np.ndarray)) for x in jax.tree.leaves(value))
                if n:
                    unannotated.append((where, n))


def arm_rig_params(
    damping=0.0, preload=0.0, inertia=2e-3, spring=20.0, friction=0.0, damping_unload=0.0, stops=(-np.inf, np.inf)
):
    """PulleyParams of the one-arm carrier rig (``jaxbelt.pulleys.rig``): pulley r = 0.03 m on an arm of
    0.08 m, arm inertia [kg m^2], spring [N m/rad], preload [N m], damping [N m s/rad]; and the numbers of a
    ``LossyCarrier`` around it (pivot friction [N m], unloading damping, stops [rad]), unread by a plain arm."""
    from jaxbelt._types import PulleyParams
    from jaxbelt.pulleys import timelaw as tl

    f = lambda x: jax.numpy.asarray([x], dtype=float)  # noqa: E731
    s = lambda x: jax.numpy.asarray(x, dtype=float)  # noqa: E731
    law = tl.stack_laws([tl.constant(0.0)])
    numbers = dict(stiffness=spring, preload=preload, damping=damping, inertia=inertia, mass=0.0, rest=0.0)
    numbers.update(length=0.08, friction_torque=friction, damping_unload=damping_unload)
    numbers.update({"stops.min": stops[0], "stops.max": stops[1]})
    return PulleyParams(
        radius=f(0.03),
        center=jax.numpy.zeros((1, 2)),
        inertia=f(1e-3),
        speed=law,
        torque=law,
        viscous=f(0.0),
        carrier=({k: s(v) for k, v in numbers.items()},),
    )


def capstan_belt(n_elements=32, belt_type="flat"):
    """The soft belt of the two-pulley capstan and overload drives (pulleys r = 0.1 m, 0.3 m apart):
    EA 5 kN (a large stable step), 200 N installed; shared so that their programs match."""
    return jb.BeltSpec(
        n_elements=n_elements,
        width=0.02,
        thickness=0.004,
        EA=5000.0,
        EI=2e-3,
        mass_per_length=0.1,
        axial_damping=0.1,
        pretension=200.0,
        type=belt_type,
        inner_offset=0.0,
    )


def _tensioner_spec(t_end=0.8):
    return jb.DriveSpec(
        belt=jb.BeltSpec(
            n_elements=60,
            width=0.02,
            thickness=0.004,
            EA=8000.0,
            EI=4e-3,
            mass_per_length=0.12,
            axial_damping=0.2,
            pretension=150.0,
            type="poly-v",
            inner_offset=0.0,
            back_offset=0.0,
        ),
        pulleys=[
            jb.PulleySpec("crank", (0, 0), 0.08, role="driver", inertia=0.1, speed={"ramp": [0.0, 0.2, 0.0, 15.0]}),
            jb.PulleySpec(
                "alt",
                (0.35, 0.05),
                0.05,
                role="driven",
                inertia=0.002,
                load={"smooth_step": [0.2, 0.35, 0.0, 3.0]},
                viscous=0.01,
            ),
            jb.PulleySpec(
                "tens",
                (0.18, -0.14),
                0.04,
                role="tensioner",
                inertia=5e-4,
                tensioner=jb.TensionerSpec(
                    kind="arm", pivot=(0.10, -0.14), stiffness=20.0, preload=-12.0, damping=0.3, inertia=2e-3
                ),
            ),
        ],
        contact=jb.ContactSpec(mu=0.4, stiffness=1e8, damping=2e3),
        solver=jb.SolverSpec(t_end=t_end, save_dt=2e-3),
    )


# the identification experiment of test_identify.py (also used by benchmarks/bench_identify.py)
TRUTH = {"belt.E": 9.5e6, "belt.eta": 3.0 / 8e-4, "contact.mu": 0.5}
START = {"belt.E": 1.3, "belt.eta": 0.7, "contact.mu": 1.3}  # 30 % off


def identification_spec():
    L0 = 0.38 * math.pi
    return jb.DriveSpec(
        belt=jb.BeltSpec(
            n_elements=26,
            width=0.08,
            thickness=0.01,
            E=TRUTH["belt.E"],
            EI=1.333e-3,
            mass_per_length=0.87,
            eta=TRUTH["belt.eta"],
            stress_free_length=L0,
            inner_offset=0.0,
        ),
        pulleys=[
            jb.PulleySpec("driver", (0, 0), 0.1, role="driver", inertia=0.25, speed={"ramp": [0.0, 0.1, 0.0, 10.0]}),
            jb.PulleySpec(
                "driven",
                (0.1 * math.pi, 0),
                0.1,
                role="driven",
                inertia=0.05,
                load={"ramp": [0.3, 0.75, 0.0, 45.0]},
                viscous=0.2,
            ),
        ],
        contact=jb.ContactSpec(mu=TRUTH["contact.mu"]),
        solver=jb.SolverSpec(t_end=0.8, save_dt=2e-3),
        gravity=(0.0, -9.81),
    )


# the drives of test_clutch.py, test_tensioner_friction.py and test_fead_parameter_keys.py: one spec each,
# so that the compiled programs are shared (persistent cache) within a test session
CLUTCH_DROP = 0.3  # crank deceleration starts [s]
CLUTCH_LOAD = 1.5  # alternator load on the rotor [N m] (viscous 0)
CLUTCH_J = (5e-4, 1.5e-3)  # the alternator's sheave and rotor inertias [kg m^2]


def clutch_serpentine_spec(clutch="oap", t_end=0.45, n_elements=32):
    """The serpentine example (coarse) with its alternator (index 2) on a one-way clutch (a decoupler:
    40 N m/rad, 0.02 N m s/rad; ``None``: a solid pulley of the summed inertia): the crank runs up,
    holds 40 rad/s, then drops to 25 rad/s in 10 ms."""
    spec = jb.load_config("examples/serpentine_tensioner.toml")
    spec.belt.n_elements = n_elements
    spec.solver.t_end, spec.solver.save_dt = t_end, 2e-3
    crank, alt = spec.pulleys[0], spec.pulleys[2]
    crank.speed = {"table": [[0.0, 0.0], [0.15, 40.0], [CLUTCH_DROP, 40.0], [CLUTCH_DROP + 0.01, 25.0]]}
    alt.load = {"smooth_step": [0.05, 0.1, 0.0, CLUTCH_LOAD]}
    alt.viscous = 0.0
    if clutch is None:
        alt.inertia = sum(CLUTCH_J)
    else:
        alt.inertia, alt.clutch, alt.rotor_inertia = CLUTCH_J[0], clutch, CLUTCH_J[1]
        alt.clutch_stiffness, alt.clutch_damping = 40.0, 0.02
    return spec


def lossy_serpentine_spec(friction=0.3, stops=(-0.3, 0.3)):
    """The serpentine example (coarse, 0.3 s) with pivot friction [N m], stops [rad] and unloading
    damping 0.1 N m s/rad on its arm tensioner (index 1)."""
    spec = jb.load_config("examples/serpentine_tensioner.toml")
    spec.belt.n_elements = 24
    spec.solver.t_end, spec.solver.save_dt = 0.3, 5e-3
    t = spec.pulleys[1].tensioner
    t.friction_torque, t.stops, t.damping_unload = friction, stops, 0.1
    return spec


def two_pulley_toml(
    *,
    n_elements: int,
    t_end: float,
    speed_ramp: tuple[float, float],
    load_ramp: tuple[float, float],
    EA: float = 7600.0,
    mu: float = 0.5,
    driven_inertia: float = 0.05,
) -> str:
    """Benchmark A's geometry as a small TOML file for the command-line tests: the driver ramps to 10 rad/s
    over ``speed_ramp`` (start, end) [s], a load ramps to 20 N m over ``load_ramp``: a short transient on
    purpose (``solver.expect_steady = false``: its window is a record of the start-up, not a duty point)."""
    return f"""
gravity = [0.0, -9.81]
[belt]
n_elements = {n_elements}
width = 0.08
thickness = 0.01
EA = {EA!r}
EI = 1.333e-3
mass_per_length = 0.8724
axial_damping = 0.95
stress_free_length = 1.1938052083641213
inner_offset = 0.0
[[pulleys]]
name = "driver"
center = [0.0, 0.0]
radius = 0.1
role = "driver"
inertia = 0.25
speed = {{ ramp = [{speed_ramp[0]!r}, {speed_ramp[1]!r}, 0.0, 10.0] }}
[[pulleys]]
name = "driven"
center = [0.3141592653589793, 0.0]
radius = 0.1
role = "driven"
inertia = {driven_inertia!r}
load = {{ ramp = [{load_ramp[0]!r}, {load_ramp[1]!r}, 0.0, 20.0] }}
viscous = 0.2
[contact]
mu = {mu!r}
[solver]
t_end = {t_end!r}
save_dt = 0.002
expect_steady = false
"""


def free_port() -> int:
    """A TCP port on 127.0.0.1 that was free a moment ago (for a jax.distributed coordinator in a test)."""
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# ------------------------------------------------------------------ the report's drives and duty results
# (tests/test_report.py and tests/test_report_layout.py)
EXAMPLES = Path(__file__).parent.parent / "examples"
RPM_RAD = 2 * math.pi / 60


def accessory_drive(n_elements: int = 40):
    spec = jb.load_config(EXAMPLES / "accessory_drive.toml")
    spec.belt.n_elements = n_elements  # statics do not depend on it; the modes little
    return jb.build_drive(spec)


def stiff_serpentine_spec(t_end=0.5, n_elements=120):
    """The fast-by-default issue's 6-pulley supplier drive, approximated on the accessory example's layout: an
    8PK belt (EA 88 kN, 0.144 kg/m, 120 elements), the arm-carried tensioner pulley of 1.5e-4 kg m^2 between
    spans of about 200 and 110 mm, the light alternator sheave on its one-way clutch, the accessory loads ramped
    in over 0.1-0.2 s while the crank reaches idle (800 rpm) by 0.15 s."""
    spec = jb.load_config(EXAMPLES / "accessory_drive.toml")
    b = spec.belt
    b.EA, b.mass_per_length, b.ribs, b.width, b.n_elements = 88e3, 0.144, 8, 8 * 3.56e-3, n_elements
    for p in spec.pulleys:
        if p.power_kw is not None:
            p.power_kw = {"ramp": [0.1, 0.2, 0.0, float(p.power_kw)]}
    spec.solver.expect_steady, spec.solver.t_end = False, t_end
    return spec


AMP = {"crank-tensioner": 40.0}  # tension amplitude [N] of a span's synthetic signal (others 10 N)
HUB_RIPPLE = 0.6  # hub-load ripple over its mean: peak / mean = 1.6 > 1.5, the default limit
ARM_RIPPLE_DEG = 1.25  # arm angle amplitude: peak-to-peak 2.5 deg
OVERRUN_SHARE = 0.3  # share of the window the alternator's rotor runs ahead of its sheave
SF_MIN = 1.25  # every pulley's minimum slip safety factor over the window (friction use 0.8)


def synthetic_duty(drive, rpm=(800.0, 3000.0)):
    """A duty result whose means and signals are known: the last point is not steady and its crank's mean slip
    safety factor is 0.8 (1.5 at the first); each span's tension oscillates at 50 Hz (sampled at 1 kHz: the
    window holds its extremes)."""
    names = list(drive.model.pulley_names)
    spans = [f"{a}-{names[(i + 1) % len(names)]}" for i, a in enumerate(names)]
    rpm = np.asarray(rpm, dtype=float)
    S = rpm.size
    t = np.linspace(0.0, 0.5, 501)
    wave = np.sin(2 * np.pi * 50 * t)
    R = np.asarray(drive.params.pulleys.radius)
    sense = np.asarray(drive.running_sense, dtype=float)
    omega = rpm[:, None] * RPM_RAD * R[0] / R[None, :] * sense[None, :]  # (S, pulleys)
    sig = {"t": t}
    for s in spans:
        sig[f"tension:{s}"] = 300.0 + AMP.get(s, 10.0) * np.tile(wave, (S, 1))
        sig[f"speed:{s}"] = np.tile(rpm[:, None] * RPM_RAD * R[0], (1, t.size))
        sig[f"deflection:{s}"] = np.zeros((S, t.size))
    for i, n in enumerate(names):
        sig[f"omega:{n}"] = np.tile(omega[:, i : i + 1], (1, t.size))
        sig[f"slip:{n}"] = np.full((S, t.size), 0.5)
        sig[f"friction_use:{n}"] = np.full((S, t.size), 1 / SF_MIN)
        sig[f"hub_load:{n}"] = 400.0 * (1 + HUB_RIPPLE * np.tile(wave, (S, 1)))
        sig[f"hub_direction:{n}"] = np.full((S, t.size), 30.0)
    sig["arm_angle:tensioner"] = np.radians(79.0 + ARM_RIPPLE_DEG * np.tile(wave, (S, 1)))
    ahead = (np.arange(t.size) % 10 < 10 * OVERRUN_SHARE).astype(float) * 5.0  # 5 rad/s ahead 3 samples in 10
    i = names.index("alternator")
    sig["rotor_omega:alternator"] = sig["omega:alternator"] + sense[i] * ahead[None, :]
    safety = {n: np.full(S, 3.0) for n in names}
    safety["crank"] = np.linspace(1.5, 0.8, S)
    from jaxbelt.analysis.duty import DutyResult

    res = DutyResult(
        rpm=rpm,
        loads={"alternator": np.linspace(3.0, 1.5, S)},
        spans={s: {"tension": np.full(S, 300.0), "tension_eff": np.full(S, 290.0)} for s in spans},
        pulleys={
            n: {"hub_load": np.full(S, 400.0), "slip_safety": safety[n], "speed": omega[:, k]}
            for k, n in enumerate(names)
        },
        tensioners={"tensioner": np.full(S, 79.0)},
        faults=np.zeros(S, dtype=int),
        timing={},
    )
    res.steady = np.arange(S) < S - 1  # as duty_study says it: the last point is not steady
    res.status = ["ok"] * (S - 1) + ["not steady: still changing over the window: tension:ac-crank -12.2 N"]
    res.signals = sig
    return res


CASES = {"nominal": 0.0, "shortest": -0.004, "longest": 0.004, "worn": 0.012}


def excited_two_pulley_spec(speed: dict, excitation, t_end: float = 1.0, n_elements: int = 12, start=None, **driver):
    """A small two-pulley drive (0.1 m pulleys 0.3 m apart, EA 5 kN, 200 N) whose driver takes ``speed`` (a dict:
    ``speed``, ``speed_rpm`` or ``torque``) and the engine orders ``excitation``; saves every 1 ms. Shared by the
    excitation tests and the summary-window tests."""
    import jaxbelt as jb

    solver = (
        jb.SolverSpec(t_end=t_end, save_dt=1e-3)
        if start is None
        else jb.SolverSpec(t_end=t_end, save_dt=1e-3, start=start)
    )
    return jb.DriveSpec(
        belt=dataclasses.replace(capstan_belt(n_elements), EI=2e-4),  # the capstan drives' belt, more flexible
        pulleys=[
            jb.PulleySpec("crank", (0, 0), 0.1, role="driver", inertia=0.1, excitation=excitation, **speed, **driver),
            jb.PulleySpec("driven", (0.3, 0), 0.1, role="driven", inertia=0.01, load=2.0),
        ],
        contact=jb.ContactSpec(mu=0.5, stiffness=1e8, damping=2e3),
        solver=solver,
    )
