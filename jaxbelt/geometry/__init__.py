"""Geometry of the installed belt: the path around the pulleys (``path``: tangent spans and arcs,
traceable with jax or run with numpy; points on it; the belt's nodes placed along it) and the layout
checks with their suggested fixes (``check``: numpy, raising ``LayoutError``); the installed path and
pretension of a built drive for any parameters (``installed``, traceable)."""

from .._errors import LayoutError as LayoutError
from .check import check_belt_path as check_belt_path
from .path import BeltPath as BeltPath, belt_path as belt_path, path_reading as path_reading
from .path import place_belt as place_belt, point_on_path as point_on_path, span_midpoints as span_midpoints
from .installed import installed_path as installed_path, installed_pretension as installed_pretension
