"""Issue 30: a drive parameter identified from a measured span spectrum (``analysis.span_spectrum``). Spectra made
by the span model at the statics' tension of a known parameter value give that value back; a spectrum whose modes
disagree is flagged; the command prints the fit and writes it."""

import json
import math

import jax
import pytest

import jaxbelt as jb
from jaxbelt.analysis.parameters import get_parameter, set_parameter
from jaxbelt.analysis.span_spectrum import fit_span_spectrum
from jaxbelt.analysis.span_tension import span_frequency, span_of
from jaxbelt.analysis.statics import statics

jax.config.update("jax_enable_x64", True)

EXAMPLE = "examples/accessory_drive.toml"
PRELOAD = "pulleys.tensioner.tensioner.preload"


def _spectrum(drive, params, name, modes=(1, 2, 3)):
    """The span's frequencies at the statics' tension and length of ``params`` (the span model's own)."""
    st = statics(drive, params=params)
    row = next(s for s in st.spans if s["name"] == name)
    sp = span_of(drive, name, length=row["length"])
    return row["tension"], {n: span_frequency(sp, row["tension"], n) for n in modes}


@pytest.fixture(scope="module")
def accessory():
    return jb.build_drive(jb.load_config(EXAMPLE))


@pytest.mark.long
def test_the_tensioner_preload_from_three_modes(accessory):
    """The accessory example's tensioner preload 20 % off its configured value: the first three modes of span
    ac-crank at the statics' tension (305 N) give the preload back within 1e-9 (measured 1.6e-14) and the span's
    tension within 1e-9; the modes agree (chi2 ~ 0); the uncertainty is the tension's (0.1 Hz per mode) over
    d T_span / d preload."""
    d = accessory
    p0 = float(get_parameter(d, d.params, PRELOAD))
    T, f = _spectrum(d, set_parameter(d, d.params, PRELOAD, 1.2 * p0), "ac-crank")
    fit = fit_span_spectrum(d, "ac-crank", f, PRELOAD, frequency_uncertainty=0.1)
    assert fit.converged and fit.consistent
    assert fit.value == pytest.approx(1.2 * p0, rel=1e-9)
    assert fit.tension == pytest.approx(T, rel=1e-9)
    assert fit.chi2 < 1e-12
    h = 1e-4 * abs(p0)  # d T_span / d preload by central differences of the statics
    up, down = (_spectrum(d, set_parameter(d, d.params, PRELOAD, 1.2 * p0 + s * h), "ac-crank")[0] for s in (1, -1))
    assert fit.uncertainty == pytest.approx(fit.tension_uncertainty / abs((up - down) / (2 * h)), rel=1e-4)


def test_the_installed_tension_of_a_fixed_centre_drive():
    """Benchmark A (fixed centres): its pretension from the first mode of the span driver-driven alone, 10 % above
    the configured value, within 1e-9."""
    d = jb.build_drive(jb.benchmark_a(n_elements=40))
    key = "belt.pretension"
    p0 = float(get_parameter(d, d.params, key))
    _, f = _spectrum(d, set_parameter(d, d.params, key, 1.1 * p0), "driver-driven", modes=(1,))
    fit = fit_span_spectrum(d, "driver-driven", f, key)
    assert fit.converged and fit.value == pytest.approx(1.1 * p0, rel=1e-9)


@pytest.mark.long
def test_modes_that_disagree_are_flagged(accessory):
    """A spectrum whose second mode is 2 Hz off (20 standard errors at 0.1 Hz): not consistent, chi2 large."""
    d = accessory
    _, f = _spectrum(d, d.params, "ac-crank")
    f[2] += 2.0
    fit = fit_span_spectrum(d, "ac-crank", f, PRELOAD, frequency_uncertainty=0.1)
    assert not fit.consistent and fit.chi2 > 100


def test_bad_inputs_are_refused(accessory):
    from jaxbelt._errors import ConfigError

    with pytest.raises(ConfigError, match="at least one mode"):
        fit_span_spectrum(accessory, "ac-crank", {}, PRELOAD)
    with pytest.raises(ConfigError, match="no such span"):
        fit_span_spectrum(accessory, "ac-moon", {1: 80.0}, PRELOAD)
    with pytest.raises(ConfigError, match="does not depend"):
        fit_span_spectrum(accessory, "ac-crank", {1: 80.0}, "pulleys.crank.inertia")


def test_the_command_fits_a_spectrum(tmp_path, capsys):
    """``jaxbelt span-tension CONFIG --span A-B --spectrum 1=F1,2=F2 --fit KEY`` prints and writes the fit."""
    from jaxbelt.cli import main

    d = jb.build_drive(jb.load_config(EXAMPLE))
    p0 = float(get_parameter(d, d.params, PRELOAD))
    _, f = _spectrum(d, set_parameter(d, d.params, PRELOAD, 0.9 * p0), "ac-crank", modes=(1, 2))
    spectrum = ",".join(f"{n}={v:.12g}" for n, v in f.items())
    out = tmp_path / "st"
    args = ["span-tension", EXAMPLE, "--span", "ac-crank", "--spectrum", spectrum, "--fit", PRELOAD, "--out", str(out)]
    assert main(args) == 0
    fit = json.loads((out / "span_fit.json").read_text())
    assert fit["value"] == pytest.approx(0.9 * p0, rel=1e-8) and fit["consistent"]
    assert PRELOAD in capsys.readouterr().out
    assert math.isfinite(fit["uncertainty"])
