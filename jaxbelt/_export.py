"""Traced programs kept on disk (``jax.export``) beside the persistent compilation cache: a warm start of a
drive's run skips Python tracing and lowering too, not only XLA's compilation.

A program is stored under a key of everything that can change its code: the static part of its arguments
(pickled: the drive's model, static numbers), the tree structure, shapes and dtypes of the array part, the
keyword options, the versions of jax, jaxlib, equinox and diffrax, the backend, and a hash of jaxbelt's own
source files. Anything that cannot be keyed (an argument that does not pickle) is traced as before. A stored
program whose inputs do not match is traced again and replaced. Files are written whole (a temporary file,
then renamed) into ``<compilation cache>/jaxbelt-exported``; without a compilation cache, or with
``JAXBELT_STORED_PROGRAMS=0``, nothing is stored (storing costs a second lowering the first time: +0.35 s on
Benchmark A's run program; the tests turn it off, their caches starting empty).

Measured on the accessory example's run program (2-core CPU): tracing and lowering took 1.6-1.9 s of a warm
start; with the stored program the program is ready (loaded and fetched from the compilation cache) in 1.3 s
against 2.6 s.
"""

from __future__ import annotations

import hashlib
import os
import pickle
from importlib import metadata
from pathlib import Path
from typing import Callable

import equinox as eqx
import jax

__all__ = ["export_dir", "lowered", "lowered_flat", "compiled_flat", "StoredJit"]

_SOURCE_HASH: str | None = None


def _source_hash() -> str:
    """sha256 of jaxbelt's Python sources (once per process): a changed line changes every key."""
    global _SOURCE_HASH
    if _SOURCE_HASH is None:
        root = Path(__file__).parent
        h = hashlib.sha256()
        for path in sorted(root.rglob("*.py")):
            h.update(str(path.relative_to(root)).encode())
            h.update(path.read_bytes())
        _SOURCE_HASH = h.hexdigest()
    return _SOURCE_HASH


def _version(name: str) -> str:
    try:
        return metadata.version(name)
    except metadata.PackageNotFoundError:
        return "?"


def export_dir() -> Path | None:
    """Where stored programs live: beside JAX's persistent compilation cache, if one is on and
    ``JAXBELT_STORED_PROGRAMS`` is not 0 (false, no, off)."""
    if os.environ.get("JAXBELT_STORED_PROGRAMS", "").strip().lower() in ("0", "false", "no", "off"):
        return None
    cache = jax.config.jax_compilation_cache_dir  # type: ignore[attr-defined]
    return Path(cache) / "jaxbelt-exported" if cache else None


def _key(name: str, static, described: str) -> str | None:
    """The stored program's key: ``static`` pickled (everything the program closes over or takes as static), the
    arguments ``described`` (tree structure, shapes, dtypes, shardings, options), versions, backend, sources."""
    try:
        blob = pickle.dumps(static)
    except Exception:  # noqa: BLE001 - a closure, a lambda: not keyable, trace as before
        return None
    h = hashlib.sha256(blob)
    for part in (
        name,
        described,
        *(f"{p}={_version(p)}" for p in ("jax", "jaxlib", "equinox", "diffrax")),
        jax.default_backend(),
        _source_hash(),
    ):
        h.update(b"\0" + part.encode())
    return h.hexdigest()[:32]


def _avals(xs) -> str:
    return repr([(tuple(x.shape), str(x.dtype), str(getattr(x, "sharding", None))) for x in xs])


def _load(path: Path, args):
    try:
        exp = jax.export.deserialize(bytearray(path.read_bytes()))
    except Exception:  # noqa: BLE001 - a torn or foreign file: trace again and replace it
        return None
    avals = [(tuple(a.shape), str(a.dtype)) for a in exp.in_avals]
    return exp if avals == [(tuple(x.shape), str(x.dtype)) for x in jax.tree.leaves(args)] else None


def _store(path: Path, exp) -> None:
    try:
        blob = exp.serialize()
    except ImportError:  # jax.export's serialiser needs flatbuffers (a declared dependency): traced next time
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_bytes(blob)
        os.replace(tmp, path)
    except OSError:  # a read-only or full cache: the run goes on, traced next time too
        pass


def lowered_flat(name: str, fn: Callable, args: tuple, options: dict, out_like, closure=None):
    """``(lowered, unflatten)``: ``fn(*args, **options)`` lowered as a function of the array leaves of ``args``
    (``lowered.compile()(*leaves)``; ``unflatten`` rebuilds ``fn``'s output, whose tree structure is
    ``out_like``'s, from the flat result). With a compilation cache on, the traced program is stored and later
    loaded instead of traced (module docstring); ``closure``: what ``fn`` closes over (pickled into the key)."""
    dyn, static = eqx.partition(args, eqx.is_array)
    leaves, treedef = jax.tree.flatten(dyn)
    out_treedef = jax.tree.structure(out_like)

    def flat(*xs):
        out = fn(*eqx.combine(jax.tree.unflatten(treedef, xs), static), **options)
        out_leaves, tree = jax.tree.flatten(out)
        assert str(tree) == str(out_treedef), f"{name}: output {tree} is not shaped as {out_treedef}"
        return tuple(out_leaves)

    def unflatten(out):
        return jax.tree.unflatten(out_treedef, list(out))

    described = f"{treedef}|{_avals(leaves)}|{sorted(options.items())!r}"
    return lowered(name, flat, (closure, static), tuple(leaves), described=described), unflatten


def compiled_flat(name: str, fn: Callable, args: tuple, out_like, closure=None) -> Callable:
    """:func:`lowered_flat` compiled: a callable taking arguments shaped as ``args`` (their array leaves are passed
    to the program, the rest was fixed when it was traced) and returning ``fn``'s output."""
    lowered_program, unflatten = lowered_flat(name, fn, args, {}, out_like, closure)
    flat = lowered_program.compile()

    def call(*a):
        return unflatten(flat(*jax.tree.leaves(eqx.filter(a, eqx.is_array))))

    return call


def lowered(name: str, fn: Callable, static, args: tuple, jit_options: dict | None = None, described: str = ""):
    """``jax.jit(fn, **jit_options).lower(*args)``, loaded from its stored traced form where a compilation cache is on
    (module docstring). ``fn`` may depend on nothing but ``args`` and what ``static`` holds (pickled into the key:
    a drive, its options); ``args``: arrays or ``jax.ShapeDtypeStruct`` (with their shardings)."""
    jit_options = jit_options or {}
    fn = _named(fn, name)
    where = export_dir()
    described = f"{described}|{_avals(jax.tree.leaves(args))}|{sorted((k, str(v)) for k, v in jit_options.items())!r}"
    key = _key(name, static, described) if where is not None else None
    if where is None or key is None:  # no cache, or not keyable: the plain program
        return jax.jit(fn, **jit_options).lower(*args)
    path = where / f"{name}-{key}.jaxexport"
    exp = _load(path, args) if path.exists() else None
    if exp is None:
        exp = jax.export.export(jax.jit(fn, **jit_options))(*args)
        _store(path, exp)
    return jax.jit(_named(exp.call, name), **jit_options).lower(*args)


def _named(fn: Callable, name: str) -> Callable:
    """``fn`` under ``name`` (the compiled program's name in JAX's logs: ``jit_<name>``), stored or traced alike."""

    def program(*args):
        return fn(*args)

    program.__name__ = program.__qualname__ = name
    return program


class StoredJit:
    """``jax.jit(fn)`` whose traced program is stored (:func:`lowered_flat`) for concrete arguments, so that a later
    process loads it instead of tracing it again: one compiled program per argument shapes, kept by this object.
    Traced arguments (``fn`` inside another transformation), arguments that are not arrays, or no store (no
    compilation cache, ``JAXBELT_STORED_PROGRAMS=0``) take ``jax.jit(fn)`` as before. ``closure``: all ``fn``
    closes over (pickled into the key); ``out_like``: a pytree shaped as ``fn``'s output (its leaves not read)."""

    def __init__(self, name: str, fn: Callable, closure, out_like):
        self.name, self._fn, self._closure, self._out_like = name, fn, closure, out_like
        self._jit = jax.jit(fn)
        self._compiled: dict = {}

    def __call__(self, *args):
        dyn, static = eqx.partition(args, eqx.is_array)
        leaves = jax.tree.leaves(dyn)
        # a non-array argument would be baked into the program (the key below holds arrays' shapes only)
        if export_dir() is None or jax.tree.leaves(static) or any(isinstance(x, jax.core.Tracer) for x in leaves):
            return self._jit(*args)
        key = (jax.tree.structure(dyn), tuple((x.shape, str(x.dtype), getattr(x, "weak_type", False)) for x in leaves))
        if key not in self._compiled:
            self._compiled[key] = compiled_flat(self.name, self._fn, args, self._out_like, self._closure)
        return self._compiled[key](*args)
