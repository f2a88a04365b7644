"""Derivatives of simulated outputs with respect to physical parameters, through the LCP contact solve.

A short start-up of a reduced Benchmark A (24 elements, 0.2 s, load brought in at 0.08-0.15 s) that
passes through stick/slip transitions (marked long), and a smaller one for the default suite (16 elements,
0.06 s). Outputs: driven speed and tight-span tension at the end.

With Coulomb friction the dependence on mu is piecewise smooth: every stick/slip switch of a point
in some step is a kink, so central differences across kinks and the exact derivative of the current
branch differ (measured 3e-4 to 8e-4 relative at a 1e-5 step in an earlier version of this run; at a
1e-3 step 4e-5 on the speed and 2.2 % on the tension, kinks in between; the current run happens to
cross none within 1e-5: 1e-7). mu is therefore checked at 1e-4 through the smooth
regularised law, and under Coulomb for forward = reverse and finiteness. Errors are measured relative to
each output's largest normalised sensitivity max_k |dy/dx_k x_k|, so that a derivative that barely matters
is not judged by its own tiny size.
"""

import numpy as np
import pytest
from helpers import (
    build_quietly,
    end_of_run_outputs,
    forward_jacobian_and_differences,
    normalised_error,
    quick_compile,
    reverse_jacobian,
    reverse_projection,
)

import jaxbelt as jb
from jaxbelt import get_parameter

SMOOTH_KEYS = [
    "belt.E",
    "belt.eta",
    "contact.stiffness",
    "contact.damping",
    "belt.pretension",
    "pulleys.driven.inertia",
    "pulleys.driven.load",
]
REL_STEP = 1e-5  # central differences: truncation ~ step^2, round-off ~ 1e-16/step


def _drive(friction_law="coulomb", n_elements=24, t_end=0.2, load_ramp=(0.08, 0.15)):
    spec = jb.benchmark_a(n_elements=n_elements, t_end=t_end, save_dt=0.01, friction_law=friction_law, nu_s=50.0)
    spec.pulleys[1].load = {"smooth_step": [*load_ramp, 0.0, 10.0]}
    return build_quietly(spec)  # 24 elements on R = 0.1 m: coarse on purpose (speed)


def _jacobians(drive, keys, rel_step=REL_STEP, reverse=True):
    outputs = end_of_run_outputs(drive, keys)
    x0 = np.array([float(get_parameter(drive, drive.params, k)) for k in keys])
    # one forward-mode program gives the Jacobian and the central differences' values (helpers)
    J_fwd, J_fd = forward_jacobian_and_differences(lambda x: outputs(x, "forward"), x0, rel_step)
    J_rev = reverse_jacobian(lambda x: outputs(x, "reverse"), x0, 2) if reverse else None
    return x0, J_fwd, J_rev, J_fd


# radius and mu last: not compared with central differences (mu: kinks; radius: checked for finiteness only)
ONSET_KEYS = ["contact.mu", "pulleys.driven.radius"]


@pytest.fixture(scope="module")
def coulomb():
    drive = _drive()
    return _jacobians(drive, SMOOTH_KEYS + ONSET_KEYS)


@pytest.mark.long
def test_forward_mode_equals_reverse_mode_to_round_off(coulomb):
    x0, J_fwd, J_rev, _ = coulomb
    # measured ~1e-12; reverse mode stores every step, so nothing is recomputed differently
    assert normalised_error(x0, J_rev, J_fwd).max() < 1e-9


@pytest.mark.long
def test_derivatives_match_central_differences(coulomb):
    x0, J_fwd, _, J_fd = coulomb
    assert np.all(np.isfinite(J_fwd))
    err = normalised_error(x0, J_fwd, J_fd)[:, : len(SMOOTH_KEYS)]
    assert err.max() < 1e-4, dict(zip(SMOOTH_KEYS, err.max(axis=0)))


@pytest.mark.long
def test_mu_derivative_through_the_regularised_law_matches_at_1e_4():
    """Forward mode against central differences; reverse = forward for this law is asserted by
    tests/test_implicit_stiffness.py's gradient test (the same law and keys through the implicit step), and for
    this scheme's contact solve by the Coulomb fixture above: one whole-run reverse program fewer to compile."""
    drive = _drive("regularized")
    keys = ["contact.mu", "contact.nu_s", "belt.E"]
    x0, J_fwd, _, J_fd = _jacobians(drive, keys, reverse=False)
    assert normalised_error(x0, J_fwd, J_fd).max() < 1e-4


@pytest.mark.long
def test_gradients_finite_at_contact_onset_and_across_stick_slip(coulomb):
    """The installed belt starts with zero gap at every wrapped point (contact onset) and the
    start-up crosses stick/slip: radius and friction derivatives stay finite, no NaN from norms
    (both modes, from the fixture's run: one program fewer to compile than a run of its own)."""
    _, J_fwd, J_rev, _ = coulomb
    for J in (J_fwd, J_rev):
        onset = J[:, len(SMOOTH_KEYS) :]
        assert np.all(np.isfinite(J)), J
        assert np.all(np.abs(onset).max(axis=0) > 0), dict(zip(ONSET_KEYS, onset.T))


def test_a_short_coulomb_start_up_differentiates_alike_forward_reverse_and_by_differences():
    """The default suite's copy of the checks above (marked long) at a smaller size: 16 elements, 0.06 s (load
    stepped in over 0.012-0.036 s), four smooth keys and mu. Forward mode against central differences on the
    smooth keys, and the dot-product test of one reverse pass against the forward Jacobian (all five keys: the
    Coulomb law's branch is the same in both modes); every entry finite (mu's is zero here: the wraps still stick
    everywhere this early, where the friction coefficient does not enter)."""
    drive = _drive(n_elements=16, t_end=0.06, load_ramp=(0.012, 0.036))
    keys = ["belt.E", "contact.stiffness", "pulleys.driven.inertia", "pulleys.driven.load", "contact.mu"]
    outputs = end_of_run_outputs(drive, keys)
    x0 = np.array([float(get_parameter(drive, drive.params, k)) for k in keys])
    with quick_compile():  # compiled once, run once: XLA's optimisations cost more than they save
        J_fwd, J_fd = forward_jacobian_and_differences(lambda x: outputs(x, "forward"), x0, REL_STEP)
        w, wJ_rev = reverse_projection(lambda x: outputs(x, "reverse"), x0, J_fwd)
    assert np.all(np.isfinite(J_fwd)), J_fwd
    assert normalised_error(x0, wJ_rev[None], (w @ J_fwd)[None]).max() < 1e-9  # forward = reverse (round-off)
    assert normalised_error(x0[:4], J_fwd[:, :4], J_fd[:, :4]).max() < 1e-4
