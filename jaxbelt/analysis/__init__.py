"""Analyses built on runs: named differentiable parameters (``parameters``: keys, get, set), the
one-call run with post-processing (``run``), parameter identification from measured signals
(``identify``) and parameter sweeps sharded over devices (``sweep``)."""

from .parameters import check_together as check_together, get_parameter as get_parameter
from .parameters import installed_path as installed_path, parameter_keys as parameter_keys
from .parameters import set_parameter as set_parameter, set_parameters as set_parameters
from .identify import IdentifyResult as IdentifyResult, Measurement as Measurement
from .identify import check_measurement as check_measurement, identify as identify
from .run import RunResult as RunResult, run as run
from .sweep import SweepResult as SweepResult, steady_figures as steady_figures, sweep as sweep
from .._errors import DataError as DataError
