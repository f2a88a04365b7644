"""jaxbelt: differentiable dynamics of flat and poly-V belt drives in JAX.

The belt is a closed loop of planar ANCF beam elements; pulleys and tensioners are rigid bodies;
belt-pulley contact uses a compliant normal law and discontinuous Coulomb friction with true
sticking, solved as a complementarity problem inside every time step (driven by diffrax).

jaxbelt never changes JAX's global configuration; call
``jax.config.update("jax_enable_x64", True)`` before using it (the CLI, examples and tests do).

The names here are the ones a user needs: describe a drive (``DriveSpec`` ... or ``load_config``),
build it (``build_drive``), run it (``run``, ``simulate_signals``), fit and sweep it. Expert names
(belt elements, paths, the time step, theory, friction laws, carriers) live in the subpackages:
``jaxbelt.belt``, ``.geometry``, ``.pulleys``, ``.contact`` (``.contact.friction``), ``.dynamics``,
``.outputs``, ``.analysis``, ``.config``; see docs/architecture.md.
"""

# _user_env first: it reads the environment before JAX (imported below) sets its defaults from there.
# The model's record types (DriveModel, DriveParams, DriveState, PulleyParams, Fault) and Trajectory live in
# jaxbelt.dynamics, LayoutError in jaxbelt.geometry, DataError in jaxbelt.analysis (both are ConfigError's
# siblings; catch ValueError for all three).
from . import _user_env as _user_env
from ._errors import ConfigError as ConfigError
from ._types import ContactState as ContactState
from ._drive import Drive as Drive
from .config import BeltSpec as BeltSpec, ContactSpec as ContactSpec, DriveSpec as DriveSpec
from .config import PulleySpec as PulleySpec, SolverSpec as SolverSpec, TensionerSpec as TensionerSpec
from .config import benchmark_a as benchmark_a, build_drive as build_drive
from .config import dump_toml as dump_toml, load_config as load_config
from .analysis import IdentifyResult as IdentifyResult, Measurement as Measurement, identify as identify
from .analysis import get_parameter as get_parameter, parameter_keys as parameter_keys
from .analysis import set_parameter as set_parameter, set_parameters as set_parameters
from .analysis import RunResult as RunResult, run as run
from .analysis import SweepResult as SweepResult, sweep as sweep
from .dynamics import simulate as simulate
from ._cache import enable_compilation_cache as enable_compilation_cache
from ._xla import use_fast_cpu_compile as use_fast_cpu_compile
from .outputs import contact_distribution as contact_distribution, summary as summary
from .outputs import signal_names as signal_names, simulate_signals as simulate_signals
from . import analysis as analysis, belt as belt, config as config, contact as contact, dynamics as dynamics
from . import geometry as geometry, outputs as outputs, pulleys as pulleys

try:  # the installed distribution's version: one source of truth, pyproject.toml
    from importlib.metadata import PackageNotFoundError as _NotInstalled, version as _version

    __version__ = _version("jaxbelt")
except _NotInstalled:  # a source tree on sys.path without installation
    __version__ = "0.0.0+unknown"
