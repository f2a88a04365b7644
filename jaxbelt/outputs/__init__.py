"""Outputs of a run, computed from saved states after the time loop: the one signal registry
(``signals``: name, unit and function of every signal; span tensions; ``simulate_signals``), the
steady-state summary and plausibility checks (``summary``), contact arcs and stick/slip states
(``contact``), the energy audit (``energy``), the independent creep theory (``theory``, numpy), the accessory-drive
outputs (``fead``: slip, slip safety factor, hub loads, span deflection) and spectra (``spectra``, numpy)."""

from .contact import contact_distribution as contact_distribution, window_contact_arcs as window_contact_arcs
from .energy import energy_audit as energy_audit, stored_energy as stored_energy
from .signals import QUANTITIES as QUANTITIES, SIGNALS as SIGNALS, Quantity as Quantity, SignalGroup as SignalGroup
from .signals import initial_state as initial_state, quantity_of as quantity_of
from .signals import signal_columns as signal_columns, signal_names as signal_names, signal_units as signal_units
from .signals import signals as signals, simulate_signals as simulate_signals
from .signals import span_names as span_names, span_tensions as span_tensions
from .summary import creep_theory_for as creep_theory_for, installed_state as installed_state, summary as summary
from .theory import CreepTheory as CreepTheory, capstan_tension as capstan_tension
from .theory import euler_eytelwein_ratio as euler_eytelwein_ratio, open_belt_geometry as open_belt_geometry
from .theory import rolling_radius_correction as rolling_radius_correction, two_pulley_creep as two_pulley_creep
from .theory import effective_tension as effective_tension, mass_per_current_length as mass_per_current_length
from .fead import fead_summary as fead_summary, mu_effective as mu_effective
from .spectra import amplitude_spectrum as amplitude_spectrum, crank_angle as crank_angle
from .spectra import order_spectrum as order_spectrum
