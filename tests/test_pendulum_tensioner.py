"""The pendulum (rocker) tensioner of belt-starter-generator drives (``pulleys/carriers/pendulum.py``): one arm
about the starter-generator's axis carrying two idlers. Statics against the arm's moment balance with both idlers'
hub loads (closed form); a run in which the starter-generator switches from generator to motor swings the arm to
the other side, as far as the statics says; the spans tier carries it too; bad pendulums are refused by name."""

import copy
import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import EXAMPLES, build_quietly, central_difference, quick_compile

import jaxbelt as jb
from jaxbelt.analysis.statics import solve_statics, statics

EXAMPLE = EXAMPLES / "bsg_pendulum.toml"
LOAD = 8.0  # N m the starter-generator absorbs as a generator (and supplies as a motor) in the example


@pytest.fixture(scope="module")
def spec():
    return jb.load_config(EXAMPLE)


@pytest.fixture(scope="module")
def drive(spec):
    return build_quietly(spec)


def _cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


@pytest.mark.parametrize("torque", [LOAD, 0.0, -LOAD], ids=["generator", "idle", "motor"])
def test_statics_holds_the_pendulum_in_moment_balance_with_both_idlers(spec, drive, torque):
    """Both idlers ride one rigid arm: with the arm angle psi the statics found, their centres are the drawn ones
    turned about the pivot by psi - psi0, and the spring torque k (psi0 - psi) balances the moments of both
    idlers' hub loads about the pivot, sum (c_i - pivot) x H_i, to round-off (1e-9 of the largest moment). Each
    idler's hub load is 2 T sin(wrap / 2) (no torque on an idler). A generator load swings the arm clockwise (the
    slack side crank -> idler_a is taken up), a motor counter-clockwise, each by about 3 degrees."""
    st = statics(drive, {"sg": torque})
    by_name = {p.name: p for p in spec.pulleys}
    t = by_name["idler_a"].tensioner
    pivot = np.asarray(t.pivot)
    psi = st.pulleys["idler_a"]["arm_angle"]
    psi0 = math.atan2(*(np.asarray(by_name["idler_a"].center) - pivot)[::-1])
    turn = np.array([[math.cos(psi - psi0), -math.sin(psi - psi0)], [math.sin(psi - psi0), math.cos(psi - psi0)]])
    moments = []
    for name in ("idler_a", "idler_b"):
        p = st.pulleys[name]
        assert p["tension_out"] == pytest.approx(p["tension_in"], rel=1e-12)
        assert p["hub_load"] == pytest.approx(2 * p["tension_in"] * math.sin(math.radians(p["wrap_deg"]) / 2), rel=1e-9)
        arm = turn @ (np.asarray(by_name[name].center) - pivot)
        direction = math.radians(p["hub_load_deg"])
        moments.append(_cross(arm, p["hub_load"] * np.array([math.cos(direction), math.sin(direction)])))
    spring = t.stiffness * (psi0 - psi)  # preload 0, rest = the drawn angle
    assert spring + sum(moments) == pytest.approx(0.0, abs=1e-9 * max(abs(m) for m in moments))
    swing = math.degrees(psi - psi0)
    if torque > 0:
        assert -4.0 < swing < -2.5
    elif torque < 0:
        assert 2.5 < swing < 4.0
    else:
        assert abs(swing) < 1e-6  # symmetric drive, equal tensions: no moment on the arm


@pytest.mark.long
def test_the_pendulum_angle_gradient_matches_central_differences(drive):
    """d(arm angle)/d(spring stiffness) under the generator load, forward and reverse mode through the statics'
    Newton solve against a central difference."""
    key = "pulleys.idler_a.tensioner.stiffness"
    torques = jnp.asarray([0.0, 0.0, LOAD, 0.0])
    k_of = {n: i for i, n in enumerate(drive.model.pulley_names)}
    assert k_of["sg"] == 2

    def arm_angle(params, k):
        return solve_statics(drive, jb.set_parameter(drive, params, key, k), torques)["psi"][k_of["idler_a"]]

    value_and_fwd = jax.jit(lambda params, k: jax.jvp(lambda k: arm_angle(params, k), (k,), (jnp.ones_like(k),)))
    k0 = float(jb.get_parameter(drive, drive.params, key))
    with quick_compile():  # two programs compiled once, run 3 times and once: 10.8 -> 7.8 s CPU for this test
        _, fwd = value_and_fwd(drive.params, jnp.asarray(k0))
        rev = jax.jit(jax.grad(arm_angle, argnums=1))(drive.params, jnp.asarray(k0))
    fd = central_difference(lambda k: float(value_and_fwd(drive.params, jnp.asarray(k))[0]), k0, 1e-4 * k0)
    assert float(fwd) == pytest.approx(float(rev), rel=1e-10)
    assert float(fwd) == pytest.approx(fd, rel=1e-6)
    assert float(fwd) > 0.0  # a stiffer spring swings the arm less far clockwise


def _window_means(signals, lo, hi, keys):
    t = signals["t"]
    sel = (t >= lo) & (t <= hi)
    return {k: float(np.mean(signals[k][sel])) for k in keys}


@pytest.mark.long
def test_the_arm_swings_to_the_new_slack_side_when_the_starter_generator_turns_motor(spec, drive):
    """The example: generator (8 N m) until 0.3 s, motor (8 N m) from 0.35 s. The arm's mean over 0.2-0.3 s and
    over 0.5-0.6 s equals the statics' arm angle at the same torque within 0.1 deg (measured +0.041 / -0.051 deg,
    80 elements, implicit 5e-5 s: the example's max_frequency) on either side of the drawn angle: the ANCF run's two
    idlers push one arm. The long spans at the crank (T - m'v^2) within 3 % of the statics (measured -1.0 / +0.2 %
    and +0.5 / +2.5 %); the energy balance closes. Each idler's two spans carry one mean tension within 1.5 %
    (no torque on an idler; measured 0.2-0.9 %): at the implicit scheme's default 1e-4 s the span idler_a -> sg
    rang at 2 kHz, 109 N against 11 N, and its mean was 6 % above the span before the idler. The summary names
    the tight span by the window's tensions: the span leaving the crank once the starter-generator drives (it was
    named by topology, entering the driver)."""
    r = jb.run(spec)
    assert r.summary["status"] == "ok", r.summary["status"]
    # the summary's window is the motor's: the crank is driven back, its tight side is the span leaving it
    belt = r.summary["belt"]
    assert (belt["tight_span"], belt["slack_span"]) == ("crank-idler_a", "idler_b-crank")
    assert abs(r.summary["energy"]["residual_relative"]) < 0.01
    m, EA = float(drive.params.belt.mass_per_length), float(drive.params.belt.EA)
    spans = ["crank-idler_a", "idler_b-crank"]
    idlers = {"idler_a": ("crank-idler_a", "idler_a-sg"), "idler_b": ("sg-idler_b", "idler_b-crank")}
    keys = ["arm_angle:idler_a"] + [f"tension:{s}" for s in spans] + [f"speed:{s}" for s in spans]
    keys += [f"tension:{s}" for s in ("idler_a-sg", "sg-idler_b")]
    psi0 = float(drive.state0.psi[1])
    for (lo, hi), torque in (((0.2, 0.3), LOAD), ((0.5, 0.6), -LOAD)):
        run = _window_means(r.signals, lo, hi, keys)
        st = statics(drive, {"sg": torque})
        assert math.degrees(run["arm_angle:idler_a"]) == pytest.approx(
            math.degrees(st.pulleys["idler_a"]["arm_angle"]), abs=0.1
        )
        assert np.sign(run["arm_angle:idler_a"] - psi0) == -np.sign(torque)
        for arriving, leaving in idlers.values():  # an idler carries no torque: one tension on either side
            assert run[f"tension:{leaving}"] == pytest.approx(run[f"tension:{arriving}"], rel=0.015)
        tension = {s["name"]: s["tension"] for s in st.spans}
        for s in spans:
            T, v = run[f"tension:{s}"], run[f"speed:{s}"]
            assert T - m * v * v / (1.0 + T / EA) == pytest.approx(tension[s], rel=0.03)


@pytest.mark.long
def test_the_spans_tier_carries_the_pendulum(spec, drive):
    """The spans tier's run of the example: the arm's mean over the motor window within 0.1 deg of the statics
    (measured -62.76 against -62.81 deg)."""
    from jaxbelt.spans import run_spans

    res = run_spans(drive)
    assert res.summary["status"] == "ok", res.summary["status"]
    run = _window_means(res.signals, 0.5, 0.6, ["arm_angle:idler_a"])
    st = statics(drive, {"sg": -LOAD})
    assert math.degrees(run["arm_angle:idler_a"]) == pytest.approx(
        math.degrees(st.pulleys["idler_a"]["arm_angle"]), abs=0.1
    )


def _with(spec, name, **changes):
    """A copy of ``spec`` with pulley ``name`` (or its tensioner, for keys given as tensioner__key) changed."""
    spec = copy.deepcopy(spec)
    for p in spec.pulleys:
        if p.name != name:
            continue
        for key, value in changes.items():
            if key.startswith("tensioner__"):
                setattr(p.tensioner, key.removeprefix("tensioner__"), value)
            else:
                setattr(p, key, value)
    return spec


@pytest.mark.parametrize(
    "change, message",
    [
        (("idler_a", {"tensioner__partner": None}), "needs its second idler"),
        (("idler_a", {"tensioner__partner": "idler_a"}), "needs its second idler"),
        (("idler_a", {"tensioner__partner": "idlr_b"}), "needs its second idler"),
        (("idler_a", {"tensioner__partner": "crank"}), "role 'idler'"),
        (("idler_a", {"tensioner__partner": "sg"}), "role 'idler'"),
        (("idler_a", {"tensioner__inertia": None}), "inertia of its whole rocker"),
        (("idler_a", {"tensioner__kind": "arm"}), "only kind = 'pendulum' has one"),
        (("idler_a", {"tensioner__pivot": (-0.058, 0.22)}), "must differ from the pendulum's pivot"),
        (("idler_a", {"tensioner__pivot": None}), "a pendulum tensioner needs its pivot"),
        (("idler_a", {"tensioner__partner": 3}), "needs its second idler"),
    ],
)
def test_a_bad_pendulum_is_refused_by_name(spec, change, message):
    name, changes = change
    with pytest.raises(jb.ConfigError, match=message):
        jb.build_drive(_with(spec, name, **changes))


def test_a_partner_with_a_carrier_of_its_own_or_claimed_twice_is_refused(spec):
    own = _with(spec, "idler_b", role="tensioner", tensioner=dataclasses.replace(spec.pulleys[1].tensioner))
    with pytest.raises(jb.ConfigError, match="role 'idler'"):
        jb.build_drive(own)
    twice = _with(spec, "idler_b", tensioner=dataclasses.replace(spec.pulleys[1].tensioner, partner="idler_b"))
    with pytest.raises(jb.ConfigError, match="needs its second idler|already the second idler|role 'idler'"):
        jb.build_drive(twice)


def test_the_pendulum_survives_the_toml_round_trip(spec, tmp_path):
    path = tmp_path / "bsg.toml"
    path.write_text(jb.dump_toml(spec))
    again = jb.load_config(path)
    t = next(p for p in again.pulleys if p.name == "idler_a").tensioner
    assert (t.kind, t.partner, tuple(t.pivot)) == ("pendulum", "idler_b", (0.0, 0.35))
    assert build_quietly(again).model.carrier_of == build_quietly(spec).model.carrier_of == (0, 1, 2, 1)


def test_a_belt_given_by_its_installed_effective_length_holds_the_pendulum_where_it_is_drawn(spec):
    """``belt.installed_effective_length`` fixes the belt by the tension its tensioner holds at the drawn position:
    for a pendulum both idlers' hub loads turn the arm, preload + T sum_i (d_out,i - d_in,i) . d(c_i)/d(psi) = 0
    (closed form, here with idler_b moved so that the two no longer balance: 83.8 N; the first idler's lever
    alone gave -56 N, and the drive was refused as holding no tension). With the drawn layout's effective
    length the statics finds the arm at its drawn angle, to round-off: the stress-free length leaves the path the
    contact compliance takes at T (each wrap phi sinks T / (R k)), which the statics has too."""
    base = copy.deepcopy(spec)
    base.pulleys[3].center = (-0.05, 0.20)
    base.pulleys[1].tensioner.preload = 2.0  # N m counter-clockwise: pushes idler_b into its span
    drawn = build_quietly(base)
    offset = 0.002  # effective line to pitch line, the PK default [m]
    installed = copy.deepcopy(base)
    installed.belt.pretension = None
    installed.belt.installed_effective_length = float(drawn.path.length) - 2.0 * math.pi * offset
    drive = build_quietly(installed)
    d = np.asarray(drive.path.span_dir)
    pivot = np.asarray(base.pulleys[1].tensioner.pivot)
    lever = 0.0
    for i in (1, 3):  # travel order crank, idler_a, sg, idler_b: span i leaves pulley i
        arm = np.asarray(base.pulleys[i].center) - pivot
        lever += (d[i] - d[i - 1]) @ np.array([-arm[1], arm[0]])
    T = -2.0 / lever
    EA = float(drive.params.belt.EA)
    k = float(drive.params.contact_stiffness)
    sink = T * float(np.sum(np.asarray(drawn.path.wrap_angle) / np.asarray(drawn.path.radii))) / k
    assert float(drive.params.belt.stress_free_length) == pytest.approx(
        (float(drawn.path.length) - sink) / (1.0 + T / EA), rel=1e-12
    )
    st = statics(drive)
    assert st.pulleys["idler_a"]["arm_angle"] == pytest.approx(float(drawn.state0.psi[1]), abs=1e-9)
    assert st.spans[0]["tension"] == pytest.approx(T, rel=1e-9)
