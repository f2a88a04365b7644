"""Belt-pulley contact: where the belt's contact points are and how they move (``kinematics``: the
constant coupling operators, nearest-pulley frames), the friction laws as types (``friction``) and
the law-agnostic contact solve (``sweeps``: the fixed-point loop with warm start and exact sticking)."""

from . import friction as friction
from .coefficients import point_mu as point_mu, pulley_mu as pulley_mu
from .kinematics import ContactFrame as ContactFrame, ContactOperators as ContactOperators
from .kinematics import contact_operators as contact_operators, contact_points as contact_points
from .kinematics import nearest_pulley as nearest_pulley, point_kinematics as point_kinematics
from .sweeps import Delassus as Delassus, PointProblem as PointProblem, SolveSettings as SolveSettings
from .sweeps import solve_contact as solve_contact
