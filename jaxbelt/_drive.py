"""``Drive``: a built drive, as the numerics, outputs and analysis read it.

It lives outside ``config/`` so that whatever reads a drive (outputs, io, viz) never imports the
configuration code: the static facts they need from the specification (run settings, pulley names,
roles and drawn geometry, how the installed state was defined) are fields here, written once by
``config.build_drive``. The spec itself is kept only to write the configuration back
(``config_used.toml``, sweeps) and to read keys as a file edit would (``set_parameter``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from ._types import DriveModel, DriveParams, DriveState
from .geometry.path import BeltPath

if TYPE_CHECKING:  # annotation only: nothing here imports config at run time
    from .config.spec import DriveSpec

__all__ = ["Drive", "PulleyInfo", "RunOptions"]


@dataclass(frozen=True)
class RunOptions:
    """Static run settings of the spec's ``[solver]`` (the time step is ``Drive.dt``)."""

    t_end: float
    save_dt: float
    settle_time: float


@dataclass(frozen=True)
class PulleyInfo:
    """What the spec says of one pulley beyond the parameters: for drawings and summaries."""

    name: str
    role: str  # driver, driven, idler or tensioner
    center: tuple[float, float]  # installed (drawn) centre [m]
    radius: float  # surface radius [m] (the parameters hold the belt-axis one)
    pivot: tuple[float, float] | None = None  # an arm tensioner's pivot [m]


@dataclass(frozen=True)
class Drive:
    """A built drive: everything ``simulate`` needs plus geometry and static facts for outputs."""

    spec: DriveSpec  # pulleys in model order; for writing it back only
    model: DriveModel
    params: DriveParams
    state0: DriveState
    path: BeltPath
    dt: float
    options: RunOptions
    pulleys: tuple[PulleyInfo, ...]  # in model order (= model.pulley_names)
    travel: int = 1  # sense the belt runs round the loop: +1 counter-clockwise, -1 clockwise
    running_sense: tuple[int, ...] = ()  # each pulley's rotation sense while the belt runs (travel x wrap side)
    # What the spec fixed (static, read by set_parameter so that a changed key gives the drive a file
    # edit of that key would build): "pretension" keeps the installed tension when EA or the path
    # change, "stress_free_length"/"effective_length"/"installed_effective_length" keep the length; and
    # which stiffnesses the spec
    # derived from E.
    installed_by: str = "stress_free_length"
    E_sets: tuple[str, ...] = ("EA", "EI")
    # with installed_by == "effective_length": the catalogue length and the effective-to-pitch offset [m]
    # (with "installed_effective_length": the offset only)
    effective_length: float | None = None
    effective_offset: float | None = None
    # the build's warnings (polygon effect, spring loads, signs, tensioner side): also in the summary
    build_warnings: tuple[str, ...] = ()
    dt_reason: str = ""  # why the time step is what it is (solver.dt, the explicit limit, the accuracy rule)
    scheme_reason: str = ""  # why this scheme (solver.scheme, or what "auto" compared)

    @property
    def scheme(self) -> str:
        """ "implicit" (belt mass scaling, Newton contact solve) or "explicit"."""
        return "implicit" if self.model.implicit_stiffness else "explicit"
