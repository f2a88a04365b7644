"""Issue 28's smaller items, each with the behaviour it fixes: build warnings in the summary, ..."""

import warnings

import jaxbelt as jb
from jaxbelt.config import load_config


def test_build_warnings_are_kept_on_the_drive_once():
    """A tensioner on the tight side warns (a Python warning) and the drive keeps the message, once,
    however often the Python warning itself is shown."""
    spec = load_config("examples/serpentine_tensioner.toml")
    spec.belt.direction = "cw"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the drive keeps it even where Python shows nothing
        drive = jb.build_drive(spec)
    assert len(drive.build_warnings) == 1
    assert "'tensioner' (a tensioner) sits on the tight side" in drive.build_warnings[0]
    spec.belt.direction = "ccw"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the example itself builds without any
        assert jb.build_drive(spec).build_warnings == ()


def test_build_warnings_reach_the_summary():
    """The polygon effect of 12 elements on 0.1 m pulleys (element 0.10 m > radius / 2) is a warning of
    the run's summary, once, in the second run of the process too (Python shows it only once)."""
    spec = jb.benchmark_a(n_elements=12, t_end=0.01)
    for _ in range(2):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r = jb.run(spec)
        polygon = [w for w in r.summary["warnings"] if "polygon effect" in w]
        assert len(polygon) == 2, r.summary["warnings"]  # driver and driven, each once
        assert "'driver'" in polygon[0] and "'driven'" in polygon[1]
