"""What a command says while XLA compiles: none of XLA's own C++ log lines, one line of its own.

* XLA logs from C++ straight to stderr: "Very slow compile?" after two minutes of one program (measured: a
  banner in the middle of ``modes --running``), constant-folding alarms, a dump directory it cannot create.
  While a command runs its level is FATAL only (``TF_CPP_MIN_LOG_LEVEL=3``), unless the user set
  ``TF_CPP_MIN_LOG_LEVEL`` (read by ``jaxbelt._user_env`` before JAX sets its own default, 1): that setting
  stays. JAX reads the variable only when it loads, so the level is set through its absl hook, and put back
  to the variable's value afterwards (``main`` may run inside a longer Python process).
* When a program missing from the persistent compilation cache has compiled for ``NOTICE_AFTER_S``, the
  command says once, on stderr, ``compiling (first run of this drive shape; cached afterwards)``. The timer is
  armed by the miss itself (JAX's ``compile_after_persistent_compilation_miss`` test event, a private hook of
  ``jax._src.util``) and disarmed by a finished compile (``/jax/core/compile/backend_compile_duration``, through
  ``jax.monitoring``): a program loaded from the cache says nothing, however long loading a large one takes on
  a busy machine (measured: an identification's Jacobian past the tests' 0.5 s at load average 5). Where the hook
  is missing (another JAX), each cache lookup (``/jax/compilation_cache/compile_requests_use_cache``) arms it and
  a hit (``.../cache_hits``) disarms it.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
from collections.abc import Callable, Iterator
from typing import Any

__all__ = ["NOTICE", "NOTICE_AFTER_S", "CompileNotice", "compile_notice", "quiet_xla_logs"]

NOTICE = "compiling (first run of this drive shape; cached afterwards) ..."
NOTICE_AFTER_S = 3.0  # a cache hit loads in milliseconds, small programs compile in less; a wait worth a line
XLA_LOG_ENV = "TF_CPP_MIN_LOG_LEVEL"
XLA_QUIET_LEVEL = 3  # absl: 0 info, 1 warning, 2 error (the slow-compile banner), 3 fatal
_LOOKUP = "/jax/compilation_cache/compile_requests_use_cache"
_HIT = "/jax/compilation_cache/cache_hits"
_COMPILED = "/jax/core/compile/backend_compile_duration"
_MISS = "compile_after_persistent_compilation_miss"  # jax._src.util.test_event, just before a missed compile


def _absl_level_setter() -> Callable[[int], None] | None:
    try:
        from jax._src.lib import utils

        return utils.absl_set_min_log_level
    except (ImportError, AttributeError):  # another jaxlib layout: XLA's log stays as it is
        return None


def _user_set_xla_log_level() -> bool:
    from .._user_env import XLA_LOG_LEVEL_GIVEN

    return XLA_LOG_LEVEL_GIVEN


@contextlib.contextmanager
def quiet_xla_logs() -> Iterator[None]:
    """XLA's C++ log at FATAL only inside the block, unless the user set ``TF_CPP_MIN_LOG_LEVEL``."""
    set_level = None if _user_set_xla_log_level() else _absl_level_setter()
    if set_level is None:
        yield
        return
    set_level(XLA_QUIET_LEVEL)
    try:
        yield
    finally:
        try:
            set_level(int(os.environ.get(XLA_LOG_ENV, "1")))  # the level XLA read when it loaded
        except ValueError:
            set_level(1)


class CompileNotice:
    """Calls ``say(NOTICE)`` once, when a program missing from the cache has compiled for ``delay`` seconds.

    ``with CompileNotice(say):`` listens to JAX's compile events inside the block (module docstring)."""

    timer_class = threading.Timer  # (delay, function): start(), cancel(); the tests give their own

    def __init__(self, say: Callable[[str], None], delay: float | None = None):
        # JAXBELT_COMPILE_NOTICE_S: another wait before the line (the tests' shorter one: a compile's length
        # depends on the machine; a cache hit takes milliseconds)
        if delay is None:
            try:
                delay = float(os.environ.get("JAXBELT_COMPILE_NOTICE_S", NOTICE_AFTER_S))
            except ValueError:
                delay = NOTICE_AFTER_S
        self._say, self._delay = say, delay
        self._lock = threading.Lock()
        self._timer: Any = None
        self.said = False
        self._miss_hook = False  # listening to the miss itself (set on entering the block)
        self._chained: Any = None  # a test-event listener that was there before

    def _event(self, event: str, **kwargs: str | int) -> None:
        if event == _LOOKUP and not self._miss_hook:
            self._arm()
        elif event == _HIT:
            self._disarm()

    def _test_event(self, name: str, *args: Any) -> None:
        if name == _MISS:
            self._arm()
        if self._chained is not None:
            self._chained(name, *args)

    def _duration(self, event: str, duration_secs: float, **kwargs: str | int) -> None:
        if event == _COMPILED:
            self._disarm()

    def _arm(self) -> None:
        with self._lock:
            if self.said or self._timer is not None:
                return
            timer = self.timer_class(self._delay, self._fire)
            timer.args = (timer,)  # the timer that fires must still be the armed one
            timer.daemon = True
            self._timer = timer
        timer.start()

    def _disarm(self) -> None:
        with self._lock:
            timer, self._timer = self._timer, None
        if timer is not None:
            timer.cancel()

    def _fire(self, timer: Any) -> None:
        with self._lock:
            if self._timer is not timer or self.said:
                return
            self._timer, self.said = None, True
        self._say(NOTICE)

    def __enter__(self) -> CompileNotice:
        from jax import monitoring

        util = _jax_util()
        if util is not None:
            self._chained, util.test_event_listener = util.test_event_listener, self._test_event
            self._miss_hook = True
        monitoring.register_event_listener(self._event)
        monitoring.register_event_duration_secs_listener(self._duration)
        return self

    def __exit__(self, *exc) -> None:
        from jax import monitoring

        self._disarm()
        monitoring.unregister_event_listener(self._event)
        monitoring.unregister_event_duration_listener(self._duration)
        util = _jax_util()
        if self._miss_hook and util is not None and util.test_event_listener == self._test_event:
            util.test_event_listener = self._chained
        self._miss_hook = False


def _jax_util() -> Any:
    """``jax._src.util`` if it has the test-event hook the miss is announced through, else None."""
    try:
        from jax._src import util
    except ImportError:
        return None
    return util if hasattr(util, "test_event_listener") and hasattr(util, "test_event") else None


def compile_notice(prog: str, enabled: bool) -> contextlib.AbstractContextManager:
    """The command ``prog``'s notice of a long compile on stderr (``enabled``: not ``--quiet``, cache on)."""
    if not enabled:
        return contextlib.nullcontext()
    return CompileNotice(lambda text: print(f"{prog}: {text}", file=sys.stderr, flush=True))
