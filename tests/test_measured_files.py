"""Measured-signal files for identification (``signals.csv`` layout): clear errors, documented handling.

Reading (``jaxbelt.io.read_signals_csv``, ``DataError`` naming file, line and column): a header
with ``t`` first and unique names, numbers only, equal field counts, at least two rows, strictly
increasing finite times, the required columns present. **NaN is a missing sample**: an empty field
or ``nan`` in a signal column is read as NaN and the fit ignores that sample (``identify`` masks
non-finite data); a column with no finite value at all, or an infinite value, is refused.

Checking against a drive (``jaxbelt.analysis.identify.check_measurement``, ``ConfigError``, before anything
is simulated): times strictly increasing and inside ``[0, t_end]`` of the simulation, every
column a signal of this drive (nearest name suggested), one value per time.
"""

from __future__ import annotations

import importlib
import math
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import jaxbelt as jb
from jaxbelt import Measurement, cli
from jaxbelt.analysis import check_measurement
from jaxbelt.io import DataError, read_signals_csv, write_signals_csv

# the module itself: jaxbelt.analysis.identify (the attribute) is the function the room re-exports
_identify = importlib.import_module("jaxbelt.analysis.identify")

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT / "examples" / "two_pulley_benchmark.toml"
T_END = 0.5
COLUMNS = ["omega:driven", "tension:driver-driven", "torque:driver"]


@pytest.fixture(scope="module")
def drive():
    spec = jb.load_config(BENCH)
    spec.solver.t_end = T_END
    return jb.build_drive(spec)


def _csv(tmp_path: Path, text: str, name: str = "measured.csv") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


GOOD = "t,omega:driven,tension:driver-driven\n0.0,0.0,400\n0.1,1.5,410\n0.2,3.0,420\n"


# --------------------------------------------------------------------------- reading
def test_a_good_file_reads_back_exactly(tmp_path):
    t = np.linspace(0, T_END, 26)
    sig = {"t": t, "omega:driven": np.sin(t), "tension:driver-driven": 400 + t}
    path = write_signals_csv(tmp_path / "s.csv", sig)
    got = read_signals_csv(path, required=["omega:driven"])
    assert list(got) == list(sig)
    for k in sig:
        np.testing.assert_allclose(got[k], sig[k], rtol=1e-11)


@pytest.mark.parametrize(
    "text, message",
    [
        (GOOD.replace("t,", "time,", 1), r"line 1: the first column must be 't'"),
        (GOOD.replace(",", ";"), r"got 't;omega:driven;tension:driver-driven' \(columns separated by ';': separate"),
        (GOOD.replace("0.1,1.5", "0.3,1.5"), r"column 't' must increase strictly \(rows 2 and 3: 0.3, 0.2\)"),
        (GOOD.replace("0.1,1.5", "0.0,1.5"), r"column 't' must increase strictly \(rows 1 and 2: 0, 0\)"),
        (GOOD.replace("0.1,1.5", "nan,1.5"), r"column 't' has missing or non-finite times"),
        (GOOD.replace("0.1,1.5", ",1.5"), r"column 't' has missing or non-finite times"),
        (GOOD.replace("0.1,1.5", "inf,1.5"), r"column 't' has missing or non-finite times"),
        (GOOD.replace("0.1,1.5,410", "0.1,1.5"), r"line 3: 2 fields, the header has 3"),
        (GOOD.replace("1.5", "fast"), r"line 3, column 'omega:driven': 'fast' is not a number"),
        (GOOD.replace("tension:driver-driven", "omega:driven"), r"line 1: duplicate column names \['omega:driven'\]"),
        (GOOD.replace("tension:driver-driven", ""), r"line 1: empty column name"),
        ("t,omega:driven\n0.0,1.0\n", r"needs at least two data rows, found 1"),
        ("", r"empty file"),
        ("\n\n  \n", r"empty file"),
    ],
)
def test_malformed_files_are_data_errors_naming_file_and_place(tmp_path, text, message):
    path = _csv(tmp_path, text)
    with pytest.raises(DataError, match=message) as err:
        read_signals_csv(path)
    assert str(err.value).startswith(str(path) + ": ")
    assert "\n" not in str(err.value)


def test_missing_required_columns_are_named(tmp_path):
    path = _csv(tmp_path, GOOD)
    with pytest.raises(
        DataError,
        match=r"missing column\(s\) \['torque:driver'\]; present: \['omega:driven', "
        r"'tension:driver-driven'\]",
    ):
        read_signals_csv(path, required=["omega:driven", "torque:driver"])


def test_not_utf8_and_missing_file(tmp_path):
    path = tmp_path / "binary.csv"
    path.write_bytes(b"t,x\n0,\xff\xfe\n")
    with pytest.raises(DataError, match="not a UTF-8 text"):
        read_signals_csv(path)
    with pytest.raises(FileNotFoundError):
        read_signals_csv(tmp_path / "nowhere.csv")


def test_nan_and_empty_fields_are_missing_samples(tmp_path):
    """Documented handling: NaN (written ``nan`` or left empty) in a signal column is a missing sample."""
    path = _csv(tmp_path, "\ufeff t , omega:driven , tension:driver-driven\n0.0, nan ,400\n\n0.1,,410\n0.2,3.0,NaN\n")
    got = read_signals_csv(path)  # a byte-order mark, spaces and blank lines are fine too
    assert list(got) == ["t", "omega:driven", "tension:driver-driven"]
    np.testing.assert_array_equal(got["t"], [0.0, 0.1, 0.2])
    np.testing.assert_array_equal(np.isnan(got["omega:driven"]), [True, True, False])
    np.testing.assert_array_equal(np.isnan(got["tension:driver-driven"]), [False, False, True])


# --------------------------------------------------------------------------- checking against the drive
def _no_simulation(*args, **kwargs):
    raise AssertionError("identify simulated a measurement that fails its checks")


def _refused(drive, m: Measurement, message: str, t_end: float = T_END):
    with pytest.raises(jb.ConfigError, match=message) as err:
        check_measurement(drive, m, t_end)
    with mock.patch.object(_identify, "simulate_signals", _no_simulation), pytest.raises(jb.ConfigError):
        jb.identify(drive, m, ["contact.mu"], t_end=t_end)  # the same error, before any simulation
    assert str(err.value).startswith("measured: ")
    return str(err.value)


def test_time_range_outside_the_simulation(drive):
    t = np.linspace(0.0, 0.8, 9)
    msg = _refused(drive, Measurement(t, {"omega:driven": np.ones(9)}), "outside the simulation")
    assert "[0, 0.8] s" in msg and f"[0, {T_END:g}] s" in msg and "t_end" in msg
    _refused(drive, Measurement(t - 0.1, {"omega:driven": np.ones(9)}), r"times span \[-0.1, 0.7\] s, outside")


def test_unsorted_and_duplicate_times(drive):
    t = np.array([0.0, 0.2, 0.1, 0.3])
    # (numpy 2 shows the times as np.float64(...): cosmetic, in _identify.check_measurement)
    _refused(
        drive, Measurement(t, {"omega:driven": np.ones(4)}), r"increase strictly \(row 3: t = \S*0.1\S* after \S*0.2"
    )
    t = np.array([0.0, 0.1, 0.1, 0.3])
    _refused(
        drive, Measurement(t, {"omega:driven": np.ones(4)}), r"increase strictly \(row 3: t = \S*0.1\S* after \S*0.1"
    )
    _refused(drive, Measurement(np.array([0.0, np.nan, 0.2]), {"omega:driven": np.ones(3)}), "non-finite")
    _refused(drive, Measurement(np.array([0.1]), {"omega:driven": np.ones(1)}), "at least 2 samples")


def test_columns_must_be_signals_of_this_drive(drive):
    t = np.linspace(0, 0.4, 5)
    msg = _refused(drive, Measurement(t, {"omega:drivn": np.ones(5)}), "unknown column 'omega:drivn'")
    assert "did you mean 'omega:driven'" in msg
    _refused(drive, Measurement(t, {}), "no signal columns")
    _refused(drive, Measurement(t, {"omega:driven": np.ones(4)}), "has 4 values for 5 times")
    _refused(drive, Measurement(t, {"omega:driven": np.full(5, np.nan)}), "no finite value")
    _refused(drive, Measurement(t, {"omega:driven": np.array([1.0, np.inf, 1.0, 1.0, 1.0])}), "infinite")


def test_partly_missing_samples_pass_the_checks(drive):
    t = np.linspace(0, 0.4, 5)
    check_measurement(drive, Measurement(t, {"omega:driven": np.array([np.nan, 1.0, np.nan, 2.0, 3.0])}), T_END)


# --------------------------------------------------------------------------- property: any corruption, a clear outcome
@st.composite
def corrupted_file(draw):
    n = draw(st.integers(2, 12))
    dt = draw(st.floats(0.005, T_END / 12))
    t = np.round(np.arange(n) * dt, 9)
    cols = draw(st.lists(st.sampled_from(COLUMNS), min_size=1, max_size=3, unique=True))
    data = {"t": list(t)}
    for c in cols:
        data[c] = [draw(st.floats(-1e3, 1e3)) for _ in range(n)]
    kind = draw(
        st.sampled_from(
            [
                "ok",
                "nan_sample",
                "swap_times",
                "repeat_time",
                "late",
                "early",
                "drop_column",
                "unknown_column",
                "all_nan",
                "inf_value",
                "nan_time",
                "text",
            ]
        )
    )
    i = draw(st.integers(0, n - 2))
    c = draw(st.sampled_from(cols))
    required = list(cols)
    if kind == "nan_sample":
        data[c][i] = math.nan
    elif kind == "swap_times":
        data["t"][i], data["t"][i + 1] = data["t"][i + 1], data["t"][i]
    elif kind == "repeat_time":
        data["t"][i + 1] = data["t"][i]
    elif kind == "late":
        data["t"] = list(np.asarray(data["t"]) + T_END + draw(st.floats(0.001, 10)))
    elif kind == "early":
        data["t"] = list(np.asarray(data["t"]) - draw(st.floats(0.001, 10)))
    elif kind == "drop_column":
        del data[c]
    elif kind == "unknown_column":
        data[c.replace(":", ":x")] = data.pop(c)
    elif kind == "all_nan":
        data[c] = [math.nan] * n
    elif kind == "inf_value":
        data[c][i] = math.inf
    elif kind == "nan_time":
        data["t"][i] = math.nan
    text = ",".join(data) + "\n" + "".join(",".join(repr(float(v)) for v in row) + "\n" for row in zip(*data.values()))
    if kind == "text":
        lines = text.splitlines()
        row = lines[1 + i].split(",")
        row[-1] = "n/a"
        lines[1 + i] = ",".join(row)
        text = "\n".join(lines) + "\n"
    return kind, text, required


EXPECT = {  # kind: (where it is refused, text of the message); None: accepted
    "ok": None,
    "nan_sample": None,
    "swap_times": ("read", "must increase strictly"),
    "repeat_time": ("read", "must increase strictly"),
    "nan_time": ("read", "non-finite times"),
    "text": ("read", "is not a number"),
    "drop_column": ("read", "missing column(s)"),
    "late": ("check", "outside the simulation"),
    "early": ("check", "outside the simulation"),
    "unknown_column": ("check", "unknown column"),
    "all_nan": ("check", "no finite value"),
    "inf_value": ("check", "infinite values"),
}


@settings(max_examples=80, deadline=None, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(corrupted_file())
def test_any_corrupted_file_is_read_or_refused_clearly(drive, tmp_path, case):
    kind, text, required = case
    path = _csv(tmp_path, text)
    expect = EXPECT[kind]
    try:
        data = read_signals_csv(path, required=required if kind == "drop_column" else ())
    except DataError as err:
        assert expect is not None and expect[0] == "read", (kind, str(err))
        assert expect[1] in str(err) and str(err).startswith(str(path)), (kind, str(err))
        return
    assert expect is None or expect[0] == "check", (kind, text)
    t = data.pop("t")
    try:
        check_measurement(drive, Measurement(t, data), T_END)
    except jb.ConfigError as err:
        assert expect is not None and expect[1] in str(err), (kind, str(err))
        return
    assert expect is None, (kind, text)
    if kind == "nan_sample":
        assert sum(int(np.isnan(v).sum()) for v in data.values()) == 1


# --------------------------------------------------------------------------- the command line
@pytest.mark.parametrize(
    "text, expected",
    [
        ("t,omega:driven\n0.0,1\n0.2,2\n0.1,3\n", ["measured.csv", "must increase strictly"]),
        ("t,omega:driven\n0.0,1\n0.1,2\n0.1,3\n", ["measured.csv", "must increase strictly"]),
        ("time,omega:driven\n0.0,1\n0.1,2\n", ["measured.csv", "first column must be 't'"]),
        ("t,omega:driven\n0.0,1\n0.1,x\n", ["measured.csv", "line 3", "'x' is not a number"]),
        ("t,omega:driven\n0.0,1\n2.0,2\n", ["measured", "outside the simulation", "[0, 0.5] s"]),
        ("t,omega:drivn\n0.0,1\n0.1,2\n", ["unknown column 'omega:drivn'", "did you mean 'omega:driven'"]),
        ("t,omega:driven\n0.0,nan\n0.1,\n", ["no finite value"]),
    ],
)
def test_identify_command_refuses_bad_files_with_one_line(tmp_path, capsys, text, expected):
    path = _csv(tmp_path, text)
    out = tmp_path / "out"
    with mock.patch.object(_identify, "simulate_signals", _no_simulation):
        rc = cli.main(
            [
                "identify",
                str(BENCH),
                "--measured",
                str(path),
                "--fit",
                "contact.mu",
                "--t-end",
                str(T_END),
                "--out",
                str(out),
                "--quiet",
            ]
        )
    err = capsys.readouterr().err
    assert rc == cli.EXIT_USAGE, err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("jaxbelt identify: error: "), err
    for e in expected:
        assert e in lines[0], (e, lines[0])
    assert not out.exists()
