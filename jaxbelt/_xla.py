"""XLA flags for the processes jaxbelt owns (the command line, the tests, the benchmarks) and for scripts
that ask for them: ``import jaxbelt`` sets nothing.

XLA reads ``XLA_FLAGS`` once, when JAX creates its backend, so a flag is added only before that, and
only where the user has not given the same flag. An ``XLA_FLAGS`` entry that the installed XLA does not
know aborts the process, so a flag is added only for the jaxlib versions it was checked with.
"""

from __future__ import annotations

import os
from importlib import metadata

__all__ = ["CPU_COMPILE_FLAGS", "add_xla_flags", "use_fast_cpu_compile"]

# XLA:CPU's LLVM IR fusion emitters instead of its newer MLIR ones. Measured on Benchmark A (2-core CPU,
# jaxlib 0.10.2): compiling the run's program 2.2 -> 1.3 s (explicit) and 4.8 -> 3.3 s (implicit
# stiffness), the compile-heavy gradient tests 221 -> 164 s, the peak memory of compiling the reverse-mode
# gradient of the full run 1,060 -> 530 MiB; time per step the same within the machine's noise.
CPU_COMPILE_FLAGS = ("--xla_cpu_use_fusion_emitters=false",)
_CHECKED_JAXLIB = ((0, 10), (0, 11))  # [from, before): versions that know the flags above


def _backend_started() -> bool:
    try:
        from jax._src import xla_bridge

        return bool(xla_bridge.backends_are_initialized())
    except (ImportError, AttributeError):  # another JAX layout: assume it has started (add nothing)
        return True


def add_xla_flags(*flags: str) -> list[str]:
    """Append ``flags`` (``--name=value``) to ``XLA_FLAGS``, each unless ``XLA_FLAGS`` already names it;
    nothing once JAX has created its backend (XLA would not read them). Returns the flags added."""
    if _backend_started():
        return []
    current = os.environ.get("XLA_FLAGS", "")
    given = {f.split("=")[0] for f in current.split()}
    added = [f for f in flags if f.split("=")[0] not in given]
    if added:
        os.environ["XLA_FLAGS"] = " ".join([current, *added]).strip()
    return added


def _jaxlib_version() -> tuple[int, ...] | None:
    try:
        return tuple(int(p) for p in metadata.version("jaxlib").split(".")[:2])
    except (metadata.PackageNotFoundError, ValueError):
        return None


def use_fast_cpu_compile() -> list[str]:
    """Have XLA's CPU compiler use its faster-compiling code generator (``CPU_COMPILE_FLAGS``): call it
    before the first JAX computation, like ``jax_enable_x64``. The command line and the tests do.

    Compiling takes 30-40 % less time and half the memory on jaxbelt's programs, the compiled programs run
    as fast. Returns the flags added (none for an unchecked jaxlib, flags the user set, or a started
    backend)."""
    return add_xla_flags(*CPU_COMPILE_FLAGS) if checked_jaxlib() else []


def checked_jaxlib() -> bool:
    """Whether the installed jaxlib is one the flags were checked with."""
    version = _jaxlib_version()
    return version is not None and _CHECKED_JAXLIB[0] <= version < _CHECKED_JAXLIB[1]
