"""Support mechanisms on hammer data from another WFE discretisation (benchmarks.blind
generators, form='cross': a straight-sided 7.5 mm mesh, 8 springs at the foot nodes) on
wfe-discrete: a flexible sleeper and the second rail are named, foot damping is named and
not taken for rail dampers.

What went wrong before: the sleeper's first-mode frequency f1 was started at 73, 113 and
440 Hz, and a lightly damped sleeper mode's misfit basin is only about +-10 % wide, so the
fit never reached a 160 Hz mode (it ended worse than the rigid sleeper) and rail_damper,
one lightly damped absorber at 914 Hz standing in for the sleeper's second symmetric
mode, was claimed; foot damping was judged at the base's rail loss factor, which had
taken up part of the added damping, and lost to a band of overdamped absorbers. The
truths are the generator's (generators.CASES), never the code's."""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks.blind import generators as g

MODEL = "wfe-discrete"
COMPETING = ("rail_damper", "sleeper_flexibility", "two_rail", "foot_damping")
SEEDS = range(10)
#: the data and the diagnoses use the run's kernel cache (tests/conftest.py: a fresh folder
#: per run; kernels are content-keyed, a cached one is the same kernel), and the cross-model
#: files run on one xdist worker: the data of every case here have one kernel (FAST_F, every
#: position), the sleeper shares the base fit's kernels with pad_frequency of
#: tests/test_diagnosis_cross_pad.py (every second position), both rails with foot damping
#: (every third)
pytestmark = pytest.mark.xdist_group("cross-model diagnosis")


def small_f():
    """Every second ninth-octave line, 50 Hz - 5 kHz (31 lines)."""
    return g.frequencies()[::2]


def cross_data(case: str, seed: int, f, every: int = 1):
    """The cross-model dataset of ``case``; ``every``: keep every n-th transfer position
    (the point mobility always)."""
    return g.thinned(g.dataset(case, seed, f=f, model=MODEL, form="cross", cache=True),
                     every)


def small_run(case: str, seed: int = 0):
    """The competing support effects only, every second line, every third position, no
    pairs."""
    from railfem.diagnosis import diagnose

    return diagnose(cross_data(case, seed, small_f(), every=3), model=MODEL,
                    effects=COMPETING, pairs=False, n_starts=2, cache=True)


#: the default run's reduced problem: every second line to 2.5 kHz (27 lines), the effect
#: and rail_damper only, one start, no final rail-loss profile unless asked (about a
#: third of small_run's CPU; small_run's forms run with -m slow). Measured on seed 0: a
#: flexible sleeper needs every second position here (every third: 'noise'), both rails
#: every third (every second: rail_damper best by BIC, no claim).
FAST_F = g.frequencies(high=2500.0)[::2]


def fast_run(case: str, every: int, profile_final: bool = False):
    from railfem.diagnosis import diagnose

    return diagnose(cross_data(case, 0, FAST_F, every=every), model=MODEL,
                    effects=(case, "rail_damper"), pairs=False, n_starts=1,
                    profile_final=profile_final, cache=True)


def check_sleeper(d, name: str, tol: float = 0.05):
    """``name`` (a sleeper effect) chosen with the held-out error down >= 50 %, its
    first-mode frequency within ``tol`` of the truth and its loss factor within a factor 2
    (inside the bounds of a concrete sleeper's own damping); no rail damper claimed."""
    truth = g.CASES[name]
    assert d.chosen is not None and d.chosen.name == name, d.statement
    assert d.verdict in ("explained", "partly explained"), d.statement
    assert d.chosen_row["final_held_out"]["reduction"] >= 0.5, d.chosen_row["final_held_out"]
    f1 = d.chosen.theta()[name]["f1"]
    assert abs(f1 / truth["f1"] - 1) < tol, f1
    eta = d.chosen.theta()[name]["eta_s"]
    assert abs(np.log(eta / truth["eta_s"])) < np.log(2), eta


def test_the_sleeper_mode_frequency_is_scanned_finely_enough_for_its_basin():
    """The multi-start tries f1 values at most 10 % apart over the whole bound (the basin
    of a 160 Hz mode of loss factor 0.03 was about +-10 % wide); a scan value outside the
    bounds is refused."""
    from railfem.diagnosis.effects import EffectParameter, get

    for name in ("sleeper_flexibility", "two_rail"):
        p = {q.name: q for q in get(name).parameters}["f1"]
        scan = np.sort(p.scan)
        assert scan[0] <= p.lower * 1.1 and scan[-1] >= p.upper / 1.1, scan
        assert np.all(scan[1:] / scan[:-1] <= 1.1), scan
    with pytest.raises(ValueError, match="scan"):
        EffectParameter(name="f", unit="Hz", lower=10.0, upper=100.0, log=True, start=20.0,
                        meaning="-", scan=(5.0, 20.0))


def test_the_refit_starts_from_the_scan():
    """railfem.diagnosis.refit.fit_fixed starts from the scan values of a parameter (33 x 3
    start vectors scored, the base part unchanged) and keeps the best by cost: on a cost
    whose minimum is a 160 Hz mode it starts within 5 % of it."""
    from types import SimpleNamespace

    from railfem.diagnosis.effects import get
    from railfem.diagnosis.refit import fit_fixed

    eff = get("sleeper_flexibility")
    enc = [(p.parameter(), p.lower, p.upper) for p in eff.parameters]
    seen = []

    def cost(x):
        seen.append(10 ** x[4])
        return abs(x[4] - np.log10(160.0))

    stub = SimpleNamespace(
        box=SimpleNamespace(parameters=[None] * 4 + [q for q, _, _ in enc],
                            lower=np.array([0.0] * 4 + [q.encode(lo) for q, lo, _ in enc]),
                            upper=np.array([1.0] * 4 + [q.encode(hi) for q, _, hi in enc])),
        model=SimpleNamespace(effects=(eff,)), analytic=False, cost=cost,
        solve=lambda x0, **kw: (x0, cost(x0), SimpleNamespace(jac=None)))
    x, _, _ = fit_fixed(stub, np.zeros(4), n_keep=1)
    assert len(set(np.round(seen[:99], 6))) == 33
    assert abs(10 ** x[4] / 160.0 - 1) < 0.05 and np.all(x[:4] == 0)


@pytest.mark.slow
def test_a_flexible_sleeper_on_cross_model_data_is_named_not_a_rail_damper():
    check_sleeper(small_run("sleeper_flexibility"), "sleeper_flexibility")


def test_a_flexible_sleeper_on_reduced_cross_model_data_is_named_not_a_rail_damper():
    check_sleeper(fast_run("sleeper_flexibility", every=2), "sleeper_flexibility")


@pytest.mark.slow
def test_both_rails_on_cross_model_data_are_named():
    check_sleeper(small_run("two_rail"), "two_rail")


def test_both_rails_on_reduced_cross_model_data_are_named():
    check_sleeper(fast_run("two_rail", every=3), "two_rail")


@pytest.mark.slow
def test_foot_damping_on_cross_model_data_is_not_taken_for_rail_dampers():
    """Foot damping (0.4 added at 1 kHz): named, not rail_damper; the rail loss factor of
    the chosen model near the truth (0.02), not the base's inflated one."""
    check_foot_damping(small_run("foot_damping"))


def test_foot_damping_on_reduced_cross_model_data_is_not_taken_for_rail_dampers():
    """The same against rail_damper alone; the rail-loss profiles kept (profile_final: the
    screening's short profile of a damping effect is what the assertion is about)."""
    check_foot_damping(fast_run("foot_damping", every=3, profile_final=True))


def check_foot_damping(d):
    assert d.chosen is not None and d.chosen.name == "foot_damping", d.statement
    assert d.chosen_row["final_held_out"]["reduction"] >= 0.5
    assert abs(d.chosen.eta_r / g.TRUTH["eta_r"] - 1) < 0.2, d.chosen.eta_r


# ------------------------------------------------------------------ the 10-seed versions


def full_runs(case: str):
    from benchmarks.blind.study import run_case

    return [run_case(case, s, model=MODEL, form="cross") for s in SEEDS]


@pytest.mark.slow
@pytest.mark.parametrize("case", ("sleeper_flexibility", "two_rail", "foot_damping"))
def test_support_effects_on_cross_model_data_ten_seeds(case):
    """Default library, every position and line: named ('explained' or 'partly') in >=
    9/10 with the held-out error down >= 50 %, never rail_damper."""
    rows = full_runs(case)
    named = [r for r in rows if r["chosen"] == case and r["held_out_reduction"] >= 0.5]
    assert len(named) >= 9, [(r["seed"], r["chosen"], r["verdict"]) for r in rows]
    assert not any(r["claim"] not in (None, case) for r in rows), rows


@pytest.mark.slow
def test_rail_dampers_on_cross_model_data_are_still_named_ten_seeds():
    rows = full_runs("rail_damper")
    assert sum(r["claim"] == "rail_damper" for r in rows) >= 9, [r["chosen"] for r in rows]
