"""Package facts: the version comes from the installed distribution's metadata (pyproject.toml), and
importing jaxbelt leaves JAX's global configuration alone."""
import importlib.metadata
import os
import subprocess
import sys


def test_version_is_the_distributions():
    import jaxbelt

    assert jaxbelt.__version__ == importlib.metadata.version("jaxbelt")


def test_import_does_not_enable_float64():
    code = "import jax, jaxbelt; print(jax.config.jax_enable_x64)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={k: v for k, v in os.environ.items() if k != "JAX_ENABLE_X64"})
    assert out.stdout.strip() == "False", out.stdout + out.stderr
