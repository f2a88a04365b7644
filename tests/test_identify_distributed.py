"""``jaxbelt identify`` over several processes (``jax.distributed``): the forward-mode Jacobian's tangents
split over the processes, the columns gathered, process 0 writes.

The split is checked in-process on a small analytic residual (every fake process's block, reassembled,
is the one-process Jacobian); the whole fit by real processes on 127.0.0.1 (one CPU device each) against
one process, on a small drive (12 elements, 0.08 s, three keys: process 1's block holds one zero tangent).
"""

import json
import os
import subprocess
import sys

import jax.numpy as jnp
import numpy as np
import pytest
from helpers import free_port, two_pulley_toml

import jaxbelt as jb
from jaxbelt.analysis.distributed import ProcessGroup, assemble, tangent_block
from jaxbelt.analysis.optimise import CountedResiduals
from jaxbelt.cli import main
from jaxbelt.io import write_signals_csv

pytestmark = pytest.mark.filterwarnings("ignore:pulley .* is wrapped by belt elements")  # 12 elements on purpose


def _config(EA: float, mu: float, J: float) -> str:
    return two_pulley_toml(
        n_elements=12, t_end=0.08, speed_ramp=(0.0, 0.02), load_ramp=(0.02, 0.05), EA=EA, mu=mu, driven_inertia=J
    )


KEYS = "belt.EA,contact.mu,pulleys.driven.inertia"


def _residuals(theta, a, b):
    """A smooth nonlinear residual of five parameters (every column different)."""
    x = jnp.exp(theta)
    return jnp.concatenate([jnp.sin(a * x[0] * x[1]) + x[2] ** 2, b * x[3] * jnp.exp(-x[4] * a), jnp.cos(x * x[0])])


@pytest.mark.parametrize("count", [2, 3])
def test_tangent_blocks_reassemble_the_one_process_jacobian(count):
    """p = 5 tangents over 2 processes (k = 3, one zero row) and 3 (k = 2, one zero row): the blocks of every
    process, concatenated in process order, give the one-process Jacobian (measured: bit for bit) and every
    process the same residuals."""
    p = 5
    k = -(-p // count)
    blocks = [tangent_block(p, ProcessGroup(i, count)) for i in range(count)]
    assert all(b.shape == (k, p) for b in blocks)
    np.testing.assert_array_equal(np.concatenate(blocks)[:p], np.eye(p))
    assert not np.concatenate(blocks)[p:].any()  # the padding: zero tangents
    args = (jnp.linspace(0.1, 1.0, 7), jnp.asarray(0.7))
    theta = np.log(np.array([0.9, 1.3, 0.4, 2.0, 0.6]))
    r1, J1 = CountedResiduals(_residuals, args, group=ProcessGroup(0, 1)).linearise(theta)
    shares = [
        CountedResiduals(_residuals, args, group=ProcessGroup(i, count)).jacobian_rows(theta) for i in range(count)
    ]
    assert all(rows.shape == (k, r1.size) for _, rows in shares)
    for r, _ in shares:
        np.testing.assert_array_equal(r, r1)
    J = assemble(np.concatenate([rows for _, rows in shares]), p)
    assert J.shape == J1.shape == (r1.size, p) and J.flags.c_contiguous
    np.testing.assert_array_equal(J, J1)


def _env() -> dict:
    return dict(os.environ, PYTHONUNBUFFERED="1", XLA_FLAGS="--xla_force_host_platform_device_count=1")


def _identify_cmd(work, out, *extra):
    return [
        sys.executable,
        "-m",
        "jaxbelt",
        "identify",
        str(work / "off.toml"),
        "--measured",
        str(work / "meas.csv"),
        "--fit",
        KEYS,
        "--iterations",
        "3",
        "--out",
        str(work / out),
        *extra,
    ]


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    """The measurement: the true drive's driven speed and tight span tension; the fit starts 10 % off."""
    d = tmp_path_factory.mktemp("identify_distributed")
    (d / "true.toml").write_text(_config(EA=7600.0, mu=0.5, J=0.05))
    (d / "off.toml").write_text(_config(EA=8360.0, mu=0.45, J=0.055))
    ts, sig = jb.simulate_signals(jb.build_drive(jb.load_config(d / "true.toml")))
    cols = {n: np.asarray(sig[n]) for n in ("omega:driven", "tension:driven-driver")}
    write_signals_csv(d / "meas.csv", dict(t=np.asarray(ts), **cols))
    return d


@pytest.mark.long
def test_two_processes_on_jax_distributed_equal_one_process(work):
    """Two processes (one CPU device each) split each Jacobian's three tangents (2 + 1 and a zero one),
    every process runs the forward runs itself; process 0 writes identify.json and prints, process 1
    writes nothing. Fitted values and standard errors equal the one-process fit's to 1e-10 relative.

    Not bit for bit: a batch of 2 tangents rounds differently from one of 3 (another vectorisation of the
    same arithmetic). Measured on this drive at the starting point: the residuals and two columns of the
    Jacobian bit for bit, the first column off by 1.5e-16 of its largest entry. Through three Levenberg-
    Marquardt steps that became 6e-14 relative in the values and 5e-13 in the standard errors (these scale
    with the residuals' RMS, a small difference of large signals, which differs by up to 1e-11 relative);
    1e-10 leaves a margin of 200 over that round-off and is far below any physical effect."""
    # the one-process fit first: its forward-run and half-step programs, the same in the two processes, are
    # then served to them from the persistent compilation cache instead of compiled twice more side by side
    one = subprocess.run(_identify_cmd(work, "one"), capture_output=True, text=True, env=_env(), timeout=900)
    addr = f"127.0.0.1:{free_port()}"
    cmds = [
        _identify_cmd(work, f"two{i}", "--coordinator", addr, "--num-processes", "2", "--process-id", str(i))
        for i in range(2)
    ]
    procs = [subprocess.Popen(c, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env()) for c in cmds]
    outs = [p.communicate(timeout=900) for p in procs] + [(one.stdout, one.stderr)]
    procs.append(one)
    for p, (out, errs) in zip(procs, outs):
        assert p.returncode == 0, errs[-3000:]
    assert "identification finished" in outs[0][0] and "iteration 1," in outs[0][0], outs[0][0]
    said = [line for line in outs[1][0].splitlines() if not line.startswith("[Gloo]")]  # gloo's own notices
    assert said == [] and not (work / "two1").exists(), said  # process 1: silent, no files
    two = json.loads((work / "two0" / "identify.json").read_text())
    one = json.loads((work / "one" / "identify.json").read_text())
    assert two["iterations"] == one["iterations"] and two["at_bound"] == one["at_bound"] == {}
    for k in KEYS.split(","):
        assert two["values"][k] == pytest.approx(one["values"][k], rel=1e-10)
        assert two["std_errors"][k] == pytest.approx(one["std_errors"][k], rel=1e-10)


def test_process_id_without_the_others_is_one_line_error(tmp_path, capsys):
    """``--process-id`` alone: the distributed options' ConfigError as one line, exit code 2 (as for sweep),
    before the measurement is read (it does not exist) or anything is compiled."""
    cfg = tmp_path / "drive.toml"
    cfg.write_text(_config(EA=7600.0, mu=0.5, J=0.05))
    argv = ["identify", str(cfg), "--measured", "missing.csv", "--fit", "belt.EA", "--process-id", "1", "--no-cache"]
    assert main(argv) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert lines == [
        f"jaxbelt identify: error: {cfg}: distributed run: --coordinator, --num-processes missing; give "
        "--coordinator HOST:PORT, --num-processes N and --process-id I together, or none of them on a cluster "
        "that JAX detects (SLURM, Open MPI)"
    ], lines
