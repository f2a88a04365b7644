"""``jaxbelt.use_fast_cpu_compile`` / ``jaxbelt._xla.add_xla_flags``: flags reach ``XLA_FLAGS`` only before
JAX starts its backend, never over a flag the user set, and only for the jaxlib versions they were checked
with (an unknown ``XLA_FLAGS`` entry aborts the process)."""

import os
import subprocess
import sys

import pytest

from jaxbelt import _xla


@pytest.fixture
def fresh(monkeypatch):
    """As in a process whose backend has not started (this test process's has)."""
    monkeypatch.setattr(_xla, "_backend_started", lambda: False)
    return monkeypatch


def test_flags_are_appended_to_the_users_flags(fresh):
    fresh.setenv("XLA_FLAGS", "--xla_dump_to=/tmp/x")
    assert _xla.add_xla_flags("--xla_a=1", "--xla_b=true") == ["--xla_a=1", "--xla_b=true"]
    assert os.environ["XLA_FLAGS"] == "--xla_dump_to=/tmp/x --xla_a=1 --xla_b=true"
    assert _xla.add_xla_flags("--xla_a=2") == []  # already there (by name): the first value stays
    assert os.environ["XLA_FLAGS"].split() == ["--xla_dump_to=/tmp/x", "--xla_a=1", "--xla_b=true"]


def test_a_flag_the_user_set_wins(fresh):
    fresh.setenv("XLA_FLAGS", "--xla_cpu_use_fusion_emitters=true")
    fresh.setattr(_xla, "_jaxlib_version", lambda: _xla._CHECKED_JAXLIB[0])
    others = [f for f in _xla.CPU_COMPILE_FLAGS if not f.startswith("--xla_cpu_use_fusion_emitters=")]
    assert _xla.use_fast_cpu_compile() == others  # the flags the user did not name are still added
    assert os.environ["XLA_FLAGS"].split() == ["--xla_cpu_use_fusion_emitters=true", *others]


@pytest.mark.parametrize("version, expect", [((0, 4), False), (None, False), ((9, 0), False), ("checked", True)])
def test_only_checked_jaxlib_versions_get_the_flags(fresh, version, expect):
    fresh.delenv("XLA_FLAGS", raising=False)
    v = _xla._CHECKED_JAXLIB[0] if version == "checked" else version
    fresh.setattr(_xla, "_jaxlib_version", lambda: v)
    added = _xla.use_fast_cpu_compile()
    assert added == (list(_xla.CPU_COMPILE_FLAGS) if expect else [])
    assert os.environ.get("XLA_FLAGS", "") == " ".join(added)


def test_nothing_is_added_once_the_backend_has_started(monkeypatch):
    import jax.numpy as jnp

    jnp.zeros(1).block_until_ready()  # this process's backend runs
    monkeypatch.setenv("XLA_FLAGS", "")
    assert _xla.add_xla_flags("--xla_a=1") == [] and os.environ["XLA_FLAGS"] == ""


def test_a_fresh_process_compiles_and_runs_with_the_flags():
    code = (
        "import os, jaxbelt, jax, jax.numpy as jnp\n"
        "added = jaxbelt.use_fast_cpu_compile()\n"
        "x = jax.jit(lambda a: jnp.sin(a) * 2 + a)(jnp.arange(3.0))\n"
        "print(added, os.environ.get('XLA_FLAGS'), [round(float(v), 6) for v in x])\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True).stdout
    added = list(_xla.CPU_COMPILE_FLAGS) if _xla.checked_jaxlib() else []
    assert out.startswith(str(added))
    assert out.strip().endswith("[0.0, 2.682942, 3.818595]")  # 2 sin(a) + a


class _Spy:
    """A lowered program that records the options it is compiled with; ``refuse``: XLA does not know them."""

    def __init__(self, refuse=False):
        self.calls, self.refuse = [], refuse

    def compile(self, compiler_options=None):
        self.calls.append(compiler_options)
        if compiler_options and self.refuse:
            raise RuntimeError("INVALID_ARGUMENT: No such compile option: 'xla_cpu_use_fusion_emitters'")
        return "compiled"


def test_forward_programs_get_the_option_where_xla_knows_it(monkeypatch):
    monkeypatch.setattr(_xla, "_unknown_option", False)
    monkeypatch.delenv("JAXBELT_FAST_COMPILE", raising=False)
    spy = _Spy()
    assert _xla.compile_forward(spy) == "compiled" and spy.calls == [_xla.FAST_COMPILE_OPTIONS]
    refused = _Spy(refuse=True)  # an XLA without the option: compiled as usual, and not asked again
    assert _xla.compile_forward(refused) == "compiled" and refused.calls == [_xla.FAST_COMPILE_OPTIONS, None]
    again = _Spy()
    assert _xla.compile_forward(again) == "compiled" and again.calls == [None]


@pytest.mark.parametrize("value, used", [("0", False), ("False", False), (" off ", False), ("1", True), ("", True)])
def test_the_environment_turns_the_option_off(monkeypatch, value, used):
    monkeypatch.setattr(_xla, "_unknown_option", False)
    monkeypatch.setenv("JAXBELT_FAST_COMPILE", value)
    spy = _Spy()
    assert _xla.compile_forward(spy) == "compiled" and spy.calls == [_xla.FAST_COMPILE_OPTIONS if used else None]


def test_other_compile_errors_are_not_swallowed(monkeypatch):
    monkeypatch.setattr(_xla, "_unknown_option", False)
    monkeypatch.delenv("JAXBELT_FAST_COMPILE", raising=False)

    class Failing(_Spy):
        def compile(self, compiler_options=None):
            raise RuntimeError("RESOURCE_EXHAUSTED: out of memory")

    with pytest.raises(RuntimeError, match="out of memory"):
        _xla.compile_forward(Failing())


def test_a_real_program_compiled_with_the_option_gives_the_same_numbers():
    import jax
    import jax.numpy as jnp
    import numpy as np

    x = jnp.linspace(0.0, 3.0, 7)
    lowered = jax.jit(lambda a: jnp.cumsum(jnp.sin(a) ** 2 + jnp.cos(2 * a)) / (1 + a)).lower(x)
    np.testing.assert_allclose(_xla.compile_forward(lowered)(x), lowered.compile()(x), rtol=1e-14, atol=1e-15)
