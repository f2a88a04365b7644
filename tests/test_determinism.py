"""Deterministic: the same configuration gives bit-identical results run to run on one machine,
in one process (the compiled program run again) and in two fresh processes (each tracing and
compiling anew, the persistent compilation cache switched off), which also agree with this one."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import jax
import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt import load_config

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "examples" / "serpentine_tensioner.toml"  # tensioner arm, back-side idler, poly-V, gravity
T_END = 0.05


def _spec():  # what `jaxbelt run CONFIG --t-end 0.05` runs (test_interrupt.py runs it in-process too)
    spec = load_config(CONFIG)
    spec.solver.t_end = T_END
    spec.solver.expect_steady = False  # 0.05 s of the start-up: a transient on purpose
    return spec


def _arrays(result) -> dict[str, np.ndarray]:
    out = {f"signal/{k}": np.asarray(v) for k, v in result.signals.items()}
    states = result.trajectory.states
    for path, leaf in jax.tree_util.tree_leaves_with_path(states):  # work terms are a Module of their own
        out["state" + jax.tree_util.keystr(path)] = np.asarray(leaf)
    out["t"] = np.asarray(result.trajectory.ts)
    return out


def _assert_identical(a: dict, b: dict, what: str) -> None:
    assert sorted(a) == sorted(b), what
    differ = [k for k in a if not np.array_equal(a[k], b[k], equal_nan=True)]
    assert not differ, f"{what}: not bit-identical: {differ}"
    assert all(a[k].dtype == b[k].dtype for k in a)


_SCRIPT = textwrap.dedent("""
    import sys
    import jax
    jax.config.update("jax_enable_x64", True)
    import numpy as np
    import jaxbelt as jb
    from jaxbelt import load_config
    spec = load_config(sys.argv[1])
    spec.solver.t_end = float(sys.argv[2])
    spec.solver.expect_steady = False
    r = jb.run(spec)
    arrays = {f"signal/{k}": np.asarray(v) for k, v in r.signals.items()}
    for path, leaf in jax.tree_util.tree_leaves_with_path(r.trajectory.states):
        arrays["state" + jax.tree_util.keystr(path)] = np.asarray(leaf)
    arrays["t"] = np.asarray(r.trajectory.ts)
    np.savez(sys.argv[3], **arrays)
    print(r.summary["status"])
""")


@pytest.fixture(scope="module")
def first():
    """The run in this process, shared by both tests (one compile and one run fewer)."""
    return jb.run(_spec())


def test_same_configuration_twice_in_one_process_is_bit_identical(first):
    second = jb.run(_spec())
    assert first.summary["status"] == "ok"
    a, b = _arrays(first), _arrays(second)
    assert len(a["t"]) > 10 and abs(a["t"][-1] - T_END) < 2e-3
    _assert_identical(a, b, "second run in the same process")


@pytest.mark.long
def test_same_configuration_in_two_fresh_processes_is_bit_identical(tmp_path, first):
    env = dict(os.environ, JAX_ENABLE_COMPILATION_CACHE="false")  # each process compiles for itself
    procs, files = [], []
    for i in range(2):  # started together: they share the machine like two users would
        files.append(tmp_path / f"run{i}.npz")
        procs.append(
            subprocess.Popen(
                [sys.executable, "-c", _SCRIPT, str(CONFIG), str(T_END), str(files[-1])],
                cwd=tmp_path,
                env=env,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                text=True,
            )
        )
    for p in procs:
        out, err = p.communicate(timeout=600)
        assert p.returncode == 0, err
        assert out.strip() == "ok", out
    runs = []
    for f in files:
        with np.load(f, allow_pickle=False) as z:
            runs.append({k: z[k] for k in z.files})
    _assert_identical(runs[0], runs[1], "two fresh processes")
    _assert_identical(runs[0], _arrays(first), "a fresh process and this one")
