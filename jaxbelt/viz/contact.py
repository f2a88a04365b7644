"""Contact forces over each wrap with the stick and slip zones."""

from __future__ import annotations


import numpy as np
from matplotlib.figure import Figure

from ._common import _SLIP_COLOR, _STICK_COLOR, _runs, _save


def plot_contact(contact: dict, path=None, title: str | None = None) -> Figure:
    """Normal and friction force per unit belt length over each pulley's wrap angle.

    ``contact`` is ``jaxbelt.contact_distribution(drive, state)`` (or ``load_result(...)["contact"]``).
    Stick zones are shaded green, slip zones red; angles from the installed belt entry in the
    direction of travel (points touching just before the entry are shown at negative angles).
    """
    from ..outputs.contact import FREE, SLIP, STICK

    names = list(contact)
    n = max(len(names), 1)
    fig = Figure(figsize=(8, 2.6 * n + 0.6), layout="constrained")
    axes = fig.subplots(n, 1, squeeze=False)[:, 0]
    for ax, name in zip(axes, names):
        d = contact[name]
        ang = np.asarray(d["angle_deg"], float)
        wrap = float(d.get("wrap_deg", 360.0))
        ang = np.where(ang > wrap + 0.5 * (360.0 - wrap), ang - 360.0, ang)
        order = np.argsort(ang)
        ang = ang[order]
        p, f, st = (np.asarray(d[k])[order] for k in ("pressure", "friction", "state"))
        touching = st != FREE
        # zones: each point stands for the arc halfway to its neighbours
        if ang.size:
            mids = 0.5 * (ang[1:] + ang[:-1])
            lo = np.concatenate([[ang[0] - (mids[0] - ang[0] if mids.size else 1.0)], mids])
            hi = np.concatenate([mids, [ang[-1] + (ang[-1] - mids[-1] if mids.size else 1.0)]])
            lo = np.maximum(lo, min(0.0, ang[0]))
            hi = np.minimum(hi, max(wrap, ang[-1]))
            for code, color, label in ((STICK, _STICK_COLOR, "stick"), (SLIP, _SLIP_COLOR, "slip")):
                for k, (a, b) in enumerate(_runs(st == code)):
                    ax.axvspan(lo[a], hi[b - 1], color=color, alpha=0.15, lw=0, label=label if k == 0 else None)
        ax.axvspan(0.0, wrap, fill=False, hatch="", ec="0.5", ls=":", lw=0.8)
        pm = np.where(touching, p, np.nan)
        fm = np.where(touching, f, np.nan)
        ax.plot(ang, pm / 1e3, "-", color="#1f77b4", lw=1.3, label="normal $p$")
        ax.plot(ang, fm / 1e3, "-", color="#ff7f0e", lw=1.3, label="friction $f$")
        for code, marker, color in ((STICK, "o", _STICK_COLOR), (SLIP, "x", _SLIP_COLOR)):
            sel = st == code
            ax.plot(ang[sel], fm[sel] / 1e3, marker, color=color, ms=3, ls="none")
        ax.axhline(0.0, color="0.6", lw=0.6)
        arcs = f"stick {float(d.get('stick_arc_deg', np.nan)):.1f}°, slip {float(d.get('slip_arc_deg', np.nan)):.1f}°"
        ax.set_title(f"{name}: wrap {wrap:.1f}°, {arcs}", fontsize="medium")
        ax.set_ylabel("force / length [kN/m]")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize="x-small", ncols=2)
    axes[-1].set_xlabel("wrap angle from belt entry [deg]")
    if title:
        fig.suptitle(title)
    return _save(fig, path)
