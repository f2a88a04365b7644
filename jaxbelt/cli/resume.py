"""Checkpoints of ``jaxbelt run`` and ``--resume DIR``.

Between chunks of the simulation the command writes ``DIR/checkpoint.npz`` (atomically: a kill leaves
the previous checkpoint whole): the state, the step reached, the saves so far, and a hash of the
effective configuration, the jaxbelt version and the layout of the drive's state. ``jaxbelt run --resume DIR``
reads it, refuses (exit 2, with advice) when the configuration's hash, the version or the state's layout
differ, and continues from there; the chunks are deterministic, so the finished run equals an
uninterrupted one. The checkpoint is removed once the results are written.
"""

from __future__ import annotations

import hashlib
import time
from pathlib import Path
from typing import NamedTuple

from .common import UsageError

__all__ = ["CHECKPOINT", "Checkpointer", "Stored", "check_layout", "config_hash", "prepare_resume", "read_resume"]

CHECKPOINT = "checkpoint.npz"
_START_AGAIN = "run without --resume to start again (the checkpoint is overwritten)"


def state_layout(state) -> str:
    """The layout of a drive's state: its tree (fields, kinds) and each leaf's shape and dtype."""
    import jax
    import numpy as np

    leaves, treedef = jax.tree.flatten(state)
    return hashlib.sha256(
        (str(treedef) + repr([(np.shape(x), str(np.asarray(x).dtype)) for x in leaves])).encode()
    ).hexdigest()


def config_hash(spec, cfg: Path) -> str:
    """sha256 of the effective configuration (``--t-end`` applied); the file's bytes for a law without a
    TOML form."""
    from ..config.toml import dump_toml

    try:
        text = dump_toml(spec).encode()
    except (TypeError, ValueError):
        text = cfg.read_bytes() + repr(float(spec.solver.t_end)).encode()
    return hashlib.sha256(text).hexdigest()


def prepare_resume(args) -> None:
    """``--resume DIR``: the output directory is DIR; configuration and ``--t-end`` default to the
    checkpoint's."""
    ckpt = Path(args.resume) / CHECKPOINT
    if not ckpt.is_file():
        raise UsageError(f"--resume {args.resume}: no checkpoint there ({ckpt} does not exist)")
    if args.out is not None and Path(args.out).resolve() != Path(args.resume).resolve():
        raise UsageError(f"--out {args.out} with --resume {args.resume}: a resumed run writes into its own directory")
    args.out = args.resume
    _, meta = _read(ckpt)
    if args.config is None:
        if not isinstance(meta.get("config"), str):
            raise UsageError(
                f"--resume {args.resume}: the checkpoint does not name its configuration (written by another "
                f"jaxbelt version, {meta.get('jaxbelt_version', 'unknown')}): {_START_AGAIN}"
            )
        args.config = meta["config"]
    if args.t_end is None:
        args.t_end = meta.get("t_end_option")


def _read(path: Path):
    from ..io import read_checkpoint

    return read_checkpoint(path)


class Stored(NamedTuple):
    """A checkpoint read for ``--resume``: its arrays (``RunProgress.arrays``) and its state's layout."""

    arrays: dict
    layout: str | None  # None: not recorded (the arrays' names and shapes are still checked)
    where: Path


def read_resume(out_dir: Path, spec, cfg: Path) -> Stored:
    """The checkpoint, after checking that it was written for this configuration by this version."""
    from .. import __version__

    from .._export import _source_hash

    arrays, meta = _read(out_dir / CHECKPOINT)
    written_by = meta.get("jaxbelt_version")
    if written_by == __version__ and meta.get("jaxbelt_source", _source_hash()) != _source_hash():
        raise UsageError(  # the same version number, other code (a development checkout changed in between)
            f"--resume {out_dir}: the checkpoint was written by other jaxbelt code (version {__version__}, its "
            f"sources since changed): {_START_AGAIN}"
        )
    if written_by != __version__:  # the chunks repeat a run bit for bit only with the same code
        raise UsageError(
            f"--resume {out_dir}: the checkpoint was written by jaxbelt {written_by or '(an older version)'}, "
            f"this is jaxbelt {__version__}: {_START_AGAIN}"
            + (f", or resume with jaxbelt {written_by}" if written_by else "")
        )
    if meta.get("config_hash") != config_hash(spec, cfg):
        raise UsageError(
            f"--resume {out_dir}: the configuration changed since the checkpoint was written (a key of "
            f"{meta.get('config')} or the run's length differs; now {cfg}, t_end {spec.solver.t_end:g} s); "
            "run without --resume to start again"
        )
    return Stored(arrays, meta.get("layout"), out_dir)


def check_layout(stored: Stored, drive) -> None:
    """Refuse (exit 2) a checkpoint whose stored state does not have this drive's layout (written by
    another build of jaxbelt whose state has other fields or shapes) before anything is compiled."""
    import jax
    import numpy as np

    arrays, leaves = stored.arrays, jax.tree.leaves(drive.state0)
    names = {"k", "n_saved", "fault"} | {f"{p}/{i}" for p in ("state", "saved") for i in range(len(leaves))}
    fits = set(arrays) == names and stored.layout in (None, state_layout(drive.state0))
    fits = fits and all(
        np.shape(arrays[f"state/{i}"]) == np.shape(x) and np.shape(arrays[f"saved/{i}"])[1:] == np.shape(x)
        for i, x in enumerate(leaves)
    )
    if not fits:
        raise UsageError(
            f"--resume {stored.where}: the checkpoint's state does not fit this drive (written by another jaxbelt "
            f"build, whose state has another layout): {_START_AGAIN}"
        )


class Checkpointer:
    """``on_chunk`` callback of ``run``: writes the checkpoint at most every ``every_s`` seconds, and on Ctrl-C."""

    def __init__(self, path: Path, meta: dict, every_s: float, inputs=()):
        from .. import __version__

        from .._export import _source_hash

        meta = {**meta, "jaxbelt_version": __version__, "jaxbelt_source": _source_hash()}
        self.path, self.meta, self.every_s, self.inputs = path, meta, every_s, list(inputs)
        self.last = time.monotonic()
        self.k_written = -1

    def __call__(self, chunked, progress, interrupted: bool) -> None:
        if chunked.done(progress) or progress.k == self.k_written:
            return  # the results follow at once; or nothing new
        if interrupted or time.monotonic() - self.last >= self.every_s:
            from ..io import write_checkpoint

            meta = {
                **self.meta,
                "step": progress.k * chunked.schedule.substeps,
                "n_macro": chunked.n_macro,
                "layout": state_layout(chunked.state0),
            }
            write_checkpoint(self.path, progress.arrays, meta, inputs=self.inputs)
            self.last, self.k_written = time.monotonic(), progress.k

    def remove(self) -> None:
        self.path.unlink(missing_ok=True)
