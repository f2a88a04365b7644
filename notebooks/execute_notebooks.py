"""Execute notebooks in place so that they are committed with their outputs (plots render on the web).

    python notebooks/execute_notebooks.py [--quick] [notebooks/NN_name.ipynb ...]

Runs each notebook top to bottom in a fresh kernel (nbclient, kernel ``python3``) from ``notebooks/``, with
this checkout first on PYTHONPATH (so the kernel imports this checkout's jaxbelt, not an installed one),
writes the outputs back, and tidies the file: execution counts 1..n, consecutive prints merged into one
output, no per-cell timing metadata, no widget state. It then fails (exit status 1) if a cell wrote to stderr
or printed a path of this machine, so that what a reader sees on the web is clean.
``--quick`` sets JAXBELT_NOTEBOOK_QUICK=1 (reduced sizes).
"""

import argparse
import os
import re
import sys
import time
from pathlib import Path

import nbclient
import nbformat

HERE = Path(__file__).resolve().parent
# absolute paths a reader must not see (home directories, this machine's checkouts and temporary files)
LOCAL_PATH = re.compile(r"(/work/|/home/|/root/|/tmp/|/Users/|site-packages)")


def _problems(nb) -> list[str]:
    found = []
    for i, cell in enumerate(nb.cells):
        if cell.cell_type != "code":
            continue
        for out in cell.outputs:
            kind = out.get("output_type")
            if kind == "error":
                found.append(f"cell {i}: error {out.get('ename')}: {out.get('evalue')}")
            if kind == "stream" and out.get("name") == "stderr":
                found.append(f"cell {i}: stderr: {out.get('text', '')[:500]}")
            text = out.get("text", "") + "".join(
                v for k, v in out.get("data", {}).items() if k.startswith("text/") and isinstance(v, str)
            )
            if LOCAL_PATH.search(text):
                found.append(f"cell {i}: prints a local path: {LOCAL_PATH.search(text).group(0)}")
    return found


def tidy(nb) -> None:
    n = 0
    for cell in nb.cells:
        cell.metadata.pop("execution", None)
        if cell.cell_type != "code":
            continue
        n += 1
        cell.execution_count = n
        merged = []
        for out in cell.outputs:
            if "execution_count" in out:
                out["execution_count"] = n
            prev = merged[-1] if merged else None
            if (
                out.get("output_type") == "stream"
                and prev is not None
                and prev.get("output_type") == "stream"
                and prev.get("name") == out.get("name")
            ):
                prev["text"] += out["text"]  # flush=True prints arrive one output each
            else:
                merged.append(out)
        cell.outputs = merged
    nb.metadata.pop("widgets", None)


def execute(path: Path, timeout_s: int = 3600) -> list[str]:
    nb = nbformat.read(path, as_version=4)
    client = nbclient.NotebookClient(
        nb,
        timeout=timeout_s,
        kernel_name="python3",
        record_timing=False,
        allow_errors=True,
        resources={"metadata": {"path": str(HERE)}},
    )
    client.execute()
    tidy(nb)
    nbformat.validate(nb)
    nbformat.write(nb, path)
    return _problems(nb)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("notebooks", nargs="*", type=Path)
    ap.add_argument("--quick", action="store_true", help="reduced sizes (JAXBELT_NOTEBOOK_QUICK=1)")
    args = ap.parse_args()
    # the kernel process inherits the environment
    os.environ["PYTHONPATH"] = os.pathsep.join(p for p in [str(HERE.parent), os.environ.get("PYTHONPATH")] if p)
    if args.quick:
        os.environ["JAXBELT_NOTEBOOK_QUICK"] = "1"
    paths = args.notebooks or sorted(HERE.glob("*.ipynb"))
    failed = False
    for path in paths:
        t0 = time.perf_counter()
        problems = execute(path.resolve())
        print(f"{path.name}: {time.perf_counter() - t0:.0f} s, {path.stat().st_size / 1e3:.0f} kB", flush=True)
        for p in problems:
            print(f"  {p}")
        failed |= bool(problems)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
