"""``dump_toml`` writes any spec as TOML that reads back to the same spec: strings with control
characters, quotes, backslashes and non-ASCII text included (the hand-written writer escaped only
backslash, quote and newline; a carriage return or another control character made a file that
``tomllib`` refuses). No simulation runs."""

from __future__ import annotations

import dataclasses

import pytest

import jaxbelt as jb
from jaxbelt import dump_toml, load_config

AWKWARD = [
    "ctrl\x00\x01\x08\x0b\x0c\x1f\x7f end",  # NUL, other C0 controls, DEL
    "cr\rlf\ntab\tend",
    "quote \" and \\ backslash \\\" and 'single'",
    "unicode Ωμ → 滑轮 😀 \u2028 \u00a0",
    '"""triple""" and [[pulleys]] = # not a comment',
]


@pytest.mark.parametrize("name", AWKWARD, ids=range(len(AWKWARD)))
def test_awkward_strings_round_trip_exactly(tmp_path, name):
    spec = jb.benchmark_a()
    pulleys = [dataclasses.replace(p, name=f"{name} {i}") for i, p in enumerate(spec.pulleys)]
    spec = dataclasses.replace(spec, pulleys=pulleys)
    path = tmp_path / "drive.toml"
    path.write_text("# effective configuration (a header as the CLI writes it)\n" + dump_toml(spec), encoding="utf-8")
    again = load_config(path)
    assert again == spec
    assert [p.name for p in again.pulleys] == [f"{name} {i}" for i in range(len(pulleys))]
