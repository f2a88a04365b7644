"""What the commands share: exit codes, one-line errors, input and output checks, loading a
configuration with the command-line overrides, and number formatting."""

from __future__ import annotations

import functools
import math
import os
import sys
from pathlib import Path

__all__ = [
    "status_kind",
    "EXIT_OK",
    "EXIT_FAILED",
    "EXIT_USAGE",
    "EXIT_INTERRUPTED",
    "UsageError",
    "one_line",
    "err",
    "show_warning",
    "check_input_file",
    "check_out_dir",
    "with_config_context",
    "load_spec",
    "output_dir",
    "start_processes",
    "fmt",
]

EXIT_OK, EXIT_FAILED, EXIT_USAGE, EXIT_INTERRUPTED = 0, 1, 2, 130


class UsageError(Exception):
    """Bad input detected by the CLI itself; printed as one line, exit code 2."""


def one_line(msg) -> str:
    return " ".join(str(msg).split())


def err(prog: str, msg) -> None:
    print(f"{prog}: error: {one_line(msg)}", file=sys.stderr, flush=True)


# The warnings this process has printed: a summary's warnings (a build's polygon-effect warning among them) are
# printed at the end of a command, each warning once (docs/config.md: "printed once per process").
_SHOWN: set[str] = set()


def show_warning(message, category, filename, lineno, file=None, line=None):
    print_warning(str(message))


def forget_warnings() -> None:
    """A new command (``cli.main``): none of its warnings printed yet."""
    _SHOWN.clear()


def print_warning(message: str) -> None:
    """``jaxbelt: warning: ...`` on stderr, unless this process printed the same warning before."""
    text = one_line(message)
    if text not in _SHOWN:
        _SHOWN.add(text)
        print(f"jaxbelt: warning: {text}", file=sys.stderr, flush=True)


def check_input_file(path: str, what: str = "configuration file") -> Path:
    p = Path(path)
    if not p.exists():
        raise UsageError(f"{path}: no such {what}")
    if p.is_dir():
        raise UsageError(f"{path}: is a directory, expected a {what}")
    if not os.access(p, os.R_OK):
        raise UsageError(f"{path}: permission denied")
    return p


def check_out_dir(out_dir: Path) -> None:
    """The output directory (or the nearest existing folder it would be made in) must accept files:
    probed by writing one, which also tells the truth for root and read-only file systems."""
    import tempfile

    if out_dir.exists() and not out_dir.is_dir():
        raise UsageError(f"--out {out_dir}: exists and is not a directory")
    base = out_dir
    while not base.exists():
        if base.is_symlink():
            raise UsageError(f"--out {out_dir}: {base} is a broken link")
        base = base.parent
    if not base.is_dir():
        raise UsageError(f"--out {out_dir}: {base} is a file, not a directory; choose another output directory")
    try:
        fd, probe = tempfile.mkstemp(prefix=".jaxbelt-probe-", dir=base)
        os.close(fd)
        os.unlink(probe)
    except OSError as error:
        where = "" if base == out_dir else f" (it would be created in {base})"
        raise UsageError(
            f"--out {out_dir}: cannot write there{where}: {error.strerror or error}; choose another output directory"
        ) from None


def with_config_context(fn):
    """``fn(args, cfg)`` for a command: the configuration file checked first, and a configuration
    error names the file it is in."""

    @functools.wraps(fn)
    def wrapped(args):
        cfg = check_input_file(args.config)
        from .._errors import ConfigError

        try:
            return fn(args, cfg)
        except ConfigError as error:
            msg = str(error)
            raise ConfigError(msg if msg.startswith(str(cfg)) else f"{cfg}: {msg}") from None

    return wrapped


def load_spec(cfg: Path, t_end: float | None, scheme: str | None = None):
    """The configuration file's DriveSpec with ``--t-end`` and ``--scheme`` applied."""
    from ..config.toml import load_config

    spec = load_config(cfg)
    if t_end is not None:
        spec.solver.t_end = t_end
    if scheme is not None:
        spec.solver.scheme = scheme
        if scheme != "implicit":  # implicit_stiffness is the implicit scheme's old name: the flag wins
            spec.solver.implicit_stiffness = False
    return spec


def claim_out_dir(out_dir: Path) -> None:
    """Refuse ``out_dir`` when it holds files and no mark of jaxbelt's (they may be the user's, and a command
    replaces and removes files in its output directory); else claim it: the command's first result written there
    marks it (``io.OUTPUT_MARK``)."""
    from ..io import OUTPUT_MARK, claim_directory

    if out_dir.is_dir() and not (out_dir / OUTPUT_MARK).exists():
        theirs = sorted(p.name for p in out_dir.iterdir())
        if theirs:
            shown = ", ".join(theirs[:4]) + (f" and {len(theirs) - 4} more" if len(theirs) > 4 else "")
            raise UsageError(
                f"--out {out_dir}: holds files jaxbelt did not write there ({shown}); it writes into a new or empty "
                f"directory, or one it wrote before (marked by {OUTPUT_MARK}): choose another --out"
            )
    claim_directory(out_dir)


def output_dir(args, cfg: Path, suffix: str = "", results=(), check: bool = True) -> Path:
    """``--out``, or ``out/<config name><suffix>``; with ``check`` refused (before anything is computed)
    when it cannot be written, when it holds files jaxbelt did not write (``claim_out_dir``; else claimed: the
    command's first result there marks it) or when one of the ``results`` (file names) written there would replace
    the configuration file."""
    out_dir = Path(args.out) if args.out else Path("out") / f"{cfg.stem}{suffix}"
    if check:
        from ..io import _check_not_input

        check_out_dir(out_dir)
        for name in results:
            _check_not_input(out_dir / name, [cfg])
        if getattr(args, "resume", None) in (None, False):  # resumed work is in a directory jaxbelt wrote
            claim_out_dir(out_dir)
        else:
            from ..io import claim_directory

            claim_directory(out_dir)
    return out_dir


def start_processes(args):
    """Join the processes of a multi-process ``sweep`` or ``identify`` (before JAX starts its backend):
    ``--coordinator``, ``--num-processes`` and ``--process-id`` together, or ``--distributed`` (the
    cluster's description); neither: one process. Returns this process's group (process 0 writes)."""
    from ..analysis.distributed import initialize, process_group

    explicit = (args.coordinator, args.num_processes, args.process_id)
    if args.distributed or any(x is not None for x in explicit):
        if args.distributed and any(x is not None for x in explicit):
            raise UsageError(
                "give either --distributed (the cluster's own description) or --coordinator, "
                "--num-processes and --process-id, not both"
            )
        initialize(*explicit)
    return process_group()


def fmt(x, spec=".4g") -> str:
    try:
        x = float(x)
    except (TypeError, ValueError):
        return "-"
    return format(x, spec) if math.isfinite(x) else "nan"


def status_kind(status: str) -> str:
    """What a summary's ``status`` other than "ok" means, for the one-line message beside the exit code."""
    for prefix, what in (
        ("implausible", "result is implausible"),
        ("gross slip", "a pulley slips grossly (the figures are not a duty point)"),
        ("not steady", "the summary window is not a steady state"),
        ("contact solver not converged", "the contact solve did not converge (the figures are not reliable)"),
        ("energy balance not closed", "the energy balance does not close: the step did not resolve the motion"),
    ):
        if status.startswith(prefix):
            return what
    return "simulation did not finish cleanly"
