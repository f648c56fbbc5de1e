"""The blind study (slow): every effect of the library switched on behind the diagnosis's
back at a realistic size (29 EN 15461 positions, 1/9-octave 50 Hz - 5 kHz, head sensor,
timoshenko-discrete, 5 % noise), 10 seeds each; data with no effect; data with an effect
outside the library (a softer rail), with the default search and with every effect
screened (effects='all': random_support too, which the default leaves out; the case
random_support itself is always diagnosed that way). Generator: benchmarks/blind/generators.py (the door);
scoring: benchmarks/blind/study.py.

Criteria (issue 12): the right mechanism ranked first in >= 9/10; its parameters all
inside their reported joint 95 % intervals (Bonferroni over the effect's parameters) in
>= 9/10 of the runs where it was chosen; held-out error down >= 50 % (median); no effect
claimed on clean data in >= 9/10; an effect outside the library: 'unexplained' in >= 9/10
and no false claim ('explained') in any."""
import pytest

from benchmarks.blind import generators as g
from benchmarks.blind.study import OUTSIDE, run_case, table

SEEDS = range(10)
IN_LIBRARY = [c for c in g.CASES if c not in ("none",) + OUTSIDE]


@pytest.mark.slow
@pytest.mark.parametrize("case", IN_LIBRARY)
def test_blind_effect_is_found(case):
    rows = [run_case(case, s) for s in SEEDS]
    t = table(rows)[0]
    assert t["rank1"] >= 9, t
    assert t["false_claims"] == 0, t
    ins, n = map(int, t["coverage"].split("/"))
    assert n >= 9 and ins >= 0.9 * n, t
    assert t["held_out_reduction_median"] >= 0.5, t


@pytest.mark.slow
@pytest.mark.parametrize("effects", (None, "all"))
@pytest.mark.parametrize("case", ("none",) + OUTSIDE)
def test_blind_no_false_claim(case, effects):
    rows = [run_case(case, s, effects=effects) for s in SEEDS]
    claims = sum(r["claim"] is not None for r in rows)
    if case in OUTSIDE:
        assert claims == 0, [(r["seed"], r["claim"]) for r in rows]
        assert sum(r["verdict"] == "unexplained" for r in rows) >= 9, [r["verdict"]
                                                                      for r in rows]
    else:
        assert claims <= 1, [(r["seed"], r["claim"]) for r in rows]
