"""Sweeps that survive being killed, point lists from CSV files, and sweeps over several processes.

The CLI runs as subprocesses (a real SIGKILL, real ``jax.distributed`` processes on 127.0.0.1). One small
drive (12 elements, 0.06 s) keeps each process to a compile and a few seconds of running.
"""

import os
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from helpers import free_port, two_pulley_toml

import jaxbelt as jb

pytestmark = pytest.mark.filterwarnings("ignore:pulley .* is wrapped by belt elements")  # 12 elements on purpose

CONFIG = two_pulley_toml(n_elements=12, t_end=0.06, speed_ramp=(0.0, 0.02), load_ramp=(0.02, 0.05))
POINTS = "contact.mu,belt.EA\n0.3,7000\n0.4,7600\n0.5,8200\n0.6,7600\n0.35,8000\n0.45,7200\n"


def _env(devices: int = 1) -> dict:
    # the killed, resumed and whole sweeps compile the same chunk program: the later ones load it from the cache
    return dict(
        os.environ,
        PYTHONUNBUFFERED="1",
        XLA_FLAGS=f"--xla_force_host_platform_device_count={devices}",
    )


def _sweep_cmd(work, out, *extra):
    return [
        sys.executable,
        "-m",
        "jaxbelt",
        "sweep",
        str(work / "drive.toml"),
        "--points",
        str(work / "points.csv"),
        "--chunk-size",
        "1",
        "--out",
        str(work / out),
        *extra,
    ]


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    d = tmp_path_factory.mktemp("sweep_resume")
    (d / "drive.toml").write_text(CONFIG)
    (d / "points.csv").write_text(POINTS)
    return d


def _rows(path):
    return path.read_text().splitlines()


@pytest.mark.long
def test_killed_sweep_resumes_to_the_files_of_an_uninterrupted_one(work):
    """SIGKILL after the first finished chunk, then --resume: sweep.csv and sweep_signals.npz equal those of
    an uninterrupted sweep (bit for bit: the same compiled chunk program on the same points), and the resumed
    run ran only the points that were missing."""
    proc = subprocess.Popen(
        _sweep_cmd(work, "killed"), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=_env()
    )
    csv_path = work / "killed" / "sweep.csv"
    deadline = time.monotonic() + 600
    while time.monotonic() < deadline and proc.poll() is None:
        if csv_path.exists() and len(_rows(csv_path)) >= 2:  # header + at least one finished chunk
            proc.send_signal(signal.SIGKILL)
            break
        time.sleep(0.05)
    proc.wait(timeout=60)
    assert proc.returncode == -signal.SIGKILL, "the sweep ended before it could be killed: " + proc.stdout.read()
    done_before = len(_rows(csv_path)) - 1
    assert 1 <= done_before < 6
    assert not (work / "killed" / "sweep_signals.npz").exists()  # written only when the sweep is complete

    resumed = subprocess.run(
        _sweep_cmd(work, "killed", "--resume"), capture_output=True, text=True, env=_env(), timeout=600
    )
    assert resumed.returncode == 0, resumed.stderr[-3000:]
    assert f"{done_before} of them done before" in resumed.stdout, resumed.stdout
    ran = [int(m) for m in re.findall(r"points (\d+)-\d+ done", resumed.stdout)]
    assert ran == list(range(done_before + 1, 7)), resumed.stdout  # no point ran twice, none was skipped

    whole = subprocess.run(_sweep_cmd(work, "whole"), capture_output=True, text=True, env=_env(), timeout=600)
    assert whole.returncode == 0, whole.stderr[-3000:]
    assert (work / "killed" / "sweep.csv").read_text() == (work / "whole" / "sweep.csv").read_text()
    a, b = np.load(work / "killed" / "sweep_signals.npz"), np.load(work / "whole" / "sweep_signals.npz")
    assert sorted(a.files) == sorted(b.files) and "omega:driven" in a.files
    for k in a.files:
        np.testing.assert_array_equal(a[k], b[k])
    assert a["omega:driven"].shape == (6, len(a["t"]))
    # the points are those of the file, in its order
    rows = np.array([r.split(",") for r in _rows(work / "whole" / "sweep.csv")[1:]], dtype=float)
    np.testing.assert_array_equal(rows[:, :2], np.loadtxt(work / "points.csv", delimiter=",", skiprows=1))

    # a finished sweep resumed again runs nothing; a changed sweep is refused rather than mixed in
    again = subprocess.run(
        _sweep_cmd(work, "whole", "--resume"), capture_output=True, text=True, env=_env(), timeout=600
    )
    assert again.returncode == 0 and "6 of them done before" in again.stdout, again.stdout + again.stderr
    (work / "points2.csv").write_text(POINTS.replace("0.3,7000", "0.31,7000"))
    cmd = _sweep_cmd(work, "whole", "--resume")
    cmd[cmd.index(str(work / "points.csv"))] = str(work / "points2.csv")
    changed = subprocess.run(cmd, capture_output=True, text=True, env=_env(), timeout=600)
    assert changed.returncode == 2 and "differs from this one (points changed)" in changed.stderr, changed.stderr


def test_two_processes_on_jax_distributed_equal_one_process(work):
    """Two processes (one CPU device each) joined by jax.distributed split every chunk; process 0 writes the
    files. They equal a one-process sweep's to 1e-12 (measured: bit-identical)."""
    addr = f"127.0.0.1:{free_port()}"
    procs = [
        subprocess.Popen(
            _sweep_cmd(work, "two", "--coordinator", addr, "--num-processes", "2", "--process-id", str(i)),
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=_env(),
        )
        for i in range(2)
    ]
    outs = [p.communicate(timeout=600) for p in procs]
    for p, (out, errs) in zip(procs, outs):
        assert p.returncode == 0, errs[-3000:]
    assert "x 2 process(es)" in outs[0][0], outs[0][0]
    one = work / "whole" / "sweep.csv"
    if not one.exists():  # the resume test makes it; run alone, make it here
        out = subprocess.run(_sweep_cmd(work, "whole"), capture_output=True, text=True, env=_env(), timeout=600)
        assert out.returncode == 0, out.stderr[-3000:]
    a = np.array([r.split(",") for r in _rows(work / "two" / "sweep.csv")[1:]], dtype=float)
    b = np.array([r.split(",") for r in _rows(one)[1:]], dtype=float)
    assert _rows(work / "two" / "sweep.csv")[0] == _rows(one)[0]
    np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12)


def test_point_lists_and_chunking_are_checked_before_compiling():
    drive = jb.build_drive(jb.benchmark_a(n_elements=12, t_end=0.02, save_dt=0.01))
    with pytest.raises(jb.ConfigError, match="one value per point"):
        jb.sweep(drive, points={"contact.mu": [0.3, 0.4], "belt.EA": [7000.0]})
    with pytest.raises(jb.ConfigError, match="either a grid"):
        jb.sweep(drive, {"contact.mu": [0.3]}, points={"contact.mu": [0.3]})
    with pytest.raises(jb.ConfigError, match="chunk_size = 0"):
        jb.sweep(drive, {"contact.mu": [0.3]}, chunk_size=0)
    with pytest.raises(jb.ConfigError, match=r"sweep point 2 of 2 \(contact.mu = -0.1\)"):
        jb.sweep(drive, points={"contact.mu": [0.3, -0.1]})


def test_resumed_sweep_finishes_past_the_temporary_file_of_a_killed_chunk_write(tmp_path):
    """A SIGKILL while a chunk's signals are being written leaves that write's temporary file in
    sweep_signals/ (seen under load in the killed-sweep test: the resume then failed with "Directory not
    empty"). Finishing the resumed sweep joins the chunks and removes the leftover."""
    from jaxbelt.analysis.sweep_store import SweepStore

    manifest = dict(keys=["contact.mu"], points=[[0.3], [0.4]])
    store = SweepStore(tmp_path, manifest, resume=False)
    t = np.array([0.0, 0.1])
    store.append(0, ["contact.mu", "x"], np.array([[0.3, 1.0]]), {"omega:driven": np.array([[1.0, 2.0]])}, t)
    (tmp_path / "sweep_signals" / ".chunk_000001.npz.abc123.tmp").write_bytes(b"partial")  # the killed write
    store = SweepStore(tmp_path, manifest, resume=True)
    assert store.done == 1
    store.append(1, ["contact.mu", "x"], np.array([[0.4, 3.0]]), {"omega:driven": np.array([[3.0, 4.0]])}, t)
    path = store.finish()
    assert not (tmp_path / "sweep_signals").exists()
    joined = np.load(path)
    np.testing.assert_array_equal(joined["omega:driven"], [[1.0, 2.0], [3.0, 4.0]])
    np.testing.assert_array_equal(joined["point"], [0, 1])


def test_a_sweep_started_by_other_jaxbelt_code_is_not_resumed(tmp_path, monkeypatch):
    """The manifest holds the version and a hash of jaxbelt's sources: an audit resumed a killed sweep with newer
    code, which appended rows of another column count to sweep.csv and then failed. Refused, naming it."""
    import jaxbelt._export as export
    from jaxbelt.analysis.sweep_store import SweepStore

    manifest = dict(keys=["contact.mu"], points=[[0.3], [0.4]])
    store = SweepStore(tmp_path, manifest, resume=False)
    store.append(0, ["contact.mu", "x"], np.array([[0.3, 1.0]]), {"omega:driven": np.array([[1.0, 2.0]])}, [0.0, 0.1])
    monkeypatch.setattr(export, "_SOURCE_HASH", "0" * 64)  # the sources changed since
    with pytest.raises(jb.ConfigError, match=r"differs from this one \(jaxbelt changed\)"):
        SweepStore(tmp_path, manifest, resume=True)
