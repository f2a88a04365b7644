"""jaxbelt: differentiable dynamics of flat and poly-V belt drives in JAX.

The belt is a closed loop of planar ANCF beam elements; pulleys and tensioners are rigid bodies;
belt-pulley contact uses a compliant normal law and discontinuous Coulomb friction with true
sticking, solved as a complementarity problem inside every time step (driven by diffrax).

jaxbelt never changes JAX's global configuration; call
``jax.config.update("jax_enable_x64", True)`` before using it (the CLI, examples and tests do).
"""

from ._belt import BeltParams
from ._cases import benchmark_a
from ._drive import (BeltSpec, ConfigError, ContactSpec, Drive, DriveSpec, PulleySpec, SolverSpec, TensionerSpec,
                     build_drive)
from ._config import dump_toml, load_config
from ._identify import IdentifyResult, Measurement, identify
from ._parameters import get_parameter, parameter_keys, set_parameter, set_parameters
from ._signals import initial_state, signal_names, simulate_signals
from ._sweep import SweepResult, sweep
from ._free_belt import FreeBeltState, free_belt_energies, simulate_free_belt
from ._layout import BeltPath, belt_path, check_belt_path, place_belt, point_on_path
from ._model import DriveModel, DriveParams, DriveState, PulleyParams
from ._outputs import (FREE, SLIP, STICK, contact_distribution, creep_theory_for, signals, span_names,
                       span_tensions, summary)
from ._run import RunResult, run
from ._simulate import Trajectory, simulate
from ._stability import stable_time_step
from ._stepper import MoreauJean, drive_operators, drive_step
from ._theory import CreepTheory, capstan_tension, euler_eytelwein_ratio, two_pulley_creep
from ._types import ContactState, Fault
from . import _timelaw as timelaw

try:  # the installed distribution's version: one source of truth, pyproject.toml
    from importlib.metadata import PackageNotFoundError as _NotInstalled, version as _version

    __version__ = _version("jaxbelt")
except _NotInstalled:  # a source tree on sys.path without installation
    __version__ = "0.0.0+unknown"

__all__ = [
    "BeltParams", "BeltPath", "BeltSpec", "ConfigError", "ContactSpec", "CreepTheory", "Drive", "DriveModel",
    "DriveParams", "DriveSpec", "DriveState", "FREE", "FreeBeltState", "MoreauJean", "PulleyParams", "PulleySpec",
    "RunResult", "SLIP", "STICK", "SolverSpec", "TensionerSpec", "Trajectory", "belt_path", "benchmark_a",
    "build_drive", "capstan_tension", "check_belt_path", "contact_distribution", "creep_theory_for",
    "drive_operators", "drive_step", "euler_eytelwein_ratio", "free_belt_energies", "place_belt", "point_on_path",
    "run", "signals", "simulate", "simulate_free_belt", "span_names", "span_tensions", "stable_time_step",
    "summary", "timelaw", "two_pulley_creep", "IdentifyResult", "Measurement", "identify", "get_parameter",
    "parameter_keys", "set_parameter", "set_parameters", "initial_state", "signal_names", "simulate_signals",
    "SweepResult", "sweep", "dump_toml", "load_config", "ContactState", "Fault",
]
