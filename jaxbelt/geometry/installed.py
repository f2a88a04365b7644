"""The installed belt of a built drive for any parameters: its path around the pulleys where the carriers
put them and the uniform pretension that the belt's stress-free length gives on it (traceable: geometry and
belt parameters act on both, so gradients see them); the order in which the belt travels round the pulleys,
and the stress-free belt on a wrap by creep theory. Read by outputs (span middles, installed state), by
analysis.parameters (the key ``belt.pretension``), the statics and the spans tier."""

from __future__ import annotations

from typing import TYPE_CHECKING

import jax.numpy as jnp

from .._types import DriveParams
from ..pulleys.carrier import carrier_centers
from .path import BeltPath, belt_path

if TYPE_CHECKING:  # _drive imports geometry.path: the built drive is only read here
    from .._drive import Drive

__all__ = ["installed_path", "installed_pretension", "travel_chain", "arc_stress_free"]


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


def travel_chain(drive: Drive):
    """Per pulley the index of the span leaving it and the one arriving, in the direction of travel,
    and the pulleys in travel order starting after the first driver."""
    k = drive.model.n_pulleys
    along = int(round(float(drive.path.orientation))) == drive.travel
    leave = [i if along else (i - 1) % k for i in range(k)]
    arrive = [(i - 1) % k if along else i for i in range(k)]
    roles = [p.role for p in drive.pulleys]
    start = roles.index("driver") if "driver" in roles else 0
    step = 1 if along else -1
    order = [(start + step * j) % k for j in range(1, k + 1)]  # ends with the driver itself
    return leave, arrive, order, start


def arc_stress_free(R, phi, T_in, T_out, mu_eff, EA, k):
    """Stress-free length of the belt on an arc of angle ``phi``: the arriving tension on the adhesion
    arc, then an exponential change to the leaving tension over the slip arc at the exit. The belt axis
    runs ``delta = T / (R k)`` inside the radius R (the contact pressure T / R over the contact stiffness k
    per unit length), which shortens the arc by ``int delta dphi`` (returned too): to first order in
    delta / R the path around the pulleys changes by the wrap angle per unit of radius, its spans stay.

    The slip arc in closed form: with ``T = T_in e^{u s}`` over it (``u = ln(T_out / T_in)``, ``s`` 0..1),
    ``int (R - T/(R k)) / (1 + T/EA) dphi = phi_s (R - (R + EA/(R k)) ln(q) / u)`` with
    ``q = (EA + T_out) / (EA + T_in)``, and ``int T dphi = phi_s T_in (e^u - 1) / u`` (series where ``|u|``
    is tiny; the spans tier evaluates this some twenty times per step, an 8-point quadrature was most of
    its cost)."""
    t_in, t_out = jnp.maximum(T_in, 1e-9), jnp.maximum(T_out, 1e-9)
    u = jnp.log(t_out / t_in)
    phi_s = jnp.minimum(jnp.abs(u) / mu_eff, phi)
    small = jnp.abs(u) < 1e-6
    u_safe = jnp.where(small, 1.0, u)
    b = t_in / (EA + t_in)
    log_q_per_u = jnp.where(small, b + 0.5 * u * b * (1.0 - b), jnp.log1p(b * jnp.expm1(u_safe)) / u_safe)
    grow_per_u = jnp.where(small, 1.0 + 0.5 * u, jnp.expm1(u_safe) / u_safe)  # (e^u - 1) / u
    slip = phi_s * (R - (R + EA / (R * k)) * log_q_per_u)
    stick = (phi - phi_s) * (R - T_in / (R * k)) / (1.0 + T_in / EA)
    shortening = ((phi - phi_s) * T_in + phi_s * t_in * grow_per_u) / (R * k)
    return stick + slip, phi_s, shortening
