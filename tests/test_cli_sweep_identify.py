"""`jaxbelt sweep` and `jaxbelt identify` as subprocesses: outputs and error paths (exit code 2, one line)."""

import csv
import json
import subprocess
import sys

import pytest
from helpers import two_pulley_toml

import jaxbelt as jb


def _config(EA: float) -> str:
    return two_pulley_toml(n_elements=26, t_end=0.15, speed_ramp=(0.0, 0.05), load_ramp=(0.05, 0.12), EA=EA)


def _jaxbelt(*args, cwd):
    return subprocess.run(
        [sys.executable, "-m", "jaxbelt", *map(str, args)], capture_output=True, text=True, cwd=cwd, timeout=900
    )


def _one_line_error(out):
    assert out.returncode == 2, (out.returncode, out.stderr[-2000:])
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in out.stderr, out.stderr
    return lines[0]


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli5")
    (d / "true.toml").write_text(_config(7600.0))
    (d / "off.toml").write_text(_config(9000.0))
    return d


@pytest.mark.long
def test_sweep_writes_csv_and_plot(work):
    out = _jaxbelt("sweep", work / "true.toml", "--vary", "contact.mu=0.3:0.6:2", "--out", work / "sw", cwd=work)
    assert out.returncode == 0, out.stderr[-2000:]
    # no long phase without a line before it: the step, compiling (with counts), running (with counts)
    lines = out.stdout.splitlines()
    assert [
        i
        for i, l in enumerate(lines)
        if "time step" in l
        or "compiling one program for 2 points" in l
        or ("running 2 points" in l and "steps each" in l)
    ] == [1, 2, 3], lines
    rows = list(csv.reader(open(work / "sw" / "sweep.csv")))
    assert rows[0][0] == "contact.mu" and "omega:driven:mean" in rows[0] and len(rows) == 3
    assert [float(r[0]) for r in rows[1:]] == [0.3, 0.6]
    assert (work / "sw" / "sweep.png").stat().st_size > 1000
    status = list(csv.reader(open(work / "sw" / "sweep_status.csv")))
    # as `run` of the file says "ok", with no warning
    assert status == [["contact.mu", "status", "warnings"], ["0.3", "ok", ""], ["0.6", "ok", ""]]
    # mu = 0.01 cannot carry the load: that point's belt slides over a whole wrap. Its figures are not a steady
    # state: the sweep says so and exits 1 (it counted diverged points only, and exited 0)
    out = _jaxbelt("sweep", work / "true.toml", "--vary", "contact.mu=0.01:0.6:2", "--out", work / "sw2", cwd=work)
    assert out.returncode == 1, out.stderr[-2000:]
    assert "1 not steady or in gross slip (sweep_status.csv)" in out.stdout, out.stdout
    rows = list(csv.reader(open(work / "sw2" / "sweep_status.csv")))
    assert rows[1][0] == "0.01" and rows[1][1].startswith("gross slip") and rows[2] == ["0.6", "ok", ""]


@pytest.mark.long
def test_identify_recovers_EA_from_a_run(work):
    out = _jaxbelt("run", work / "true.toml", "--out", work / "run", "--quiet", "--no-plots", cwd=work)
    assert out.returncode == 0, out.stderr[-2000:]
    rows = list(csv.reader(open(work / "run" / "signals.csv")))
    h = rows[0]
    keep = [h.index(c) for c in ("t", "omega:driven", "tension:driven-driver")]
    with open(work / "meas.csv", "w", newline="") as f:
        csv.writer(f).writerows([[r[i] for i in keep] for r in rows[::2]])
    out = _jaxbelt(
        "identify",
        work / "off.toml",
        "--measured",
        work / "meas.csv",
        "--fit",
        "belt.EA",
        "--iterations",
        "6",
        "--out",
        work / "id",
        cwd=work,
    )
    assert out.returncode == 0, out.stderr[-2000:]
    # no silent phase: a line before the first (compiling) iteration, then one per iteration
    assert "fitting belt.EA to" in out.stdout and "compiling first" in out.stdout, out.stdout
    assert "iteration 1," in out.stdout, out.stdout
    res = json.loads((work / "id" / "identify.json").read_text())
    assert res["values"]["belt.EA"] == pytest.approx(7600.0, rel=1e-3)  # from 9000 (18 % off)
    # the final misfit: noise estimated (no --sigma), RMS residual per measured column, printed too
    fit = res["misfit"]
    assert fit["noise"] == "estimated" and set(fit["rms_residual"]) == {"omega:driven", "tension:driven-driver"}
    assert fit["rms_residual"]["tension:driven-driver"] < 1.0 and res["at_bound"] == {}  # N; noise-free data
    assert "misfit: reduced chi^2" in out.stdout, out.stdout
    assert res["converged"] is True and "iterations, converged" in out.stdout, out.stdout


def _measured(work):
    """The noise-free record of true.toml (driven speed and one span tension, every other sample)."""
    if not (work / "meas.csv").exists():
        out = _jaxbelt("run", work / "true.toml", "--out", work / "run", "--quiet", "--no-plots", cwd=work)
        assert out.returncode == 0, out.stderr[-2000:]
        rows = list(csv.reader(open(work / "run" / "signals.csv")))
        keep = [rows[0].index(c) for c in ("t", "omega:driven", "tension:driven-driver")]
        with open(work / "meas.csv", "w", newline="") as f:
            csv.writer(f).writerows([[r[i] for i in keep] for r in rows[::2]])
    return work / "meas.csv"


def test_identify_that_has_not_converged_exits_1_without_standard_errors(work):
    """One iteration from EA 18 % off: the fit stops at its iteration cap. Before, this printed "+- ..."
    standard errors and "finished in 1 iterations" with exit code 0; now the exit code is 1 (EXIT_FAILED),
    the print-out says NOT CONVERGED and why, and identify.json has converged = false, the reason, and no
    standard errors (null)."""
    meas = _measured(work)
    args = ("identify", work / "off.toml", "--measured", meas, "--fit", "belt.EA", "--iterations", "1")
    out = _jaxbelt(*args, "--out", work / "id1", "--quiet", cwd=work)
    assert out.returncode == 1, (out.returncode, out.stderr[-2000:])
    assert "NOT CONVERGED" in out.stdout and "iteration cap (1 per window) reached" in out.stdout, out.stdout
    assert "no standard error: not converged" in out.stdout and "+-" not in out.stdout, out.stdout
    res = json.loads((work / "id1" / "identify.json").read_text())
    assert res["converged"] is False and "iteration cap" in res["convergence"]["reason"], res["convergence"]
    assert res["std_errors"] == {"belt.EA": None} and res["error_budget"] == {}, res


@pytest.mark.parametrize(
    "args, needle",
    [
        (("sweep", "{cfg}", "--vary", "contact.mu=0.3:0.6"), "KEY=START:STOP:N"),
        (("sweep", "{cfg}", "--vary", "contact.muu=0.3:0.6:2"), "did you mean 'contact.mu'"),
        (("sweep", "{cfg}"), "--vary"),
        (
            ("sweep", "{cfg}", "--vary", "contact.mu=-0.5:0.5:3"),
            "sweep point 1 of 3 (contact.mu = -0.5): contact.mu = -0.5: must be a finite number > 0",
        ),
        (("sweep", "{dtcfg}", "--vary", "belt.EA=7600:30400:2"), "exceeds the stability limit"),
        (("identify", "{cfg}", "--measured", "missing.csv", "--fit", "belt.EA"), "no such"),
        (("identify", "{cfg}", "--measured", "{bad}", "--fit", "belt.EA"), "not a number"),
        (("identify", "{cfg}", "--measured", "{good}", "--fit", "belt.EAA"), "did you mean 'belt.EA'"),
        (("identify", "{cfg}", "--measured", "{good}", "--fit", "belt.EA", "--sigma", "omega:driven"), "COLUMN=LEVEL"),
        (
            ("identify", "{cfg}", "--measured", "{good}", "--fit", "belt.EA", "--sigma", "omega:driven=-1"),
            "positive, finite noise level",
        ),
        (("identify", "{cfg}", "--measured", "{good}", "--fit", "belt.EA,contact.mu,belt.EA"), "belt.EA given more"),
        (
            ("identify", "{cfg}", "--measured", "{good}", "--fit", "belt.EA")
            + ("--sigma", "omega:driven=1", "--sigma", "omega:driven=2"),
            "has a noise level already",
        ),
    ],
)
def test_error_paths_are_one_line(work, args, needle):
    (work / "bad.csv").write_text("t,omega:driven\n0,1\n0.1,abc\n")
    (work / "good.csv").write_text("t,omega:driven\n0,1\n0.1,2\n")
    # solver.dt given: the configuration's own default step, too large for a four times stiffer belt
    dt = jb.build_drive(jb.load_config(work / "true.toml")).dt
    (work / "dt.toml").write_text(_config(7600.0) + f"dt = {dt!r}\n")
    filled = [
        a.format(cfg=work / "true.toml", bad=work / "bad.csv", good=work / "good.csv", dtcfg=work / "dt.toml")
        for a in args
    ]
    line = _one_line_error(_jaxbelt(*filled, cwd=work))
    assert needle in line, line
