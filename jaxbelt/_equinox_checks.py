"""diffrax's run-time checks without host callbacks, inside jaxbelt's own solves only.

``diffrax.diffeqsolve`` checks its ``SaveAt`` times at run time (``_check_subsaveat_ts``: increasing,
within ``[t0, t1]``) with ``equinox.error_if``. Under equinox's default (``EQX_ON_ERROR=raise``) each
check is a host callback, and JAX never writes a program holding a host callback to the persistent
compilation cache: every sweep, identification and gradient through ``simulate`` was compiled again by
every process. jaxbelt builds those save times itself (they cannot fail the checks), so while
``callback_free_checks()`` is active -- around jaxbelt's ``diffeqsolve`` calls, that is while they are
traced -- a check left at equinox's default resolves as ``EQX_ON_ERROR=nan`` does: a failed check turns
the checked values (the save times) into NaN instead of raising, there is no callback, and the program is
cached like any other.

Nothing global changes for the user: equinox's setting is not touched, and the substitute is a separate
jitted function (its traces are never shared with a check traced outside jaxbelt). A user who set
``EQX_ON_ERROR`` to anything but ``raise`` (``nan``, ``off``, ``breakpoint``) keeps that setting. Another
thread tracing its own equinox checks at the very same moment would get the NaN form too (a check
that never fires behaves the same either way). With an equinox release that lays its internals out
differently the context does nothing: programs are then correct but not cached
(tests/test_compile_cache.py notices).
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Iterator
from typing import Any

import equinox as eqx

try:  # equinox's internals: where ``error_if`` resolves ``on_error="default"`` at trace time
    from equinox import _errors as _eqx_errors

    _HOOKABLE = hasattr(_eqx_errors, "branched_error_if_impl_jit") and hasattr(_eqx_errors, "branched_error_if_impl")
except ImportError:  # pragma: no cover - another equinox layout
    _eqx_errors = None  # type: ignore[assignment]
    _HOOKABLE = False

__all__ = ["callback_free_checks"]


def _nan_on_error(x, pred, index, msgs, *, on_error):
    if on_error == "default" and _eqx_errors.EQX_ON_ERROR == "raise":
        on_error = "nan"
    return _eqx_errors.branched_error_if_impl(x, pred, index, msgs, on_error=on_error)


_nan_on_error_jit = eqx.filter_jit(_nan_on_error)
_lock = threading.Lock()
_depth = 0  # nested or concurrent jaxbelt solves: equinox's own function is put back by the last one out
_saved: Any = None  # equinox's own function while the substitute is in place


@contextlib.contextmanager
def callback_free_checks() -> Iterator[None]:
    """While active, equinox checks at their default resolve without a host callback (module docstring)."""
    global _depth, _saved
    if not _HOOKABLE:
        yield
        return
    with _lock:
        if _depth == 0:
            _saved = _eqx_errors.branched_error_if_impl_jit
            _eqx_errors.branched_error_if_impl_jit = _nan_on_error_jit
        _depth += 1
    try:
        yield
    finally:
        with _lock:
            _depth -= 1
            if _depth == 0:
                _eqx_errors.branched_error_if_impl_jit = _saved
                _saved = None
