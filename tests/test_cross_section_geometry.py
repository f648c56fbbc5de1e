"""A rail foot thicker than the drawing, diagnosed on data from another WFE discretisation
(benchmarks.blind generators, form='cross': a straight-sided 7.5 mm mesh, 8 springs at the
foot nodes), where the foot's cut-on shift and the model-form discrepancy share the 5 kHz
bands (railfem.diagnosis.residual.along_discrepancy, railfem.diagnosis.refit.
widen): the effect is named, its interval holds the truth although the other mesh
puts the cut-on elsewhere, and clean data of the same form are not given a foot change."""
from __future__ import annotations

import numpy as np
import pytest

from benchmarks.blind import generators as g
from railfem.standards import iec61260

MODEL = "wfe-discrete"
TRUTH = g.CASES["section_geometry"]["foot_thickness"]
KEY = ("section_geometry", "foot_thickness")


def grid(step_low: int = 3, low: float = 100.0):
    """Ninth-octave lines to 6.3 kHz, every ``step_low``-th below 2.9 kHz (the cut-on's
    peak is about 100 Hz wide: above 2.9 kHz every line is kept)."""
    f9 = iec61260.ninth_octave_grid(low, 6300.0)
    return np.concatenate([f9[f9 < 2900][::step_low], f9[f9 >= 2900]])


def cross_data(case: str, seed: int, f, every: int = 1):
    """The cross-model dataset of ``case``; ``every``: keep every n-th transfer position
    (the point mobility always)."""
    return g.thinned(g.dataset(case, seed, f=f, model=MODEL, form="cross"), every)


def run(case, seed, f, effects, every=1):
    from railfem.diagnosis import diagnose

    return diagnose(cross_data(case, seed, f, every), model=MODEL, effects=effects,
                    pairs=False, n_starts=2)


def check_named(d):
    assert d.chosen is not None and d.chosen.name == "section_geometry", d.statement
    assert d.verdict in ("explained", "partly explained"), d.statement
    assert d.chosen_row["final_held_out"]["reduction"] >= 0.5
    lo, hi = d.chosen.grid_profiles[KEY]["ci95"]
    assert lo <= TRUTH <= hi, (d.chosen.grid[KEY], lo, hi)
    along = d.chosen_row["final_held_out"]["discrepancy"]["along"]
    assert along["z2"] > along["threshold"], along


def check_clean(d):
    assert d.chosen is None and d.verdict in ("noise", "consistent"), d.statement
    sg = next((r for r in d.candidates if r["name"] == "section_geometry"), None)
    assert sg is None or not sg["kept"], sg


def test_the_gate_tells_a_thicker_foot_from_the_other_meshs_cut_on():
    """The gate alone, on the geometry of a cross-model hammer test (WFE, lines near the
    cut-on): against the base's discretisation variants, a foot 3.5 mm thicker (where a
    foot 2.5 mm thicker in the other mesh is estimated) lies far outside the variants'
    spread along its change (z^2 > t^2(0.975, 3) = 10.1), a foot 0.5 mm thicker (what
    the clean other mesh's cut-on offset is fitted as) inside it, although both change
    the prediction by more than a tenth of the discrepancy summed over the bands: the
    summed ratio alone would keep both."""
    from railfem.diagnosis import effects
    from railfem.diagnosis import residual as R
    from railfem.diagnosis.data import prepare
    from railfem.diagnosis.evaluate import Evaluator
    from railfem.diagnosis.problem import ensemble
    from railfem.identify.problem import Prediction, Scale

    f9 = iec61260.ninth_octave_grid(100.0, 6300.0)
    f = np.concatenate([f9[f9 < 3500][::9], f9[f9 >= 3500]])
    data = prepare(cross_data("none", 0, f, every=3))
    spec, ev = g.truth_spec(MODEL), Evaluator()
    sc = Scale({"point": 0.43, "transfer": 0.43, "tdr": 0.3},
               ensemble(data.records, ev, spec))
    sg = effects.get("section_geometry")

    def pred(s):  # each spec evaluated once: no eigen form (Evaluator.receptance_once)
        return {r.name: Prediction(level=a, power=a)
                for r in data.records for a in [ev.receptance_once(s, r)]}

    base = pred(spec)
    out = {t: R.beyond_discrepancy(data, base, pred(sg.apply(spec, {"foot_thickness": t})),
                                   sc) for t in (0.0005, 0.0035)}
    assert out[0.0035]["along"]["threshold"] == pytest.approx(3.182 ** 2, rel=1e-3)
    assert out[0.0035]["pass"] and out[0.0035]["along"]["z2"] > 30, out[0.0035]
    assert out[0.0005]["ratio"] > R.BEYOND_RATIO, out[0.0005]
    assert not out[0.0005]["pass"] and out[0.0005]["along"]["z2"] < 10.1, out[0.0005]


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_thicker_foot_on_cross_model_data(seed):
    """Every position, section_geometry against pad_frequency (seed 0 measured: named,
    estimate 3.52 mm, 95 % interval 2.42-4.61 mm (profile alone 3.30-3.72 mm, the
    variants' shift SD 0.34 mm), held-out error down 82 %, z^2 along the discrepancy 565
    against a threshold of 10.1). Seed 1 failed the held-out test (p = 0.026) while the
    screening held the rail loss factor at the base's, which had widened the misplaced
    cut-on (0.0245 for a truth of 0.02); with it freed (railfem.diagnosis.loop.
    screen_single) the foot is named there too."""
    check_named(run("section_geometry", seed, grid(), ("section_geometry", "pad_frequency")))


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_clean_cross_model_data_get_no_foot_change(seed):
    """No effect: no claim, 'noise' or 'consistent' (the other mesh's cut-on offset is a
    foot change inside the variants' spread)."""
    check_clean(run("none", seed, grid(), ("section_geometry", "pad_frequency")))


@pytest.mark.slow
def test_softer_rail_on_cross_model_data_is_unexplained():
    """A rail 20 % softer (outside the library; every cut-on 10 % lower): no claim."""
    d = run("rail_stiffness", 0, grid(), ("section_geometry", "pad_frequency", "rail_damper"))
    assert d.verdict == "unexplained" and d.chosen is None, d.statement
