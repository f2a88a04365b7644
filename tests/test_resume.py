"""Checkpoints and ``jaxbelt run --resume DIR``, with a real kill: a run SIGKILLed mid-simulation and
resumed from its last checkpoint writes the same results, bit for bit, as an uninterrupted run; a
changed configuration is refused. The processes share a compilation cache in the test's directory:
the resumed process must load the chunk program from it (logged by JAX_LOG_COMPILES).

Also, in-process: the chunked run equals ``simulate`` (the single program) to round-off.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import jax
import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt.dynamics.chunked import ChunkedRun
from jaxbelt.io import load_result, read_checkpoint

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "examples" / "two_pulley_benchmark.toml"


def _config(tmp: Path, name: str = "bench.toml", mu: str = "0.5") -> Path:
    # 0.6 s of the start-up (a transient on purpose: expect_steady = false)
    text = BENCH.read_text().replace("n_elements = 60", "n_elements = 26")
    text = text.replace("t_end = 2.45", "t_end = 0.6\nexpect_steady = false")
    path = tmp / name
    path.write_text(text.replace("mu = 0.5", f"mu = {mu}"))
    return path


def _env(tmp: Path, **extra) -> dict:
    return {**os.environ, "JAXBELT_CACHE_DIR": str(tmp / "cache"), "JAXBELT_STEPS_PER_CHUNK": "300", **extra}


def _run(args, tmp: Path, **extra) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "jaxbelt", "run", *map(str, args)],
        cwd=tmp,
        env=_env(tmp, **extra),
        capture_output=True,
        text=True,
        timeout=600,
    )


def _kill_after_checkpoint(cfg: Path, out: Path, tmp: Path) -> None:
    """Start a run, SIGKILL it once a checkpoint holds saves (after the settle phase, mid-simulation)."""
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "jaxbelt",
            "run",
            str(cfg),
            "--out",
            str(out),
            "-q",
            "--no-plots",
            "--checkpoint-every",
            "0",
        ],
        cwd=tmp,
        env=_env(tmp),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 600
    while not ((out / "checkpoint.npz").exists() and int(read_checkpoint(out / "checkpoint.npz")[0]["n_saved"]) > 0):
        assert proc.poll() is None, proc.stderr.read() if proc.stderr else ""
        assert time.monotonic() < deadline
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait()


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("resume")
    cfg = _config(tmp)
    ref = _run([cfg, "--out", tmp / "ref", "-q", "--no-plots"], tmp)
    assert ref.returncode == 0, ref.stderr
    _kill_after_checkpoint(cfg, tmp / "killed", tmp)
    shutil.copytree(tmp / "killed", tmp / "killed2")  # for the changed-configuration case
    shutil.copytree(tmp / "killed", tmp / "killed3")  # for the changed-code case
    return tmp, cfg


def test_killed_run_resumes_to_the_uninterrupted_result(runs):
    tmp, cfg = runs
    out = tmp / "killed"
    assert not (out / "summary.json").exists()  # killed before any result
    arrays, meta = read_checkpoint(out / "checkpoint.npz")
    assert meta["step"] > 0 and Path(meta["config"]) == cfg.resolve()
    assert int(arrays["n_saved"]) > 0
    resumed = _run(["--resume", out, "-q", "--no-plots"], tmp, JAX_LOG_COMPILES="1")
    assert resumed.returncode == 0, resumed.stderr
    assert "Persistent compilation cache hit for 'jit_chunk'" in resumed.stderr  # compiled once, never again
    assert not (out / "checkpoint.npz").exists()  # done: nothing left to resume
    assert (out / "signals.csv").read_bytes() == (tmp / "ref" / "signals.csv").read_bytes()
    a, b = load_result(out / "result.npz"), load_result(tmp / "ref" / "result.npz")
    for key in (k for k in a if k.startswith("state/") or k == "t"):
        np.testing.assert_array_equal(a[key], b[key], err_msg=key)


def test_resume_refuses_a_changed_configuration(runs):
    tmp, cfg = runs
    changed = _config(tmp, "changed.toml", mu="0.45")
    res = _run([changed, "--resume", tmp / "killed2", "-q"], tmp)
    assert res.returncode == 2, res.stderr
    assert "configuration changed since the checkpoint" in res.stderr and "Traceback" not in res.stderr
    missing = _run(["--resume", tmp / "ref", "-q"], tmp)  # finished: no checkpoint left
    assert missing.returncode == 2 and "no checkpoint there" in missing.stderr


def test_chunked_run_equals_simulate_to_round_off():
    """The chunks take simulate's steps and times (bit-identical up to 5 macro steps, see chunked.py);
    compiled as another program, they round differently: measured 1e-12 on q after 2.45 s of Benchmark A."""
    d = jb.build_drive(jb.benchmark_a(n_elements=26, t_end=0.05))
    kw = dict(t_end=0.05, dt=d.dt, save_dt=d.options.save_dt, settle_time=d.options.settle_time)
    ref = jb.simulate(d.model, d.params, d.state0, **kw)
    chunked = ChunkedRun(d.model, d.params, d.state0, **kw)
    at = chunked.start()
    while not chunked.done(at):
        at = chunked.advance(at)
    got = chunked.trajectory(at)
    np.testing.assert_array_equal(got.ts, ref.ts)
    assert int(got.num_steps) == int(ref.num_steps)
    for name in ("q", "v", "omega", "theta", "angular_impulse"):
        x, y = np.asarray(getattr(ref.states, name)), np.asarray(getattr(got.states, name))
        scale = np.max(np.abs(x))
        np.testing.assert_allclose(y, x, rtol=0, atol=1e-9 * scale, err_msg=name)
    assert jax.tree.structure(got.final) == jax.tree.structure(ref.final)


def test_resume_refuses_a_checkpoint_of_other_code(runs, monkeypatch, capsys):
    """The version number alone let a development checkout resume a checkpoint its older code wrote (the chunks
    repeat a run bit for bit only with the same code): the checkpoint holds a hash of jaxbelt's sources."""
    import jaxbelt._export as export
    from jaxbelt import cli

    tmp, _ = runs
    monkeypatch.setattr(export, "_SOURCE_HASH", "0" * 64)
    assert cli.main(["run", "--resume", str(tmp / "killed3"), "-q"]) == 2
    assert "written by other jaxbelt code" in capsys.readouterr().err
    assert (tmp / "killed3" / "checkpoint.npz").exists()
