"""The belt in a spec: its numbers (EA, EI, m', eta A) from what is given, its checks, and the
installed state (which key fixed it: pretension, stress-free, effective or installed effective length)."""

from __future__ import annotations

import math

from .checks import _given, _integer, _is_number, _non_negative, _positive, _require, _warn
from .spec import BeltSpec, DriveSpec

__all__ = ["installed_state_definition"]

MAX_ELEMENTS = 20_000  # belt.n_elements

# ISO 9981:2020 (PK profile) 5.4: a nominal "effective line differential" of 2 mm, read as the radial
# distance by which the belt's pitch line (tension cord) lies outside its effective line. Any closed belt
# loop turns by 2 pi, so the pitch length is L_effective + 2 pi * offset (+12.6 mm for PK).
EFFECTIVE_OFFSET_PK = 0.002  # belt.effective_offset default [m]
MAX_EFFECTIVE_OFFSET = 0.01  # [m]; more is a unit slip (mm for m), not a belt profile


def _belt_numbers(b: BeltSpec) -> dict:
    """The belt's checked inputs and the numbers the build needs (EA, EI, m', eta A, axis offsets)."""
    _check_belt_inputs(b)
    EA, EI, m, cd = _belt_section_numbers(b)
    _check_belt_profile(b)
    inner = b.thickness / 2 if b.inner_offset is None else b.inner_offset
    back = b.thickness / 2 if b.back_offset is None else b.back_offset
    _non_negative("belt.inner_offset", inner)
    _non_negative("belt.back_offset", back)
    return dict(EA=EA, EI=EI, m=m, cd=cd, inner=inner, back=back)


# The stiffest belt the configuration accepts, EA [N]: fifty times a 100 mm x 1 mm steel band.
MAX_EA = 1e9


def _check_belt_inputs(b: BeltSpec) -> None:
    """Mesh size, section and every number given (also one another key overrides)."""
    _integer("belt.n_elements", b.n_elements, 8, MAX_ELEMENTS)
    _positive("belt.width", b.width)
    _positive("belt.thickness", b.thickness)
    # every value given is checked, also one that another key overrides (EA over E, ...)
    lengths = ("stress_free_length", "effective_length", "installed_effective_length")
    for key in ("E", "EA", "EI", "rho", "mass_per_length", *lengths):
        if getattr(b, key) is not None:
            _positive(f"belt.{key}", getattr(b, key))
    for key in ("eta", "axial_damping", "pretension", "inner_offset", "back_offset"):
        if getattr(b, key) is not None:
            _non_negative(f"belt.{key}", getattr(b, key))


def _belt_section_numbers(b: BeltSpec) -> tuple[float, float, float, float]:
    """EA, EI, mass per length and axial damping eta A: given, or from E, rho, eta and the section."""
    A = b.width * b.thickness
    try:
        I = b.width * b.thickness**3 / 12.0
    except OverflowError:
        I = math.inf
    EA = b.EA if b.EA is not None else _given(b.E, "belt.E", "give E (Young's modulus, Pa) or EA (N)") * A
    EI = _given(
        b.EI if b.EI is not None else (b.E * I if b.E is not None else None), "belt.EI", "give EI (N m^2) or E (Pa)"
    )
    if b.mass_per_length is not None:
        m = b.mass_per_length
    else:
        m = _given(b.rho, "belt.rho", "give rho (kg/m^3) or mass_per_length (kg/m)") * A
    if b.axial_damping is not None:
        cd = b.axial_damping
    else:
        eta = 0.0 if b.eta is None else b.eta
        cd = eta * A
    for key, value in (("EA", EA), ("EI", EI), ("mass_per_length", m)):  # E*A etc. may under/overflow
        _require(
            math.isfinite(value) and value > 0,
            f"belt.{key}",
            value,
            "comes out non-finite or zero from E/rho and the section (width, thickness)",
        )
    _require(math.isfinite(cd), "belt.axial_damping", cd, "comes out non-finite from eta and the section")
    _require(  # beyond it the tension of any strain overflows the solvers (an audit's 1e300 N crashed the spans tier)
        EA <= MAX_EA,
        "belt.EA" if b.EA is not None else "belt.E",
        EA,
        f"EA = {EA:.3g} N is stiffer than any belt (a steel band 100 mm x 1 mm: 2e7 N); at most {MAX_EA:g} N",
    )
    return EA, EI, m, cd


def _check_belt_profile(b: BeltSpec) -> None:
    """Damping, belt type and ribs, the poly-V effective length and offset, the groove angle."""
    _non_negative("belt.bending_damping", b.bending_damping)
    _non_negative("belt.mass_damping", b.mass_damping)
    _require(
        isinstance(b.type, str) and b.type in ("flat", "poly-v"), "belt.type", b.type, "must be 'flat' or 'poly-v'"
    )
    _integer("belt.ribs", b.ribs, 1)
    if b.effective_length is not None:
        _require(
            b.type == "poly-v",
            "belt.effective_length",
            b.effective_length,
            "is the catalogue (effective) length of a poly-V belt (type = 'poly-v', ISO 9981); for a flat "
            "belt give stress_free_length (unstretched, at the belt axis) or pretension",
        )
    if b.installed_effective_length is not None:
        _require(
            b.type == "poly-v",
            "belt.installed_effective_length",
            b.installed_effective_length,
            "is a poly-V belt's effective length as installed (type = 'poly-v', ISO 9981); for a flat belt give "
            "stress_free_length (unstretched, at the belt axis) or pretension",
        )
    if b.effective_offset is not None:
        _require(
            b.effective_length is not None or b.installed_effective_length is not None,
            "belt.effective_offset",
            b.effective_offset,
            "is used only with belt.effective_length or belt.installed_effective_length (it converts an effective "
            "length to the pitch length)",
        )
        _require(
            _is_number(b.effective_offset) and 0 <= b.effective_offset <= MAX_EFFECTIVE_OFFSET,
            "belt.effective_offset",
            b.effective_offset,
            f"must be in [0, {MAX_EFFECTIVE_OFFSET:g}] m: the radial distance from the belt's effective line out "
            f"to its pitch line (tension cord), {EFFECTIVE_OFFSET_PK:g} m nominal for PK (ISO 9981)",
        )
    _require(
        _is_number(b.groove_angle_deg) and 0 < b.groove_angle_deg < 180,
        "belt.groove_angle_deg",
        b.groove_angle_deg,
        "must be in (0, 180)",
    )


_INSTALLED_KEYS = ("stress_free_length", "effective_length", "installed_effective_length", "pretension")


def installed_state_definition(spec) -> str:
    """The belt key that defines the installed state of ``spec`` (a ``DriveSpec`` or ``BeltSpec``):
    ``"stress_free_length"``, ``"effective_length"``, ``"installed_effective_length"`` or ``"pretension"``.
    ``ConfigError`` unless exactly one of them is given."""
    b = spec.belt if isinstance(spec, DriveSpec) else spec
    given = [k for k in _INSTALLED_KEYS if getattr(b, k, None) is not None]
    _require(
        len(given) == 1,
        "belt." + "/".join(_INSTALLED_KEYS),
        tuple(getattr(b, k, None) for k in _INSTALLED_KEYS),
        "give exactly one of them",
    )
    return given[0]


def _effective_offset(b: BeltSpec) -> float:
    return EFFECTIVE_OFFSET_PK if b.effective_offset is None else float(b.effective_offset)


def _stress_free_length(
    b: BeltSpec, EA: float, L_path, installation_tension: float | None = None, shortening: float = 0.0
):
    """Stress-free length at the belt axis (the pitch line) from the key that defines the installed
    state; ``L_path`` is the installed path length (a float or a JAX scalar); ``installation_tension``
    the tension the tensioner holds at its drawn position (``tensioner.installation_tension``; only with
    ``installed_effective_length``: that pitch length, ``L_eff + 2 pi e``, less ``shortening``, the path the
    contact compliance takes at that tension (``installed_contact_shortening``), is the belt stretched by it:
    so the tensioner sits at its drawn position in the statics and the run, which have the compliance)."""
    installed_state_definition(b)  # exactly one of the keys is given
    if b.pretension is not None:
        return L_path / (1.0 + b.pretension / EA)
    if b.effective_length is not None:
        return b.effective_length + 2.0 * math.pi * _effective_offset(b)
    if b.installed_effective_length is not None:
        assert installation_tension is not None  # validation computed it
        pitch = b.installed_effective_length + 2.0 * math.pi * _effective_offset(b)
        return (pitch - shortening) / (1.0 + installation_tension / EA)
    return b.stress_free_length


def _check_installed_length(
    bl: BeltSpec, EA: float, L_path: float, installation_tension: float | None = None, shortening: float = 0.0
) -> tuple[float, float]:
    """The stress-free length and the installed stretch; refuses a slack belt or one beyond 20 % strain."""
    how = installed_state_definition(bl)
    L0 = _stress_free_length(bl, EA, L_path, installation_tension, shortening)
    stretch = L_path / L0
    key, value = f"belt.{how}", getattr(bl, how)
    pitch = (
        f" (at the pitch line: effective length + 2π × effective_offset {_effective_offset(bl):g} m)"
        if how == "effective_length"
        else f" (the installed pitch length, effective length + 2π × effective_offset {_effective_offset(bl):g} m, "
        f"at the tension {installation_tension:.4g} N the tensioner holds at its drawn position)"
        if how == "installed_effective_length"
        else ""
    )
    _require(
        stretch >= 1.0,
        key,
        value,
        f"the stress-free length {L0:.6g} m{pitch} is longer than the belt path around the pulleys "
        f"({L_path:.6g} m): the belt would be slack (shorten it or move the pulleys apart)",
    )
    _require(
        stretch < 1.2,
        key,
        value,
        f"the stress-free length {L0:.6g} m{pitch} needs {100 * (stretch - 1):.1f} % strain to reach the belt "
        f"path ({L_path:.6g} m); a belt cannot be installed beyond 20 % strain",
    )
    return L0, stretch


# A drive report's installed length differing from the drawn layout's by more than this is not rounding:
# the tensioner will not sit at its drawn position.
INSTALLED_LENGTH_MISMATCH = 1e-3  # [m]


def _check_installed_effective_length(b: BeltSpec, L_path: float) -> None:
    """Warn when ``installed_effective_length`` is not the drawn layout's effective path length."""
    assert b.installed_effective_length is not None
    drawn = L_path - 2.0 * math.pi * _effective_offset(b)
    gap = b.installed_effective_length - drawn
    if abs(gap) > INSTALLED_LENGTH_MISMATCH:
        _warn(
            f"belt.installed_effective_length = {b.installed_effective_length:.6g} m differs from the effective "
            f"length of the drawn layout ({drawn:.6g} m, path at the pitch line {L_path:.6g} m less 2π × "
            f"effective_offset) by {1e3 * gap:+.3g} mm: the belt is built that much "
            f"{'longer' if gap > 0 else 'shorter'}, and its tensioner will settle away from its drawn position; "
            "draw the tensioner where the drive report puts it"
        )
