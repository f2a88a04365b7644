"""float32 smoke test: jaxbelt runs under JAX's default precision (float64 is only switched on by the tests
and the CLI), and a short benchmark-A spin-up there matches the float64 run of the same drive.

Measured (16 elements, 0.3 s, driven pulley at ~5.5 rad/s): status ok, the driven speed differs from the
float64 run by at most 5e-6 of its peak over the record; the tolerance below is 1e-3 of the peak."""

import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import jaxbelt as jb

ROOT = Path(__file__).resolve().parents[1]

# n_elements=16 is below the polygon-effect advice (26): warned about, and irrelevant to a precision comparison.
SCRIPT = """
import sys, warnings
import jax
import numpy as np
import jaxbelt as jb
assert not jax.config.jax_enable_x64
warnings.simplefilter("ignore", UserWarning)
spec = jb.benchmark_a(n_elements=16, t_end=0.3)
spec.solver.expect_steady = False  # a spin-up on purpose
r = jb.run(spec)
np.savez(sys.argv[1], t=r.signals["t"], omega=r.signals["omega:driven"],
         finite=all(np.all(np.isfinite(np.asarray(v))) for v in r.signals.values()),
         status=r.summary["status"], dtype=str(r.trajectory.final.q.dtype))
"""


@pytest.mark.long
def test_float32_run_matches_float64(tmp_path):
    out = tmp_path / "f32.npz"
    env = {k: v for k, v in os.environ.items() if k != "JAX_ENABLE_X64"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    proc = subprocess.run([sys.executable, "-c", SCRIPT, str(out)], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr[-3000:]
    f32 = np.load(out)
    assert str(f32["dtype"]) == "float32"  # really ran in single precision
    assert str(f32["status"]) == "ok"
    assert bool(f32["finite"])

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        r64 = jb.run(jb.benchmark_a(n_elements=16, t_end=0.3))  # conftest enables float64 in this process
    t64, w64 = np.asarray(r64.signals["t"]), np.asarray(r64.signals["omega:driven"])
    np.testing.assert_allclose(np.asarray(f32["t"], dtype=float), t64, rtol=0, atol=1e-6)
    peak = np.max(np.abs(w64))
    assert peak > 5.0  # the driven pulley has spun up (driver ramp reaches 5.45 rad/s at 0.3 s)
    err = np.max(np.abs(np.asarray(f32["omega"], dtype=float) - w64)) / peak
    assert err < 1e-3, f"float32 driven speed differs from float64 by {err:.2e} of its peak"
