"""Issue 28's smaller items, each with the behaviour it fixes: build warnings in the summary, ..."""

import importlib
import json
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt.cli import EXIT_USAGE, main
from jaxbelt.config import load_config

ROOT = Path(__file__).resolve().parents[1]


def test_build_warnings_are_kept_on_the_drive_once():
    """A tensioner on the tight side warns (a Python warning) and the drive keeps the message, once,
    however often the Python warning itself is shown."""
    spec = load_config("examples/serpentine_tensioner.toml")
    spec.belt.direction = "cw"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the drive keeps it even where Python shows nothing
        drive = jb.build_drive(spec)
    assert len(drive.build_warnings) == 1
    assert "'tensioner' (a tensioner) sits on the tight side" in drive.build_warnings[0]
    spec.belt.direction = "ccw"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the example itself builds without any
        assert jb.build_drive(spec).build_warnings == ()


def test_build_warnings_reach_the_summary():
    """The polygon effect of 12 elements on 0.1 m pulleys (element 0.10 m > radius / 2) is a warning of
    the run's summary, once, in the second run of the process too (Python shows it only once)."""
    spec = jb.benchmark_a(n_elements=12, t_end=0.01)
    for _ in range(2):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = jb.run(spec)
        polygon = [w for w in r.summary["warnings"] if "polygon effect" in w]
        assert len(polygon) == 2, r.summary["warnings"]  # driver and driven, each once
        assert "'driver'" in polygon[0] and "'driven'" in polygon[1]


def _checkpoint(tmp_path: Path, meta_change: dict, drop_leaf: bool = False):
    """A run's checkpoint of the benchmark (26 elements) as it stood at t = 0, with its metadata changed."""
    from jaxbelt.cli.resume import config_hash
    from jaxbelt.dynamics.chunked import ChunkedRun
    from jaxbelt.io import write_checkpoint

    cfg = tmp_path / "bench.toml"
    cfg.write_text(
        (ROOT / "examples" / "two_pulley_benchmark.toml").read_text().replace("n_elements = 60", "n_elements = 26")
    )
    spec = load_config(cfg)
    drive = jb.build_drive(spec)
    o = drive.options
    chunked = ChunkedRun(
        drive.model,
        drive.params,
        drive.state0,
        t_end=o.t_end,
        dt=drive.dt,
        save_dt=o.save_dt,
        settle_time=o.settle_time,
    )
    arrays = chunked.start().arrays
    if drop_leaf:  # another build whose state has one field less
        n = sum(k.startswith("state/") for k in arrays)
        del arrays[f"state/{n - 1}"], arrays[f"saved/{n - 1}"]
    meta = {"config": str(cfg), "config_hash": config_hash(spec, cfg), "t_end_option": None}
    meta.update({"jaxbelt_version": jb.__version__, **meta_change})
    out = tmp_path / "out"
    out.mkdir()
    write_checkpoint(out / "checkpoint.npz", arrays, {k: v for k, v in meta.items() if v is not None})
    return out


@pytest.mark.parametrize(
    "meta_change, drop_leaf, says",
    [
        ({"jaxbelt_version": "0.0.1"}, False, "written by jaxbelt 0.0.1, this is jaxbelt"),
        ({"jaxbelt_version": None}, False, "written by jaxbelt (an older version)"),
        ({}, True, "the checkpoint's state does not fit this drive"),
        ({"config": None}, False, "the checkpoint does not name its configuration"),
    ],
)
def test_checkpoint_of_another_version_or_layout_is_refused(tmp_path, capsys, meta_change, drop_leaf, says):
    """Refused with exit 2 and advice, before anything is compiled (was: "internal error: KeyError", or a
    resumed run from another version's state)."""
    out = _checkpoint(tmp_path, meta_change, drop_leaf)
    assert main(["run", "--resume", str(out), "-q", "--no-plots"]) == EXIT_USAGE
    err = capsys.readouterr().err
    assert says in err and "run without --resume to start again" in err, err
    assert "internal error" not in err
    assert (out / "checkpoint.npz").exists() and not (out / "summary.json").exists()


def test_announced_step_count_is_the_run_s(tmp_path, capsys):
    """The count printed before a run includes the settle phase and the whole macro steps: it equals the
    steps the run reports at the end (was t_end / dt: 478 announced here, 1,440 taken)."""
    cfg = tmp_path / "bench.toml"
    text = (ROOT / "examples" / "two_pulley_benchmark.toml").read_text()
    cfg.write_text(text.replace("n_elements = 60", "n_elements = 26"))
    code = main(["run", str(cfg), "--t-end", "0.05", "--out", str(tmp_path / "out"), "--no-plots"])
    assert code in (0, 1)  # 0.05 s is no steady state: the status says so, the step count is what matters
    printed = capsys.readouterr().out
    announced = int(re.search(r"dt [0-9.e-]+ s: [^;]*; ([0-9,]+) steps: ", printed).group(1).replace(",", ""))
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert announced == summary["num_steps"]
    assert announced > 2 * math.ceil(0.05 / summary["dt"])  # the 0.1 s settle phase is twice the run


def test_run_without_a_bar_estimates_the_time_left(capsys):
    """After a timed chunk, a line with the steps done and the time left (rate of the chunks after the
    first), then one a minute; the checkpoint is still written after every chunk."""
    from types import SimpleNamespace

    from jaxbelt.cli.run import _Estimate

    calls = []
    times = iter([100.0, 110.0, 120.0, 150.0, 185.0])
    est = _Estimate(lambda c, p, i: calls.append(p.k), "drive", clock=lambda: next(times))
    chunked = SimpleNamespace(n_macro=1000, schedule=SimpleNamespace(substeps=4), done=lambda p: p.k >= 1000)
    for k in (100, 200, 300, 400, 500, 1000):  # 100 macro steps per chunk, 10 s each after the first
        est(chunked, SimpleNamespace(k=k), False)
    assert calls == [100, 200, 300, 400, 500, 1000]
    lines = capsys.readouterr().out.splitlines()
    # after 200: (1000 - 200) / (100 / 10 s) = 80 s; at 185 s (65 s later): 500 of 1000 at 400/85 per s: 106 s
    assert lines == ["drive: 800 of 4,000 steps; about 80 s left", "drive: 2,000 of 4,000 steps; about 2 min left"]


def test_large_sweep_checks_show_progress(monkeypatch):
    """The checks of every point and their stability limits print, once they have taken 5 s, the points
    done and the time left (then every 30 s): here a clock that advances 2 s per point."""
    from types import SimpleNamespace

    import numpy as np

    sweep_mod = importlib.import_module("jaxbelt.analysis.sweep")  # (the package's `sweep` is the function)

    now = iter(np.arange(0.0, 1000.0, 2.0))
    monkeypatch.setattr(sweep_mod, "time", SimpleNamespace(perf_counter=lambda: float(next(now))))
    drive = jb.build_drive(jb.benchmark_a(n_elements=26, t_end=0.05))
    points = np.linspace(7000.0, 8000.0, 24)[:, None]
    lines: list[str] = []
    sweep_mod._check_points(drive, ["belt.EA"], points, None, None, lines.append)
    # started at 0 s, point i checked at 2 (i + 1) s: the first line at point 3 (6 s), the next 30 s later
    assert lines == [
        "checking the points: 2 of 24 points in 6 s; about 66 s left",
        "checking the points: 17 of 24 points in 36 s; about 15 s left",
    ]
    lines.clear()
    sweep_mod._shared_time_step(drive, ["belt.EA"], points, lines.append)
    assert lines[0].startswith("stability limits: 2 of 24 points in 6 s; about 66 s left")


# the default output directory of each command, out/<config name><suffix> (docs/cli.md)
_OUT = {
    "run": "",
    "sweep": "_sweep",
    "statics": "_statics",
    "duty": "_duty",
    "report": "_report",
    "modes": "_modes",
    "runup": "_runup",
    "identify": "_identify",
}
_ARGS = {
    "sweep": ["--vary", "contact.mu=0.4:0.5:2"],
    "duty": ["--rpm", "100"],
    "runup": ["--rpm", "800:900", "--duration", "0.1"],
}


class _Seen(Exception):
    pass


@pytest.mark.parametrize("command", list(_OUT))
def test_help_shows_the_real_default_output_directory(command, monkeypatch, capsys):
    """``--help`` names each command's own default (was ./out/<config name> for every command), and the
    command uses it: ``output_dir`` gets the same suffix (stopped there, before anything runs)."""
    with pytest.raises(SystemExit):
        main([command, "--help"])
    shown = " ".join(capsys.readouterr().out.split())
    assert f"output directory (default: ./out/<config name>{_OUT[command]})" in shown
    if command == "identify":  # it needs a measurement first: its suffix is read in its source
        assert 'output_dir(args, cfg, "_identify")' in (ROOT / "jaxbelt" / "cli" / "identify.py").read_text()
        return
    module = importlib.import_module(f"jaxbelt.cli.{'report_page' if command == 'report' else command}")
    seen = []

    def output_dir(args, cfg, suffix="", **kw):
        seen.append(suffix)
        raise _Seen

    monkeypatch.setattr(module, "output_dir", output_dir)
    main([command, str(ROOT / "examples" / "two_pulley_benchmark.toml"), *_ARGS.get(command, [])])
    assert seen == [_OUT[command]]


def _figure_data(fig):
    """Every drawn line, circle, text and arrow and the limits of a one-axes figure: arrays, and the words."""
    ax = fig.axes[0]
    numbers = {
        "lines": [np.asarray(line.get_xydata()) for line in ax.lines],
        "circles": [np.array([*c.center, c.radius]) for c in ax.patches],
        "texts": [np.hstack([np.ravel(t.xy), np.ravel(t.xyann)]) for t in ax.texts],
        "limits": [np.array([*ax.get_xlim(), *ax.get_ylim()])],
    }
    return numbers, [ax.get_title(), *(t.get_text() for t in ax.texts)]


@pytest.mark.long
@pytest.mark.filterwarnings("ignore:pulley")  # 24 elements: a polygon effect warning
def test_plot_belt_of_a_loaded_result_equals_the_run_s(tmp_path):
    """``plot_belt(load_result(...))`` draws the figure ``plot_belt(RunResult)`` draws (was an AttributeError:
    the dict has no trajectory): the serpentine example's tensioner arm moved, spans tagged, at the last
    and at an earlier saved state, and with the deformation exaggerated."""
    import jax

    from jaxbelt import viz
    from jaxbelt.io import load_result, write_result_npz

    spec = load_config("examples/serpentine_tensioner.toml")
    spec.belt.n_elements, spec.solver.t_end, spec.solver.save_dt = 24, 0.03, 5e-3
    result = jb.run(spec)
    loaded = load_result(write_result_npz(tmp_path / "result.npz", result))
    arm = result.signals["arm_angle:tensioner"]
    assert abs(arm[-1] - arm[0]) > 1e-3  # the arm moved: its pulley is drawn where it is now
    for index, kw in ((None, {}), (3, {}), (None, {"exaggeration": 10.0})):
        state = None if index is None else jax.tree.map(lambda x: x[index], result.trajectory.states)
        a, a_words = _figure_data(viz.plot_belt(result, state=state, **kw))
        b, b_words = _figure_data(viz.plot_belt(loaded, state=index, **kw))
        if index is not None:  # the RunResult's title names its last time whatever state is drawn
            b_words[0] = b_words[0].replace(f"{loaded['t'][index]:.4g}", f"{loaded['t'][-1]:.4g}")
        assert a_words == b_words and "tight" in a_words and "crank" in a_words
        for key in a:
            assert len(a[key]) == len(b[key]), key
            for x, y in zip(a[key], b[key]):
                np.testing.assert_allclose(y, x, rtol=0, atol=1e-9, err_msg=key)


def _torque_driven_benchmark(t_end=0.05):
    """Benchmark A (26 elements) with its driver torque-driven (4 N m, stepped in over 20 ms) against the
    driven pulley's viscous load (2 N m s) and a 1.5 N m brake."""
    spec = jb.benchmark_a(n_elements=26, t_end=t_end)
    driver, driven = spec.pulleys
    driver.speed, driver.torque = None, {"smooth_step": [0.0, 0.02, 0.0, 4.0]}
    driven.load = {"smooth_step": [0.0, 0.02, 0.0, 1.5]}
    return spec


def test_creep_theory_of_a_torque_driven_driver_at_the_run_s_mean_speed():
    """Was silently absent: now the closed form at the run's mean driver speed, said so in the summary."""
    from jaxbelt.outputs.summary import creep_theory_absent, creep_theory_for

    r = jb.run(_torque_driven_benchmark())
    s = r.summary
    w1 = abs(s["pulleys"]["driver"]["omega_mean"])
    assert w1 > 0.1  # the driver runs
    assert s["creep_theory"] == creep_theory_for(r.drive, w1).as_dict()
    assert s["creep_theory"]["omega_driver"] == w1 and "mean driver speed" in s["creep_theory_note"]
    # the load it carries: the 1.5 N m brake and 2 N m s at the theory's driven speed
    th = s["creep_theory"]
    assert th["torque_driven"] == pytest.approx(1.5 + 2.0 * th["omega_driven"], rel=1e-12)
    assert creep_theory_for(r.drive) is None  # without a speed: none, and why
    assert "is torque-driven and no driver speed was given" in creep_theory_absent(r.drive)


@pytest.mark.long
def test_creep_theory_absence_is_stated():
    """A two-pulley drive whose driven pulley sits on a slider (dead-weight tensioning) has no creep theory
    (fixed centres): the reason is given, and the summary's warnings carry it."""
    from jaxbelt.config.spec import TensionerSpec
    from jaxbelt.outputs.summary import creep_theory_absent

    spec = jb.benchmark_a(n_elements=26, t_end=0.05)
    spec.pulleys[1].tensioner = TensionerSpec(kind="slider", direction=(1.0, 0.0), stiffness=1e4, inertia=1.0)
    why = "a pulley sits on a movable carrier (the theory is for fixed centres)"
    assert creep_theory_absent(jb.build_drive(spec)) == why
    r = jb.run(spec, t_end=0.01)
    s = r.summary
    assert "creep_theory" not in s and f"creep theory not computed: {why}" in s["warnings"]
    # the slider's travel is a window figure as an arm's angle is (was missing from summary and table)
    x = r.signals["travel:driven"][r.ts >= s["window_s"][0]]
    assert s["pulleys"]["driven"]["travel_mean"] == pytest.approx(float(np.mean(x)), rel=1e-12)
    assert s["pulleys"]["driven"]["travel_mean_mm"] == pytest.approx(1e3 * float(np.mean(x)), rel=1e-12)
    assert s["pulleys"]["driven"]["travel_p2p_mm"] == pytest.approx(1e3 * float(np.ptp(x)), rel=1e-12)
    from jaxbelt.cli.report import fead_table_lines

    (row,) = [line for line in fead_table_lines(s) if line.split()[:1] == ["driven"]]
    assert row.rstrip().endswith(" mm")


def test_arm_stops_given_in_degrees_get_a_hint():
    """Arm stops beyond a full turn, or that contain the installed arm angle only read as degrees, are
    refused with the values in radians (was: "must contain the installed arm angle", no hint)."""
    from helpers import lossy_serpentine_spec

    from jaxbelt.config.validate import check_spec

    with pytest.raises(jb.ConfigError) as refused:  # the arm is installed at 0 rad: 72..92 rad are 11-15 turns
        check_spec(lossy_serpentine_spec(stops=(72.0, 92.0)))
    assert "within [-2π, 2π] ([72, 92] rad are [4125, 5271] deg)" in str(refused.value)
    assert "these look like degrees: write stops = [1.25664, 1.6057] (radians)" in str(refused.value)
    spec = lossy_serpentine_spec(stops=(2.0, 4.0))  # 2..4 deg round an arm installed at 2.86 deg
    spec.pulleys[1].tensioner.pivot = (0.10, -0.134)  # arm 0.08 m long at atan(0.004 / 0.08) = 0.04996 rad
    with pytest.raises(jb.ConfigError) as refused:
        check_spec(spec)
    assert "must contain the installed arm angle 0.0499584 rad" in str(refused.value)
    assert "these look like degrees: write stops = [0.0349066, 0.0698132] (radians)" in str(refused.value)
    spec.pulleys[1].tensioner.stops = (0.5, 2.0)  # radians that miss the arm in degrees too: no hint
    with pytest.raises(jb.ConfigError) as refused:
        check_spec(spec)
    assert "look like degrees" not in str(refused.value)
    spec.pulleys[1].tensioner.stops = (0.0349066, 0.0698132)  # as the hint says: accepted
    check_spec(spec)


def test_csv_numbers_are_the_intended_values():
    """15 significant digits: 0.1 + 0.2 is written 0.3 (was 0.30000000000000004), a 15-digit number reads
    back exactly, and no CSV writer of the package formats floats with repr any more."""
    from jaxbelt.io import csv_number

    assert csv_number(0.1 + 0.2) == "0.3" and csv_number(3 * 0.1) == "0.3"
    assert csv_number(1.0) == "1" and csv_number(-2.5e-300) == "-2.5e-300" and csv_number(800) == "800"
    assert csv_number(1 / 3) == "0.333333333333333" and csv_number(float("nan")) == "nan"
    for x in (0.123456789012345, 6.02214076e23, -1.25e-7, 83.7758040957278):
        assert float(csv_number(x)) == x
    writers = [ROOT / "jaxbelt" / f for f in ("io.py", "analysis/sweep_store.py", "cli/duty.py", "cli/runup.py")]
    assert not [f for f in writers if "repr(float" in f.read_text()]


def test_sweep_rows_without_binary_artefacts_resume_as_written(tmp_path):
    """A point 0.1 + 0.2 and a figure 0.30000000000000004 are written 0.3; resuming reads the row back as
    the same point (the check compares the numbers as written) and the file is unchanged."""
    from jaxbelt.analysis.sweep_store import CSV, SweepStore

    points = [[0.1 + 0.2, 7600.0], [0.45, 7000.0]]
    manifest = {"keys": ["contact.mu", "belt.EA"], "points": points}
    store = SweepStore(tmp_path, manifest, resume=False)
    header = ["contact.mu", "belt.EA", "omega:driven:mean"]
    store.append(0, header, np.array([[*points[0], 0.1 + 0.2]]), None, None)
    text = (tmp_path / CSV).read_text()
    assert text == "contact.mu,belt.EA,omega:driven:mean\n0.3,7600,0.3\n"
    again = SweepStore(tmp_path, manifest, resume=True)
    assert again.done == 1 and again.table().tolist() == [[0.3, 7600.0, 0.3]]
    again.append(1, header, np.array([[*points[1], 11.25]]), None, None)
    assert (tmp_path / CSV).read_text() == text + "0.45,7000,11.25\n"


def test_accessory_example_header_states_its_own_crank_oscillation():
    """The header's crank speed oscillation is the file's excitation: amplitude x order x idle speed
    (1.5 deg x 2 x 83.8 rad/s = 4.39 rad/s; the header said 2.6). Measured in a run of the example (0.4-0.5 s):
    the crank's 2nd-order amplitude 4.40 rad/s."""
    path = ROOT / "examples" / "accessory_drive.toml"
    spec = load_config(path)
    crank = spec.pulleys[0]
    amplitude = math.radians(crank.excitation["2"]["amplitude_deg"]) * 2 * 800.0 * 2 * math.pi / 60
    stated = re.search(r"\+-([0-9.]+) rad/s of crank speed at idle", path.read_text())
    assert stated is not None and float(stated.group(1)) == pytest.approx(amplitude, abs=0.05)
    assert "the belt slips on the crank, not on the accessories" in path.read_text()


def test_no_plots_rerun_leaves_no_stale_plots(tmp_path, capsys):
    """A rerun with --no-plots into a directory that holds an earlier run's plots removes them (they
    showed the earlier data) and says so; a file of the user's own is kept."""
    cfg = tmp_path / "bench.toml"
    text = (ROOT / "examples" / "two_pulley_benchmark.toml").read_text()
    cfg.write_text(text.replace("n_elements = 60", "n_elements = 26"))
    out = tmp_path / "out"
    out.mkdir()
    from jaxbelt.io import OUTPUT_MARK

    (out / OUTPUT_MARK).write_text("an earlier run's\n")  # jaxbelt's output directory (else refused: user files)
    earlier = ["speeds.png", "tensions.png", "torques.png", "contact.png", "belt.png", "fead.png", "belt.gif"]
    for name in [*earlier, "my_sketch.png"]:
        (out / name).write_bytes(b"an earlier run's plot")
    assert main(["run", str(cfg), "--t-end", "0.05", "--out", str(out), "--no-plots"]) in (0, 1)
    assert sorted(p.name for p in out.iterdir()) == [
        OUTPUT_MARK,
        "config_used.toml",
        "my_sketch.png",
        "result.npz",
        "signals.csv",
        "summary.json",
    ]
    assert "removed plots of an earlier run that no longer match the data: " + ", ".join(earlier) in (
        capsys.readouterr().out
    )


def test_run_up_gives_arm_amplitudes_in_degrees(tmp_path, monkeypatch, capsys):
    """runup.csv and the print-out give a tensioner arm's amplitudes in degrees (columns ``..._deg``; they
    were radians); other signals keep their units. The run-up itself is replaced by known amplitudes."""
    import csv
    from types import SimpleNamespace

    from jaxbelt.analysis.runup import RunUp

    analysis_runup = importlib.import_module("jaxbelt.analysis.runup")
    arm, span = "arm_angle:tensioner", "tension:crank-tensioner"
    known = RunUp(
        rpm=np.array([1000.0, 1500.0]),
        amplitude={arm: np.radians([0.5, 1.25]), span: np.array([40.0, 55.0])},
        orders={arm: {2.0: np.radians([0.25, 1.0])}, span: {2.0: np.array([30.0, 50.0])}},
        crossings=[],
        result=SimpleNamespace(summary={"status": "ok"}),
    )
    monkeypatch.setattr(analysis_runup, "run_up", lambda *a, **kw: known)
    out = tmp_path / "out"
    argv = ["runup", str(ROOT / "examples" / "serpentine_tensioner.toml"), "--rpm", "1000:1500", "--duration", "1"]
    assert main(argv + ["--orders", "2", "--no-modes", "--no-plots", "--out", str(out)]) == 0
    with open(out / "runup.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == ["rpm", f"amplitude_deg:{arm}", f"amplitude:{span}", f"order2_deg:{arm}", f"order2:{span}"]
    assert [float(r[f"amplitude_deg:{arm}"]) for r in rows] == [0.5, 1.25]
    assert [float(r[f"order2_deg:{arm}"]) for r in rows] == [0.25, 1.0]
    assert [float(r[f"amplitude:{span}"]) for r in rows] == [40.0, 55.0]
    printed = capsys.readouterr().out
    assert f"{arm}: largest half peak-to-peak 1.25 deg at 1500 rpm" in printed
    assert f"{span}: largest half peak-to-peak 55 N at 1500 rpm" in printed
