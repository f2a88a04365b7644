"""jaxbelt: differentiable dynamics of flat and poly-V belt drives in JAX.

The belt is a closed loop of planar ANCF beam elements; pulleys and tensioners are rigid bodies;
belt-pulley contact uses a compliant normal law and discontinuous Coulomb friction with true
sticking, solved as a complementarity problem inside every time step (driven by diffrax).

jaxbelt never changes JAX's global configuration; call
``jax.config.update("jax_enable_x64", True)`` before using it (the CLI, examples and tests do).
"""

from .belt.ring import BeltParams
from ._drive import Drive
from ._errors import ConfigError
from .config import (BeltSpec, ContactSpec, DriveSpec, PulleySpec, SolverSpec, TensionerSpec, benchmark_a, build_drive,
                     dump_toml, load_config)
from .analysis.identify import IdentifyResult, Measurement, identify
from .analysis.parameters import get_parameter, parameter_keys, set_parameter, set_parameters
from .outputs.signals import initial_state, signal_names, simulate_signals
from .analysis.sweep import SweepResult, sweep
from .dynamics.free_belt import FreeBeltState, free_belt_energies, simulate_free_belt
from .geometry.check import check_belt_path
from .geometry.path import BeltPath, belt_path, place_belt, point_on_path
from ._types import DriveModel, DriveParams, DriveState, PulleyParams
from .outputs.summary import (FREE, SLIP, STICK, contact_distribution, creep_theory_for, signals, span_names,
                       span_tensions, summary)
from .analysis.run import RunResult, run
from .dynamics.simulate import Trajectory, simulate
from .dynamics.stability import stable_time_step
from .dynamics.step import MoreauJean, drive_operators, drive_step
from .outputs.theory import CreepTheory, capstan_tension, euler_eytelwein_ratio, two_pulley_creep
from ._types import ContactState, Fault
from .pulleys import timelaw as timelaw

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
