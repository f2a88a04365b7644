"""Linearised modes about the installed state against closed forms: the rotational mode of the driven
pulley on its two belt springs (an independent discrete model) at any contact stiffness, the
spans' string frequencies with the bending correction, and eigen-sensitivities against central
differences (forward = reverse)."""

import math
import warnings

import jax
import numpy as np
import pytest
from helpers import central_difference

import jaxbelt as jb
from jaxbelt.analysis.modes import linear_modes, mode_frequencies, mode_sensitivities, settled_state

N_ELEMENTS = 40


@pytest.fixture(scope="module")
def installed():
    drive = jb.build_drive(jb.benchmark_a(n_elements=N_ELEMENTS, t_end=0.1))
    return drive, settled_state(drive)


def _discrete_rotational(drive):
    """Driven pulley (driver held) on two spans of stiffness EA / L each, no slip, plus the belt's inertia:
    the arc it carries and a third of each span's mass (linear axial velocity profile)."""
    p, b = drive.params.pulleys, drive.params.belt
    R, J = float(p.radius[1]), float(p.inertia[1])
    L = float(drive.path.span_length[0])
    m = float(b.mass_per_length)
    J_eff = J + m * R * math.pi * R**2 + 2 * (m * L / 3) * R**2
    k_theta = 2 * float(b.EA) / L * R**2
    return math.sqrt(k_theta / J_eff) / (2 * math.pi)


def test_rotational_mode_is_the_discrete_model_at_any_contact_stiffness(installed):
    """The stuck contacts hold exactly (tangential springs STICK_FACTOR x k, as the runs' Coulomb law sticks):
    the rotational mode is the rigid-wrap discrete model whatever the normal contact stiffness. Measured 0.04 /
    0.32 / 0.37 % at 1e7 / 1e8 / 1e10 N/m^2 (with tangential springs of k itself: -6.6 / -1.0 / +0.35 %)."""
    drive, state = installed
    f_ref = _discrete_rotational(drive)
    errors = []
    for k in (1e7, 1e8, 1e10):
        m = linear_modes(drive, state=state, contact_stiffness=k, count=4)
        assert m.kinds[0] == "rotational" and m.rotational_share[0] > 0.5, m.table()
        errors.append(abs(m.frequencies[0] / f_ref - 1))
    assert max(errors) < 0.005, errors


def _span_frequencies(drive, state):
    """The first three transverse frequencies of both spans, each over the string's
    f_n = n c / (2 L) sqrt(1 + B n^2), c = sqrt(T / m') (m' per current length), B = pi^2 EI / (T L^2)."""
    m = linear_modes(drive, state=state, count=8)
    b = drive.params.belt
    strain = float(drive.path.length) / float(b.stress_free_length) - 1
    T = float(b.EA) * strain
    L = float(drive.path.span_length[0])
    c = math.sqrt(T * (1 + strain) / float(b.mass_per_length))
    B = math.pi**2 * float(b.EI) / (T * L**2)
    transverse = [f for f, kind in zip(m.frequencies, m.kinds) if kind == "transverse"]
    spans = [s for s, kind in zip(m.span, m.kinds) if kind == "transverse"]
    assert len(transverse) >= 6 and set(spans[:6]) == {"driver-driven", "driven-driver"}, m.table()
    n = np.arange(6) // 2 + 1  # the two equal spans come in pairs
    return np.asarray(transverse[:6]) / (n * c / (2 * L) * np.sqrt(1 + B * n * n))


def test_span_frequencies_converge_to_the_string_with_bending_correction(installed):
    """Both spans, n = 1, 2, 3, at 40 and 80 elements: the error shrinks like the element length (the span
    ends where the belt leaves its last contact point, two per element: measured -3.0 to -3.2 % at 40 and
    -1.3 to -1.5 % at 80 elements; without gravity -0.8 % at 120 and -0.55 % at 160; the simulated span at
    rest in test_span_vibration shows the same), and the first-order Richardson extrapolation
    2 f(80) - f(40) is within 1 % of the string (measured +0.1 to +0.3 %). The string's m' is per current
    length: per stress-free length (5 % more mass here) it would hide the 40-element error."""
    coarse = _span_frequencies(*installed)
    drive = jb.build_drive(jb.benchmark_a(n_elements=2 * N_ELEMENTS, t_end=0.1))
    fine = _span_frequencies(drive, settled_state(drive))
    assert np.all(np.abs(fine - 1) < 0.6 * np.abs(coarse - 1)), (coarse, fine)
    np.testing.assert_allclose(2 * fine - coarse, 1.0, atol=0.01)


def test_eigen_sensitivities_match_central_differences_and_closed_forms(installed):
    """d f / d p by Hellmann-Feynman with the equilibrium's shift (mode_sensitivities) against central
    differences of the frequencies (equilibrium re-found at each parameter value), and against closed forms:
    rotational mode f ~ J_eff^-1/2 in the driven inertia, first span mode f ~ sqrt(T) in the pretension."""
    drive, state = installed
    keys = ["pulleys.driven.inertia", "belt.pretension"]
    sens = mode_sensitivities(drive, keys, count=2, state=state)
    for key, mode in zip(keys, (0, 1)):
        x0 = float(jb.get_parameter(drive, drive.params, key))

        def freq(x, key=key):
            return np.asarray(mode_frequencies(drive, jb.set_parameter(drive, drive.params, key, x), state, count=2))

        fd = central_difference(freq, x0, 1e-4 * x0)
        assert sens[key][mode] == pytest.approx(fd[mode], rel=1e-5), (key, sens[key], fd)
        # the other mode too (a small cross-sensitivity; the two span modes are 0.2 % apart, nearly degenerate)
        np.testing.assert_allclose(sens[key], fd, rtol=0, atol=1e-3 * np.max(np.abs(fd)), err_msg=key)
        f0 = freq(x0)[mode]
        if key == "pulleys.driven.inertia":  # d f / d J = -f / (2 J_eff)
            assert sens[key][mode] == pytest.approx(-f0 / (2 * (x0 + _belt_inertia(drive))), rel=0.02)
        else:  # d f / d T = f / (2 T)
            assert sens[key][mode] == pytest.approx(f0 / (2 * x0), rel=0.05)


def _belt_inertia(drive):
    p, b = drive.params.pulleys, drive.params.belt
    R, L, m = float(p.radius[1]), float(drive.path.span_length[0]), float(b.mass_per_length)
    return m * R * math.pi * R**2 + 2 * (m * L / 3) * R**2


def test_bad_contact_stiffness_is_refused(installed):
    drive, state = installed
    with pytest.raises(jb.ConfigError, match="contact_stiffness = -1"):
        linear_modes(drive, state=state, contact_stiffness=-1.0)
    assert np.all(np.isfinite(linear_modes(drive, state=state, count=2).frequencies))


def test_more_modes_than_the_model_has_are_all_returned_with_a_warning(installed):
    """count beyond the coordinates (40 elements: 4 per node x 40 nodes + the driven spin (the driver is
    speed-driven) = 161) wrote every mode
    without a word; now a warning says how many the model has."""
    drive, state = installed
    with pytest.warns(UserWarning, match=r"modes: 100000 asked for, the model has 161 "):
        m = linear_modes(drive, state=state, count=100000)
    assert len(m.frequencies) == 161 and np.all(np.diff(m.frequencies) >= 0)


@pytest.mark.long
def test_a_freely_turning_drive_has_its_rigid_mode_at_zero_hz_not_an_instability():
    """A drive without a speed-prescribed pulley (torque-driven driver, Benchmark A at 26 elements, 0.05 s
    into a torque ramp): the whole drive turning is a 0 Hz mode about the installed state and about running
    (its eigenvalue pair, ~0 up to the equilibrium's accuracy, is no instability; its sensitivity is 0)."""
    spec = jb.benchmark_a(n_elements=26, t_end=0.05)
    spec.pulleys[0].speed, spec.pulleys[0].torque = None, {"ramp": [0.0, 0.02, 0.0, 5.0]}
    spec.pulleys[1].load = None
    drive = jb.build_drive(spec)
    assert not any(drive.model.kinematic)
    rest = linear_modes(drive, count=2)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        running = linear_modes(drive, count=2, about="running")
        sens = mode_sensitivities(drive, ["belt.EA"], count=2, about="running", state=running.equilibrium)
    # the drive still accelerates (no steady running shape: that warning is right), but nothing is unstable
    assert not [w for w in caught if "unstable" in str(w.message)], [str(w.message) for w in caught]
    assert rest.frequencies[0] < 1e-6 and running.frequencies[0] == 0.0 and sens["belt.EA"][0] == 0.0
    assert running.frequencies[1] > 0.5 * rest.frequencies[1]  # the next one is a vibration


def test_a_saved_state_in_numpy_arrays_is_taken_as_it_is(installed):
    """A state read back from a run's trajectory (numpy arrays) gives the same modes as the device one."""
    drive, state = installed
    host = jax.tree.map(np.asarray, state)
    np.testing.assert_array_equal(
        linear_modes(drive, state=host, count=3).frequencies, linear_modes(drive, state=state, count=3).frequencies
    )


@pytest.mark.long
def test_the_rotational_mode_is_the_runs_own_ring_down():
    """The modes hold the contacts stuck as the runs' Coulomb law does (no tangential compliance): Benchmark A
    with a soft contact (1e7 N/m^2), the driver held, a 0.05 N m torque step on the driven pulley (small enough
    that the wraps' microslip does not soften it: at 5 N m the ring is 4.7 % lower), no belt damping: the
    driven pulley rings at the first mode's frequency within 0.1 % (measured 0.01 %; with tangential springs of
    the contact stiffness the modes were 6.6 % lower)."""
    from scipy.optimize import least_squares

    spec = jb.benchmark_a(n_elements=N_ELEMENTS, t_end=0.8, save_dt=5e-4)
    spec.contact.stiffness = 1e7
    spec.pulleys[0].speed = 0.0
    driven = spec.pulleys[1]
    driven.load, driven.viscous, driven.torque = None, 0.0, {"smooth_step": [0.1, 0.101, 0.0, 0.05]}
    spec.belt.axial_damping, spec.gravity = 0.0, (0.0, 0.0)
    drive = jb.build_drive(spec)
    f_mode = linear_modes(drive, count=2).frequencies[0]
    res = jb.run(spec)
    t, w = (np.asarray(res.signals[k]) for k in ("t", "omega:driven"))
    keep = t > 0.11
    t, x = t[keep], w[keep] - w[keep].mean()

    def ring(p):
        f, decay, a, b = p
        return np.exp(-decay * (t - t[0])) * (a * np.cos(2 * np.pi * f * t) + b * np.sin(2 * np.pi * f * t)) - x

    fit = least_squares(ring, [f_mode, 0.0, x.std(), 0.0])
    assert np.sqrt(np.mean(fit.fun**2)) < 0.05 * x.std()  # one mode rings (measured 1 % residual)
    assert fit.x[0] == pytest.approx(f_mode, rel=1e-3)
