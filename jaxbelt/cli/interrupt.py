"""Ctrl-C during a command: remembered in a flag wherever it lands, so that no result is written
after it and the command ends with the ordinary interruption (exit code 130)."""

from __future__ import annotations

import os
import signal
import threading

__all__ = ["INTERRUPTED", "on_sigint", "raise_if_interrupted"]

# Ctrl-C arrives wherever the main thread happens to be: inside a host callback of the compiled run
# (JAX re-raises it as a runtime error), inside JAX's C++ pytree code (a ValueError), or inside a
# garbage-collection callback (swallowed). The flag remembers it in every case; the command checks it
# before writing anything and main() turns any error it caused into the ordinary interruption.
INTERRUPTED = threading.Event()


def on_sigint(signum, frame):
    INTERRUPTED.set()
    f = frame
    while f is not None:
        if getattr(f.f_code, "co_name", "") == "_xla_gc_callback":
            # Inside JAX's garbage-collection callback: Python prints an exception raised there as
            # "Exception ignored in ..." with a traceback and drops it. Deliver the signal again a
            # moment later, when the callback has returned.
            threading.Timer(0.05, os.kill, (os.getpid(), signal.SIGINT)).start()
            return
        if f.f_code.co_filename.replace("\\", "/").endswith("jax/_src/callback.py"):
            # Inside a host callback of the compiled run (the progress bar): raising there makes JAX
            # print a traceback. The run goes on to its end and the flag stops the command before it
            # writes anything.
            return
        f = f.f_back
    raise KeyboardInterrupt


def raise_if_interrupted() -> None:
    """Called before results are written: an interrupt that got swallowed still stops the command."""
    if INTERRUPTED.is_set():
        raise KeyboardInterrupt
