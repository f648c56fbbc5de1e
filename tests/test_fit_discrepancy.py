"""The fit's model-form discrepancy (railfem.identify.fit, discrepancy='ensemble' as
``railfem diagnose``): blind fits of data made by another WFE implementation
(benchmarks/blind/generators.py, form='cross': a straight-sided 7.5 mm section mesh, 8
springs per support at the foot nodes), the truth generators.TRUTH never given to the
fitter. With the discrepancy the base parameters (kp, eta_p, kb, eta_b, eta_r) lie inside
their 95 % intervals; the same data fitted without it (noise alone) get intervals that
exclude the truth. Plus the option's checks, the reported profile of the rail loss factor
and what fit.json / the summary say."""
from __future__ import annotations

import importlib

import numpy as np
import pytest

from benchmarks.blind import generators as g

F = importlib.import_module("railfem.identify.fit")  # the module (identify.fit is the function)

BASE = ("kp", "eta_p", "kb", "eta_b", "eta_r")
SMALL_F = g.frequencies(low=50.0, high=4000.0)[::3]  # 20 lines: the default run


def _cross(seed, f):
    (meas,) = g.dataset("none", seed, f=f, model="wfe-discrete", form="cross")
    return meas


def _inside(res) -> dict:
    return {n: res.parameter(n)["ci95"][0] <= g.TRUTH[n] <= res.parameter(n)["ci95"][1]
            for n in BASE}


def _fit(meas, forward, discrepancy):
    return F.fit(meas, forward=forward, n_starts=2, workers=1, profiles=(),
                 discrepancy=discrepancy)


def _forward(meas):
    return F.prepare(meas, "wfe-discrete", parameters=F.DEFAULT_PARAMETERS, base=None,
                     bounds=None, use=None, cache=False, forward=None,
                     target_options=None)[0]


@pytest.fixture(scope="module")
def cross_fits():
    """Seed 0 of the clean cross-model data, 5 % noise, fitted with and without the
    discrepancy (one forward model: the kernels of the rail-loss profile shared)."""
    meas = _cross(0, SMALL_F)
    fwd = _forward(meas)
    return _fit(meas, fwd, "ensemble"), _fit(meas, fwd, None)


def test_cross_model_intervals_hold_the_truth_with_the_discrepancy(cross_fits):
    with_d, _ = cross_fits
    assert all(_inside(with_d).values()), with_d.parameters
    d = with_d.discrepancy
    assert d["method"] == "ensemble"
    assert d["variants"] == ["straight edges", "mesh 15 mm", "node springs 8"]
    assert set(d["sd_db"]) == {"point", "transfer", "tdr"}
    for sd in d["sd_db"].values():
        assert len(sd) == len(d["bands_hz"]) and max(sd) > 0.5  # dB: the forms differ
    assert with_d.analysis["discrepancy_terms"] == 3


def test_cross_model_intervals_without_the_discrepancy_exclude_the_truth(cross_fits):
    """The same data and fitter with noise alone: the intervals are several times narrower
    and kp's (biased by the other discretisation) excludes the truth."""
    with_d, without = cross_fits
    assert without.discrepancy["method"] == "none"
    inside = _inside(without)
    assert not inside["kp"] and sum(inside.values()) <= 3, without.parameters
    hw = {n: np.log10(p["ci95"][1] / p["ci95"][0]) for n, p in
          ((n, without.parameter(n)) for n in ("kp", "eta_p"))}
    for n, w in hw.items():
        p = with_d.parameter(n)
        assert np.log10(p["ci95"][1] / p["ci95"][0]) > 3 * w, (n, p, w)


def test_rail_loss_estimate_is_the_minimum_of_its_reported_profile(cross_fits):
    """Under the discrepancy's scales as well: the reported rail loss factor is where the
    reported profile (every cost under the final scales) is lowest, the fit's cost is that
    minimum, and its interval (the profile's, widened by the discrepancy) holds it."""
    with_d, _ = cross_fits
    sp = with_d.slow_profile
    p = with_d.parameter("eta_r")
    k = int(np.argmin(sp["cost"]))
    assert p["value"] == pytest.approx(sp["value"][k], rel=1e-12)
    assert with_d.cost == pytest.approx(min(sp["cost"]), rel=1e-9)
    assert p["ci95"][0] <= p["value"] <= p["ci95"][1]
    prof = with_d.profiles["eta_r"]["ci95"]
    assert p["ci95"][0] <= prof[0] and prof[1] <= p["ci95"][1]


def test_fit_json_and_summary_state_the_discrepancy(cross_fits):
    from railfem.jobs.fit import discrepancy_bands, discrepancy_line, fit_summary

    with_d, without = cross_fits
    doc = with_d.to_dict()["model_form_discrepancy"]
    assert doc["variants"] and len(doc["bands_hz"]) == len(doc["sd_db"]["point"])
    line = discrepancy_line(with_d.discrepancy)
    assert "straight edges" in line and "transfer RMS" in line
    assert "none" in discrepancy_line(without.discrepancy)
    assert line in fit_summary(with_d, "data")
    per_band = discrepancy_bands(with_d.discrepancy, with_d.target.bands.nominal)  # the plot
    assert set(per_band) == {"point", "transfer", "tdr"}
    assert np.isfinite(per_band["point"]).sum() == len(doc["bands_hz"])
    assert discrepancy_bands(without.discrepancy, with_d.target.bands.nominal) == {}


@pytest.mark.slow
def test_cross_model_coverage_over_seeds():
    """Ten seeds on every other line of 50-4000 Hz (30 lines): all five base parameters
    inside their intervals in at least 9 of 10 runs with the discrepancy (measured 9/10,
    eta_b out once; benchmarks/results/results_fit.txt, section "cross"); without it kp
    outside in at least 8 (measured 10/10)."""
    f = g.frequencies(low=50.0, high=4000.0)[::2]
    fwd, hits, misses = None, 0, 0
    for seed in range(10):
        meas = _cross(seed, f)
        fwd = fwd or _forward(meas)
        hits += all(_inside(_fit(meas, fwd, "ensemble")).values())
        misses += not _inside(_fit(meas, fwd, None))["kp"]
    assert hits >= 9 and misses >= 8, (hits, misses)


def test_fit_and_diagnose_agree_on_the_base_within_their_intervals():
    """The same cross-model data (beam form: section constants from a straight 7.5 mm
    mesh) through ``fit`` and ``diagnose``, both with their default base and discrepancy:
    the 95 % intervals of the four support parameters overlap and hold the truth (on the
    WFE form, seed 0, 20 lines, measured: each estimate inside the other's interval)."""
    from railfem.diagnosis import diagnose

    meas = g.dataset("none", 0, f=SMALL_F, form="cross")[0]
    fitted = F.fit(meas, "timoshenko-discrete", n_starts=2, workers=1, profiles=())
    base = {p["name"]: p for p in diagnose([meas], model="timoshenko-discrete",
                                           effects=("noise_floor",), n_starts=2)
            .base.parameters()}
    for n in ("kp", "eta_p", "kb", "eta_b"):
        a, b = fitted.parameter(n)["ci95"], base[n]["ci95"]
        assert max(a[0], b[0]) <= min(a[1], b[1]), (n, a, b)
        assert a[0] <= g.TRUTH[n] <= a[1] and b[0] <= g.TRUTH[n] <= b[1], (n, a, b)


def test_bad_discrepancy_options_are_named():
    meas = g.measurement(*g.clean(g.truth_spec(), SMALL_F[:6]), SMALL_F[:6])
    with pytest.raises(ValueError, match="discrepancy 'gaussian'"):
        F.fit(meas, "timoshenko-continuous", discrepancy="gaussian", workers=1)
    with pytest.raises(ValueError, match="band weights other than 0 and 1"):
        F.fit(meas, "timoshenko-continuous", workers=1, use=("point", "tdr"),
              target_options={"band_weights": {100: 0.5}})


def test_fit_and_diagnose_take_the_same_discrepancy_flag():
    from railfem.cli import build_parser

    p = build_parser()
    for cmd in ("fit", "diagnose"):
        assert p.parse_args([cmd, "d"]).discrepancy == "ensemble"
        assert p.parse_args([cmd, "d", "--discrepancy", "none"]).discrepancy == "none"
