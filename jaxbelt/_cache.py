"""JAX's persistent compilation cache in the user's cache directory: a drive compiled once is loaded
from disk by every later process instead of compiled again.

``import jaxbelt`` changes no JAX configuration; the CLI turns the cache on, Python users call
``jaxbelt.enable_compilation_cache()``. Where: ``$JAXBELT_CACHE_DIR`` if set (empty: no cache), else
``$XDG_CACHE_HOME/jaxbelt/jax``, else ``~/.cache/jaxbelt/jax``.

What is cached: every program a command compiles (tests/test_compile_cache.py: a second process of each
command compiles nothing). JAX never caches a program that holds a host callback; those built on
``dynamics.simulate`` (sweeps, duty points, identification, gradients through a run) would hold diffrax's
run-time checks of the save times as callbacks, and are traced with those checks resolved without one
(``_equinox_checks``; no environment variable needed).
"""

from __future__ import annotations

import os
import weakref
from pathlib import Path

__all__ = ["enable_compilation_cache", "default_cache_dir", "per_drive"]

ENV = "JAXBELT_CACHE_DIR"


def default_cache_dir() -> Path | None:
    """The cache directory from the environment; ``None`` when ``JAXBELT_CACHE_DIR`` is set empty."""
    env = os.environ.get(ENV)
    if env is not None:
        return Path(env).expanduser() if env.strip() else None
    base = os.environ.get("XDG_CACHE_HOME", "").strip() or str(Path.home() / ".cache")
    return Path(base) / "jaxbelt" / "jax"


def enable_compilation_cache(path: str | os.PathLike | None = None) -> Path | None:
    """Store compiled programs in ``path`` (default: ``default_cache_dir()``) and load them from there.

    Every program is cached, however fast it compiled (a small one is still traced and loaded faster
    than compiled). Returns the directory, or ``None`` when the cache is disabled (``JAXBELT_CACHE_DIR=""``) or
    the directory cannot be created (the run then just compiles, as without a cache).
    """
    import jax

    where = Path(path).expanduser() if path is not None else default_cache_dir()
    if where is None:
        return None
    try:
        where.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    jax.config.update("jax_compilation_cache_dir", str(where))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.0)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    return where


def per_drive(store: dict, drive, build, *key):
    """``build()`` once per drive object (and ``key``), kept while that drive lives: the in-process home of
    an analysis's compiled programs (``jax.jit`` closures over a drive whose parameters are arguments)."""
    slot = (id(drive), *key)
    ref, fn = store.get(slot, (None, None))
    if ref is None or ref() is not drive:  # a new drive, or a dead one's id reused
        fn = build()
        store[slot] = (weakref.ref(drive), fn)
    return fn
