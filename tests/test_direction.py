"""Direction of travel and the senses of loads, torques and speeds (issue 16, items 8 and 9).

Drive: driver and driven pulley (R = 0.1 m) side by side with a small idler above, a 30 N m load.
Listed drv, dvn, idl the loop runs counter-clockwise; listed drv, idl, dvn, clockwise. Runs are
short (24 elements, 0.3 s) and share two compilations: a drive's compiled program depends only on
the pulley order in the model, not on its geometry or its senses.
"""

import math
import warnings

import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt import get_parameter, load_config
from jaxbelt.config import spec_from_dict

LOAD = 30.0
R = 0.1


def _spec(order, *, mirror=False, direction=None, t_end=0.3, driver=None, driven=None):
    x = -1.0 if mirror else 1.0
    p = {
        "drv": jb.PulleySpec(
            "drv",
            (0.0, 0.0),
            R,
            role="driver",
            inertia=0.05,
            **(driver or {"speed": {"smooth_step": [0.0, 0.1, 0.0, 20.0]}}),
        ),
        "dvn": jb.PulleySpec("dvn", (0.45 * x, 0.0), R, role="driven", inertia=0.01, **(driven or {"load": LOAD})),
        "idl": jb.PulleySpec("idl", (0.225 * x, 0.17), 0.05, role="idler", inertia=1e-3),
    }
    belt = jb.BeltSpec(
        n_elements=24,
        EA=7600.0,
        EI=1e-3,
        mass_per_length=0.3,
        axial_damping=0.5,
        pretension=400.0,
        inner_offset=0.0,
        direction=direction,
    )
    return jb.DriveSpec(
        belt=belt,
        pulleys=[p[n] for n in order],
        contact=jb.ContactSpec(mu=0.5, stiffness=1e8, damping=2e3),
        # 0.3 s of a start-up under a 30 N m load: the idler still spins up (a transient on purpose)
        solver=jb.SolverSpec(t_end=t_end, save_dt=5e-3, settle_time=0.05, expect_steady=False),
    )


def _run(spec):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.filterwarnings("ignore", "pulley .* is wrapped by belt elements")  # 24 elements: coarse on purpose
        r = jb.run(spec)
    assert r.summary["status"] == "ok"
    return r, [str(w.message) for w in caught if issubclass(w.category, UserWarning)]


def _tension(r, name):
    return next(s["tension_mean"] for s in r.summary["spans"] if s["name"] == name)


def _belt_figures(r):
    """summary["belt"] less the installed-state record and the contact compliance (tested elsewhere)."""
    other = ("installed_state", "contact_path_shortening_mm", "contact_stiffness")
    return {k: v for k, v in r.summary["belt"].items() if k not in other}


def _check_power_flow(r):
    """The load brakes: in the running sense the driven pulley gets +LOAD from the belt, the belt
    resists the driver (the driver delivers power) and the driven pulley runs slower (creep)."""
    p = r.summary["pulleys"]
    sense = {n: v["running_sense"] for n, v in p.items()}
    assert sense["dvn"] * p["dvn"]["torque_mean"] == pytest.approx(LOAD, rel=0.03)
    assert sense["drv"] * p["drv"]["torque_mean"] < -0.9 * LOAD
    loss = sense["drv"] * p["drv"]["omega_mean"] - sense["dvn"] * p["dvn"]["omega_mean"]  # equal radii
    assert 0.0 < loss < 1.0
    assert sense["drv"] * p["drv"]["omega_mean"] == pytest.approx(20.0)


@pytest.fixture(scope="module")
def ccw():
    """The reference: listed counter-clockwise, no belt.direction (as before the key existed)."""
    r, caught = _run(_spec(["drv", "dvn", "idl"]))
    assert caught == []
    return r


def test_counter_clockwise_drive_brakes_and_names_its_direction(ccw):
    _check_power_flow(ccw)
    belt = _belt_figures(ccw)
    assert belt == dict(
        direction="counter-clockwise",
        travel_order=["drv", "dvn", "idl"],
        spans_in_travel_order=True,
        tight_span="idl-drv",
        slack_span="drv-dvn",
    )
    assert _tension(ccw, "idl-drv") > _tension(ccw, "drv-dvn") + 0.9 * LOAD / R
    assert all(p["running_sense"] == 1 for p in ccw.summary["pulleys"].values())


@pytest.mark.parametrize(
    "order", [["drv", "idl", "dvn"], ["drv", "dvn", "idl"]], ids=["reverse-listed", "travel-order"]
)
def test_clockwise_drive_is_the_mirror_image(ccw, order):
    """The mirror image (x -> -x) of the reference runs clockwise. With belt.direction = "cw" it
    gives the reference's numbers mirrored, whichever order the pulleys are listed in: speeds and
    torques change sign, tensions are equal span by span."""
    r, caught = _run(_spec(order, mirror=True, direction="cw"))
    assert caught == []
    assert list(r.drive.model.pulley_names) == ["drv", "dvn", "idl"]  # put in travel order
    assert _belt_figures(r) == dict(
        direction="clockwise",
        travel_order=["drv", "dvn", "idl"],
        spans_in_travel_order=True,
        tight_span="idl-drv",
        slack_span="drv-dvn",
    )
    _check_power_flow(r)
    for name, p in r.summary["pulleys"].items():
        q = ccw.summary["pulleys"][name]
        assert p["running_sense"] == -1
        assert p["omega_mean"] == pytest.approx(-q["omega_mean"], rel=1e-9, abs=1e-9)
        assert p["torque_mean"] == pytest.approx(-q["torque_mean"], rel=1e-9, abs=1e-9)
    for name in ("drv-dvn", "dvn-idl", "idl-drv"):
        assert _tension(r, name) == pytest.approx(_tension(ccw, name), rel=1e-9)


@pytest.fixture(scope="module")
def cw_listed():
    """Listed clockwise without belt.direction: the positive speed still turns the belt
    counter-clockwise (as before the key existed), against the listed order; now with a warning."""
    return _run(_spec(["drv", "idl", "dvn"]))


def test_clockwise_listing_without_direction_runs_against_the_listing_and_says_so(ccw, cw_listed):
    r, caught = cw_listed
    assert len(caught) == 1
    assert "listed clockwise but the belt runs counter-clockwise" in caught[0]
    assert 'belt.direction = "cw"' in caught[0]
    assert _belt_figures(r) == dict(
        direction="counter-clockwise",
        travel_order=["drv", "dvn", "idl"],
        spans_in_travel_order=False,
        tight_span="drv-idl",
        slack_span="dvn-drv",
    )
    # the span named drv-idl carries the belt from the idler into the driver: it is the tight one
    assert _tension(r, "drv-idl") > _tension(r, "dvn-drv") + 0.9 * LOAD / R
    _check_power_flow(r)
    # physically the reference drive (the mesh starts elsewhere, so 2 %, not exact)
    assert r.summary["pulleys"]["dvn"]["omega_mean"] == pytest.approx(
        ccw.summary["pulleys"]["dvn"]["omega_mean"], rel=0.02
    )


def test_clockwise_direction_runs_the_listed_order_and_the_load_still_brakes():
    """The same listing with belt.direction = "cw": the belt runs clockwise in the listed order
    (the span entering the driver, dvn-drv, is now the tight one) and load = 30 brakes the
    driven pulley, which turns clockwise (before, a clockwise drive needed a negative speed, and
    load = 30, a fixed clockwise torque, then drove the pulley)."""
    r, caught = _run(_spec(["drv", "idl", "dvn"], direction="cw"))
    assert caught == []
    assert _belt_figures(r) == dict(
        direction="clockwise",
        travel_order=["drv", "idl", "dvn"],
        spans_in_travel_order=True,
        tight_span="dvn-drv",
        slack_span="drv-idl",
    )
    assert r.summary["pulleys"]["dvn"]["omega_mean"] < -19.0
    _check_power_flow(r)
    assert _tension(r, "dvn-drv") > _tension(r, "drv-idl") + 0.9 * LOAD / R


# --------------------------------------------------------------------------- build only (nothing compiled)
def _build(spec):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        warnings.filterwarnings("ignore", "pulley .* is wrapped by belt elements")
        drive = jb.build_drive(spec)
    return drive, [str(w.message) for w in caught if issubclass(w.category, UserWarning)]


def _final(law, i):
    return float(np.asarray(law.values)[i, -1])


@pytest.mark.parametrize("direction, sense", [(None, 1), ("ccw", 1), ("cw", -1)])
def test_speed_rpm_is_speed_in_rpm(direction, sense):
    rpm = 20.0 * 60 / (2 * math.pi)
    a, _ = _build(_spec(["drv", "dvn", "idl"], direction=direction, driver={"speed": {"ramp": [0.0, 0.1, 0.0, 20.0]}}))
    b, _ = _build(
        _spec(["drv", "dvn", "idl"], direction=direction, driver={"speed_rpm": {"ramp": [0.0, 0.1, 0.0, rpm]}})
    )
    assert b.model.kinematic == a.model.kinematic == (True, False, False)
    np.testing.assert_allclose(
        np.asarray(b.params.pulleys.speed.values), np.asarray(a.params.pulleys.speed.values), rtol=1e-14
    )
    assert _final(b.params.pulleys.speed, 0) == pytest.approx(sense * 20.0)  # stored counter-clockwise positive


@pytest.mark.parametrize("direction, sense", [(None, 1), ("cw", -1)])
def test_power_kw_is_a_brake_torque_at_the_nominal_speed(direction, sense):
    # driver R = 0.1 m at 20 rad/s, driven R = 0.1 m (offsets 0): 6 kW -> 300 N m; an idler of
    # R = 0.05 m turns at 40 rad/s: 0.4 kW -> 10 N m
    spec = _spec(["drv", "dvn", "idl"], direction=direction, driven={"power_kw": 6.0})
    spec.pulleys[2].power_kw = {"smooth_step": [0.1, 0.2, 0.0, 0.4]}
    drive, _ = _build(spec)
    torque, names = drive.params.pulleys.torque, drive.model.pulley_names  # "cw": put in travel order
    dvn, idl = names.index("dvn"), names.index("idl")
    assert _final(torque, dvn) == pytest.approx(-sense * 6000.0 / 20.0)
    assert _final(torque, idl) == pytest.approx(-sense * 400.0 / 40.0)
    assert float(np.asarray(torque.values)[idl, 0]) == 0.0
    assert float(get_parameter(drive, drive.params, "pulleys.dvn.load")) == pytest.approx(300.0)


def test_back_side_load_brakes_its_clockwise_rotation():
    """The serpentine's back-side idler turns clockwise while the belt runs counter-clockwise:
    its load is stored as a counter-clockwise torque (before: clockwise, driving it)."""
    spec = load_config("examples/serpentine_tensioner.toml")
    idler = [p.name for p in spec.pulleys].index("idler")
    spec.pulleys[idler].load = 1.5
    drive, _ = _build(spec)
    assert drive.running_sense[idler] == -1
    assert _final(drive.params.pulleys.torque, idler) == pytest.approx(1.5)
    assert float(get_parameter(drive, drive.params, "pulleys.idler.load")) == pytest.approx(1.5)
    crank = [p.name for p in spec.pulleys].index("crank")
    assert _final(drive.params.pulleys.speed, crank) == pytest.approx(40.0)  # unchanged


def test_tensioner_on_the_tight_side_is_warned_about():
    """The serpentine example runs counter-clockwise with its tensioner just after the crank
    (slack side). Run clockwise, the tensioner sits between the alternator and the crank."""
    spec = load_config("examples/serpentine_tensioner.toml")
    names = [p.name for p in spec.pulleys]
    _, caught = _build(spec)
    assert caught == []
    spec.belt.direction = "cw"
    drive, caught = _build(spec)
    assert len(caught) == 1 and "'tensioner' (a tensioner) sits on the tight side" in caught[0]
    assert 'set belt.direction = "ccw"' in caught[0]
    # the reverse listing with belt.direction = "ccw" is the example itself, in its own order
    spec.belt.direction = "ccw"
    spec.pulleys = [spec.pulleys[0], *spec.pulleys[:0:-1]]
    drive, caught = _build(spec)
    assert caught == [] and list(drive.model.pulley_names) == names


def test_two_pulleys_run_clockwise_only_with_direction():
    spec = jb.benchmark_a(n_elements=40)
    drive, caught = _build(spec)
    assert caught == [] and drive.travel == 1
    spec.belt.direction = "cw"
    drive, caught = _build(spec)
    assert caught == [] and drive.travel == -1 and float(drive.path.orientation) == -1.0
    assert _final(drive.params.pulleys.speed, 0) == pytest.approx(-12.0)
    assert _final(drive.params.pulleys.torque, 1) == pytest.approx(25.0)  # the load brakes clockwise rotation
    # without the key a negative speed runs the belt clockwise against the (counter-clockwise) listing
    spec.belt.direction = None
    spec.pulleys[0].speed = {"ramp": [0.05, 0.6, 0.0, -12.0]}
    drive, caught = _build(spec)
    assert drive.travel == -1 and _final(drive.params.pulleys.torque, 1) == pytest.approx(25.0)
    assert len(caught) == 1 and "belt runs clockwise (set by the sign of pulleys.driver.speed)" in caught[0]
    # with the key a negative speed runs against it: warned
    spec.belt.direction = "cw"
    _, caught = _build(spec)
    assert len(caught) == 1 and "pulleys.driver.speed is negative" in caught[0]


# --------------------------------------------------------------------------- validation
BASE = {
    "belt": {"n_elements": 24, "EA": 7600.0, "EI": 1e-3, "mass_per_length": 0.3, "pretension": 400.0},
    "pulleys": [
        {"name": "drv", "center": [0.0, 0.0], "radius": 0.1, "role": "driver", "speed": 20.0},
        {"name": "dvn", "center": [0.45, 0.0], "radius": 0.1, "role": "driven", "load": 30.0},
    ],
}


@pytest.mark.parametrize(
    "edit, words",
    [
        (lambda d: d["belt"].update(direction="clockwise"), ["belt.direction = 'clockwise'", "'cw', 'ccw'"]),
        (lambda d: d["belt"].update(direction=1), ["belt.direction = 1", "'cw', 'ccw'"]),
        (lambda d: d["pulleys"][0].update(speed_rpm=200.0), ["pulleys.drv.speed/speed_rpm", "exactly one"]),
        (lambda d: d["pulleys"][0].update(speed_rpm="fast"), ["pulleys.drv.speed_rpm = 'fast'", "a number"]),
        (lambda d: d["pulleys"][1].update(speed_rpm=200.0), ["pulleys.dvn.speed_rpm = 200.0", "only a driver"]),
        (lambda d: d["pulleys"][0].update(power_kw=2.0), ["pulleys.drv.power_kw = 2.0", "a driver delivers power"]),
        (lambda d: d["pulleys"][1].update(power_kw=2.0), ["pulleys.dvn", "either 'load' or 'power_kw'"]),
        (
            lambda d: d["pulleys"][1].update(power_kw={"ramp": [0.2, 0.1, 0.0, 1.0]}),
            ["pulleys.dvn.power_kw.ramp", "t1 > t0"],
        ),
        (
            lambda d: (
                d["pulleys"][1].pop("load"),
                d["pulleys"][1].update(power_kw=2.0),
                d["pulleys"][0].pop("speed"),
                d["pulleys"][0].update(torque=5.0),
            ),
            ["pulleys.dvn.power_kw = 2.0", "exactly one driver with a prescribed speed"],
        ),
        (
            lambda d: (
                d["pulleys"][1].pop("load"),
                d["pulleys"][1].update(power_kw=2.0),
                d["pulleys"][0].update(speed={"ramp": [0.0, 1.0, 10.0, 0.0]}),
            ),
            ["pulleys.dvn.power_kw = 2.0", "non-zero final speed", "pulleys.drv.speed"],
        ),
    ],
)
def test_new_keys_are_checked_before_compiling(edit, words):
    import copy

    data = copy.deepcopy(BASE)
    edit(data)
    with pytest.raises(jb.ConfigError) as err:
        jb.build_drive(spec_from_dict(data))
    for w in words:
        assert w in str(err.value), (w, str(err.value))


def test_direction_of_a_python_spec_is_checked():
    spec = _spec(["drv", "dvn", "idl"], direction="CW")
    with pytest.raises(jb.ConfigError, match=r"belt.direction = 'CW': must be 'cw' \(clockwise\) or 'ccw'"):
        jb.build_drive(spec)


@pytest.mark.parametrize("driven", [{"load": -5.0}, {"power_kw": {"smooth_step": [0.1, 0.2, 0.0, -1.0]}}])
def test_a_negative_load_is_warned_about_and_a_positive_one_is_not(driven):
    """load/power_kw mean braking; a negative one drives the pulley and says so (the opt-in is torque)."""
    key = next(iter(driven))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        jb.build_drive(_spec(["drv", "dvn", "idl"], driven=driven))
        jb.build_drive(_spec(["drv", "dvn", "idl"], driven={key: 5.0}))
    said = [str(w.message) for w in caught if f"negative {key}" in str(w.message)]
    assert len(said) == 1 and f"pulleys.dvn.{key} reaches -" in said[0] and "pulleys.dvn.torque" in said[0], said
