"""Installation statics against closed forms: the tension chain, belt-length compatibility, hub loads and
the tensioner arm's moment balance; gradients against central differences. (The comparison with a
dynamic run's settled state is in test_drive_cases.py, which has that run.)"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import _tensioner_spec, central_difference

import jaxbelt as jb
from jaxbelt.analysis.statics import solve_statics, statics, statics_table


@pytest.fixture(scope="module")
def two_pulley():
    return jb.build_drive(jb.benchmark_a(n_elements=30, t_end=0.1))


@pytest.fixture(scope="module")
def arm_drive():
    return jb.build_drive(_tensioner_spec())


def test_installed_tension_is_EA_times_the_path_strain(two_pulley):
    """No torque: one tension T = EA ((L_path - S) / L0 - 1) exactly, hub load 2 T; S = 2 pi T / (R k) the
    path the belt loses by sinking delta = T / (R k) into both pulleys (k the contact stiffness): 0.5 N
    below EA (L_path / L0 - 1) = 400 N here (the path shortening without it was not in the statics)."""
    st = statics(two_pulley)
    b = st.belt
    R, k = 0.1, float(two_pulley.params.contact_stiffness)
    T = b["EA"] * (b["path_length"] / b["stress_free_length"] - 1.0)
    T /= 1.0 + b["EA"] * 2.0 * math.pi / (R * k * b["stress_free_length"])  # linear in T: solved
    assert b["contact_path_shortening"] == pytest.approx(2.0 * math.pi * T / (R * k), rel=1e-12)
    for span in st.spans:
        assert span["tension"] == pytest.approx(T, rel=1e-12)
    assert st.pulleys["driven"]["hub_load"] == pytest.approx(2 * T, rel=1e-12)
    assert st.pulleys["driven"]["slip_safety"] == math.inf and st.gross_slip == []


def test_tension_chain_slip_arc_and_safety_follow_creep_theory(two_pulley):
    """A 20 N m accessory torque on a 0.1 m pulley: T_tight - T_slack = Q / R = 200 N; slip arc
    ln(T1/T2)/mu; safety factor mu phi / ln(T1/T2); the driver supplies the same torque."""
    Q, R, mu = 20.0, float(two_pulley.params.pulleys.radius[1]), 0.5
    st = statics(two_pulley, {"driven": Q})
    p = st.pulleys["driven"]
    assert p["tension_out"] - p["tension_in"] == pytest.approx(Q / R, rel=1e-12)
    ratio = p["tension_out"] / p["tension_in"]
    assert math.radians(p["slip_arc_deg"]) == pytest.approx(math.log(ratio) / mu, rel=1e-12)
    assert p["slip_safety"] == pytest.approx(mu * math.pi / math.log(ratio), rel=1e-12)
    assert st.pulleys["driver"]["torque"] == pytest.approx(Q * float(two_pulley.params.pulleys.radius[0]) / R)
    # beyond the Euler-Eytelwein limit the torque cannot be carried: flagged
    assert statics(two_pulley, {"driven": 60.0}).gross_slip == ["driver", "driven"]


def test_hub_loads_and_arm_moment_balance_in_closed_form(arm_drive):
    """|H|^2 = T_in^2 + T_out^2 - 2 T_in T_out cos(wrap) on every pulley, and the arm in equilibrium:
    preload + k (rest - psi) = -(moment of the hub load about the pivot) = -T L sin(beta) 2 sin(phi / 2)
    (equal tensions on an idle tensioner pulley)."""
    st = statics(arm_drive, {"alt": 3.0})
    for p in st.pulleys.values():
        phi = math.radians(p["wrap_deg"])
        H2 = p["tension_in"] ** 2 + p["tension_out"] ** 2 - 2 * p["tension_in"] * p["tension_out"] * math.cos(phi)
        assert p["hub_load"] == pytest.approx(math.sqrt(H2), rel=1e-9)
    t = _tensioner_spec().pulleys[2].tensioner
    tens = st.pulleys["tens"]
    psi, T, phi = tens["arm_angle"], tens["tension_in"], math.radians(tens["wrap_deg"])
    assert tens["tension_out"] == pytest.approx(T, rel=1e-12)  # an idler carries no torque
    L = math.hypot(0.18 - t.pivot[0], -0.14 - t.pivot[1])
    arm = np.array([math.cos(psi), math.sin(psi)])
    hub_dir = np.radians(tens["hub_load_deg"])
    sin_beta = arm[0] * math.sin(hub_dir) - arm[1] * math.cos(hub_dir)  # arm x hub direction (signed)
    hub_moment = T * L * sin_beta * 2 * math.sin(phi / 2)
    spring = t.preload + t.stiffness * (0.0 - psi)  # rest angle 0: the installed arm direction
    assert spring + hub_moment == pytest.approx(0.0, abs=1e-9 * abs(spring))


def test_length_cases_in_one_batched_solve_equal_single_solves(arm_drive):
    cases = {"nominal": 0.0, "shortest": -0.004, "longest": 0.004, "worn": 0.012}
    table = statics_table(arm_drive, {"alt": 3.0}, cases)
    for label, dl in cases.items():
        single = statics(arm_drive, {"alt": 3.0}, length_change=dl)
        assert table[label].pulleys["tens"]["arm_angle"] == pytest.approx(
            single.pulleys["tens"]["arm_angle"], abs=1e-12
        )
    # a shorter belt is tighter and pushes the arm back against its spring; a longer or worn one the other way
    T = {k: v.belt["max_tension"] for k, v in table.items()}
    assert T["shortest"] > T["nominal"] > T["longest"] > T["worn"]
    psi = {k: v.pulleys["tens"]["arm_angle"] for k, v in table.items()}
    assert len({np.sign(psi[k] - psi["nominal"]) for k in ("shortest", "longest")}) == 2


@pytest.mark.long
def test_arm_angle_gradient_matches_central_differences_forward_and_reverse(arm_drive):
    q = jnp.asarray([0.0, 3.0, 0.0])
    key = "pulleys.tens.tensioner.stiffness"

    def arm_angle(params, k):
        p = jb.set_parameter(arm_drive, params, key, k)
        return solve_statics(arm_drive, p, q)["psi"][2]

    # jitted, the drive's parameters an argument (not closure constants): one forward-mode program gives
    # the value (for the differences, compiled once and called three times) and the forward derivative,
    # one reverse-mode program the gradient (eagerly, every primitive of the Newton solve compiled apart)
    value_and_fwd = jax.jit(lambda params, k: jax.jvp(lambda k: arm_angle(params, k), (k,), (jnp.ones_like(k),)))
    rev_fn = jax.jit(jax.grad(arm_angle, argnums=1))
    k0 = float(jb.get_parameter(arm_drive, arm_drive.params, key))
    _, fwd = value_and_fwd(arm_drive.params, jnp.asarray(k0))
    rev = rev_fn(arm_drive.params, jnp.asarray(k0))
    fd = central_difference(lambda k: float(value_and_fwd(arm_drive.params, jnp.asarray(k))[0]), k0, 1e-4 * k0)
    assert float(fwd) == pytest.approx(float(rev), rel=1e-10)
    assert float(fwd) == pytest.approx(fd, rel=1e-6)
    assert float(fwd) != 0.0


def test_bad_torques_are_refused_with_the_name(two_pulley):
    with pytest.raises(jb.ConfigError, match="did you mean 'driven'"):
        statics(two_pulley, {"drivn": 1.0})
    with pytest.raises(jb.ConfigError, match="is the driver"):
        statics(two_pulley, {"driver": 1.0})
    with pytest.raises(jb.ConfigError, match="finite number"):
        statics(two_pulley, {"driven": float("nan")})
    with pytest.raises(jb.ConfigError, match="finite length"):
        statics_table(two_pulley, None, {"worn": float("inf")})


def test_cli_statics_writes_every_case_and_refuses_a_driver_torque(tmp_path):
    import json
    import subprocess
    import sys
    from pathlib import Path

    cfg = Path(__file__).parent.parent / "examples" / "serpentine_tensioner.toml"
    cmd = [sys.executable, "-m", "jaxbelt", "statics", str(cfg), "--out", str(tmp_path / "st")]
    out = subprocess.run(
        cmd + ["--torque", "alternator=4", "--length-tolerance", "4", "--wear", "8"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    data = json.loads((tmp_path / "st" / "statics.json").read_text())
    assert list(data) == ["nominal", "shortest", "longest", "worn"]
    assert data["worn"]["belt"]["stress_free_length"] - data["nominal"]["belt"]["stress_free_length"] == (
        pytest.approx(0.012, abs=1e-12)
    )
    alt = data["nominal"]["pulleys"]["alternator"]
    assert alt["tension_out"] - alt["tension_in"] == pytest.approx(4.0 / _radius(cfg, "alternator"), rel=1e-9)
    assert "tensioner" in out.stdout and "worn" in out.stdout
    bad = subprocess.run(cmd + ["--torque", "crank=4"], capture_output=True, text=True, timeout=600)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1 and "is the driver" in bad.stderr


def _radius(cfg, name):
    drive = jb.build_drive(jb.load_config(cfg))
    return float(drive.params.pulleys.radius[list(drive.model.pulley_names).index(name)])


def test_cli_statics_names_the_case_that_slips_and_exits_1(tmp_path, capsys):
    """40 N m on the serpentine's alternator: the nominal belt holds it (slip SF 1.02), the longest (+4 mm) and the
    worn one (+12 mm) do not (0.98; 0.89, the crank 0.99): the command names each case with its pulleys and exits
    1, as a run in gross slip does (the statics' tensions are not an equilibrium the belt can hold there); 20 N m:
    every case holds, exit 0."""
    from pathlib import Path

    from jaxbelt import cli

    cfg = Path(__file__).parent.parent / "examples" / "serpentine_tensioner.toml"
    args = ["statics", str(cfg), "--length-tolerance", "4", "--wear", "8", "--quiet"]
    rc = cli.main(args + ["--torque", "alternator=40", "--out", str(tmp_path / "a")])
    out = capsys.readouterr().out
    assert rc == cli.EXIT_FAILED, out
    (line,) = [x for x in out.splitlines() if "gross slip" in x]
    assert "longest belt: alternator;" in line and "worn belt: alternator, crank" in line and "nominal" not in line
    assert cli.main(args + ["--torque", "alternator=20", "--out", str(tmp_path / "b")]) == cli.EXIT_OK
