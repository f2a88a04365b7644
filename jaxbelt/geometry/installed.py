"""The installed belt of a built drive for any parameters: its path around the pulleys where the carriers
put them, and the uniform pretension that the belt's stress-free length gives on it (traceable: geometry and
belt parameters act on both, so gradients see them). Read by outputs (span middles, installed state) and by
analysis.parameters (the key ``belt.pretension``)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._types import DriveParams
from ..pulleys.carrier import carrier_centers
from .path import BeltPath, belt_path

if TYPE_CHECKING:  # _drive imports geometry.path: the built drive is only read here
    from .._drive import Drive

__all__ = ["installed_path", "installed_pretension"]


def installed_path(drive: Drive, params: DriveParams) -> BeltPath:
    """The belt path for the pulley geometry in ``params`` (traceable), read in the built drive's
    orientation (a loop that can be read both ways keeps the reading the build chose)."""
    centers, _ = carrier_centers(drive.model, params.pulleys, drive.state0.psi)
    orientation = 1 if float(drive.path.orientation) > 0 else -1
    return belt_path(centers, params.pulleys.radius, drive.model.wrap_side, orientation=orientation)


def installed_pretension(drive: Drive, params: DriveParams):
    """EA (L_path / L0 - 1): the uniform tension of the belt stretched over its installed path (traceable)."""
    b = params.belt
    return b.EA * (installed_path(drive, params).length / b.stress_free_length - 1.0)
