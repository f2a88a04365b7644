"""The contact entry (landing) loss: the energy audit books it on its own, the summary window's power
balance lists it beside the physical losses, and a run warns when it is a large share of the power.

A free-running belt (no load) on Benchmark A's pulleys at v/c = 0.7 with the contact damper off: the
normal law then has no physical dissipation, so what it takes out is the numerical loss of belt points
landing on the pulleys (docs/outputs.md, "Energy audit and power balance"); 20 elements make it large.
"""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt.dynamics import step as st
from jaxbelt.outputs import mass_per_current_length

jax.config.update("jax_enable_x64", True)

T0 = 300.0


def test_entry_window_is_the_upstream_end_of_each_arc():
    """On the installed belt, the window holds the first ``points_per_element`` points of each wrap, at the
    end the pulley's surface comes from: its velocity there points along the arc, into it."""
    d = jb.build_drive(jb.benchmark_a(n_elements=12))
    ops = jb.dynamics.drive_operators(d.model, d.params)
    frames = st.contact_frames(d.model, d.params, ops, d.state0)
    fr = frames.frame
    lam = jnp.where(fr.gap < 1e-7, 1.0, 0.0)  # the wraps (the spans lie outside the pulleys)
    m = d.model.contact_points_per_element
    rx, ry, pulley = np.asarray(frames.rx), np.asarray(frames.ry), np.asarray(fr.pulley)
    centers = np.asarray(d.params.pulleys.center)
    for omega in (1.0, -1.0):
        entry = np.asarray(st.entry_window(d.model, frames, lam, jnp.full(2, omega)))
        for k in range(2):
            arc = (np.asarray(lam) > 0) & (pulley == k)
            assert arc.sum() > 2 * m
            flagged = np.nonzero(entry & (pulley == k))[0]
            assert flagged.size == m
            cx, cy = rx[flagged].mean() - centers[k, 0], ry[flagged].mean() - centers[k, 1]
            surface = omega * np.array([-cy, cx])  # the surface's velocity at the window
            inward = np.array([rx[arc].mean() - rx[flagged].mean(), ry[arc].mean() - ry[flagged].mean()])
            assert surface @ inward > 0.0, (omega, k)


@pytest.fixture(scope="module")
def coarse_fast():
    """20 elements, v/c = 0.7 (13.2 m/s), no load, contact damper off; 0.45 s (the driver ramps up in 0.2 s)."""
    spec = jb.benchmark_a(n_elements=20, t_end=0.45, save_dt=5e-3)
    spec.belt.stress_free_length = None
    spec.belt.pretension = T0
    v = 0.7 * math.sqrt(T0 / mass_per_current_length(spec.belt.mass_per_length, T0, spec.belt.EA))
    spec.pulleys[0].speed = {"ramp": [0.0, 0.2, 0.0, v / 0.1]}
    spec.pulleys[1].load = None
    spec.pulleys[1].viscous = 0.0
    spec.pulleys[1].inertia = 0.02
    spec.contact.damping = 0.0
    return jb.run(spec).summary


def test_the_normal_laws_loss_is_booked_at_entry(coarse_fast):
    """With the damper off, the entry term is the normal law's whole dissipation (measured 100.3 %: outside the
    windows the law gives back 0.3 %), within 5 %; the audit still closes within 0.1 % (measured 1.4e-4)."""
    a = coarse_fast["energy"]
    assert abs(a["residual_relative"]) < 1e-3, a
    assert a["contact_damping_J"] > 0.0
    assert a["contact_entry_J"] == pytest.approx(a["contact_damping_J"], rel=0.05)
    losses = coarse_fast["power_balance"]["losses"]
    assert abs(losses["contact_normal_W"]) < 0.05 * losses["contact_entry_W"], losses


def test_a_large_entry_loss_warns_with_the_element_length(coarse_fast):
    """At no load the entry loss is most of what the drive takes in. Over the window the driven pulley is still
    slowing down, so the driver supplies less than the drive dissipates (measured 29.5 W supplied, 31.7 W of
    entry loss): the share is taken of the delivered power, supplied less the stored energy's rate of change
    (the losses, to the residual), and a share of that cannot exceed 1. The warning names an element count
    above the run's 20 and the element length that goes with it."""
    pb = coarse_fast["power_balance"]
    assert pb["delivered_W"] == pytest.approx(pb["supplied_W"] - pb["stored_change_W"], rel=1e-12)
    assert pb["stored_change_W"] < 0.0  # the slowing pulley gives energy back
    assert pb["losses"]["contact_entry_W"] > pb["supplied_W"]  # measured 31.7 > 29.5 W
    assert 0.5 < pb["entry_share"] < 1.0
    (w,) = [w for w in coarse_fast["warnings"] if w.startswith("numerical contact entry loss")]
    n = int(w.split(" instead of 20")[0].rsplit("(", 1)[1])
    assert n > 20
    length_mm = float(w.split("elements of about ")[1].split(" mm")[0])
    L0 = coarse_fast["belt"]["installed_state"]["stress_free_length"]
    assert length_mm == pytest.approx(1e3 * L0 / n, rel=1e-2)


def test_three_contact_points_per_element_are_accepted_four_refused():
    """3 points per element (docs/config.md: less entry loss on coarse meshes) build a drive whose step tests
    3 Gauss points per element; 4 over-constrain the element and are refused by name."""
    spec = jb.benchmark_a(n_elements=12)
    spec.contact.points_per_element = 3
    d = jb.build_drive(spec)
    assert d.model.n_contacts == 36
    spec.contact.points_per_element = 4
    with pytest.raises(jb.ConfigError, match=r"contact.points_per_element = 4: must be 1, 2 or 3"):
        jb.build_drive(spec)
