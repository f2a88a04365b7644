"""jaxbelt: differentiable planar belt-drive dynamics in JAX."""

__version__ = "0.1.0"
