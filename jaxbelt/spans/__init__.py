"""The spans tier: the same drive reduced to its pulleys' and carriers' coordinates, each span an axial
spring-damper (its stress-free length a state), the belt's mass lumped on the pulleys, and every wrap in
creep (adhesion at the entry, the belt carried at the pulley's surface speed) or in gross slip at the capstan
limit ``T_tight - m'v^2 = e^{mu phi} (T_slack - m'v^2)``, chosen per step by a complementarity solve
(``step.capstan_projection``). Carriers, clutches, pivot friction, stops, loads and engine orders are the
ANCF tier's own (``jaxbelt.pulleys``). Milliseconds per simulated second: for duty points, run-ups and
design variants; what it leaves out (span vibration, the contact distribution, entry effects) is in
docs/spans.md. ``simulate_spans(drive, t_end=...)`` runs it; ``SpansModel.of(drive)`` is its static part."""

from .model import SpansModel as SpansModel, SpansState as SpansState, initial_spans_state as initial_spans_state
from .simulate import SpansTrajectory as SpansTrajectory, simulate_spans as simulate_spans
from .simulate import spans_signals as spans_signals, spans_time_step as spans_time_step
from .simulate import SpansResult as SpansResult, run_spans as run_spans
from .modes import spans_modes as spans_modes, spans_mode_sensitivities as spans_mode_sensitivities
from .modes import spans_campbell_modes as spans_campbell_modes, spans_span_modes as spans_span_modes
from .simulate import spans_signal_names as spans_signal_names, spans_signals_of as spans_signals_of
from .simulate import spans_time_steps as spans_time_steps
from .step import spans_step as spans_step
