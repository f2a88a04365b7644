"""The belt: one planar ANCF beam element (``element``: shape functions, mass, strains, forces and
energy, written for one element and vmapped), the closed ring of equal elements (``ring``: parameters,
assembly, mass matrix and inverse, internal and gravity forces, energies) and the axial force along
it (``tension``: force profile, sampling at points)."""

from .element import element_energy as element_energy, element_forces as element_forces
from .element import element_mass_unit as element_mass_unit, gauss_legendre as gauss_legendre
from .element import make_quadrature as make_quadrature, shape_functions as shape_functions
from .element import strain_measures as strain_measures
from .ring import BeltOperators as BeltOperators, BeltParams as BeltParams, belt_operators as belt_operators
from .ring import elastic_energy as elastic_energy, element_coordinates as element_coordinates
from .ring import gravity_forces as gravity_forces, internal_forces as internal_forces
from .ring import ring_mass_inverse as ring_mass_inverse, ring_mass_matrix as ring_mass_matrix
from .ring import scatter_to_nodes as scatter_to_nodes
from .tension import axial_force_profile as axial_force_profile, sample_nearest as sample_nearest
from .tension import tension_at as tension_at
