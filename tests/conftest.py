"""Test configuration: float64 everywhere (the library itself never flips global config)."""
import jax

jax.config.update("jax_enable_x64", True)
