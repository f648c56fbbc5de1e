"""The base parameters' 95 % intervals (kp, eta_p, kb, eta_b, eta_r) hold the truth on data
from a WFE model of another form (benchmarks.blind generators, form='cross': a
straight-sided 7.5 mm mesh, 8 springs at the foot nodes), the truth generators.TRUTH never
given to the code under test.

Two causes were found (benchmarks/results/results_base_coverage.md):

* the diagnosis's start fit (railfem.identify.fit on the first record) ran without the
  model-form discrepancy, so its rail loss factor, which a WFE base keeps, followed the
  cut-on bands the other form misplaces (0.034 decades low on every clean cross seed) and
  the other base parameters were estimated beside it (eta_b +0.6 %, out of its interval);
* the discrepancy's share of a parameter's variance was added to the model-based noise
  variance only, and the cluster-robust one replaced both where it was larger: the rail
  loss factor kept the noise's share alone.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from benchmarks.blind import generators as g

BASE = ("kp", "eta_p", "kb", "eta_b", "eta_r")
MODEL = "wfe-discrete"
#: every second ninth-octave line 50 Hz - 5 kHz, every third position: the data of the
#: cross-model support tests' small runs (tests/test_diagnosis_cross_support.py)
SMALL_F = g.frequencies()[::2]
pytestmark = pytest.mark.xdist_group("cross-model diagnosis")


def _robust(J, r, clusters):
    """The cluster-robust (sandwich) covariance, written out here."""
    A = np.linalg.inv(J.T @ J)
    G = clusters.max() + 1
    S = np.array([J[clusters == k].T @ r[clusters == k] for k in range(G)])
    return A @ (S.T @ S * G / (G - 1)) @ A


def test_the_discrepancy_adds_to_the_cluster_robust_noise_variance():
    """Noise shared within clusters makes the cluster-robust variance the larger one; the
    discrepancy's variance (the estimate's shift under the variants, G G') is then added
    to it, not to the smaller model-based one (where the robust one swallowed it)."""
    from railfem.identify import uncertainty
    from railfem.identify.problem import Box
    from railfem.params import Parameter

    rng = np.random.default_rng(3)
    n, k = 240, 40
    clusters = np.repeat(np.arange(k), n // k)
    J = np.column_stack([np.ones(n), np.linspace(-1, 1, n)])
    r = rng.standard_normal(k)[clusters] + 0.2 * rng.standard_normal(n)  # shared noise
    r -= J @ np.linalg.lstsq(J, r, rcond=None)[0]  # the residual at the optimum
    Nd = 0.05 * np.column_stack([np.sin(np.arange(n) / 7.0), np.cos(np.arange(n) / 11.0)])
    box = Box([Parameter(name=f"p{i}", unit="-", log=False, lower=-10.0, upper=10.0)
               for i in range(2)])
    out = uncertainty.analyse(box, np.zeros(2), J, r, clusters=clusters, discrepancy=Nd)
    model = np.diag(np.linalg.inv(J.T @ J)) * (r @ r) / (n - 2)
    robust = np.diag(_robust(J, r, clusters))
    G = np.linalg.lstsq(J, Nd, rcond=None)[0]
    shift = np.sum(G ** 2, axis=1)
    assert np.all(robust > 2 * model)  # the case: noise shared within the clusters
    sd = np.array([p["std_vector"] for p in out["parameters"]])
    np.testing.assert_allclose(sd ** 2, robust + shift, rtol=1e-9)
    # a linear combination's SD carries it as well
    assert uncertainty.combination_std(out, [1.0, 0.0]) ** 2 == pytest.approx(
        robust[0] + shift[0], rel=1e-9)


def test_the_diagnosis_start_fit_carries_the_model_form_discrepancy():
    """The start of the diagnosis's base is ``railfem fit`` with the same discrepancy (its
    rail loss factor is what a WFE base keeps); with discrepancy=None neither has one."""
    from railfem.diagnosis import diagnose

    f = g.frequencies(high=2000.0)[::4]
    data = g.dataset("none", 0, f=f, model="timoshenko-discrete", form="cross")
    d = diagnose(data, model="timoshenko-discrete", effects=(), pairs=False, n_starts=1,
                 profile_final=False)
    assert d.base_fit.discrepancy["method"] == "ensemble"
    assert d.base_fit.discrepancy["variants"] == list(d.base.problem.scale.discrepancy
                                                       .variants)
    d0 = diagnose(data, model="timoshenko-discrete", effects=(), pairs=False, n_starts=1,
                  profile_final=False, discrepancy=None)
    assert d0.base_fit.discrepancy["method"] == "none"


def _base(seed: int, form: str = "cross") -> dict:
    """{name: parameter} of the WFE base of a diagnosis with no candidates (one start) on
    the clean data of ``seed`` (SMALL_F, every third position)."""
    from railfem.diagnosis import diagnose

    data = g.thinned(g.dataset("none", seed, f=SMALL_F, model=MODEL, form=form, cache=True), 3)
    d = diagnose(data, model=MODEL, effects=(), pairs=False, n_starts=1, cache=True)
    return {p["name"]: p for p in d.base.parameters() if p["name"] in BASE}


def _inside(p, name) -> bool:
    return p["ci95"][0] <= g.TRUTH[name] <= p["ci95"][1]


def _half_width(p) -> float:
    return math.log10(p["ci95"][1] / p["ci95"][0]) / 2


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 4])
def test_cross_model_base_intervals_hold_the_truth(seed):
    """Seeds where the pad loss factor's interval excluded the truth (estimate 0.11 and
    0.14 decades high, half-widths 0.098 and 0.085: the start's rail loss factor 0.061 and
    0.088 decades low) now hold every base parameter's truth."""
    base = _base(seed)
    assert all(_inside(base[n], n) for n in BASE), base
    assert _half_width(base["eta_r"]) < 0.1, base["eta_r"]


@pytest.mark.slow
def test_own_form_base_intervals_are_no_wider_than_needed():
    """The same reduced data made by the estimator's own configuration (seed 1): every
    truth inside, and half-widths (decades) no wider than stated (measured kp 0.074, eta_p
    0.093, kb 0.0040, eta_b 0.0058, eta_r 0.021)."""
    base = _base(1, form="own")
    limits = {"kp": 0.08, "eta_p": 0.10, "kb": 0.005, "eta_b": 0.007, "eta_r": 0.03}
    for n, w in limits.items():
        assert _inside(base[n], n) and _half_width(base[n]) < w, (n, base[n])


@pytest.mark.slow
def test_cross_model_base_coverage_over_ten_seeds():
    """The full clean cross-model data (29 positions, 50 Hz - 5 kHz, 5 % noise), seeds
    0-9: each base parameter inside its 95 % interval in at least 9 of 10 (measured: kp,
    eta_p, kb, eta_r 10/10, eta_b 9/10; benchmarks/results/results_base_coverage.md)."""
    from railfem.diagnosis import diagnose

    hits = dict.fromkeys(BASE, 0)
    for seed in range(10):
        data = g.dataset("none", seed, model=MODEL, form="cross", cache=True)
        d = diagnose(data, model=MODEL, effects=(), pairs=False, n_starts=2, cache=True)
        for p in d.base.parameters():
            if p["name"] in BASE:
                hits[p["name"]] += _inside(p, p["name"])
    assert all(v >= 9 for v in hits.values()), hits


#: the reduced data of the default-suite support tests (tests/test_diagnosis_cross_support.py
#: fast_run: every second line to 2.5 kHz, every third position): their kernels are shared
FAST_F = g.frequencies(high=2500.0)[::2]


def _half_width_of(outcome, name: str) -> float:
    return _half_width(next(p for p in outcome.parameters() if p["name"] == name))


def test_the_chosen_models_base_intervals_carry_its_own_variants_shift():
    """Both rails on flexible sleepers, cross-model data of seed 0 (reduced): the base
    absorbs the effect (kp about 224 MN/m), the chosen two_rail model estimates kp about
    430 MN/m as the base of clean data does (the other form's shift: truth 400). Its kp
    interval holds the truth and carries the model-form discrepancy as the clean data's
    base does, the two models' kp being shifted by the same form at the same value.
    Before, the chosen model's intervals took the base's variant differences (at the
    base's kp, another rail-on-pad resonance): kp's half-width 0.047 here against the
    clean base's 0.077, and 0.021 on the full data, outside in every run."""
    from railfem.diagnosis import diagnose

    def data(case):
        return g.thinned(g.dataset(case, 0, f=FAST_F, model=MODEL, form="cross", cache=True), 3)

    clean = diagnose(data("none"), model=MODEL, effects=(), pairs=False, n_starts=1,
                     cache=True)
    d = diagnose(data("two_rail"), model=MODEL, effects=("two_rail", "rail_damper"),
                 pairs=False, n_starts=1, cache=True)
    assert d.chosen is not None and d.chosen.name == "two_rail", d.statement
    kp = next(p for p in d.chosen.parameters() if p["name"] == "kp")
    assert _inside(kp, "kp"), kp
    assert _half_width(kp) >= 0.7 * _half_width_of(clean.base, "kp"), kp
    eta_p = next(p for p in d.chosen.parameters() if p["name"] == "eta_p")
    assert _inside(eta_p, "eta_p"), eta_p


def test_a_grid_parameters_t_quantile_counts_the_chosen_models_variants_once():
    """The chosen model's discrepancy columns (model_scale) are the base's three variants
    and the same three at its own estimate: six columns, three variants. Student's t of a
    grid parameter's widening (refit.rewiden_grid, discrepancy_terms) takes three degrees
    of freedom, not six (t 3.18 against 2.45)."""
    from types import SimpleNamespace

    from scipy import stats

    from railfem.diagnosis.intervals import discrepancy_terms, distinct_variants
    from railfem.diagnosis.problem import MODEL_VARIANT

    names = ("straight edges", "mesh 15 mm", "node springs 8")
    N6 = np.random.default_rng(1).standard_normal((40, 6))

    def problem(labels, N):
        return SimpleNamespace(scale=SimpleNamespace(discrepancy=SimpleNamespace(
            variants=labels)), discrepancy_columns=lambda: N)

    joined = problem(names + tuple(v + MODEL_VARIANT for v in names), N6)
    assert distinct_variants(joined, N6) == 3
    assert distinct_variants(problem(names, N6[:, :3]), N6[:, :3]) == 3
    assert distinct_variants(problem(names, N6), N6) is None  # per-cell columns
    k = stats.t.ppf(0.975, 3) / stats.t.ppf(0.975, 200)
    np.testing.assert_allclose(discrepancy_terms(joined, 200), N6 * k, rtol=1e-12)


def test_a_pads_variants_refine_its_rows():
    """Each discretisation variant of a track with a pad of finite length gives the pad
    one more spring row (a refinement, as a finer mesh), whatever its rows: a pad of two
    rows (the pad_length effect's) is compared with three, never with one row (which is
    no discretisation of a pad: it moved a chosen 0.18 m pad's length by +-0.2 m); point
    supports keep their rows."""
    import railfem as rf
    from railfem.identify import discrepancy

    for rows in (1, 2, 3):
        spec = rf.preset("site").replace(pad_length=0.15, n_rows=rows)
        assert [s.n_rows for _, s in discrepancy.variants(spec)] == [rows + 1] * 3
    point = rf.preset("site").replace(pad_length=0.0)
    assert {s.n_rows for _, s in discrepancy.variants(point)} == {point.n_rows}
