"""A sweep's result directory, written chunk by chunk so that a killed sweep can be resumed.

Files (every write atomic: a temporary file renamed over the target, see ``jaxbelt.io.atomic_write``):

``sweep_manifest.json``
    What the sweep is: keys, points, the configuration's hash, time step, chunk size, figures' names.
    A resume with anything different is refused (the files would mix two studies).
``sweep.csv``
    Header (varied keys, then the figures), one row per finished point in point order. Rewritten
    whole after each chunk, so that it always holds complete rows of finished chunks only.
``sweep_signals/chunk_NNNNNN.npz``
    Per chunk: ``point`` (indices) and ``t``, and each signal's histories ``(points, saves)``.
``sweep_signals.npz``
    When the sweep is complete: the chunks joined (``point``, ``t``, every signal ``(N, saves)``); the chunk
    files are removed after it is written.

Finished points are always a prefix of the point list (chunks run in order and are written in
order), so a resume starts at the first row missing from ``sweep.csv``.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from .._errors import ConfigError
from ..io import _check_not_input, atomic_write, csv_number

__all__ = ["SweepStore", "MANIFEST", "CSV", "SIGNALS"]

MANIFEST, CSV, SIGNALS, CHUNKS = "sweep_manifest.json", "sweep.csv", "sweep_signals.npz", "sweep_signals"


def _fingerprint(manifest: dict) -> str:
    text = json.dumps({k: v for k, v in manifest.items() if k != "fingerprint"}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def format_row(values) -> str:
    """One CSV row (``csv_number``: 15 significant digits). A resumed sweep reads its finished rows back
    as written, so its file equals an uninterrupted sweep's byte for byte."""
    return ",".join(csv_number(x) for x in values)


def _as_written(values) -> np.ndarray:
    """Numbers as a CSV row holds them (rounded to 15 significant digits): a point read back from
    ``sweep.csv`` is compared with the manifest's point in this form (rows of ``repr`` text too)."""
    return np.array([float(csv_number(x)) for x in values])


class SweepStore:
    """The result directory of one sweep (see the module docstring for its files)."""

    def __init__(self, directory, manifest: dict, *, resume: bool, inputs=()):
        from .. import __version__
        from .._export import _source_hash

        self.dir = Path(directory)
        self.inputs = list(inputs)
        # the code that computed the rows: resumed by other code, old and new rows would not match (an audit's
        # resume across an update mixed 25- and 27-column rows in one sweep.csv)
        manifest = dict(manifest, jaxbelt=f"{__version__} {_source_hash()[:16]}")
        manifest = dict(manifest, fingerprint=_fingerprint(manifest))
        self.manifest = manifest
        for name in (MANIFEST, CSV, SIGNALS):  # before anything there is removed: an input is never a result
            _check_not_input(self.dir / name, self.inputs)
        old = self._read_manifest()
        if old is not None and not resume:
            done, total = self._count_rows(), len(old.get("points", []))
            if done < total:
                raise ConfigError(
                    f"sweep: {self.dir} holds an unfinished sweep ({done} of {total} points done); "
                    "resume it (--resume, resume=True) or choose another output directory"
                )
            for name in (CSV, SIGNALS):  # a finished sweep there is replaced, as a rerun of `run` replaces its files
                (self.dir / name).unlink(missing_ok=True)
            old = None
        if old is None:
            if (self.dir / CSV).exists():  # results of an older jaxbelt or of a sweep whose manifest was lost
                if resume:
                    raise ConfigError(f"sweep --resume {self.dir}: no {MANIFEST} there, so nothing to resume")
                (self.dir / CSV).unlink()
            self.dir.mkdir(parents=True, exist_ok=True)
            with atomic_write(self.dir / MANIFEST, "w", inputs=self.inputs) as fh:
                json.dump(manifest, fh, indent=1)
            self.header: list[str] | None = None
            self.rows: list[str] = []
            return
        if old.get("fingerprint") != manifest["fingerprint"]:
            changed = sorted(k for k in manifest if k != "fingerprint" and old.get(k) != manifest[k])
            raise ConfigError(
                f"sweep --resume {self.dir}: the sweep there differs from this one ({', '.join(changed) or 'format'} "
                "changed); run it into another output directory"
            )
        self.header, self.rows = self._read_csv()

    def _read_manifest(self) -> dict | None:
        path = self.dir / MANIFEST
        if not path.exists():
            return None
        try:
            return json.loads(path.read_text())
        except (OSError, ValueError) as err:
            raise ConfigError(
                f"sweep: {path} is not a readable manifest ({err}); remove it or choose another output directory"
            ) from None

    def _count_rows(self) -> int:
        path = self.dir / CSV
        return max(len(path.read_text().splitlines()) - 1, 0) if path.exists() else 0

    def _read_csv(self):
        path = self.dir / CSV
        if not path.exists():
            return None, []
        lines = path.read_text().splitlines()
        if not lines:
            return None, []
        header, rows = lines[0].split(","), lines[1:]
        points = np.asarray(self.manifest["points"], dtype=float)
        k = len(self.manifest["keys"])
        for i, row in enumerate(rows):  # the rows must be this sweep's points, in order
            if i >= len(points) or not np.array_equal(_as_written(row.split(",")[:k]), _as_written(points[i])):
                raise ConfigError(f"sweep --resume {self.dir}: row {i + 1} of {CSV} is not point {i + 1} of this sweep")
        return header, rows

    @property
    def done(self) -> int:
        """Number of finished points (a prefix of the point list)."""
        return len(self.rows)

    def append(self, first: int, header: list[str], rows: np.ndarray, signals: dict | None, t) -> None:
        """Record the finished points ``first, first + 1, ...``: their signals first, then the CSV (whose
        rows say which points are done), each atomically."""
        if first != self.done:
            raise RuntimeError(f"sweep store: chunk starts at point {first}, but {self.done} points are done")
        if signals is not None:
            (self.dir / CHUNKS).mkdir(exist_ok=True)
            with atomic_write(self.dir / CHUNKS / f"chunk_{first:06d}.npz", "wb", inputs=self.inputs) as fh:
                np.savez(fh, point=np.arange(first, first + len(rows)), t=np.asarray(t), **signals)
        self.header = header
        self.rows = self.rows + [format_row(r) for r in rows]
        with atomic_write(self.dir / CSV, "w", inputs=self.inputs) as fh:
            fh.write(",".join(header) + "\n" + "".join(r + "\n" for r in self.rows))

    def table(self) -> np.ndarray:
        return np.array([r.split(",") for r in self.rows], dtype=float).reshape(len(self.rows), -1)

    def finish(self) -> Path | None:
        """Join the chunks' signals into ``sweep_signals.npz`` (then drop the chunk files)."""
        chunk_dir = self.dir / CHUNKS
        files = sorted(chunk_dir.glob("chunk_*.npz")) if chunk_dir.exists() else []
        if not files:
            return None
        parts = [dict(np.load(f)) for f in files]
        joined = {k: np.concatenate([p[k] for p in parts]) for k in parts[0] if k != "t"}
        if not np.array_equal(joined["point"], np.arange(len(joined["point"]))):
            raise RuntimeError(f"sweep store: the chunks in {chunk_dir} do not cover the points in order")
        with atomic_write(self.dir / SIGNALS, "wb", inputs=self.inputs) as fh:
            np.savez(fh, **{"t": parts[0]["t"], **joined})
        for f in files:
            f.unlink()
        # a sweep killed while it wrote a chunk leaves that write's temporary file (never renamed, so never
        # data: the chunk was run again on resume); without removing it the directory is not empty
        for f in chunk_dir.glob(".chunk_*.tmp"):
            f.unlink()
        chunk_dir.rmdir()
        return self.dir / SIGNALS
