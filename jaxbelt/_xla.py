"""XLA:CPU's LLVM IR code generator (``xla_cpu_use_fusion_emitters = false``) instead of its newer MLIR
fusion emitters: on jaxbelt's programs it compiles in 30-40 % less time and half the memory. Measured on
Benchmark A (2-core CPU, jaxlib 0.10.2): the run's program 2.3 -> 1.5 s (explicit) and 5.6 -> 3.3 s
(implicit stiffness), the peak memory of compiling the reverse-mode gradient of the full run 1,063 -> 532
MiB, the compile-heavy gradient tests 221 -> 164 s. Forward programs run as fast (Benchmark A forward run
5.94 s both ways, a 64-point sweep within noise), derivative programs slower (forward-mode Jacobian
+10-20 %, reverse-mode gradient +13 %). So:

* jaxbelt compiles its own forward programs (the run's chunks, the post-processing) with it, as a per-program
  compile option (``compile_forward``; ``JAXBELT_FAST_COMPILE=0`` turns that off);
* a process can have every program compiled with it (``use_fast_cpu_compile``: through ``XLA_FLAGS``,
  before JAX creates its backend): the tests do, where compiling dominates. ``import jaxbelt`` sets nothing.
  An ``XLA_FLAGS`` entry the installed XLA does not know aborts the process, so the flag is added only for
  the jaxlib versions it was checked with (a per-program option XLA does not know is an ordinary error).
"""

from __future__ import annotations

import os
from importlib import metadata

import jax

__all__ = [
    "CPU_COMPILE_FLAGS",
    "FAST_COMPILE_OPTIONS",
    "IMPLICIT_COMPILE_OPTIONS",
    "add_xla_flags",
    "checked_jaxlib",
    "compile_forward",
    "use_fast_cpu_compile",
]

FAST_COMPILE_OPTIONS = {"xla_cpu_use_fusion_emitters": False}  # per program (compile options)
# And for the implicit scheme's run programs: no YNN fusions. Its step (small dense blocks, the Newton contact
# solve) ran 1.73 x faster without them on the accessory example (1.94 -> 1.12 ms per step, 114 elements),
# Benchmark A's 1.1 x; measured 2026-11-27, jaxlib 0.10.2, 2-core CPU, load ~1. Not for every program: it
# changes round-off enough to move a central-difference check of a mode sensitivity (2.6e-4 of a 1e-3 entry).
IMPLICIT_COMPILE_OPTIONS = {"xla_cpu_experimental_ynn_fusion_type": ""}
CPU_COMPILE_FLAGS = tuple(f"--{k}={str(v).lower()}" for k, v in FAST_COMPILE_OPTIONS.items())  # per process
_unknown_option = False  # set when XLA refused the option once: never tried again in this process
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
    """Have XLA's CPU compiler use its faster-compiling code generator (``CPU_COMPILE_FLAGS``) for every
    program of this process: call it before the first JAX computation, like ``jax_enable_x64``. The tests do.

    Compiling takes 30-40 % less time and half the memory on jaxbelt's programs; forward programs run as
    fast, derivative programs 10-20 % slower (module docstring). Returns the flags added (none for an
    unchecked jaxlib, flags the user set, or a started backend)."""
    return add_xla_flags(*CPU_COMPILE_FLAGS) if checked_jaxlib() else []


def checked_jaxlib() -> bool:
    """Whether the installed jaxlib is one the flags were checked with."""
    version = _jaxlib_version()
    return version is not None and _CHECKED_JAXLIB[0] <= version < _CHECKED_JAXLIB[1]


def compile_forward(lowered, implicit: bool = False):
    """``lowered.compile()`` with ``FAST_COMPILE_OPTIONS`` on a CPU backend (for forward programs, which run
    as fast with it; ``implicit``: the implicit scheme's run, ``IMPLICIT_COMPILE_OPTIONS`` too); as
    ``lowered.compile()`` where XLA does not know the option or ``JAXBELT_FAST_COMPILE`` is 0 (false, no, off)."""
    global _unknown_option
    off = os.environ.get("JAXBELT_FAST_COMPILE", "").strip().lower() in ("0", "false", "no", "off")
    if _unknown_option or off or jax.default_backend() != "cpu":
        return lowered.compile()
    try:
        options = FAST_COMPILE_OPTIONS | (IMPLICIT_COMPILE_OPTIONS if implicit else {})
        return lowered.compile(compiler_options=options)
    except Exception as error:  # noqa: BLE001 - JaxRuntimeError: an XLA that no longer knows the option
        if "compile option" not in str(error):
            raise
        _unknown_option = True
        return lowered.compile()
