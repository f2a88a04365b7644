"""Command line: ``jaxbelt run | sweep | identify | statics | duty | report | modes | runup | span-tension``
(also ``python -m jaxbelt``).

    jaxbelt run CONFIG.toml [--t-end T] [--out DIR] [--window F] [--animate] [--exaggerate X]
                            [--no-plots] [--quiet] [--no-cache] [--checkpoint-every S]
    jaxbelt run --resume DIR                    (continue a killed run from DIR/checkpoint.npz)

Exit codes: 0 success; 1 the simulation ran but did not finish cleanly or its result is
physically implausible (``status`` in ``summary.json`` says why; the files are still written); 2 bad
input (unknown key, value out of range, missing or unreadable file, an output directory that cannot
be written, bad option), printed as one line on stderr; 130 interrupted.
Set ``JAXBELT_DEBUG=1`` to get the full traceback of an unexpected internal error.

Layout: ``parser.py`` (options), one module per command (``run.py``, ``sweep.py``, ``identify.py``,
each with ``command(args) -> exit code``), ``common.py`` (shared checks, loading, formatting) and
``interrupt.py`` (Ctrl-C handling); ``main`` here dispatches and turns errors into exit codes.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import warnings

from . import duty as _duty, identify as _identify, modes as _modes, report_page as _report_page, run as _run
from . import runup as _runup, span_tension as _span_tension, statics as _statics
from . import sweep as _sweep
from .compile_notice import compile_notice, quiet_xla_logs
from .common import EXIT_FAILED, EXIT_INTERRUPTED, EXIT_OK, EXIT_USAGE, UsageError, err, forget_warnings, show_warning
from .interrupt import INTERRUPTED as _INTERRUPTED, on_sigint as _on_sigint
from .interrupt import raise_if_interrupted as _raise_if_interrupted
from .parser import build_parser

__all__ = ["main", "script_main", "EXIT_OK", "EXIT_FAILED", "EXIT_USAGE", "EXIT_INTERRUPTED", "UsageError"]

_COMMANDS = {
    "run": _run.command,
    "sweep": _sweep.command,
    "identify": _identify.command,
    "statics": _statics.command,
    "duty": _duty.command,
    "report": _report_page.command,
    "modes": _modes.command,
    "runup": _runup.command,
    "span-tension": _span_tension.command,
}


def _enable_x64() -> None:
    import jax

    jax.config.update("jax_enable_x64", True)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``jaxbelt`` command; returns the exit code."""
    args = build_parser().parse_args(argv)
    prog = f"jaxbelt {args.command}"
    if args.command in ("sweep", "duty", "report"):
        _sweep.split_cpu_into_devices()
    _enable_x64()  # before anything creates an array: jaxbelt itself never flips global config
    cached = None
    if not args.no_cache:
        from .._cache import enable_compilation_cache

        cached = enable_compilation_cache()  # compiled programs from earlier runs are loaded, not compiled again
    old_show = warnings.showwarning
    warnings.showwarning = show_warning
    forget_warnings()  # each command prints each of its warnings once
    _INTERRUPTED.clear()
    in_main_thread = threading.current_thread() is threading.main_thread()
    old_sigint = signal.signal(signal.SIGINT, _on_sigint) if in_main_thread else None
    try:
        if getattr(args, "model", "ancf") is None:
            args.model = _configured_model(args)
        with quiet_xla_logs(), compile_notice(prog, enabled=cached is not None and not args.quiet):
            code = _COMMANDS[args.command](args)
        _raise_if_interrupted()
        return code
    except KeyboardInterrupt:
        print(f"\n{prog}: interrupted (no result file was left half-written)", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as error:  # noqa: BLE001 - bad input: one line, exit 2; an internal error: see _failure
        return _failure(prog, error)
    finally:
        warnings.showwarning = old_show
        if old_sigint is not None:
            signal.signal(signal.SIGINT, old_sigint)


def _configured_model(args) -> str:
    """The tier of a command without ``--model``: the configuration's ``solver.model`` (checked with the rest of
    the file when the command loads it), else "ancf" (a resumed run, a file that does not read: the command
    says what is wrong with it)."""
    if getattr(args, "config", None) is None:
        return "ancf"
    from ..config.toml import read_toml

    try:
        solver = read_toml(args.config).get("solver", {})
    except Exception:  # noqa: BLE001 - the command loads the file again and reports its error
        return "ancf"
    return solver.get("model", "ancf") if isinstance(solver, dict) else "ancf"


def _failure(prog: str, error: Exception) -> int:
    """The exit code of a command that raised ``error``, its one-line message printed."""
    from .._errors import ConfigError
    from .._errors import DataError

    if isinstance(error, (ConfigError, DataError, UsageError, FileExistsError)):
        err(prog, error)
        return EXIT_USAGE
    if isinstance(error, OSError):
        where = f"{error.filename}: " if getattr(error, "filename", None) else ""
        err(prog, f"{where}{error.strerror or error}")
        return EXIT_USAGE
    if _INTERRUPTED.is_set():  # the error is how the interrupt surfaced (see interrupt.py)
        print(f"\n{prog}: interrupted (no result file was left half-written)", file=sys.stderr)
        return EXIT_INTERRUPTED
    if os.environ.get("JAXBELT_DEBUG"):
        raise error
    err(prog, f"internal error: {type(error).__name__}: {error} (set JAXBELT_DEBUG=1 for the traceback)")
    return EXIT_FAILED


def script_main() -> None:
    """The installed ``jaxbelt`` command and ``python -m jaxbelt``.

    After an interrupt XLA may still be running the abandoned computation in its own threads, and
    tearing the interpreter down under it can crash (measured: SIGSEGV at exit). The output is
    flushed and the process ends at once instead.
    """
    code = main()
    if code == EXIT_INTERRUPTED:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)
