"""The diagnosis's candidates and pairs screened in worker processes
(railfem.diagnosis.parallel): the same result as the serial path, failures reported, the
workers' log in the parent, shared objects by reference, the pool ended when the caller
stops."""
import logging
import multiprocessing
import time
from dataclasses import replace

import numpy as np
import pytest

from railfem.diagnosis import diagnose, effects, loop, parallel
from benchmarks.blind import generators as g

pytestmark = pytest.mark.skipif("fork" not in multiprocessing.get_all_start_methods(),
                                reason="the parallel screening forks")

SMALL_F = g.frequencies(low=50.0, high=4000.0)[::4]
log = logging.getLogger("railfem.diagnosis.test_parallel")


class Big:
    """A shared object the results refer to (must come back as the parent's own)."""

    def __init__(self):
        self.values = np.arange(10.0)


def square(big, x):
    log.info("item %d on %s", x, "a worker")
    if x == 3:
        raise ValueError("three is refused")
    return {"square": x * x, "big": big}


def test_run_yields_every_item_with_its_error_and_log_in_the_parent(caplog):
    big = Big()
    caplog.set_level(logging.INFO, logger="railfem")
    got = {i: (ok, v) for i, ok, v in parallel.run(lambda x: square(big, x), range(6), 2,
                                                    {"big": big}, groups=[[5, 4], [0, 1, 2, 3]])}
    assert sorted(got) == list(range(6))
    for i in (0, 1, 2, 4, 5):
        ok, v = got[i]
        assert ok and v["square"] == i * i
        assert v["big"] is big  # by reference, not a copy
    ok, exc = got[3]
    assert not ok and type(exc).__name__ == "ValueError" and "three is refused" in str(exc)
    lines = [r.getMessage() for r in caplog.records if r.name == log.name]
    assert sorted(lines) == sorted(f"item {i} on a worker" for i in range(6))


def test_serial_run_is_in_order_and_reports_errors():
    out = list(parallel.run(lambda x: 10 // x, [1, 0, 5], 1, {}))
    assert [(i, ok) for i, ok, _ in out] == [(0, True), (1, False), (2, True)]
    assert isinstance(out[1][2], ZeroDivisionError) and out[2][2] == 2


def test_an_exception_that_does_not_pickle_keeps_its_name_and_message():
    class Odd(Exception):
        def __init__(self, a, b):
            super().__init__(f"{a} and {b}")

    def boom(x):
        raise Odd(x, "lost")

    got = {i: (ok, exc) for i, ok, exc in parallel.run(boom, [7, 8], 2, {})}
    for i, x in enumerate((7, 8)):
        ok, exc = got[i]
        assert not ok and type(exc).__name__ == "Odd" and str(exc) == f"{x} and lost"


def test_the_pool_ends_when_the_caller_stops():
    before = set(multiprocessing.active_children())
    gen = parallel.run(lambda x: time.sleep(0.05 if x == 0 else 30), range(3), 2, {})
    next(gen)
    assert set(multiprocessing.active_children()) - before  # the workers run
    t = time.perf_counter()
    gen.close()  # as a KeyboardInterrupt in the caller's loop does
    assert time.perf_counter() - t < 10
    assert not set(multiprocessing.active_children()) - before


def _diagnosis(workers, effects_=("pad_frequency", "foot_damping", "noise_floor"), *,
               n_starts=1, **kw):
    return diagnose(g.dataset("pad_frequency", 3, f=SMALL_F), model="timoshenko-discrete",
                    effects=effects_, n_starts=n_starts, workers=workers, **kw)


def _same(a, b):
    """Same ranking, kept flags, verdict, scores and parameters (rel 1e-8)."""
    assert b.ranking == a.ranking and b.verdict == a.verdict
    assert [r["kept"] for r in b.candidates] == [r["kept"] for r in a.candidates]
    for ra, rb in zip(a.candidates, b.candidates):
        assert rb["bic"] == pytest.approx(ra["bic"], rel=1e-8, abs=1e-8)
        assert rb["held_out"]["reduction"] == pytest.approx(ra["held_out"]["reduction"],
                                                            rel=1e-8, abs=1e-10)
        for pa, pb in zip(ra["parameters"], rb["parameters"]):
            assert pa["name"] == pb["name"]
            assert pb["value"] == pytest.approx(pa["value"], rel=1e-8)
    assert (b.chosen is None) == (a.chosen is None)
    if a.chosen is not None:
        assert b.chosen.name == a.chosen.name
        np.testing.assert_allclose(b.chosen.x, a.chosen.x, rtol=1e-8)
    assert b.failures == a.failures == []


def test_parallel_screening_gives_the_serial_result():
    """Three candidates and (every single kept: gate forced open) their three pairs, the
    cheap form (no rail-loss profiles, no discrepancy): workers=2 as workers=1."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(loop, "passes", lambda row, ref_bic: True)
        a, b = (_diagnosis(w, profile_final=False, discrepancy=None) for w in (1, 2))
    assert len(a.candidates) == 6 and "pad_frequency+foot_damping" in a.ranking
    _same(a, b)


@pytest.mark.slow
def test_parallel_screening_gives_the_serial_result_with_profiles():
    """The default options (rail-loss profiles shared by the candidates, the discrepancy,
    the final refit), four candidates and the pair pad_frequency+rail_damper."""
    eff = ("pad_frequency", "foot_damping", "rail_damper", "noise_floor")
    a, b = (_diagnosis(w, eff, n_starts=2) for w in (1, 2))
    assert "pad_frequency+rail_damper" in a.ranking
    _same(a, b)


def test_a_candidate_that_raises_in_a_worker_is_reported(monkeypatch, caplog):
    def boom(spec, theta, record=None):
        raise TypeError("boom in foot_damping")

    monkeypatch.setitem(effects.REGISTRY, "foot_damping",
                        replace(effects.get("foot_damping"), apply=boom))
    caplog.set_level(logging.INFO, logger="railfem")
    d = _diagnosis(2, ("pad_frequency", "foot_damping", "rail_damper", "noise_floor"),
                   pairs=False, profile_final=False, discrepancy=None)
    assert [(f["candidate"], f["stage"]) for f in d.failures] == [("foot_damping",
                                                                   "screening")]
    assert "TypeError: boom in foot_damping" in d.failures[0]["error"]
    assert "foot_damping" not in d.ranking and len(d.ranking) == 3
    screened = [r.getMessage().split(":")[1].strip() for r in caplog.records
                if r.getMessage().startswith("diagnosis: ") and ": dBIC" in r.getMessage()]
    assert sorted(screened) == ["noise_floor", "pad_frequency", "rail_damper"]


def test_candidates_sharing_kernels_are_one_group_the_costliest_first():
    """WFE: the support effects (one rail-loss lattice), the deviating supports (one
    Woodbury form) and the geometry effects (one bank) each in one worker; the rail
    section grid (a kernel per value) starts first. Beam: support effects alone."""
    names = ("ballast_mass", "foot_damping", "hammer_position", "noise_floor",
             "pad_length", "random_support", "section_geometry", "sensor_position",
             "voided_sleeper")
    cands = [effects.get(n) for n in names]

    def groups(wfe):
        return [[names[i] for i in g] for g in parallel.kernel_groups(cands, wfe)]

    wfe = groups(True)
    assert wfe[0] == ["section_geometry"]
    assert sorted(map(tuple, wfe)) == sorted([
        ("section_geometry",), ("pad_length",), ("random_support", "voided_sleeper"),
        ("ballast_mass", "foot_damping"), ("hammer_position", "sensor_position"),
        ("noise_floor",)])
    assert wfe[-1] == ["noise_floor"]  # a measurement effect: no kernel
    beam = groups(False)
    assert ["ballast_mass"] in beam and ["foot_damping"] in beam


def _in_a_pool(_):
    return [i for i, ok, v in parallel.run(lambda x: x * 2, [1, 2, 3], 2, {}) if ok]


def test_in_a_pool_worker_the_run_is_serial():
    """A daemonic process (a pool's worker, e.g. a study running diagnoses) cannot have
    children: the items run there, in order."""
    with multiprocessing.get_context("fork").Pool(1) as pool:
        assert pool.map(_in_a_pool, [0]) == [[0, 1, 2]]
