"""Gradient-based design on the linearised modes: move one natural frequency to a target by changing
chosen parameters within bounds (e.g. the tensioner arm's mode of an accessory drive above the firing
order, by the tensioner's spring and arm inertia: examples/design_tensioner_mode.py).

The frequency is ``analysis.modes.mode_frequencies`` (a traceable function of the parameters; the
equilibrium's shift is in it), its gradient exact by ``jax.jacfwd``. The step is a projected Gauss-Newton
step on the logarithms of the parameters (they are positive and span decades): for the scalar residual
``r = f(p) - target`` the minimum-norm step ``d = -r g / |g|^2`` with ``g = d f / d ln p``, the parameters
then clipped into their bounds; a parameter at a bound whose step pushes outward is frozen for the
step (so the others take over). A fixed number of iterations (one compiled program, any bounds).
"""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np

from .._cache import per_drive
from .._drive import Drive
from .._errors import ConfigError
from .._types import DriveState

__all__ = ["FrequencyDesign", "tune_frequency"]


@dataclasses.dataclass
class FrequencyDesign:
    values: dict  # key -> designed value
    frequency_hz: float  # the mode's frequency at the designed values
    target_hz: float
    reached: bool  # |f - target| <= tol * target
    history: list  # per iteration: {"values": {...}, "frequency_hz": f}
    at_bound: list  # keys that ended on a bound


def tune_frequency(
    drive: Drive,
    bounds: dict,
    target_hz: float,
    *,
    mode: int = 0,
    iterations: int = 8,
    tol: float = 1e-3,
    state: DriveState | None = None,
) -> FrequencyDesign:
    """Values of the parameters ``bounds`` (``{key: (low, high)}``, ``jaxbelt.parameter_keys``) that put the
    ``mode``-th lowest natural frequency at ``target_hz`` (or as near as the bounds allow)."""
    from .modes import settled_state
    from .parameters import get_parameter

    keys = list(bounds)
    if not keys:
        raise ConfigError("tune_frequency: bounds = {}: give at least one parameter key with (low, high)")
    lo, hi = [], []
    for key in keys:
        start = float(get_parameter(drive, drive.params, key))  # unknown key: ConfigError with a suggestion
        b = bounds[key]
        ok = isinstance(b, (tuple, list)) and len(b) == 2 and all(isinstance(x, (int, float)) for x in b)
        if not (ok and 0 < b[0] < b[1] and math.isfinite(b[1])):
            raise ConfigError(f"tune_frequency: bounds[{key!r}] = {b!r}: must be (low, high) with 0 < low < high")
        if not b[0] <= start <= b[1]:
            raise ConfigError(f"tune_frequency: {key} = {start:g} lies outside its bounds {tuple(b)}")
        lo.append(math.log(b[0]))
        hi.append(math.log(b[1]))
    if not (isinstance(target_hz, (int, float)) and math.isfinite(target_hz) and target_hz > 0):
        raise ConfigError(f"tune_frequency: target_hz = {target_hz!r}: must be a finite frequency > 0 [Hz]")
    if not (isinstance(mode, int) and mode >= 0):
        raise ConfigError(f"tune_frequency: mode = {mode!r}: must be a mode index >= 0 (0: the lowest)")
    state = settled_state(drive) if state is None else state
    value_and_grad = _compiled(drive, tuple(keys), mode)
    x = np.array([math.log(float(get_parameter(drive, drive.params, k))) for k in keys])
    lo_a, hi_a = np.asarray(lo), np.asarray(hi)
    history: list[dict] = []
    for _ in range(iterations + 1):
        f_arr, g = (np.asarray(a, dtype=float) for a in value_and_grad(jnp.asarray(x), state))
        f = float(f_arr)
        history.append({"values": {k: float(np.exp(v)) for k, v in zip(keys, x)}, "frequency_hz": f})
        r = f - target_hz
        if abs(r) <= tol * target_hz or len(history) > iterations:
            break
        # freeze parameters on a bound whose descent direction points outward
        step_dir = -r * g
        free = ~(((x <= lo_a + 1e-12) & (step_dir < 0)) | ((x >= hi_a - 1e-12) & (step_dir > 0)))
        gf = np.where(free, g, 0.0)
        norm2 = float(gf @ gf)
        if norm2 == 0.0:
            break
        x = np.clip(x - r * gf / norm2, lo_a, hi_a)
    final = history[-1]
    at_bound = [k for k, v, a, b in zip(keys, x, lo_a, hi_a) if v <= a + 1e-12 or v >= b - 1e-12]
    return FrequencyDesign(
        values=final["values"],
        frequency_hz=final["frequency_hz"],
        target_hz=float(target_hz),
        reached=bool(abs(final["frequency_hz"] - target_hz) <= tol * target_hz),
        history=history,
        at_bound=at_bound,
    )


_COMPILED: dict = {}


def _compiled(drive: Drive, keys: tuple, mode: int):
    """One compiled (frequency, gradient) per drive, keys and mode (values and state are arguments)."""
    from .modes import mode_frequencies
    from .parameters import set_parameters

    def frequency(log_values, state):
        params = set_parameters(drive, drive.params, {k: jnp.exp(v) for k, v in zip(keys, log_values)})
        return mode_frequencies(drive, params, state, count=mode + 1)[mode]

    build = lambda: jax.jit(lambda x, state: (frequency(x, state), jax.jacfwd(frequency)(x, state)))  # noqa: E731
    return per_drive(_COMPILED, drive, build, keys, mode)
