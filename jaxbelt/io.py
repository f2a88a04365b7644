"""Result files: ``summary.json``, ``signals.csv``, ``result.npz`` (and reading them back).

Every file is written atomically: the data goes to a temporary file in the target directory,
which then replaces the target with ``os.replace``. An interrupted run leaves either the previous
file or the new one, never half of one. A result file never replaces an input: passing the
configuration (or a measured-data file) as ``inputs`` makes a write onto it an error.

Layouts
-------
``summary.json``
    The dictionary of ``jaxbelt.summary`` (``pulleys``, ``spans``, ``status``, ``warnings``,
    ``num_steps``, ``wall_time_s``, ``compile_time_s``, ``creep_theory`` for two-pulley drives,
    ...), plus whatever the caller adds. Non-finite numbers are written as ``null``.
``signals.csv``
    Header line, then one row per saved time: column ``t`` [s] then the signals in the order of
    ``RunResult.signals``: ``omega:<pulley>`` [rad/s], ``torque:<pulley>`` [N m],
    ``tension:<from>-<to>`` [N], per carrier in pulley order ``arm_angle:<tensioner>`` [rad]
    (``travel:<slider>`` [m]) with, for pivot friction or stops, ``pivot_friction:<tensioner>`` [N m]
    and ``stop_torque:<tensioner>`` [N m] (``guide_friction:<slider>`` [N], ``stop_force:<slider>`` [N]),
    and for a one-way clutch pulley ``rotor_omega:<pulley>`` [rad/s] and ``clutch_torque:<pulley>`` [N m],
    then the accessory-drive signals (docs/outputs.md): ``slip:<pulley>`` [%], ``friction_use:<pulley>`` [1],
    ``hub_load:<pulley>`` [N], ``hub_direction:<pulley>`` [deg], ``speed:<from>-<to>`` [m/s],
    ``deflection:<from>-<to>`` [m].
    Names, order and units are those of the signal registry (``jaxbelt.outputs.signals``:
    ``signal_names``, ``signal_units``); no unit row, so that a measured file is the same layout.
``result.npz``
    ``t`` (saved times), ``state/<field>`` for every field of ``DriveState`` stacked over the saved
    times (``state/q``: ``(T, n, 2, 2)`` nodal positions and slopes, ``state/omega``: ``(T, p)``, ...),
    ``pulley_names``, ``span_names``, ``pulley_centers``, ``pulley_radii`` (belt axis),
    what ``viz.plot_belt`` draws a loaded result from (``pulley_roles``, ``pulley_surface_radii``,
    ``pulley_pivots``, ``pulley_wrap_side``, ``pulley_center_history`` ``(T, p, 2)``, ``path_orientation``,
    ``span_tags``, ``spans_in_travel_order``, ``belt_direction``),
    and for each pulley ``contact/<pulley>/<key>`` with the final contact distribution
    (``angle_deg``, ``pressure`` [N/m], ``friction`` [N/m], ``state`` 0 free / 1 stick / 2 slip,
    and the scalars ``stick_arc_deg``, ``slip_arc_deg``, ``contact_arc_deg``, ``wrap_deg``).
"""

from __future__ import annotations

import contextlib
import csv
import dataclasses
import io as _io
import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from ._errors import DataError as DataError  # its home is _errors; jaxbelt.io.DataError stays importable

__all__ = [
    "DataError",
    "atomic_write",
    "write_summary",
    "write_signals_csv",
    "write_result_npz",
    "read_signals_csv",
    "read_summary",
    "load_result",
    "csv_number",
    "write_run_outputs",
    "to_jsonable",
    "write_checkpoint",
    "read_checkpoint",
]


# --------------------------------------------------------------------------- atomic writes
def _check_not_input(path: Path, inputs: Iterable) -> None:
    for src in inputs or ():
        if src is None:
            continue
        src = Path(src)
        same = False
        if path.exists() and src.exists():
            same = os.path.samefile(path, src)
        else:
            same = path.resolve() == src.resolve()
        if same:
            raise FileExistsError(
                f"refusing to overwrite the input file {src} with a result; choose another output directory (--out)"
            )


# The file that marks a directory as a command's output directory (``cli.common.claim_out_dir``): a command writes,
# replaces and removes its own files only in a new or empty directory or in one holding this mark.
OUTPUT_MARK = ".jaxbelt-output"
_CLAIMED: set[Path] = set()  # output directories a command of this process claimed: marked by their first write


def claim_directory(directory) -> None:
    """Mark ``directory`` as this command's output directory once a result is written into it (not before: a
    command refused later leaves no directory behind)."""
    _CLAIMED.add(Path(directory).absolute())


def _mark(directory: Path) -> None:
    if directory.absolute() in _CLAIMED and not (directory / OUTPUT_MARK).exists():
        (directory / OUTPUT_MARK).write_text("written by jaxbelt: its commands may replace their own files here\n")


@contextlib.contextmanager
def atomic_write(path, mode: str = "wb", inputs: Iterable = ()):
    """Context manager yielding a file object; on success the file replaces ``path`` atomically,
    on an exception (or Ctrl-C) the temporary file is removed and ``path`` is left untouched."""
    path = Path(path)
    _check_not_input(path, inputs)
    path.parent.mkdir(parents=True, exist_ok=True)
    _mark(path.parent)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; results are ordinary files
        encoding, newline = (None, None) if "b" in mode else ("utf-8", "")
        with os.fdopen(fd, mode, encoding=encoding, newline=newline) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def to_jsonable(obj):
    """Plain-JSON form: numpy/JAX scalars and arrays to numbers and lists, non-finite to None."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return to_jsonable(dataclasses.asdict(obj))
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        x = float(obj)
        return x if math.isfinite(x) else None
    if isinstance(obj, str) or obj is None:
        return obj
    if hasattr(obj, "shape") and hasattr(obj, "dtype"):  # numpy / jax arrays
        arr = np.asarray(obj)
        return to_jsonable(arr.item() if arr.ndim == 0 else arr.tolist())
    return str(obj)


def write_summary(path, summary: dict, inputs: Iterable = ()) -> Path:
    text = json.dumps(to_jsonable(summary), indent=2, allow_nan=False) + "\n"
    with atomic_write(path, "w", inputs) as fh:
        fh.write(text)
    return Path(path)


def csv_number(x) -> str:
    """A float as a CSV field: 15 significant digits, the shortest text of the intended value (0.1 + 0.2
    is written 0.3, not 0.30000000000000004, the artefact of its last binary digit)."""
    return format(float(x), ".15g")


def write_signals_csv(path, signals: dict, inputs: Iterable = ()) -> Path:
    """Column ``t`` first, then the other signals in their dictionary order."""
    if "t" not in signals:
        raise ValueError("signals need a time column 't'")
    names = ["t"] + [k for k in signals if k != "t"]
    cols = [np.asarray(signals[k], dtype=float).ravel() for k in names]
    n = cols[0].size
    bad = [k for k, c in zip(names, cols) if c.size != n]
    if bad:
        raise ValueError(f"signals {bad} do not have one value per saved time ({n})")
    table = np.column_stack(cols) if n else np.zeros((0, len(names)))
    buf = _io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow(names)
    np.savetxt(buf, table, delimiter=",", fmt="%.12g")
    with atomic_write(path, "w", inputs) as fh:
        fh.write(buf.getvalue())
    return Path(path)


def write_result_npz(path, result, contact: dict | None = None, inputs: Iterable = ()) -> Path:
    """Saved states, names, geometry and the final contact distribution of a ``RunResult``."""
    from .outputs.signals import span_names

    traj, drive = result.trajectory, result.drive
    arrays: dict[str, Any] = {"t": np.asarray(traj.ts)}  # Any: numpy's stub checks **arrays against allow_pickle
    states = traj.states
    for f in dataclasses.fields(states) if dataclasses.is_dataclass(states) else ():
        value = getattr(states, f.name)  # work terms (a Module): one array each, state/work/<term>
        if value is None:  # an optional part the drive does not have (constraints of clutches, stops)
            continue
        parts = (
            {f"/{g.name}": getattr(value, g.name) for g in dataclasses.fields(value)}
            if dataclasses.is_dataclass(value)
            else {"": value}
        )
        for suffix, x in parts.items():
            if x is not None:
                arrays[f"state/{f.name}{suffix}"] = np.asarray(x)
    names = list(drive.model.pulley_names)
    arrays["pulley_names"] = np.asarray(names, dtype=str)
    arrays["span_names"] = np.asarray([f"{a}-{b}" for a, b in span_names(drive)], dtype=str)
    arrays["pulley_radii"] = np.asarray(drive.params.pulleys.radius)
    arrays["pulley_centers"] = np.asarray([p.center for p in drive.pulleys], dtype=float)
    arrays["stress_free_length"] = np.asarray(drive.params.belt.stress_free_length)
    arrays.update(_drawing(drive, states, (getattr(result, "summary", None) or {}).get("belt")))
    for name, d in (contact or {}).items():
        for key, value in d.items():
            arrays[f"contact/{name}/{key}"] = np.asarray(value)
    with atomic_write(path, "wb", inputs) as fh:
        write_npz(fh, arrays)
    return Path(path)


def _drawing(drive, states, belt: dict | None = None) -> dict[str, np.ndarray]:
    """What ``viz.plot_belt`` needs to draw a loaded result without its drive: pulley roles, surface radii,
    arm pivots (NaN: none), wrap sides, every saved state's pulley centres (tensioners moved), the path's
    orientation, the spans' tight/slack tags (``belt``: a run summary's, decided by its tensions; else the
    driver's) and sense of travel."""
    from .outputs.signals import span_names
    from .outputs.summary import belt_direction
    from .pulleys.carrier import carrier_centers

    info = {**belt_direction(drive), **(belt or {})}
    spans = [f"{a}-{b}" for a, b in span_names(drive)]
    centers, _ = carrier_centers(drive.model, drive.params.pulleys, np.asarray(states.psi))
    return {
        "pulley_roles": np.asarray([p.role for p in drive.pulleys], dtype=str),
        "pulley_surface_radii": np.asarray([p.radius for p in drive.pulleys], dtype=float),
        "pulley_pivots": np.asarray([p.pivot or (np.nan, np.nan) for p in drive.pulleys], dtype=float),
        "pulley_wrap_side": np.asarray(drive.path.wrap_side, dtype=int),
        "pulley_center_history": np.asarray(centers, dtype=float),
        "path_orientation": np.asarray(int(round(float(drive.path.orientation)))),
        "span_tags": np.asarray(
            ["tight" if n == info["tight_span"] else "slack" if n == info["slack_span"] else "" for n in spans],
            dtype=str,
        ),
        "spans_in_travel_order": np.asarray(bool(info["spans_in_travel_order"])),
        "belt_direction": np.asarray(info["direction"]),
    }


def write_npz(fh, arrays: dict) -> None:
    """``arrays`` as an uncompressed ``.npz`` into the open binary file ``fh``. Not compressed: float64
    states compress by only ~30 %, and compressing Benchmark A's 2.45 s result took 0.35 s of a 5 s run
    (writing it uncompressed: 0.02 s)."""
    np.savez(fh, **arrays)


def write_run_outputs(
    result, out_dir, *, contact: dict | None = None, extra_summary: dict | None = None, inputs: Iterable = ()
) -> dict[str, Path]:
    """``signals.csv``, ``result.npz`` and ``summary.json`` of a ``RunResult`` into ``out_dir``.

    The raw results come first: a final contact distribution that cannot be computed is left out
    of ``result.npz`` and recorded in the summary's ``warnings`` instead of losing the run.
    """
    from .outputs.contact import contact_distribution
    from .outputs.summary import guarded

    out = Path(out_dir)
    summ = dict(result.summary)
    summ.update(extra_summary or {})
    summ["warnings"] = list(summ.get("warnings", []))
    if contact is None:
        import jax

        last = jax.tree.map(lambda x: x[-1], result.trajectory.states)
        contact = guarded(
            summ["warnings"], "final contact distribution", lambda: contact_distribution(result.drive, last)
        )
    return {
        "signals": write_signals_csv(out / "signals.csv", result.signals, inputs),
        "result": write_result_npz(out / "result.npz", result, contact, inputs),
        "summary": write_summary(out / "summary.json", summ, inputs),
    }


def write_checkpoint(path, arrays: dict, meta: dict, inputs: Iterable = ()) -> Path:
    """A checkpoint of a run: ``arrays`` (``RunProgress.arrays``) and ``meta`` (JSON: configuration
    hash, ...) in one uncompressed npz, written atomically (a killed write leaves the previous one)."""
    data = {**arrays, "meta": np.asarray(json.dumps(to_jsonable(meta)))}
    with atomic_write(path, "wb", inputs) as fh:
        np.savez(fh, **data)
    return Path(path)


def read_checkpoint(path) -> tuple[dict, dict]:
    """``(arrays, meta)`` of a checkpoint file; ``DataError`` if it is not one."""
    import zipfile

    if Path(path).is_file() and not zipfile.is_zipfile(path):  # np.load would offer to unpickle it
        raise DataError(
            f"{path}: not a readable jaxbelt checkpoint (not an .npz archive: damaged or another program's file); "
            "remove it and run again without --resume"
        )
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        meta = json.loads(str(arrays.pop("meta")))
    except (OSError, ValueError, KeyError) as error:
        raise DataError(f"{path}: not a readable jaxbelt checkpoint ({error})") from None
    return arrays, meta


# --------------------------------------------------------------------------- reading
def read_summary(path) -> dict:
    with open(path, encoding="utf-8") as fh:
        return json.load(fh)


def load_result(path) -> dict:
    """``result.npz`` as a dict of arrays (``contact`` grouped by pulley)."""
    with np.load(path, allow_pickle=False) as z:
        out = {k: z[k] for k in z.files}
    contact: dict = {}
    for key in [k for k in out if k.startswith("contact/")]:
        _, name, field = key.split("/", 2)
        v = out.pop(key)
        contact.setdefault(name, {})[field] = v.item() if v.ndim == 0 else v
    out["contact"] = contact
    return out


def read_signals_csv(path, required: Iterable[str] = ()) -> dict[str, np.ndarray]:
    """Read a file in the ``signals.csv`` layout (e.g. measurements for identification).

    Checks: a header with a ``t`` column first and unique names, numbers only, the same number of
    fields on every row, at least two rows, strictly increasing ``t``, and the ``required``
    columns. Empty fields and ``nan`` are allowed (missing samples). Raises ``DataError`` naming
    the file, line and column; ``FileNotFoundError`` if it does not exist.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError:
        raise DataError(f"{path}: not a UTF-8 text (CSV) file") from None
    rows = [(i + 1, r) for i, r in enumerate(csv.reader(_io.StringIO(text))) if r and any(c.strip() for c in r)]
    if not rows:
        raise DataError(f"{path}: empty file (expected a header line 't,<signal>,...' and data rows)")
    header = [h.strip() for h in rows[0][1]]
    if header[0] != "t":
        hint = " (columns separated by ';': separate them by ',')" if len(header) == 1 and ";" in header[0] else ""
        raise DataError(f"{path}: line 1: the first column must be 't' (time in s), got '{header[0]}'{hint}")
    dup = sorted({h for h in header if header.count(h) > 1})
    if dup:
        raise DataError(f"{path}: line 1: duplicate column names {dup}")
    if any(not h for h in header):
        raise DataError(f"{path}: line 1: empty column name in the header")
    data = []
    for lineno, r in rows[1:]:
        if len(r) != len(header):
            raise DataError(f"{path}: line {lineno}: {len(r)} fields, the header has {len(header)}")
        vals = []
        for j, c in enumerate(r):
            c = c.strip()
            try:
                vals.append(float(c) if c else math.nan)
            except ValueError:
                raise DataError(f"{path}: line {lineno}, column '{header[j]}': '{c}' is not a number") from None
        data.append(vals)
    if len(data) < 2:
        raise DataError(f"{path}: needs at least two data rows, found {len(data)}")
    arr = np.asarray(data, dtype=float)
    t = arr[:, 0]
    if not np.all(np.isfinite(t)):
        raise DataError(f"{path}: column 't' has missing or non-finite times")
    if np.any(np.diff(t) <= 0):
        k = int(np.argmax(np.diff(t) <= 0))
        raise DataError(f"{path}: column 't' must increase strictly (rows {k + 1} and {k + 2}: {t[k]:g}, {t[k + 1]:g})")
    missing = [c for c in required if c not in header]
    if missing:
        raise DataError(f"{path}: missing column(s) {missing}; present: {header[1:]}")
    return {h: arr[:, j] for j, h in enumerate(header)}
