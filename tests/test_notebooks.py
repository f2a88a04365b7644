"""Execute every notebook in ``notebooks/`` (reduced sizes: JAXBELT_NOTEBOOK_QUICK=1) so they never rot.

Each notebook ends with a cell that asserts its own physics and prints one JSON line with the numbers it
computed; these tests run the notebook with nbclient (outputs are kept in memory, never written back),
fail on any cell error, and check a few of those numbers again. Quick mode takes a few minutes for all
four notebooks on a 2-core CPU.
"""
import json
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")

NOTEBOOKS = sorted((Path(__file__).resolve().parent.parent / "notebooks").glob("*.ipynb"))
CELL_TIMEOUT_S = 600


def _execute(path: Path, monkeypatch) -> tuple[object, dict]:
    monkeypatch.setenv("JAXBELT_NOTEBOOK_QUICK", "1")  # inherited by the kernel process
    nb = nbformat.read(path, as_version=4)
    client = nbclient.NotebookClient(nb, timeout=CELL_TIMEOUT_S, kernel_name="python3",
                                     resources={"metadata": {"path": str(path.parent)}})
    client.execute()
    last = [c for c in nb.cells if c.cell_type == "code"][-1]
    text = "".join(o.get("text", "") for o in last.get("outputs", []) if o.get("output_type") == "stream")
    lines = [ln for ln in text.splitlines() if ln.startswith("{")]
    assert lines, f"{path.name}: the last cell printed no JSON summary; output was:\n{text}"
    return nb, json.loads(lines[-1])


def test_notebooks_exist():
    names = [p.name for p in NOTEBOOKS]
    assert names == ["01_quick_start.ipynb", "02_friction_laws.ipynb", "03_identification.ipynb",
                     "04_sweeps.ipynb"], names


@pytest.mark.parametrize("path", NOTEBOOKS, ids=lambda p: p.stem)
def test_notebook_committed_without_outputs(path):
    nb = nbformat.read(path, as_version=4)
    nbformat.validate(nb)
    for i, cell in enumerate(nb.cells):
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None, f"{path.name}: cell {i} has stale outputs"


@pytest.mark.slow
def test_01_quick_start(monkeypatch):
    _, out = _execute(NOTEBOOKS[0], monkeypatch)
    assert abs(out["speed_loss_error_pct"]) < 5, out
    assert abs(out["T_tight_error_pct"]) < 5 and abs(out["T_slack_error_pct"]) < 5, out


@pytest.mark.slow
def test_02_friction_laws(monkeypatch):
    _, out = _execute(NOTEBOOKS[1], monkeypatch)
    rows = out["table"]
    coulomb, reg = rows[0], rows[1:]
    assert coulomb["law"].startswith("Coulomb") and abs(coulomb["error_vs_theory_pct"]) < 5, coulomb
    assert [r["nu_s"] for r in reg] == [10.0, 20.0, 50.0, 200.0]
    errs = [abs(r["error_vs_coulomb_pct"]) for r in reg]
    assert errs == sorted(errs, reverse=True), errs  # the regularised law converges to Coulomb as nu_s grows
    assert all(r["converged"] for r in rows), rows


@pytest.mark.slow
def test_03_identification(monkeypatch):
    _, out = _execute(NOTEBOOKS[2], monkeypatch)
    res = out["results"]
    assert abs(res["belt.E"]["error_pct"]) < 2 and abs(res["contact.mu"]["error_pct"]) < 2, res
    assert abs(res["belt.eta"]["error_pct"]) < 10, res


@pytest.mark.slow
def test_04_sweeps(monkeypatch):
    _, out = _execute(NOTEBOOKS[3], monkeypatch)
    assert out["max_creep_speed_loss_error"] < 0.1, out
    for mu, o in out["onset"].items():
        # the simulated onset of gross slip is bracketed by the grid around creep theory's limit load
        lo = -1.0 if o["sim_last_creep"] is None else o["sim_last_creep"]
        hi = out["max_load"] if o["sim_first_gross"] is None else o["sim_first_gross"]
        assert lo - 5.0 < o["theory"] < hi + 5.0, (mu, o)
