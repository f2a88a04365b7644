"""Hostile inputs found by trying what nobody had tried: each is refused early (before anything is
compiled or simulated) with one line naming the option or key, the value and what is allowed, and no
file a user made is removed or overwritten.

Found so far: a sweep whose points file sits in the output directory as ``sweep.csv`` (it was deleted
and the refusal came only after compiling); output directories of ``sweep``/``duty``/``modes``/
``statics``/``runup``/``report`` that cannot be written (refused only after the computation, with a raw
OS error); ``solver.save_dt`` longer than ``t_end`` (a run that saved only t = 0 and reported its means
as ``ok``); a key given twice to ``--vary`` (the last silently won); a grid of 10^10 points (a
``MemoryError``); a points file with a byte-order mark, ';' separators or NaN cells; ``duty --rpm 0,100``
("need at least one speed > 0" although one is); ``statics --length-tolerance`` beyond the belt's length
("no equilibrium found (residual nan)").
"""

from __future__ import annotations

import importlib
from pathlib import Path

import pytest

import jaxbelt as jb
import jaxbelt.config.build as _build
from jaxbelt import cli
from jaxbelt._errors import ConfigError
from jaxbelt.analysis.statics import statics, statics_table
from jaxbelt.config.validate import check_spec

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "examples" / "two_pulley_benchmark.toml"
_sweep = importlib.import_module("jaxbelt.analysis.sweep")  # the module (the package exports a function of that name)


def _config(tmp_path: Path, name: str = "bench.toml") -> Path:
    """The benchmark with a tiny mesh and horizon (nothing here is meant to run)."""
    text = BENCH.read_text().replace("n_elements = 60", "n_elements = 12").replace("t_end = 2.45", "t_end = 0.02")
    cfg = tmp_path / name
    cfg.write_text(text)
    return cfg


@pytest.fixture
def nothing_compiles(monkeypatch):
    """Building a drive or compiling a sweep chunk fails the test: the refusal must come first."""

    def forbidden(*args, **kwargs):
        raise AssertionError("built or compiled before the input was refused")

    monkeypatch.setattr(_build, "build_drive", forbidden)
    monkeypatch.setattr(_sweep, "_compiled_chunk", forbidden)


def _refused(capsys, argv) -> str:
    assert cli.main(argv) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if "warning" not in line]
    assert len(err) == 1 and "Traceback" not in err[0], err
    return err[0]


# ------------------------------------------------------------------ files a user made
def test_points_file_named_like_the_sweep_result_is_kept(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(_sweep, "_compiled_chunk", lambda *a, **k: pytest.fail("compiled before refusing"))
    cfg = _config(tmp_path)
    points = tmp_path / "sweep.csv"
    points.write_text("contact.mu\n0.4\n")
    line = _refused(capsys, ["sweep", str(cfg), "--points", str(points), "--out", str(tmp_path), "--quiet"])
    # refused as a directory of the user's files (before that: as a result that would replace an input)
    assert "holds files jaxbelt did not write there" in line and "sweep.csv" in line
    assert points.read_text() == "contact.mu\n0.4\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bench.toml", "sweep.csv"]  # nothing half-written


@pytest.mark.parametrize(
    "command, result",
    [
        (["modes"], "modes.json"),
        (["statics"], "statics.json"),
        (["duty", "--rpm", "100"], "duty.png"),
        (["runup", "--rpm", "100:200", "--duration", "0.01"], "orders.png"),
        (["report"], "report.html"),
    ],
)
def test_a_configuration_named_like_a_result_is_refused_first(tmp_path, capsys, nothing_compiles, command, result):
    cfg = _config(tmp_path, result)
    before = cfg.read_text()
    line = _refused(capsys, [command[0], str(cfg), *command[1:], "--out", str(tmp_path)])
    assert "refusing to overwrite the input file" in line and result in line
    assert cfg.read_text() == before


@pytest.mark.parametrize(
    "command", [["modes"], ["statics"], ["duty", "--rpm", "100"], ["sweep", "--vary", "contact.mu=0.3:0.5:2"]]
)
def test_an_output_path_below_a_file_is_refused_first(tmp_path, capsys, nothing_compiles, command):
    cfg = _config(tmp_path)
    blocker = tmp_path / "results.txt"
    blocker.write_text("not a folder")
    line = _refused(capsys, [command[0], str(cfg), *command[1:], "--out", str(blocker / "sub")])
    assert "--out" in line and "results.txt is a file, not a directory" in line
    line = _refused(capsys, [command[0], str(cfg), *command[1:], "--out", str(blocker)])
    assert "exists and is not a directory" in line
    assert blocker.read_text() == "not a folder"


# ------------------------------------------------------------------ run length and saves
def test_save_interval_longer_than_the_run_is_refused():
    spec = jb.benchmark_a(n_elements=12, t_end=5e-4, save_dt=1e-3)
    with pytest.raises(
        ConfigError,
        match=r"^solver.save_dt = 0.001: is longer than solver.t_end = 0.0005 s: .*"
        r"save only its initial state.*use save_dt <= t_end",
    ):
        jb.build_drive(spec)


def test_cli_t_end_below_the_save_interval_is_refused(tmp_path, capsys):
    line = _refused(capsys, ["run", str(_config(tmp_path)), "--t-end", "1e-4", "--out", str(tmp_path / "o")])
    assert "solver.save_dt = 0.001: is longer than solver.t_end = 0.0001 s" in line
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("t_end, needle", [(-1.0, "> 0"), (float("nan"), "> 0"), (1e-6, "shorter than solver.save_dt")])
def test_run_of_a_built_drive_checks_its_t_end(t_end, needle):
    drive = jb.build_drive(jb.benchmark_a(n_elements=12, t_end=0.02))
    with pytest.raises(ConfigError, match=r"^t_end = ") as info:
        jb.run(drive, t_end=t_end)
    assert needle in str(info.value)


# ------------------------------------------------------------------ sweep grids and points files
def test_a_key_varied_twice_is_refused(tmp_path, capsys, nothing_compiles):
    argv = ["sweep", str(_config(tmp_path)), "--vary", "contact.mu=0.3:0.6:2", "--vary", "contact.mu=0.1:0.2:3"]
    line = _refused(capsys, argv + ["--out", str(tmp_path / "s")])
    assert "--vary contact.mu=0.1:0.2:3: 'contact.mu' is varied twice" in line


@pytest.mark.parametrize(
    "vary, needle",
    [
        (["contact.mu=0.3:0.6:1000000000000"], "N = 1000000000000: at most 1,000,000 points"),
        (["contact.mu=0.3:0.6:100000", "belt.EA=7000:8000:100000"], "100000 x 100000 = 10,000,000,000 points"),
    ],
)
def test_a_grid_beyond_reason_is_refused_without_allocating_it(tmp_path, capsys, nothing_compiles, vary, needle):
    argv = ["sweep", str(_config(tmp_path))] + [a for v in vary for a in ("--vary", v)]
    assert needle in _refused(capsys, argv + ["--out", str(tmp_path / "s")])


@pytest.mark.parametrize(
    "content, needle",
    [
        (b"contact.mu\nnan\n", "line 2: contact.mu = nan: must be a finite number"),
        (b"contact.mu,belt.EA\n0.4,7000\n0.5,-inf\n", "line 3: belt.EA = -inf: must be a finite number"),
        (b"contact.mu;belt.EA\n0.4;7000\n", "separated by ';': separate keys and values by ','"),
        (b"contact.mu\n\xff\xfe0.4\n", "not a UTF-8 text file"),
    ],
)
def test_points_files_are_read_with_their_faults_named(tmp_path, capsys, nothing_compiles, content, needle):
    points = tmp_path / "points.csv"
    points.write_bytes(content)
    line = _refused(capsys, ["sweep", str(_config(tmp_path)), "--points", str(points), "--out", str(tmp_path / "s")])
    assert line.startswith(f"jaxbelt sweep: error: --points {points}: ") and needle in line


def test_a_byte_order_mark_is_not_part_of_the_first_key():
    import tempfile

    from jaxbelt.cli.sweep import _read_points

    with tempfile.NamedTemporaryFile("wb", suffix=".csv", delete=False) as fh:
        fh.write("\ufeffcontact.mu,belt.EA\n0.4,7000\n".encode())
    table = _read_points(fh.name)
    Path(fh.name).unlink()
    assert list(table) == ["contact.mu", "belt.EA"] and table["belt.EA"].tolist() == [7000.0]


# ------------------------------------------------------------------ duty and statics arguments
def test_duty_names_every_speed_it_refuses(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(_sweep, "_compiled_chunk", lambda *a, **k: pytest.fail("compiled before refusing"))
    line = _refused(capsys, ["duty", str(_config(tmp_path)), "--rpm", "0,100", "--out", str(tmp_path / "d")])
    assert "speeds = [0.0, 100.0]: need at least one, and every speed > 0 and finite [rpm]" in line


def test_duty_load_values_are_named_with_their_pulley(tmp_path, capsys, nothing_compiles):
    argv = ["duty", str(_config(tmp_path)), "--rpm", "100", "--power", "driven=nan", "--out", str(tmp_path / "d")]
    line = _refused(capsys, argv)
    assert "--power driven=nan: expected comma-separated finite numbers, e.g. alternator=0.8,1.2,1.5" in line


def test_a_length_tolerance_beyond_the_belt_is_named():
    drive = jb.build_drive(jb.benchmark_a(n_elements=12, t_end=0.02))
    with pytest.raises(ConfigError, match=r"length change of case 'shortest' = -2.0 m: more than 20% of the belt's"):
        statics_table(drive, cases={"nominal": 0.0, "shortest": -2.0})
    with pytest.raises(ConfigError, match=r"length_change = True: must be a finite length"):
        statics(drive, length_change=True)


def test_report_reads_every_argument_before_the_duty_runs(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(_sweep, "_compiled_chunk", lambda *a, **k: pytest.fail("duty runs before refusing"))
    cfg, out = str(_config(tmp_path)), str(tmp_path / "r")
    line = _refused(capsys, ["report", cfg, "--rpm", "800", "--torque", "nosuch=1", "--out", out])
    assert "torques['nosuch']: no such pulley" in line
    line = _refused(capsys, ["report", cfg, "--rpm", "800", "--torque", "driven=x", "--out", out])
    assert "--torque driven=x: expected PULLEY=Q" in line
    line = _refused(capsys, ["report", cfg, "--power", "driven=1", "--out", out])
    assert "--power gives the load at each duty point" in line and "--rpm" in line


# ------------------------------------------------------------------ pulley names
def _four_pulleys(names):
    centres = [(0.0, 0.0), (0.4, 0.0), (0.4, 0.4), (0.0, 0.4)]
    pulleys = [
        jb.PulleySpec(
            name=n, center=c, radius=0.06, role="driver" if i == 0 else "idler", speed=10.0 if i == 0 else None
        )
        for i, (n, c) in enumerate(zip(names, centres))
    ]
    belt = jb.BeltSpec(n_elements=24, EA=8000.0, EI=4e-3, mass_per_length=0.1, pretension=200.0)
    return jb.DriveSpec(belt=belt, pulleys=pulleys, solver=jb.SolverSpec(t_end=0.02))


def test_two_spans_with_one_signal_name_are_refused():
    """Spans a -> b-c and a-b -> c were both 'a-b-c': one tension signal silently stood for two spans."""
    with pytest.raises(ConfigError, match=r"the spans a -> b-c and a-b -> c would both be named 'a-b-c'"):
        check_spec(_four_pulleys(["a", "b-c", "a-b", "c"]))
    check_spec(_four_pulleys(["crank", "water-pump", "alternator", "idler"]))  # a '-' alone is fine


@pytest.mark.parametrize(
    "name, needle",
    [
        (" idler ", "must not start or end with spaces"),  # --torque ' idler =3' is read as 'idler'
        ("idler\n", "control characters such as a line break"),  # a line break in the signals.csv header
        ("a=b", "without '.', ',' or '='"),  # --torque a=b=3 is read as pulley 'a'
    ],
)
def test_pulley_names_the_command_line_cannot_address_are_refused(name, needle):
    with pytest.raises(ConfigError, match=r"^pulleys\[3\].name = ") as info:
        check_spec(_four_pulleys(["crank", "water-pump", "alternator", name]))
    assert needle in str(info.value)
    check_spec(_four_pulleys(["crank", "Ω pump", "alternator", "0"]))  # unicode, inner spaces, digits are fine


# ------------------------------------------------------------------ files from other programs
def test_a_configuration_saved_with_a_byte_order_mark_reads_as_without(tmp_path):
    """Windows editors save UTF-8 with a byte-order mark; it was 'TOML syntax error ... line 1, column 1'."""
    from jaxbelt.config import load_config

    with_bom = tmp_path / "bom.toml"
    with_bom.write_bytes(b"\xef\xbb\xbf" + BENCH.read_bytes())
    assert load_config(with_bom) == load_config(BENCH)


def test_a_damaged_checkpoint_is_named_without_advice_to_unpickle(tmp_path, capsys):
    """A text file as checkpoint.npz was refused with numpy's advice to load it with allow_pickle."""
    (tmp_path / "checkpoint.npz").write_text("not a checkpoint\n")
    line = _refused(capsys, ["run", "--resume", str(tmp_path)])
    assert "not a readable jaxbelt checkpoint (not an .npz archive" in line and "run again without --resume" in line
    assert "pickle" not in line


# ------------------------------------------------------------------ the Python API's own arguments
@pytest.mark.parametrize("window", [float("nan"), -0.5, 0.0, 1.5])
def test_a_summary_window_outside_the_run_is_refused(window, monkeypatch):
    """run(spec, window=nan) selected no saved state: every mean was NaN, and the status said ok."""
    run_module = importlib.import_module("jaxbelt.analysis.run")
    monkeypatch.setattr(run_module, "build_drive", lambda *a, **k: pytest.fail("built before refusing"))
    with pytest.raises(ConfigError, match=r"^window = .*: must be a fraction of the run in \(0, 1\]"):
        jb.run(jb.benchmark_a(n_elements=12, t_end=0.02), window=window)


def test_a_sweep_window_outside_the_run_is_refused():
    drive = jb.build_drive(jb.benchmark_a(n_elements=12, t_end=0.02))
    with pytest.raises(ConfigError, match=r"^window = -1.0: must be a fraction of the run"):
        _sweep.sweep(drive, {"contact.mu": [0.4, 0.5]}, window=-1.0)


def test_a_run_up_too_short_for_one_window_is_refused_before_running(monkeypatch):
    """100 -> 200 rpm in 0.01 s turns the crank 0.025 times: it simulated, then tracked 0 windows."""
    from jaxbelt.analysis.runup import run_up

    run_module = importlib.import_module("jaxbelt.analysis.run")
    monkeypatch.setattr(run_module, "run", lambda *a, **k: pytest.fail("simulated before refusing"))
    spec = jb.benchmark_a(n_elements=12, t_end=0.02)
    with pytest.raises(ConfigError, match=r"^run-up: duration = 0.01 s: 100 -> 200 rpm turns the crank 0.025 times, "):
        run_up(spec, 100.0, 200.0, 0.01, modes=False)
    with pytest.raises(ConfigError, match=r"at least 1.6 s \(about 16 s for ten windows\)"):
        run_up(spec, 100.0, 200.0, 1.0, modes=False)


@pytest.mark.parametrize(
    "values, points, needle",
    [
        ({"contact.mu": ["a"]}, None, "contact.mu: value 1 of 1 = 'a'"),  # was a bare ValueError
        ({"contact.mu": [0.4, float("nan")]}, None, "contact.mu: value 2 of 2 = nan"),  # did not name the key
        (None, {"contact.mu": [0.4, 0.5], "belt.EA": [7000.0, True]}, "belt.EA: value 2 of 2 = True"),
    ],
)
def test_sweep_values_that_are_not_numbers_are_named(values, points, needle):
    drive = jb.build_drive(jb.benchmark_a(n_elements=12, t_end=0.02))
    with pytest.raises(ConfigError, match=r"^sweep: ") as info:
        _sweep.sweep(drive, values, points=points)
    assert needle + ": every value must be a finite number" in str(info.value)


@pytest.mark.parametrize(
    "command",
    [
        ["statics", "--torque", "driven=1", "--torque", "driven=2"],
        ["duty", "--rpm", "100", "--torque", "driven=1", "--torque", "driven=2"],
        ["report", "--torque", "driven=1", "--torque", "driven=2"],
    ],
)
def test_a_pulley_loaded_twice_is_refused(tmp_path, capsys, nothing_compiles, command):
    """The last of two --torque options for one pulley silently won."""
    line = _refused(capsys, [command[0], str(_config(tmp_path)), *command[1:], "--out", str(tmp_path / "o")])
    assert "--torque driven=2: 'driven' is given twice; give each pulley once" in line


def test_a_key_set_twice_is_refused():
    """set_parameters([(k, a), (k, b)]) silently kept the last value."""
    drive = jb.build_drive(jb.benchmark_a(n_elements=12, t_end=0.02))
    with pytest.raises(ConfigError, match=r"^belt.EA is given twice: give each key once"):
        jb.set_parameters(drive, drive.params, [("belt.EA", 7000.0), ("belt.EA", 8000.0)])


def test_a_zero_dimensional_array_is_refused_saying_what_it_is():
    """radius = jnp.asarray(0.1) read 'Array(0.1, ...): must be a finite number > 0', which it is."""
    import jax.numpy as jnp
    import numpy as np

    for value in (jnp.asarray(0.1), np.asarray(0.1)):
        spec = jb.benchmark_a(n_elements=12, t_end=0.02)
        spec.pulleys[0].radius = value
        with pytest.raises(
            ConfigError, match=r"^pulleys.driver.radius = .*: must be a finite number > 0 \(this is a 0-d"
        ):
            check_spec(spec)
    spec.pulleys[0].radius = np.float64(0.1)  # a NumPy scalar is a number
    check_spec(spec)


def test_identify_refuses_a_key_listed_twice():
    """identify(drive, m, ["belt.EA", "belt.EA"]) merged the two into one fitted key without a word."""
    import numpy as np

    drive = jb.build_drive(jb.benchmark_a(n_elements=12, t_end=0.02))
    m = jb.Measurement(np.array([0.0, 0.01]), {"omega:driven": np.array([0.0, 0.0])})
    with pytest.raises(ConfigError, match=r"^identify: belt.EA given more than once"):
        jb.identify(drive, m, ["belt.EA", "contact.mu", "belt.EA"])


@pytest.mark.parametrize(
    "command",
    [["run"], ["statics"], ["sweep", "--vary", "contact.mu=0.3:0.5:2"], ["duty", "--rpm", "100"], ["report"]],
)
def test_a_directory_holding_a_users_files_is_refused_untouched(tmp_path, capsys, nothing_compiles, command):
    """An audit found ``--out`` into a folder of the user's own files (named like jaxbelt's results, or not)
    overwriting them and deleting their plots; a sweep died after its whole run on a user's file in
    ``sweep_signals/``. jaxbelt now writes only into a new or empty directory or one it marked as its own."""
    cfg = _config(tmp_path)
    mine = tmp_path / "mine"
    mine.mkdir()
    for name in ("summary.json", "notes.txt", "speeds.png"):
        (mine / name).write_text(f"the user's {name}\n")
    line = _refused(capsys, [command[0], str(cfg), *command[1:], "--out", str(mine)])
    assert "holds files jaxbelt did not write there" in line and "notes.txt" in line
    assert sorted(p.name for p in mine.iterdir()) == ["notes.txt", "speeds.png", "summary.json"]
    assert (mine / "summary.json").read_text() == "the user's summary.json\n"


def test_a_fresh_run_into_a_killed_runs_directory_keeps_its_checkpoint(tmp_path, capsys, nothing_compiles):
    """A run started again into the directory of a killed run (its checkpoint.npz there) deleted that progress
    without a word; now refused, naming --resume, the checkpoint kept."""
    from jaxbelt.io import OUTPUT_MARK

    cfg = _config(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    (out / OUTPUT_MARK).write_text("jaxbelt's\n")
    (out / "checkpoint.npz").write_bytes(b"a killed run's progress")
    line = _refused(capsys, ["run", str(cfg), "--out", str(out)])
    assert "holds an unfinished run" in line and f"--resume {out}" in line
    assert (out / "checkpoint.npz").read_bytes() == b"a killed run's progress"


def test_a_run_up_whose_windows_hold_too_few_saves_is_refused_first(tmp_path, capsys, monkeypatch):
    """300 -> 320 rpm with one revolution per window: a window lasts 0.1875 s at the top speed, saved every 20 ms
    that is 9 samples, fewer than a window's order spectrum takes (16), so every window was skipped and the run-up
    said "0 windows ... status ok" (an audit's find, 3000 -> 3200 rpm saved every 2 ms). Refused before the run,
    naming solver.save_dt and the interval that would do."""
    monkeypatch.setattr(importlib.import_module("jaxbelt.analysis.run"), "run", lambda *a, **k: pytest.fail("ran"))
    cfg = _config(tmp_path)
    cfg.write_text(cfg.read_text().replace("save_dt = 1e-3", "save_dt = 0.02", 1))
    argv = ["runup", str(cfg), "--rpm", "300:320", "--duration", "0.5", "--revolutions", "1", "--no-modes"]
    line = _refused(capsys, [*argv, "--out", str(tmp_path / "ru")])
    assert "solver.save_dt = 0.02 s" in line and "save at least every 0.0117 s" in line


@pytest.mark.parametrize("window", ["0.04:0.01", "nan:inf", "5:6", "0.011:0.0115"])
def test_identify_windows_outside_the_record_or_backwards_are_refused(tmp_path, capsys, nothing_compiles, window):
    """``identify --window``: backwards (0.04:0.01), not finite, beyond the record (5:6 s of a 0.02 s record) or
    between two samples were accepted and "converged" (an audit's find); refused before the drive is built."""
    cfg = _config(tmp_path)
    meas = tmp_path / "measured.csv"
    meas.write_text("t,omega:driven\n" + "".join(f"{0.002 * i:.3f},{0.1 * i}\n" for i in range(11)))
    argv = ["identify", str(cfg), "--measured", str(meas), "--fit", "contact.mu", "--window", window]
    line = _refused(capsys, [*argv, "--out", str(tmp_path / "id")])
    assert f"--window {window}" in line


@pytest.mark.parametrize("model", ["ancf", "spans"])
def test_a_belt_stiffer_than_any_belt_is_refused_first(tmp_path, capsys, model):
    """EA = 1e300 N: the ANCF tier ran it to "ok" with 5e298 N of span tension, the spans tier crashed with an
    OverflowError (an audit's find). Refused by name by the configuration's validation."""
    cfg = _config(tmp_path)
    cfg.write_text(cfg.read_text().replace("EA = 7600.0", "EA = 1e300", 1))
    line = _refused(capsys, ["run", str(cfg), "--model", model, "--out", str(tmp_path / "o")])
    assert "belt.EA = 1e+300" in line and "at most 1e+09 N" in line


def test_each_warning_of_a_run_is_printed_once(tmp_path, capsys):
    """A build warning (12 elements on 0.1 m pulleys: the polygon effect) was printed when the drive was built and
    again with the summary's warnings at the end (docs/config.md says once per process): now once."""
    cfg = _config(tmp_path)
    cli.main(["run", str(cfg), "--out", str(tmp_path / "o"), "--no-plots", "--quiet"])
    err = capsys.readouterr().err.splitlines()
    polygon = [line for line in err if "is wrapped by belt elements" in line]
    assert len(polygon) == 2 and len(set(polygon)) == 2, err  # one per pulley, each once


def test_a_load_on_a_speed_driven_driver_is_refused():
    """A speed-prescribed driver turns at its speed whatever loads it: its ``load`` was accepted and silently did
    nothing (an audit's find). Refused by name (a torque-driven driver with a load was refused before: its brake is
    part of its torque)."""
    spec = jb.benchmark_a(n_elements=12)
    spec.pulleys[0].load = 5.0
    with pytest.raises(ConfigError, match=r"pulleys.driver.load = 5.0: a driver with a prescribed speed"):
        check_spec(spec)


def test_a_contact_so_soft_the_belt_sinks_through_its_pulleys_is_refused_first():
    """contact.stiffness = 1 N/m^2: the installed 400 N would sink the belt 4 km into its pulleys; the run diverged
    in its settle phase and the message blamed solver.dt (an audit's find). Refused by name, with the least
    stiffness that keeps the sink within the belt's thickness (T / (R t) = 400 / (0.1 x 0.01) = 4e5 N/m^2)."""
    spec = jb.benchmark_a(n_elements=12)
    spec.contact.stiffness = 1.0
    with pytest.raises(ConfigError, match=r"contact.stiffness = 1.0: the installed belt \(400 N\) would sink") as e:
        check_spec(spec)
    assert "at least 4e+05 N/m^2" in str(e.value)
    spec.contact.stiffness = 5e5
    check_spec(spec)


def test_a_friction_coefficient_beyond_any_belt_is_refused():
    """contact.mu = 1e6 ran, and its creep theory failed with a raw "OverflowError: math range error" (an audit's
    find): refused above 10 (e^(10 pi) holds any wrap), by name."""
    spec = jb.benchmark_a(n_elements=12)
    spec.contact.mu = 1e6
    with pytest.raises(ConfigError, match=r"contact.mu = 1000000.0: is beyond any belt's grip .* at most 10"):
        check_spec(spec)
