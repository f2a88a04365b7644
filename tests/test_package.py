"""Package facts: the version comes from the installed distribution's metadata (pyproject.toml),
importing jaxbelt leaves JAX's global configuration alone, the top level offers the curated 31 names (40 with the rooms)
and every room (subpackage) re-exports its expert names."""

import ast
import importlib.metadata
import os
import subprocess
import sys


def test_version_is_the_distributions():
    import jaxbelt

    assert jaxbelt.__version__ == importlib.metadata.version("jaxbelt")


def test_import_does_not_enable_float64():
    code = "import jax, jaxbelt; print(jax.config.jax_enable_x64)"
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        check=True,
        env={k: v for k, v in os.environ.items() if k != "JAX_ENABLE_X64"},
    )
    assert out.stdout.strip() == "False", out.stdout + out.stderr


# The curated top level: what a user needs to describe, build, run, fit and sweep a drive.
PUBLIC = {
    "DriveSpec",
    "BeltSpec",
    "PulleySpec",
    "TensionerSpec",
    "ContactSpec",
    "SolverSpec",
    "load_config",
    "dump_toml",
    "build_drive",
    "benchmark_a",
    "Drive",
    "ConfigError",
    "run",
    "RunResult",
    "simulate",
    "simulate_signals",
    "signal_names",
    "summary",
    "contact_distribution",
    "ContactState",
    "identify",
    "Measurement",
    "IdentifyResult",
    "sweep",
    "SweepResult",
    "get_parameter",
    "set_parameter",
    "set_parameters",
    "parameter_keys",
    "enable_compilation_cache",
    "use_fast_cpu_compile",
}
ROOMS = ["analysis", "belt", "config", "contact", "dynamics", "geometry", "outputs", "pulleys"]
SUBPACKAGES = ROOMS + ["contact.friction"]


def _names(module) -> set:
    """Public names a module offers: no underscore, no submodule."""
    import types

    return {n for n in dir(module) if not n.startswith("_") and not isinstance(getattr(module, n), types.ModuleType)}


def test_top_level_is_the_curated_set():
    import jaxbelt

    assert _names(jaxbelt) == PUBLIC
    # what a fresh ``import jaxbelt`` offers, names and rooms together (later imports of jaxbelt.cli, .viz,
    # ... add attributes in this process)
    code = "import jaxbelt; print(sorted(n for n in dir(jaxbelt) if not n.startswith('_')))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    offered = ast.literal_eval(out.stdout)
    assert len(offered) <= 40 and PUBLIC <= set(offered), offered
    for room in ROOMS:  # the rooms are reachable as attributes (jaxbelt.outputs.two_pulley_creep)
        assert getattr(jaxbelt, room).__name__ == f"jaxbelt.{room}"


def test_every_public_name_imports():
    code = "from jaxbelt import " + ", ".join(sorted(PUBLIC))
    exec(code, {})


def test_subpackages_have_docstrings_and_their_names_resolve():
    import importlib

    for sub in SUBPACKAGES:
        module = importlib.import_module(f"jaxbelt.{sub}")
        assert module.__doc__ and len(module.__doc__) > 80, f"jaxbelt.{sub}: the docstring says what the room holds"
        names = _names(module) - {"annotations"}
        assert names, f"jaxbelt.{sub} re-exports nothing"
        for name in names:
            value = getattr(module, name)
            if callable(value):  # a re-export of jaxbelt's own, not of a third-party name imported in passing
                assert value.__module__.startswith("jaxbelt."), (sub, name, value.__module__)


def test_moved_names_live_in_their_rooms():
    import jaxbelt

    moved = {
        "belt": ["BeltParams", "belt_operators", "internal_forces"],
        "geometry": ["BeltPath", "belt_path", "check_belt_path", "place_belt", "point_on_path", "LayoutError"],
        "analysis": ["DataError"],
        "pulleys": ["timelaw", "CARRIERS", "FixedCarrier", "ArmCarrier", "SliderCarrier"],
        "contact": ["solve_contact", "friction"],
        "dynamics": [
            "MoreauJean",
            "drive_operators",
            "drive_step",
            "stable_time_step",
            "simulate_free_belt",
            "FreeBeltState",
            "free_belt_energies",
            "DriveModel",
            "DriveParams",
            "PulleyParams",
            "DriveState",
            "Fault",
            "Trajectory",
        ],
        "outputs": [
            "CreepTheory",
            "capstan_tension",
            "creep_theory_for",
            "euler_eytelwein_ratio",
            "two_pulley_creep",
            "signals",
            "span_names",
            "span_tensions",
            "initial_state",
        ],
    }
    for room, names in moved.items():
        for name in names:
            assert hasattr(getattr(jaxbelt, room), name), f"jaxbelt.{room}.{name}"
            assert not hasattr(jaxbelt, name), f"jaxbelt.{name} left the top level"
    assert set(jaxbelt.contact.friction.FRICTION_LAWS) == {"coulomb", "regularized", "static-kinetic"}
