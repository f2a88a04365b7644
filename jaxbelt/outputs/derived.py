"""The traced part of a run's post-processing as one compiled program; the rest is numpy.

From the saved states one program computes everything that needs the model's (traced) functions: the
named signals, the contact geometry of the summary window's states and of the last saved state, the
stored energy of the first saved state and of each of the window's, the pulleys' friction coefficients
and the installed pretension. The summary, the contact arcs and distribution, the energy audit and the
window's power balance then read these numpy arrays (``derived=`` / ``geometry=`` / ``stored=`` arguments)
instead of tracing and compiling a dozen small programs and eager operations of their own: measured on
Benchmark A in a fresh
process, 1.0-1.4 s of post-processing, nearly all of it compiling.

The program's shapes are known before the run (the number of saved states, where the window starts),
so ``run`` compiles it on a background thread while the simulation runs (``DerivedProgram.start``);
the persistent compilation cache stores it with the run's chunk program. The functions are the same
ones the separate programs call, so the numbers are those of the separate programs (compiled together,
XLA may round a last bit differently). A run whose saves stop early (a fault) or that asks for a
window which is not a tail of the saved states compiles the program for its own shapes.
"""

from __future__ import annotations

import dataclasses
import threading

import jax
import jax.numpy as jnp
import numpy as np

from .._drive import Drive
from .._xla import compile_forward
from .._types import DriveState

__all__ = ["Derived", "DerivedProgram", "window_start"]


@dataclasses.dataclass(frozen=True)
class Derived:
    """The arrays of the post-processing program (numpy), for states ``[0, n_saved)``."""

    signals: dict[str, np.ndarray]  # every named signal (without "t"), in signals.csv order
    n_saved: int
    window_start: int  # the summary window: saved states window_start .. n_saved - 1
    window_geometry: tuple  # belt length per contact point (W, nc), points (W, nc, 2), centres (W, p, 2)
    last_geometry: tuple  # the last saved state's points (nc, 2), lengths (nc,), centres (p, 2)
    stored_ends: np.ndarray | None  # stored energy terms (2, 7) of the first and last saved state
    stored_window: np.ndarray | None  # stored energy terms (W, 7) of the window's saved states
    mu: np.ndarray  # each pulley's effective friction coefficient (contact.coefficients.pulley_mu)
    friction: dict  # the friction law's other coefficients (model.friction_law.coefficients)
    pretension: float  # the key belt.pretension (geometry.installed.installed_pretension)

    def window_inputs(self, select) -> dict:
        """``window_contact_arcs`` keywords for the states ``select`` (a mask or indices): the geometry's
        rows when ``select`` lies inside this window (the summary trims its start to whole periods of the
        engine orders), else only the coefficients."""
        idx = np.arange(self.n_saved)[select]
        out: dict = dict(mu=self.mu, coefficients=self.friction)
        if idx.size and idx[0] >= self.window_start:
            out["geometry"] = tuple(np.asarray(g)[idx - self.window_start] for g in self.window_geometry)
        return out

    def stored_at(self, i: int) -> np.ndarray | None:
        """Stored energy terms (7,) of saved state ``i`` (the first, or one of the window's), else None."""
        if self.stored_ends is None or self.stored_window is None:
            return None
        if i == 0:
            return self.stored_ends[0]
        j = i % self.n_saved - self.window_start
        return self.stored_window[j] if 0 <= j < self.stored_window.shape[0] else None

    def last_inputs(self) -> dict:
        """``contact_distribution`` keywords for the last saved state."""
        return dict(geometry=self.last_geometry, mu=self.mu, coefficients=self.friction)


def window_start(ts, window: float) -> int | None:
    """First saved state of the untrimmed summary window (``outputs.window.window_mask`` without an angle: the
    summary trims its start to whole engine periods, inside it), or None when the mask is not a tail of the
    states (or there are none)."""
    from .window import window_mask

    ts = np.asarray(ts)
    if ts.size == 0:
        return None
    sel = window_mask(ts, window)
    w0 = int(np.argmax(sel))
    return w0 if bool(sel[w0:].all()) and not bool(sel[:w0].any()) else None


def _program(drive: Drive, n_saved: int, w0: int, names: list[str]):
    """``(params, states, path) -> arrays`` of ``Derived`` (traceable); ``names`` receives the signal order."""
    from ..geometry.installed import installed_pretension
    from ..contact.coefficients import pulley_mu
    from .contact import _contact_geometry, _window_geometry
    from .energy import _stored
    from .signals import signals_of

    model = drive.model

    def fn(params, states: DriveState, path):
        sig = signals_of(drive, params, states, path)
        names[:] = list(sig)  # a dict returned from jit would come back sorted
        window = _window_geometry(model, params, states.q[w0:], states.psi[w0:])
        last = _contact_geometry(model, params, states.q[-1], states.psi[-1])
        # the first state and the window's (the summary trims the window's start to whole engine periods): one
        # batch, one vmapped program (two calls compiled it twice: +0.4 s per run in a fresh process)
        both = jax.tree.map(lambda x: jnp.concatenate([x[:1], x[w0:]]), states)
        stored = _stored(model, params, both) if n_saved >= 2 else None
        return dict(
            signals=[sig[k] for k in names],
            window_geometry=window,
            last_geometry=last,
            stored_ends=stored,
            mu=pulley_mu(model, params),
            friction=model.friction_law.coefficients(params),
            pretension=installed_pretension(drive, params),
        )

    return fn


class DerivedProgram:
    """The post-processing program of one drive for ``n_saved`` states and a window from ``w0``.

    ``start()`` traces and compiles it on a background thread (the states need not exist yet);
    calling it with the saved states (host arrays) returns ``Derived``. States of other shapes, or a
    background compilation that failed, compile it here, for the states given.
    """

    def __init__(self, drive: Drive, states_like: DriveState, w0: int):
        self.drive = drive
        self.w0 = w0
        self.n_saved = int(jax.tree.leaves(states_like)[0].shape[0])
        self._like = jax.tree.map(lambda x: jax.ShapeDtypeStruct(x.shape, x.dtype), states_like)
        self._names: list[str] = []
        self._compiled: jax.stages.Compiled | None = None
        self._thread: threading.Thread | None = None

    def start(self) -> "DerivedProgram":
        """Compile on a background thread. Not a daemon: a process that ends while it compiles (an
        interrupted run) waits for it rather than tear JAX's backend down under a running compilation."""
        self._thread = threading.Thread(target=self._compile, name="jaxbelt-postprocess-compile", daemon=False)
        self._thread.start()
        return self

    def _compile(self) -> None:
        try:
            fn = _program(self.drive, self.n_saved, self.w0, self._names)
            d = self.drive
            self._compiled = compile_forward(jax.jit(fn).lower(d.params, self._like, d.path))
        except Exception:  # noqa: BLE001 - compiled again in the caller's thread, where the error shows
            self._compiled = None

    def __call__(self, states: DriveState, w0: int) -> Derived:
        """``Derived`` of the saved ``states`` (host arrays) with the summary window from state ``w0``."""
        if self._thread is not None:
            self._thread.join()
        d = self.drive
        n_saved = int(jax.tree.leaves(states)[0].shape[0])
        like = jax.tree.leaves(self._like)
        fits = (
            w0 == self.w0
            and jax.tree.structure(states) == jax.tree.structure(self._like)  # type: ignore[operator]
            and all(x.shape == s.shape and x.dtype == s.dtype for x, s in zip(jax.tree.leaves(states), like))
        )
        names: list[str] = self._names
        if fits and self._compiled is not None:
            out = self._compiled(d.params, states, d.path)
        else:
            names = []
            out = jax.jit(_program(d, n_saved, w0, names))(d.params, states, d.path)
        out = jax.device_get(out)
        stored = out["stored_ends"]
        first, window_stored = (None, None) if stored is None else (np.asarray(stored)[:1], np.asarray(stored)[1:])
        return Derived(
            signals=dict(zip(names, out["signals"], strict=True)),
            n_saved=n_saved,
            window_start=w0,
            window_geometry=tuple(out["window_geometry"]),
            last_geometry=tuple(out["last_geometry"]),
            stored_ends=None if first is None or window_stored is None else np.concatenate([first, window_stored[-1:]]),
            stored_window=window_stored,
            mu=np.asarray(out["mu"]),
            friction={k: np.asarray(v) for k, v in out["friction"].items()},
            pretension=float(out["pretension"]),
        )
