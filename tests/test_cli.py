"""The command line as a user meets it: ``python -m jaxbelt run`` in a subprocess, on a short
Benchmark A; every input error is one line on stderr with exit code 2 and no traceback. Also the
TOML loader (round trip of the examples, dotted keys) in-process.

Each subprocess pays the JAX import (and the run its compilation), so all error cases start at
once and share one module-scoped fixture, and the successful run happens once.
"""

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt.config import toml as _config
from jaxbelt.io import DataError, load_result, read_signals_csv

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
BENCH = EXAMPLES / "two_pulley_benchmark.toml"
SIGNALS = [
    "t",
    "omega:driver",
    "omega:driven",
    "torque:driver",
    "torque:driven",
    "tension:driver-driven",
    "tension:driven-driver",
    # accessory-drive signals (outputs/fead.py, docs/outputs.md)
    *(f"{q}:{p}" for q in ("slip", "friction_use", "hub_load", "hub_direction") for p in ("driver", "driven")),
    *(f"{q}:{s}" for q in ("speed", "deflection") for s in ("driver-driven", "driven-driver")),
]


def _short_benchmark(text: str) -> str:
    """The benchmark file with a short run and a coarse mesh (keys replaced, not appended): 0.05 s of the
    start-up, a transient on purpose (solver.expect_steady = false: its window is not a steady state)."""
    text = text.replace("n_elements = 60", "n_elements = 24").replace(
        "t_end = 2.45", "t_end = 0.05\nexpect_steady = false"
    )
    assert "n_elements = 24" in text and "t_end = 0.05" in text
    return text


def _start(args, cwd):
    return subprocess.Popen(
        [sys.executable, "-m", "jaxbelt", *map(str, args)],
        cwd=cwd,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _finish(proc, timeout=300):
    out, err = proc.communicate(timeout=timeout)
    return proc.returncode, out, err


# ------------------------------------------------------------------ error cases (started together)
def _error_cases(tmp: Path) -> dict:
    base = _short_benchmark(BENCH.read_text())
    files = {
        "unknown_key": base.replace("mu = 0.5", "mue = 0.5"),
        "out_of_range": base.replace("mu = 0.5", "mu = -0.5"),
        "wrong_type": base.replace("n_elements = 24", 'n_elements = "many"'),
        "syntax": base.replace("[contact]", "[contact"),
        "bad_pulley_key": base.replace('role = "driven"', 'role = "driven"\nlaod = 3.0'),
        "bad_role": base.replace('role = "driven"', 'role = "drivn"'),
    }
    cases = {}
    for name, text in files.items():
        path = tmp / f"{name}.toml"
        path.write_text(text)
        cases[name] = ["run", path, "--out", tmp / f"out_{name}", "--quiet"]
    cases["missing_file"] = ["run", tmp / "no_such_drive.toml", "--quiet"]
    cases["bad_option"] = ["run", tmp / "unknown_key.toml", "--t-end", "-1"]
    # a config named like a result file, with --out its own directory: refused before simulating
    trap = tmp / "trap"
    trap.mkdir()
    (trap / "summary.json").write_text(base)
    cases["overwrite_input"] = ["run", trap / "summary.json", "--out", trap, "--quiet"]
    return cases


EXPECTED = {  # case: substrings of the one stderr line
    "unknown_key": ["unknown key 'contact.mue'", "did you mean 'contact.mu'"],
    "out_of_range": ["contact.mu", "-0.5"],
    "wrong_type": ["belt.n_elements", "'many'", "integer"],
    "syntax": ["TOML syntax error", "line"],
    "bad_pulley_key": ["pulleys.driven.laod", "did you mean 'pulleys.driven.load'"],
    "bad_role": ["pulleys.driven.role", "'drivn'", "did you mean 'driven'"],
    "missing_file": ["no_such_drive.toml", "no such"],
    "bad_option": ["--t-end", "> 0"],
    "overwrite_input": ["refusing to overwrite", "summary.json"],
}


@pytest.fixture(scope="module")
def cli_runs(tmp_path_factory):
    """Start the successful run and every error case at once; collect all results."""
    tmp = tmp_path_factory.mktemp("cli")
    cfg = tmp / "bench_short.toml"
    cfg.write_text(_short_benchmark(BENCH.read_text()))
    cfg_bytes = cfg.read_bytes()
    out = tmp / "out"
    procs = {"ok": _start(["run", cfg, "--out", out, "--window", "0.5"], cwd=tmp)}
    for name, args in _error_cases(tmp).items():
        procs[name] = _start(args, cwd=tmp)
    results = {name: _finish(p) for name, p in procs.items()}
    return dict(results=results, out=out, cfg=cfg, cfg_bytes=cfg_bytes, tmp=tmp)


def test_run_succeeds_and_reports(cli_runs):
    rc, out, err = cli_runs["results"]["ok"]
    assert rc == 0, err
    assert "Traceback" not in err
    assert "status: ok" in out
    assert "creep theory" in out and "driven" in out and "timing:" in out
    # the input is untouched
    assert cli_runs["cfg"].read_bytes() == cli_runs["cfg_bytes"]


def test_run_writes_documented_files(cli_runs):
    out = cli_runs["out"]
    for name in ("summary.json", "signals.csv", "result.npz", "speeds.png", "tensions.png", "contact.png", "belt.png"):
        f = out / name
        assert f.is_file() and f.stat().st_size > 0, name
    for png in out.glob("*.png"):
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert not list(out.glob(".*tmp*")), "temporary files left behind"


def test_summary_json_keys(cli_runs):
    s = json.loads((cli_runs["out"] / "summary.json").read_text())
    assert s["status"] == "ok"
    for key in ("num_steps", "wall_time_s", "compile_time_s"):
        assert isinstance(s[key], (int, float)) and s[key] > 0
    assert set(s["pulleys"]) == {"driver", "driven"}
    for p in s["pulleys"].values():
        for key in ("omega_mean", "torque_mean", "stick_arc_deg", "slip_arc_deg"):
            assert isinstance(p[key], float) and math.isfinite(p[key])
    spans = {sp["name"]: sp for sp in s["spans"]}
    assert set(spans) == {"driver-driven", "driven-driver"}
    assert spans["driver-driven"]["from"] == "driver" and spans["driver-driven"]["to"] == "driven"
    for sp in spans.values():
        assert 300 < sp["tension_mean"] < 500  # installed 400 N, the load step is still far off
    theory = s["creep_theory"]
    assert theory["omega_driven"] == pytest.approx(11.308, abs=2e-3)  # benchmark numbers (reference §3)
    assert set(s["creep_comparison"]["omega_driven"]) == {"simulation", "theory"}
    assert s["window"] == 0.5
    # what defined the installed belt (held when E, EA or a radius change): the benchmark gives its length
    st = s["belt"]["installed_state"]
    assert st["defined_by"] == "stress_free_length" and st["pretension"] == pytest.approx(400.0, rel=1e-9)


def test_signals_csv_layout(cli_runs):
    path = cli_runs["out"] / "signals.csv"
    assert path.read_text().splitlines()[0].split(",") == SIGNALS
    sig = read_signals_csv(path, required=SIGNALS)
    t = sig["t"]
    assert t[0] == 0.0 and t[-1] == pytest.approx(0.05, abs=2e-3) and np.all(np.diff(t) > 0)
    assert all(np.all(np.isfinite(v)) for v in sig.values())
    # the driver follows its ramp (0 until 0.05 s): at rest before it starts
    assert np.abs(sig["omega:driver"][t < 0.049]).max() < 1e-9


def test_result_npz_contents(cli_runs):
    r = load_result(cli_runs["out"] / "result.npz")
    n_t = r["t"].size
    assert r["state/q"].shape == (n_t, 24, 2, 2)
    assert r["state/omega"].shape == (n_t, 2)
    assert list(r["pulley_names"]) == ["driver", "driven"]
    for name in ("driver", "driven"):
        c = r["contact"][name]
        assert c["angle_deg"].shape == c["pressure"].shape == c["friction"].shape == c["state"].shape
        assert c["pressure"].max() > 1e3  # 400 N / 0.1 m = 4 kN/m
        assert isinstance(c["stick_arc_deg"], float)


@pytest.mark.parametrize("case", sorted(EXPECTED))
def test_input_errors_are_one_line_with_exit_code_2(cli_runs, case):
    rc, out, err = cli_runs["results"][case]
    lines = [l for l in err.splitlines() if l.strip() and "warning:" not in l]
    assert rc == 2, (out, err)
    assert "Traceback" not in err
    assert len(lines) == 1, err
    assert lines[0].startswith("jaxbelt")
    for text in EXPECTED[case]:
        assert text in lines[0], lines[0]


def test_no_output_for_a_failed_config(cli_runs):
    tmp = cli_runs["tmp"]
    assert not (tmp / "out_unknown_key").exists()
    assert not (tmp / "out_out_of_range" / "summary.json").exists()
    assert sorted(p.name for p in (tmp / "trap").iterdir()) == ["summary.json"]


# ------------------------------------------------------------------ configuration files (in-process)
def test_benchmark_file_is_benchmark_a():
    assert _config.load_config(BENCH) == jb.benchmark_a()


@pytest.mark.parametrize("path", sorted(EXAMPLES.glob("*.toml")), ids=lambda p: p.name)
def test_examples_load_build_and_round_trip(path):
    spec = _config.load_config(path)
    assert _config.spec_from_dict(__import__("tomllib").loads(_config.dump_toml(spec))) == spec
    drive = jb.build_drive(spec)
    assert drive.dt > 0


def test_dotted_keys():
    data = _config.read_toml(BENCH)
    assert _config.get_key(data, "contact.mu") == 0.5
    _config.set_key(data, "contact.mu", 0.3)
    _config.set_key(data, "pulleys.driven.load", 10.0)
    _config.set_key(data, "pulleys.driven.inertia", 0.5)
    _config.set_key(data, "pulleys.driver.speed.ramp.3", 8.0)
    _config.set_key(data, "gravity.y", 0.0)
    _config.set_key(data, "pulleys.driven.tensioner.stiffness", 5.0)  # creates the table
    assert _config.get_key(data, "pulleys.driven.tensioner.stiffness") == 5.0
    del data["pulleys"][1]["tensioner"]
    spec = _config.spec_from_dict(data)
    assert spec.contact.mu == 0.3 and spec.gravity == (0.0, 0.0)
    assert spec.pulleys[1].load == 10.0 and spec.pulleys[1].inertia == 0.5
    assert spec.pulleys[0].speed == {"ramp": [0.05, 0.6, 0.0, 8.0]}
    with pytest.raises(jb.ConfigError, match="did you mean 'contact.mu'"):
        _config.set_key(data, "contact.muu", 0.2)
    with pytest.raises(jb.ConfigError, match="no pulley named 'drivn'.*'driven'"):
        _config.set_key(data, "pulleys.drivn.load", 1.0)
    with pytest.raises(jb.ConfigError, match="pulleys.driven.inertia = 'heavy': expected a number"):
        _config.set_key(data, "pulleys.driven.inertia", "heavy")
    with pytest.raises(jb.ConfigError, match="did you mean 'belt'"):
        _config.set_key(data, "blet.E", 1e7)


@pytest.mark.parametrize(
    "change, message",
    [
        ({"speed": {"ramp": [0.6, 0.05, 0.0, 12.0]}}, r"pulleys\.driver\.speed\.ramp.*t1 > t0"),
        ({"speed": {"rampe": [0.0, 1.0, 0.0, 1.0]}}, r"unknown key 'pulleys\.driver\.speed\.rampe'.*'.*ramp'"),
        ({"speed": "fast"}, r"pulleys\.driver\.speed = 'fast': expected a number or an inline table"),
        ({"center": [0.0]}, r"pulleys\.driver\.center = \[0\.0\]: expected a list of 2 numbers"),
    ],
)
def test_pulley_value_errors(change, message):
    data = _config.read_toml(BENCH)
    data["pulleys"][0].update(change)
    with pytest.raises(jb.ConfigError, match=message):
        _config.spec_from_dict(data)


def test_bad_signals_csv_is_a_data_error(tmp_path):
    bad = tmp_path / "m.csv"
    bad.write_text("t,omega:driven\n0,1\n0.1,abc\n")
    with pytest.raises(DataError, match=r"line 3, column 'omega:driven': 'abc' is not a number"):
        read_signals_csv(bad)
    bad.write_text("time,omega:driven\n0,1\n0.1,2\n")
    with pytest.raises(DataError, match="first column must be 't'"):
        read_signals_csv(bad)
