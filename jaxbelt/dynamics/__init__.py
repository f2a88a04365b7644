"""Dynamics: the time step as named stages (``step``: smooth forces -> free velocities -> contact frames ->
Delassus diagonal -> impulses -> update -> work terms -> fault check; ``stages``: the belt-only stages it
shares with the free belt), the diffrax solvers holding it (``solver``, ``step.MoreauJean``), the fixed-step
solve (``simulate``: one program, for gradients, jit and vmap), the same run as compiled chunks called from a
loop (``chunked``: progress, Ctrl-C and checkpoints between chunks), the explicit stability limit
(``stability``), the implicit scheme's contact solve (``contact_newton``) and accuracy step (``time_step``),
the free belt (``free_belt``) and the one kinetic energy (``kinetic``). The model's records are re-exported
here: ``DriveModel`` (static), ``DriveParams`` / ``PulleyParams`` (differentiable numbers), ``DriveState``
(what a step advances) and ``Fault`` (its fault codes)."""

from .._types import DriveModel as DriveModel, DriveParams as DriveParams, DriveState as DriveState
from .._types import Fault as Fault, PulleyParams as PulleyParams
from .free_belt import FreeBeltState as FreeBeltState, free_belt_energies as free_belt_energies
from .free_belt import simulate_free_belt as simulate_free_belt
from .kinetic import KineticEnergy as KineticEnergy, kinetic_energy as kinetic_energy
from .simulate import Trajectory as Trajectory, simulate as simulate
from .chunked import ChunkedRun as ChunkedRun, RunProgress as RunProgress
from .solver import FixedStepSolver as FixedStepSolver
from .stability import BeltNumbers as BeltNumbers, largest_rates as largest_rates, rate_bounds as rate_bounds
from .stability import stable_time_step as stable_time_step, step_limit as step_limit
from .step import DriveOperators as DriveOperators, MoreauJean as MoreauJean
from .step import drive_operators as drive_operators, drive_step as drive_step
from .contact_newton import newton_contact as newton_contact
from .time_step import StepChoice as StepChoice, implicit_time_step as implicit_time_step
