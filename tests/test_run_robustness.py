"""A run is refused before it starts when it cannot fit in memory or write its results, and a
finished run is never lost to a failing derived output (creep theory, plots, ...)."""

import json
import math
import os
from pathlib import Path

import jax
import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt.config import resources as _drive
from jaxbelt.io import load_result

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "examples" / "two_pulley_benchmark.toml"


# ------------------------------------------------------------------ memory (item: 20 000 elements)
def _operator_array_bytes(n: int, m: int) -> int:
    """Bytes of the operator arrays ``drive_operators`` returns (shapes only: nothing is computed)."""
    spec = jb.benchmark_a(n_elements=n)
    spec.contact.points_per_element = m
    drive = jb.build_drive(spec)
    shapes = jax.eval_shape(jb.dynamics.drive_operators, drive.model, drive.params)
    leaves = jax.tree.leaves(shapes)  # the matrices: both dimensions grow with n (not the quadrature tables)
    return sum(
        math.prod(x.shape) * np.dtype(x.dtype).itemsize for x in leaves if len(x.shape) == 2 and min(x.shape) >= n
    )


@pytest.mark.parametrize("m", [1, 2, 3])
def test_operator_estimate_counts_the_arrays_the_step_builds(m):
    # The stored operators plus one (2n)^2 work array of the mass-matrix inversion: exactly.
    n = 40
    itemsize = np.dtype(jax.numpy.result_type(float)).itemsize
    assert _drive._operator_bytes(n, m, itemsize) == _operator_array_bytes(n, m) + itemsize * (2 * n) ** 2


def test_documented_maximum_is_refused_with_the_largest_count_that_fits(monkeypatch):
    free = 16e9
    monkeypatch.setattr(_drive, "_available_memory", lambda: (int(free), "memory"))
    spec = jb.benchmark_a(n_elements=20_000, t_end=0.01)
    spec.solver.scheme = "explicit"  # the figures below ("auto" would run it implicit: other saves, 102 GB)
    with pytest.raises(jb.ConfigError) as err:
        jb.build_drive(spec)
    msg = str(err.value)
    assert msg.startswith("belt.n_elements = 20000:") and "\n" not in msg
    # float64: 8 (2n)^2 numbers of 8 bytes = 102 GB
    assert "needs about 103 GB" in msg and "operators 102 GB" in msg and "16 GB this machine has free" in msg
    fit = int(msg.split("at most ")[1].split()[0])
    assert 7000 < fit < 7100  # about sqrt(0.8 * 16e9 / 256): the operators dominate
    # that count passes the check, one more does not (the check only; nothing is built or run)
    spec = jb.benchmark_a(n_elements=fit, t_end=0.01)
    n_saves = 12  # 0.01 s every 1 ms, plus the start and the final state
    _drive._check_memory(spec, fit, 2, 2 * fit, n_saves, _drive._state_bytes(fit, 2, 2 * fit))  # no error
    with pytest.raises(jb.ConfigError, match=f"at most {fit} elements fit"):
        _drive._check_memory(spec, fit + 1, 2, 2 * fit + 2, n_saves, _drive._state_bytes(fit + 1, 2, 2 * fit + 2))


def test_long_trajectory_on_a_small_machine_names_save_dt(monkeypatch):
    monkeypatch.setattr(_drive, "_available_memory", lambda: (int(1e9), "memory"))
    spec = jb.benchmark_a(n_elements=30, t_end=50.0, save_dt=5e-5)
    with pytest.raises(
        jb.ConfigError,
        match=r"^solver.save_dt = 5e-05: the run needs about .* raise solver.save_dt "
        r"to at least ([0-9.e+-]+) s",
    ) as err:
        jb.build_drive(spec)
    spec.solver.save_dt = float(str(err.value).split("at least ")[1].split()[0])
    jb.build_drive(spec)  # the suggested save_dt passes


def test_available_memory_is_positive_and_below_physical():
    avail, _ = _drive._available_memory()
    total = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    assert 0 < avail <= total


# ------------------------------------------------------------------ a finished run is never lost
def _short_config(tmp_path, **replace) -> Path:
    # 0.05 s of the start-up (a transient on purpose: expect_steady = false)
    text = BENCH.read_text().replace("n_elements = 60", "n_elements = 30")
    text = text.replace("t_end = 2.45", "t_end = 0.05\nexpect_steady = false")
    for old, new in replace.items():
        assert old in text
        text = text.replace(old, new)
    cfg = tmp_path / "drive.toml"
    cfg.write_text(text)
    return cfg


def test_failing_derived_outputs_become_warnings(tmp_path, monkeypatch, capsys):
    """Creep theory that fails after the simulation (contact.mu = 1e9 overflowed exp(mu phi); mu is now refused
    above 10, so here the theory is made to fail), and a plot that fails: before, nothing was written. Now every
    raw result is there and summary.json says what is missing."""
    import importlib

    from jaxbelt import cli, viz

    summary_module = importlib.import_module("jaxbelt.outputs.summary")  # the package exports a function so named

    def broken(*args, **kwargs):
        raise RuntimeError("no display of torques today")

    def overflow(*args, **kwargs):
        raise OverflowError("math range error")

    monkeypatch.setattr(viz, "plot_torques", broken)
    monkeypatch.setattr(summary_module, "two_pulley_creep", overflow)
    cfg = _short_config(tmp_path)
    out = tmp_path / "out"
    assert cli.main(["run", str(cfg), "--out", str(out), "--quiet"]) == 0
    err = capsys.readouterr().err
    for name in ("result.npz", "signals.csv", "summary.json", "speeds.png", "tensions.png", "contact.png", "belt.png"):
        assert (out / name).is_file(), name
    assert not (out / "torques.png").exists()
    s = json.loads((out / "summary.json").read_text())
    assert s["status"] == "ok" and "creep_theory" not in s
    assert any(w.startswith("creep theory not computed: OverflowError") for w in s["warnings"]), s["warnings"]
    assert any(w.startswith("torques.png not computed: RuntimeError: no display") for w in s["warnings"])
    assert "warning: creep theory not computed" in err and "Traceback" not in err
    # the raw results are complete: the saved states and the signals of the whole run
    r = load_result(out / "result.npz")
    assert r["state/q"].shape[1:] == (30, 2, 2) and r["t"][-1] == pytest.approx(0.05, abs=2e-3)
    assert set(r["contact"]) == {"driver", "driven"}


def _refused(capsys, argv) -> str:
    from jaxbelt import cli

    assert cli.main(argv) == 2
    captured = capsys.readouterr()
    assert "simulating" not in captured.out  # refused before the run started
    lines = [l for l in captured.err.splitlines() if l.strip()]
    assert len(lines) == 1 and lines[0].startswith("jaxbelt run: error: --out"), captured.err
    return lines[0]


def test_out_below_a_file_is_refused_before_simulating(tmp_path, capsys):
    cfg = _short_config(tmp_path)
    blocker = tmp_path / "results.txt"
    blocker.write_text("not a folder")
    line = _refused(capsys, ["run", str(cfg), "--out", str(blocker / "run1")])
    assert "results.txt is a file, not a directory" in line
    assert blocker.read_text() == "not a folder"


def test_read_only_out_is_refused_before_simulating(tmp_path, capsys):
    cfg = _short_config(tmp_path)
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        probe = locked / "probe"
        try:  # root (or a file system without permissions) writes anyway: nothing to refuse there
            probe.write_text("x")
            probe.unlink()
            pytest.skip("this user can write into a read-only directory (root)")
        except PermissionError:
            pass
        line = _refused(capsys, ["run", str(cfg), "--out", str(locked / "new")])
        assert "cannot write there" in line and "Permission denied" in line
        line = _refused(capsys, ["run", str(cfg), "--out", str(locked)])
        assert "cannot write there" in line
    finally:
        locked.chmod(0o755)
