"""Per-pulley friction coefficient ``pulleys.<name>.mu`` (overrides contact.mu on that pulley's contact
points): its slip limits follow Euler-Eytelwein with the pulley's own mu; checks and parameter keys."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from helpers import build_quietly, capstan_belt

import jaxbelt as jb
from jaxbelt import ConfigError, get_parameter, set_parameter, simulate_signals
from jaxbelt.config import validate_spec
from jaxbelt.contact import pulley_mu


def test_capstan_slips_at_euler_eytelwein_with_the_pulleys_own_mu():
    """As tests/test_drive_cases.py's capstan: A locked, a torque ramp on B. contact.mu = 0.8 holds B;
    A has its own mu = 0.3: the belt slides on A once T_tight/T_slack = exp(0.3 pi) (1 %)."""
    mu_a = 0.3
    spec = jb.DriveSpec(
        belt=capstan_belt(),
        pulleys=[
            jb.PulleySpec("A", (0, 0), 0.1, role="driver", inertia=0.1, speed=0.0, mu=mu_a),
            jb.PulleySpec("B", (0.3, 0), 0.1, role="driver", inertia=0.01, torque={"ramp": [0.0, 1.0, 0.0, 40.0]}),
        ],
        contact=jb.ContactSpec(mu=0.8, stiffness=1e8, damping=2e3),
        solver=jb.SolverSpec(t_end=0.9, save_dt=2e-3),
    )
    s = jb.run(spec).signals
    limit = math.exp(mu_a * math.pi)
    hi, lo = np.maximum(s["tension:A-B"], s["tension:B-A"]), np.minimum(s["tension:A-B"], s["tension:B-A"])
    ratio = hi / lo
    slipping = np.abs(s["omega:B"]) > 2.0
    assert slipping.any() and not slipping[s["t"] < 0.2].any()
    onset = np.argmax(slipping)
    assert ratio[:onset].max() < limit * 1.005
    assert ratio[onset - 10 : onset].mean() == pytest.approx(limit, rel=0.01)


LOAD = 15.0  # N m; capacity 2 T0 R tanh(mu pi / 2): 29.5 N m at mu = 0.6, 9.2 N m at mu = 0.15


@pytest.fixture(scope="module")
def driven_mu_runs():
    """Speed driver + loaded driven pulley; only the driven pulley's mu differs (0.6 and 0.15), one batched run."""
    spec = jb.DriveSpec(
        belt=capstan_belt(24),
        pulleys=[
            jb.PulleySpec("driver", (0, 0), 0.1, role="driver", inertia=0.1, speed=20.0),
            jb.PulleySpec(
                "driven", (0.3, 0), 0.1, role="driven", inertia=0.01, mu=0.6, load={"ramp": [0.05, 0.25, 0.0, LOAD]}
            ),
        ],
        contact=jb.ContactSpec(mu=0.6, stiffness=1e8, damping=2e3),
        solver=jb.SolverSpec(t_end=0.4, save_dt=2e-3),
    )
    drive = build_quietly(spec)

    def signals(mu):
        _, s = simulate_signals(drive, set_parameter(drive, drive.params, "pulleys.driven.mu", mu))
        return s

    s = jax.jit(jax.vmap(signals))(jnp.asarray([0.6, 0.15]))
    return drive, {k: np.asarray(v) for k, v in s.items()}


def test_only_the_driven_pulleys_mu_decides_whether_it_slips(driven_mu_runs):
    drive, s = driven_mu_runs
    assert get_parameter(drive, drive.params, "pulleys.driven.mu") == 0.6
    assert "pulleys.driven.mu" in jb.parameter_keys(drive) and "pulleys.driver.mu" not in jb.parameter_keys(drive)
    end = slice(-25, None)  # the last 50 ms, full load
    held, slid = s["omega:driven"][0, end].mean(), s["omega:driven"][1, end].mean()
    # mu 0.6: creep only, about (T1 - T2)/EA = LOAD/(R EA) = 3 % (measured 3.7 %: polygon, dynamics)
    assert 20.0 * (1 - 2 * LOAD / (0.1 * 5000.0)) < held < 20.0
    assert slid < 10.0  # mu 0.15: gross slip, the load wins
    # sliding on the driven pulley: the span tensions' ratio sits at exp(0.15 pi) (centrifugal part 0.4 N)
    hi = np.maximum(s["tension:driver-driven"][1, end], s["tension:driven-driver"][1, end])
    lo = np.minimum(s["tension:driver-driven"][1, end], s["tension:driven-driver"][1, end])
    assert (hi / lo).mean() == pytest.approx(math.exp(0.15 * math.pi), rel=0.02)


def test_own_mu_equal_to_contact_mu_gives_the_plain_coefficient_bit_for_bit():
    spec = jb.benchmark_a(n_elements=12)
    plain = build_quietly(spec)
    spec.pulleys[1].mu = spec.contact.mu
    own = build_quietly(spec)
    assert own.model.own_mu == (False, True) and plain.model.own_mu == ()
    np.testing.assert_array_equal(pulley_mu(own.model, own.params), pulley_mu(plain.model, plain.params))


@pytest.mark.parametrize("mu", [0.0, -0.2, float("nan"), "0.3"])
def test_bad_pulley_mu_refused(mu):
    spec = jb.benchmark_a(n_elements=12)
    spec.pulleys[1].mu = mu
    with pytest.raises(ConfigError, match=r"^pulleys\.driven\.mu = .*: must be a finite number > 0"):
        validate_spec(spec)
