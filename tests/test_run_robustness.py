"""A run is refused before it starts when it cannot fit in memory or write its results, and a
finished run is never lost to a failing derived output (creep theory, plots, ...)."""
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import jax
import numpy as np
import pytest

import jaxbelt as jb
from jaxbelt import _drive

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "examples" / "two_pulley_benchmark.toml"


# ------------------------------------------------------------------ memory (item: 20 000 elements)
def _operator_array_bytes(n: int, m: int) -> int:
    """Bytes of the operator arrays ``drive_operators`` returns (shapes only: nothing is computed)."""
    spec = jb.benchmark_a(n_elements=n)
    spec.contact.points_per_element = m
    drive = jb.build_drive(spec)
    shapes = jax.eval_shape(jb.drive_operators, drive.model, drive.params)
    leaves = jax.tree.leaves(shapes)  # the matrices: both dimensions grow with n (not the quadrature tables)
    return sum(math.prod(x.shape) * np.dtype(x.dtype).itemsize for x in leaves if len(x.shape) == 2 and min(x.shape) >= n)


@pytest.mark.parametrize("m", [1, 2])
def test_operator_estimate_counts_the_arrays_the_step_builds(m):
    # The stored operators plus one (2n)^2 work array of the mass-matrix inversion: exactly.
    n = 40
    itemsize = np.dtype(jax.numpy.result_type(float)).itemsize
    assert _drive._operator_bytes(n, m, itemsize) == _operator_array_bytes(n, m) + itemsize * (2 * n) ** 2


def test_documented_maximum_is_refused_with_the_largest_count_that_fits(monkeypatch):
    free = 16e9
    monkeypatch.setattr(_drive, "_available_memory", lambda: (int(free), "memory"))
    with pytest.raises(jb.ConfigError) as err:
        jb.build_drive(jb.benchmark_a(n_elements=20_000, t_end=0.01))
    msg = str(err.value)
    assert msg.startswith("belt.n_elements = 20000:") and "\n" not in msg
    # float64: 8 (2n)^2 numbers of 8 bytes = 102 GB
    assert "needs about 103 GB" in msg and "operators 102 GB" in msg and "16 GB this machine has free" in msg
    fit = int(msg.split("at most ")[1].split()[0])
    assert 7000 < fit < 7100  # about sqrt(0.8 * 16e9 / 256): the operators dominate
    # that count passes the check, one more does not (the check only; nothing is built or run)
    spec = jb.benchmark_a(n_elements=fit, t_end=0.01)
    n_saves = 12  # 0.01 s every 1 ms, plus the start and the final state
    _drive._check_memory(spec, fit, 2, 2 * fit, n_saves, _drive._state_bytes(fit, 2, 2 * fit))  # no error
    with pytest.raises(jb.ConfigError, match=f"at most {fit} elements fit"):
        _drive._check_memory(spec, fit + 1, 2, 2 * fit + 2, n_saves, _drive._state_bytes(fit + 1, 2, 2 * fit + 2))


def test_long_trajectory_on_a_small_machine_names_save_dt(monkeypatch):
    monkeypatch.setattr(_drive, "_available_memory", lambda: (int(1e9), "memory"))
    spec = jb.benchmark_a(n_elements=30, t_end=50.0, save_dt=5e-5)
    with pytest.raises(jb.ConfigError, match=r"^solver.save_dt = 5e-05: the run needs about .* raise solver.save_dt "
                                             r"to at least ([0-9.e+-]+) s") as err:
        jb.build_drive(spec)
    spec.solver.save_dt = float(str(err.value).split("at least ")[1].split()[0])
    jb.build_drive(spec)  # the suggested save_dt passes


def test_available_memory_is_positive_and_below_physical():
    avail, _ = _drive._available_memory()
    total = os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    assert 0 < avail <= total
