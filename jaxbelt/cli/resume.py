"""Checkpoints of ``jaxbelt run`` and ``--resume DIR``.

Between chunks of the simulation the command writes ``DIR/checkpoint.npz`` (atomically: a kill leaves
the previous checkpoint whole): the state, the step reached, the saves so far, and a hash of the
effective configuration. ``jaxbelt run --resume DIR`` reads it, refuses when the configuration's hash
differs, and continues from there; the chunks are deterministic, so the finished run equals an
uninterrupted one. The checkpoint is removed once the results are written.
"""

from __future__ import annotations

import hashlib
import time
from pathlib import Path

from .common import UsageError

__all__ = ["CHECKPOINT", "Checkpointer", "config_hash", "prepare_resume", "read_resume"]

CHECKPOINT = "checkpoint.npz"


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
        args.config = meta["config"]
    if args.t_end is None:
        args.t_end = meta.get("t_end_option")


def _read(path: Path):
    from ..io import read_checkpoint

    return read_checkpoint(path)


def read_resume(out_dir: Path, spec, cfg: Path) -> dict:
    """The checkpoint's arrays, after checking that it was written for this configuration."""
    arrays, meta = _read(out_dir / CHECKPOINT)
    if meta.get("config_hash") != config_hash(spec, cfg):
        raise UsageError(
            f"--resume {out_dir}: the configuration changed since the checkpoint was written "
            f"(checkpoint of {meta.get('config')}, t_end {meta.get('t_end')}; now {cfg}, t_end {spec.solver.t_end:g}); "
            "run without --resume to start again"
        )
    return arrays


class Checkpointer:
    """``on_chunk`` callback of ``run``: writes the checkpoint at most every ``every_s`` seconds, and on Ctrl-C."""

    def __init__(self, path: Path, meta: dict, every_s: float, inputs=()):
        self.path, self.meta, self.every_s, self.inputs = path, meta, every_s, list(inputs)
        self.last = time.monotonic()
        self.k_written = -1

    def __call__(self, chunked, progress, interrupted: bool) -> None:
        if chunked.done(progress) or progress.k == self.k_written:
            return  # the results follow at once; or nothing new
        if interrupted or time.monotonic() - self.last >= self.every_s:
            from ..io import write_checkpoint

            meta = {**self.meta, "step": progress.k * chunked.schedule.substeps, "n_macro": chunked.n_macro}
            write_checkpoint(self.path, progress.arrays, meta, inputs=self.inputs)
            self.last, self.k_written = time.monotonic(), progress.k

    def remove(self) -> None:
        self.path.unlink(missing_ok=True)
