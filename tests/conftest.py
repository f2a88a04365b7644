"""Test configuration: float64 everywhere (the library itself never flips global config), strict dtype
promotion (an int array meeting a float array, or float32 meeting float64, is an error in the tests rather
than a silent up-cast in the library), and a persistent compilation cache shared with the subprocesses the
CLI tests start (the same drive programs are compiled by several tests and processes; XLA compilation
dominates test time), and XLA's faster-compiling CPU code generator, as the command line uses it
(``jaxbelt.use_fast_cpu_compile``). These settings go through the environment so that those subprocesses inherit them.
The simulation's programs reach that cache without any further setting (``jaxbelt._equinox_checks``).
tests/ is put on sys.path so that test files can ``from helpers import ...`` whatever pytest's import mode."""

import os
import sys
import tempfile

os.environ.setdefault("JAX_COMPILATION_CACHE_DIR", os.path.join(tempfile.gettempdir(), "jaxbelt-test-jax-cache"))
os.environ.setdefault("JAXBELT_CACHE_DIR", os.environ["JAX_COMPILATION_CACHE_DIR"])  # the CLI's own cache: the same
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "1.0")
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES", "0")
os.environ.setdefault("JAX_NUMPY_DTYPE_PROMOTION", "strict")
# no programs stored traced (jaxbelt._export) in the suite: every cache starts empty on CI, where storing costs a
# second lowering per program and is rarely read back (80 -> 74 CPU s on four run/sweep/duty test files);
# tests/test_compile_cache.py turns it on in its own processes, which test exactly that
os.environ.setdefault("JAXBELT_STORED_PROGRAMS", "0")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from jaxbelt import use_fast_cpu_compile  # noqa: E402

use_fast_cpu_compile()  # as the command line: XLA_FLAGS, inherited by the subprocesses too

import jax  # noqa: E402

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_dtype_promotion", os.environ["JAX_NUMPY_DTYPE_PROMOTION"])


def pytest_addoption(parser):
    parser.addoption(
        "--long",
        action="store_true",
        help="also run the long physical checks (marker `long`; deselected by default so that the suite fits "
        "CI's 10 minutes on two cores): `python -m pytest -q -n auto --dist worksteal --long tests`",
    )


def pytest_collection_modifyitems(config, items):
    """Without --long, tests marked ``long`` are deselected (reported as such in pytest's summary line)."""
    if config.getoption("--long"):
        return
    keep, long = [], []
    for item in items:
        (long if item.get_closest_marker("long") else keep).append(item)
    if long:
        config.hook.pytest_deselected(items=long)
        items[:] = keep
