"""Linearised modes with one-way clutch pulleys (``analysis.modes.clutch_states``): an engaged overrunning
pulley (OAP) is the rigid pulley of sheave + rotor inertia, an open one the sheave alone, an engaged
decoupler the two-inertia system of sheave and rotor on its spring; the rotor's inertia and the spring get
their sensitivities; about steady running the clutch is taken as it is in the snapshot. Benchmark A at 40
elements (test_modes' drive: its programs are shared) with the driven pulley split into sheave and rotor."""

import dataclasses
import json
import math

import numpy as np
import pytest
from helpers import central_difference

import jaxbelt as jb
from jaxbelt.analysis.modes import clutch_states, linear_modes, mode_frequencies, mode_sensitivities, settled_state
from jaxbelt.analysis.running_modes import running_state
from jaxbelt.cli import main

JS, JR = 0.05, 0.2  # sheave and rotor inertia [kg m^2] (Benchmark A's driven pulley: 0.25 in one piece)
KC = 200.0  # decoupler spring [N m/rad]: its mode (~18 Hz) well below the spans' (34 Hz)
COUNT = 4


def _spec(clutch, load=(0.0, 0.05, 0.0, 25.0), viscous=0.0, torque=None):
    """Benchmark A (40 elements, 0.1 s) with the driven pulley on a clutch, its load ``smooth_step`` on by
    the end of the run (the default); ``torque``: a torque in the running sense instead."""
    spec = jb.benchmark_a(n_elements=40, t_end=0.1)
    d = spec.pulleys[1]
    d.load = None if load is None else {"smooth_step": list(load)}
    d.torque, d.viscous = torque, viscous
    d.inertia, d.clutch, d.rotor_inertia = JS, clutch, JR
    if clutch == "decoupler":
        d.clutch_stiffness, d.clutch_damping = KC, 0.0
    return spec


@pytest.fixture(scope="module")
def rigid():
    """Benchmark A itself: the driven pulley's inertia set through its parameter key."""
    drive = jb.build_drive(jb.benchmark_a(n_elements=40, t_end=0.1))
    state = settled_state(drive)

    def freqs(J, count=COUNT):
        params = jb.set_parameter(drive, drive.params, "pulleys.driven.inertia", J)
        return np.asarray(mode_frequencies(drive, params, state, count=count))

    return drive, state, freqs


@pytest.fixture(scope="module")
def oap():
    drive = jb.build_drive(_spec("oap"))
    return drive, settled_state(drive)


def test_the_engagement_rule_and_its_override():
    """Installed: engaged when the rotor's load at the end of the run brakes it (or a viscous load does);
    a load not yet on at t_end, none, or one that drives the rotor leaves it open. Decided without
    compiling anything; bad overrides are refused by name."""
    cases = [
        (_spec("oap"), "locked"),
        (_spec("decoupler"), "spring"),
        (_spec("oap", load=(1.0, 1.5, 0.0, 25.0)), "open"),  # Benchmark A's load step: after t_end
        (_spec("oap", load=None, torque=5.0), "open"),  # drives the rotor: the rotor overruns
        (_spec("oap", load=None), "open"),
        (_spec("oap", load=None, viscous=0.01), "locked"),  # a viscous load brakes a turning rotor
    ]
    for spec, expected in cases:
        drive = jb.build_drive(spec)
        assert clutch_states(drive) == (None, expected), spec.pulleys[1]
    drive = jb.build_drive(_spec("decoupler"))
    assert clutch_states(drive, clutch="open") == (None, "open")
    assert clutch_states(jb.build_drive(cases[2][0]), clutch={"driven": "locked"}) == (None, "locked")
    assert clutch_states(jb.build_drive(jb.benchmark_a(n_elements=40))) == (None, None)
    with pytest.raises(jb.ConfigError, match="clutch driven = 'closed'"):
        clutch_states(drive, clutch="closed")
    with pytest.raises(jb.ConfigError, match=r"clutch 'driver': not a one-way clutch pulley of this drive \(driven\)"):
        clutch_states(drive, clutch={"driver": "open"})


def test_an_engaged_oap_is_the_rigid_pulley_of_summed_inertia_and_an_open_one_the_sheave_alone(rigid, oap):
    """Every mode within 1e-6 (measured 1e-10); before, the rotor was left out whatever the clutch did."""
    drive, state = oap
    engaged = linear_modes(drive, state=state, count=COUNT)
    assert engaged.clutches == {"driven": "engaged (locked)"}
    np.testing.assert_allclose(engaged.frequencies, rigid[2](JS + JR), rtol=1e-6)
    assert engaged.kinds[0] == "rotational"
    assert engaged.shapes["psi"][0][1] == pytest.approx(engaged.shapes["theta"][0][1])  # the rotor turns with it
    opened = linear_modes(drive, state=state, count=COUNT, clutch="open")
    assert opened.clutches == {"driven": "open"} and np.all(opened.shapes["psi"] == 0)
    np.testing.assert_allclose(opened.frequencies, rigid[2](JS), rtol=1e-6)


def test_a_decoupler_is_the_two_inertia_system_of_sheave_and_rotor_on_its_spring(rigid):
    """The driven sheave on the belt: a torsional spring k_b with the belt's inertia J_b added, both read off
    the rigid pulley's mode at two inertias (f^-2 linear in J); the decoupler adds the rotor on its spring
    k_c: M = diag(J_s + J_b, J_r), K = [[k_b + k_c, -k_c], [-k_c, k_c]]. Both rotational modes within 2e-4
    (measured 5e-6 and 5e-5: the lumped belt inertia)."""
    _, _, freqs = rigid
    wa, wb = ((2 * math.pi * freqs(J, 1)[0]) ** 2 for J in (JS, JS + JR))
    k_b = JR / (1 / wb - 1 / wa)
    J_b = k_b / wa - JS
    # an estimate of the belt's inertia about the axis: the arc it carries and a third of each span's mass
    # (test_modes' lumped model; measured -5.4 % from it)
    drive = jb.build_drive(_spec("decoupler"))
    R, L, m = 0.1, float(drive.path.span_length[0]), float(drive.params.belt.mass_per_length)
    assert J_b == pytest.approx(m * R * math.pi * R**2 + 2 * (m * L / 3) * R**2, rel=0.1)
    M = np.diag([JS + J_b, JR])
    K = np.array([[k_b + KC, -KC], [-KC, KC]])
    closed = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real)) / (2 * math.pi)
    m = linear_modes(drive, state=settled_state(drive), count=COUNT)
    assert m.clutches == {"driven": "decoupler spring"}
    rotational = m.frequencies[[i for i, k in enumerate(m.kinds) if k == "rotational"]][:2]
    np.testing.assert_allclose(rotational, closed, rtol=2e-4)
    # the spring mode: sheave and rotor in opposite senses
    j = list(m.frequencies).index(rotational[1])
    assert m.shapes["theta"][j][1] * m.shapes["psi"][j][1] < 0


@pytest.mark.long
def test_rotor_inertia_and_decoupler_spring_sensitivities_match_central_differences(oap):
    """Engaged, the rotor's inertia counts (before: exactly 0 in every mode): d f / d J_r equals central
    differences (1e-5) and, the OAP locked, the sheave's d f / d J_s (one body); the decoupler's spring and
    rotor too."""
    drive, state = oap
    keys = ["pulleys.driven.rotor_inertia", "pulleys.driven.inertia"]
    sens = mode_sensitivities(drive, keys, count=2, state=state)
    assert sens[keys[0]][0] < 0
    np.testing.assert_allclose(sens[keys[0]], sens[keys[1]], rtol=1e-9)
    dec = jb.build_drive(_spec("decoupler"))
    dec_state = settled_state(dec)
    dec_keys = ["pulleys.driven.rotor_inertia", "pulleys.driven.clutch_stiffness"]
    dec_sens = mode_sensitivities(dec, dec_keys, count=2, state=dec_state)
    for d, st, key, s in [(drive, state, keys[0], sens)] + [(dec, dec_state, k, dec_sens) for k in dec_keys]:
        x0 = float(jb.get_parameter(d, d.params, key))

        def f(x, d=d, st=st, key=key):
            return np.asarray(mode_frequencies(d, jb.set_parameter(d, d.params, key, x), st, count=2))

        # the stuck contacts' stiff springs (modes.STICK_FACTOR) leave ~3e-9 Hz of round-off in a frequency: a
        # difference quotient over h carries 2 noise / h besides its rtol, measured here (on the OAP's second
        # mode, d f / d J_r = -1.5e-3 Hz per kg m^2, that is 2 % at a relative step of 1e-4, 0.2 % at 1e-3)
        # Nor is the round-off all at the 1e-12 scale: the decoupler's second mode, d f / d J_r = -1.1376, has
        # quotients -1.137593 / -1.137609 / -1.137611 at relative steps 1e-3 / 3e-4 / 1e-4 (not the h^2 of a
        # truncation error: ~4e-9 Hz of scatter at the larger steps), so the quotient's own error is taken as its
        # spread between two steps, and the sensitivity is held to the finer one
        h = 1e-3 * x0
        noise = np.max(np.abs([f(x0 * (1 + e)) - f(x0) for e in (-1e-12, 1e-12)]), axis=0)
        coarse, fd = central_difference(f, x0, h), central_difference(f, x0, h / 3)
        atol = np.maximum(2 * np.maximum(noise, 1e-10) / (h / 3), 1e-8 * np.max(np.abs(fd)))
        atol = atol + np.abs(coarse - fd)
        assert np.all(np.abs(s[key] - fd) <= 1e-5 * np.abs(fd) + atol), (key, s[key], fd, coarse, atol)
        assert np.all(np.abs(s[key]) > 0), (key, s[key])


@pytest.mark.long
def test_running_modes_take_the_clutch_as_the_snapshot_has_it(oap):
    """At the end of the run the braked rotor is driven through the clutch (impulse > 0): engaged, the
    running modes are those of the rigid pulley of summed inertia at the same state (1e-6), and the rotor's
    inertia has the sheave's sensitivity; open, the first mode rises to the sheave alone's."""
    drive, _ = oap
    state = running_state(drive)
    assert float(state.constraints.impulse[1]) > 0 and clutch_states(drive, state, about="running") == (None, "locked")
    engaged = linear_modes(drive, state=state, about="running", count=COUNT)
    assert engaged.clutches == {"driven": "engaged (locked)"}
    rigid = jb.build_drive(jb.benchmark_a(n_elements=40, t_end=0.1))
    params = jb.set_parameter(rigid, rigid.params, "pulleys.driven.inertia", JS + JR)
    one_body = linear_modes(
        rigid, state=dataclasses.replace(state, constraints=None), about="running", count=COUNT, params=params
    )
    np.testing.assert_allclose(engaged.frequencies, one_body.frequencies, rtol=1e-6)
    keys = ["pulleys.driven.rotor_inertia", "pulleys.driven.inertia"]
    sens = mode_sensitivities(drive, keys, count=2, state=state, about="running")
    assert sens[keys[0]][0] < 0
    np.testing.assert_allclose(sens[keys[0]], sens[keys[1]], rtol=1e-9)


def test_the_cli_says_how_each_clutch_is_linearised_and_takes_an_override(tmp_path, capsys, oap):
    """``jaxbelt modes --clutch open`` on the loaded OAP (engaged by the rule): the clutch's state on its own
    line and in modes.json, and the rotor's inertia without effect (its sensitivity exactly 0)."""
    cfg = tmp_path / "oap.toml"
    cfg.write_text(jb.dump_toml(_spec("oap")))
    argv = ["modes", str(cfg), "--out", str(tmp_path / "out"), "--count", "2", "--clutch", "open"]
    assert main(argv + ["--sensitivity", "pulleys.driven.rotor_inertia"]) == 0
    assert "  clutches: driven open\n" in capsys.readouterr().out
    out = json.loads((tmp_path / "out" / "modes.json").read_text())
    assert out["clutches"] == {"driven": "open"}
    assert [r["sensitivity"]["pulleys.driven.rotor_inertia"] for r in out["modes"]] == [0.0, 0.0]
