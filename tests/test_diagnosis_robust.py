"""The diagnosis on data it did not make: a candidate that fails does not end the run (it is
reported), pairs of effects with grid values are screened, the final refit of the chosen
effect is gated as at screening, hammer data are diagnosed on a band (--f-low/--f-high),
and fit and diagnose start from one base model (railfem.identify.base)."""
import json
import subprocess
import sys
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from railfem.diagnosis import diagnose, effects, gates, loop, prepare
from railfem.identify.problem import Box
from railfem.params import Parameter
from benchmarks.blind import generators as g

SMALL_F = g.frequencies(low=50.0, high=4000.0)[::2]  # 1/4.5-octave: a cheap grid


# ------------------------------------------------------------------ pairs with grid values


def _data(outputs):
    rec = SimpleNamespace(fit=SimpleNamespace(outputs=outputs))
    return SimpleNamespace(records=(rec,))


def test_pair_grid_values_merge_tuple_keys():
    """Both effects' grids survive the merge (keys are (effect, name) tuples: a merge by
    keyword arguments raised TypeError whenever the second effect had grid values)."""
    pad, sensor = effects.get("pad_length"), effects.get("sensor_resonance")
    gv = loop.pair_grid_values(pad, sensor, _data(("head", "foot")), "wfe-discrete")
    assert gv == {("pad_length", "pad_length"): loop.WFE_PAD_LENGTHS,
                  ("sensor_resonance", "sensor"): ("all", "foot", "head")}
    gv = loop.pair_grid_values(sensor, pad, _data(("head",)), "timoshenko-discrete")
    assert gv == {("sensor_resonance", "sensor"): ("all",)}


def test_a_pair_whose_second_effect_has_grid_values_is_screened(monkeypatch):
    """End to end: every single kept (gate forced open), so the pair pad_frequency +
    sensor_resonance (the second has a sensor grid) is refitted; it used to crash the
    run with 'keywords must be strings'."""
    monkeypatch.setattr(loop, "passes", lambda row, ref_bic: True)
    d = diagnose(g.dataset("pad_frequency", 3, f=SMALL_F), model="timoshenko-discrete",
                 effects=("pad_frequency", "sensor_resonance"), n_starts=2,
                 profile_final=False)
    assert d.failures == []
    pair = [c for c in d.candidates if len(c["effects"]) == 2]
    assert [c["name"] for c in pair] == ["pad_frequency+sensor_resonance"]
    assert "sensor_resonance" in pair[0]["theta"]


# ------------------------------------------------------------------ failures are reported


def test_a_candidate_that_raises_is_reported_and_the_run_goes_on(monkeypatch, tmp_path):
    """foot_damping made to raise inside its refit: the diagnosis still names pad_frequency,
    and the failure (candidate, stage, error) is in the result, diagnosis.json, report.md
    and the statement."""
    from railfem.jobs.diagnose import write_report

    def boom(spec, theta, record=None):
        raise TypeError("boom in foot_damping")

    monkeypatch.setitem(effects.REGISTRY, "foot_damping",
                        replace(effects.get("foot_damping"), apply=boom))
    d = diagnose(g.dataset("pad_frequency", 3, f=SMALL_F), model="timoshenko-discrete",
                 effects=("pad_frequency", "foot_damping"), n_starts=2)
    assert d.chosen is not None and d.chosen.name == "pad_frequency", d.statement
    assert len(d.failures) == 1
    f = d.failures[0]
    assert f["candidate"] == "foot_damping" and f["stage"] == "screening"
    assert "TypeError" in f["error"] and "boom in foot_damping" in f["error"]
    assert "foot_damping at screening" in d.statement
    assert d.ranking == ["pad_frequency"]
    write_report(tmp_path, d, title="t")
    s = json.loads((tmp_path / "diagnosis.json").read_text())
    assert s["failures"] == d.failures
    assert "boom in foot_damping" in (tmp_path / "report.md").read_text()


# ------------------------------------------------------------------ the final refit's gates


def _outcome(name, identifiable, value=1.0):
    """A refitted model as plausibility() reads it: the base's kp and one effect
    parameter, its identifiability as given."""
    box = Box([Parameter(name="kp", unit="N/m", log=True, lower=1e7, upper=1e10),
               Parameter(name=f"{name}.a", unit="-", log=True, lower=0.01, upper=100.0)])
    analysis = {"parameters": [{"identifiable": "yes", "reason": ""},
                               {"identifiable": identifiable,
                                "reason": "interval [1e-300, 1e300]"}]}
    return SimpleNamespace(name=name, bic=0.0, x=np.array([8.0, np.log10(value)]),
                           problem=SimpleNamespace(box=box), analysis=analysis,
                           grid_profiles={})


def _row(name, bic):
    return {"name": name, "reference": "base", "bic": bic, "plausible": True,
            "held_out": {"pass": True, "reduction": 0.5}}


def _search():
    return loop.Search(data=None, model="timoshenko-discrete", ev=None, spec=None, scale={},
                       base=SimpleNamespace(bic=100.0))


def test_the_final_refit_is_gated_and_the_next_candidate_considered(monkeypatch):
    """The best candidate at screening (sensor_resonance) ends its final refit with an
    unidentifiable parameter: not kept, the row says why, and the next kept candidate
    (pad_frequency, plausible after its final refit) is chosen."""
    finals = {"sensor_resonance": _outcome("sensor_resonance", "no"),
              "pad_frequency": _outcome("pad_frequency", "yes")}
    monkeypatch.setattr(loop, "final_refit", lambda s, o: finals[o.name])
    outcomes = {n: _outcome(n, "yes") for n in finals}
    rows = [_row("pad_frequency", 60.0), _row("sensor_resonance", 50.0)]
    chosen, row = loop.choose(_search(), outcomes, rows)
    assert chosen is finals["pad_frequency"] and row["name"] == "pad_frequency"
    sr = [r for r in rows if r["name"] == "sensor_resonance"][0]
    assert sr["kept"] is False and "sensor_resonance.a is not identifiable" in \
        sr["final_rejected"]
    assert [r["name"] for r in rows] == ["pad_frequency", "sensor_resonance"]  # kept first
    assert [r["rank"] for r in rows] == [1, 2]


def test_no_candidate_is_kept_when_every_final_refit_fails_its_gate(monkeypatch):
    """Both final refits fail (one unidentifiable, one raises): nothing is chosen, the
    failure is recorded at its stage and the verdict says why each was not kept."""
    def final(s, o):
        if o.name == "pad_frequency":
            raise np.linalg.LinAlgError("singular")
        return _outcome(o.name, "no")

    monkeypatch.setattr(loop, "final_refit", final)
    s = _search()
    outcomes = {n: _outcome(n, "yes") for n in ("sensor_resonance", "pad_frequency")}
    rows = [_row("sensor_resonance", 50.0), _row("pad_frequency", 60.0)]
    assert loop.choose(s, outcomes, rows) == (None, None)
    assert not any(r["kept"] for r in rows)
    assert s.failures == [{"candidate": "pad_frequency", "stage": "final refit",
                           "error": "LinAlgError: singular"}]
    st = {"verdict": "structure", "p": 1e-9, "structured_rms_db": 2.0}
    verdict, statement = loop.decide(st, None, None, None, rows, s.failures)
    assert verdict == "unexplained"
    assert "sensor_resonance passed the screening gates but not after its final refit: " \
           "sensor_resonance.a is not identifiable" in statement
    assert "pad_frequency at final refit" in statement


def test_an_effect_parameter_at_a_bound_after_the_final_refit_is_implausible():
    ok, why = gates.final_gate(_outcome("sensor_resonance", "yes", value=99.99))
    assert not ok and "at a bound" in why
    assert gates.final_gate(_outcome("sensor_resonance", "weak", value=3.0)) == (True, "")


# ------------------------------------------------------------------ the CLI and the base


def _parse(argv):
    from railfem.cli import build_parser

    return build_parser().parse_args(argv)


def test_diagnose_cli_takes_a_frequency_band_for_hammer_data():
    from railfem.cli.measure import f_range_from_args

    a = _parse(["diagnose", "d", "--f-low", "200", "--f-high", "2000"])
    assert f_range_from_args(a) == (200.0, 2000.0)
    assert f_range_from_args(_parse(["diagnose", "d", "--f-high", "2000"])) == (0.0, 2000.0)
    assert f_range_from_args(_parse(["diagnose", "d"])) is None
    assert f_range_from_args(_parse(["fit", "d", "--f-low", "200"])) == (200.0, np.inf)


def test_the_band_is_honoured(tmp_path):
    """`railfem diagnose DATA --f-low 200 --f-high 2000` on a hammer test: every frequency of
    the diagnosis data lies in the band (the report's error table only has bands in it);
    the same data without the band reach 4 kHz. One worker process (the parallel
    screening is test_diagnosis_parallel's)."""
    from railfem.io import write_dataset

    meas = g.dataset("none", 0, f=SMALL_F)[0]
    data = prepare(meas, f_range=(200.0, 2000.0))
    for r in data.records:
        for t in (r.fit, r.held):
            assert t.frequency.min() >= 200.0 and t.frequency.max() <= 2000.0
    assert prepare(meas).records[0].fit.frequency.max() > 3000.0
    src = tmp_path / "data"
    write_dataset(src, meas)
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "railfem.cli", "diagnose", str(src),
                        "--model", "timoshenko-discrete", "--effects", "pad_frequency",
                        "--starts", "2", "--workers", "1", "--f-low", "200", "--f-high", "2000",
                        "--out", str(out)], capture_output=True, text=True, timeout=900)
    assert r.returncode == 0, r.stderr
    s = json.loads((out / "diagnosis.json").read_text())
    bands = {e["band_hz"] for e in s["error_before"]}
    assert bands and min(bands) >= 200 and max(bands) <= 2000, sorted(bands)
    assert s["base_model"].startswith("timoshenko-discrete, point supports, site preset")
    assert "Base model: timoshenko-discrete, point supports" in \
        (out / "report.md").read_text()


@pytest.mark.parametrize("options", [[], ["--preset", "soft"], ["--pad-length", "120"],
                                     ["--model", "timoshenko-discrete"]])
def test_fit_and_diagnose_build_the_same_base(options):
    """Same data and options -> the same base spec in fit and diagnose: the site preset on
    point supports by default (not the 0.15 m pad of preset('site')), with the data's
    sleeper spacing, and the same fitted parameters."""
    from railfem.cli.measure import base_from_args
    from railfem.identify.base import BASE_PARAMETERS
    from railfem.identify.fit import DEFAULT_PARAMETERS, base_spec

    meas = g.dataset("none", 0, f=SMALL_F)[0]
    meas = replace(meas, sleeper_spacing=0.65)
    af, ad = _parse(["fit", "d", *options]), _parse(["diagnose", "d", *options])
    bf, bd = base_from_args(af), base_from_args(ad)
    assert bf == bd
    spec_fit = base_spec(meas, af.model, bf)
    spec_diag = loop.base_of(prepare(meas), ad.model, bd)
    assert spec_fit == spec_diag
    assert spec_fit.spacing == 0.65 and spec_fit.model == af.model
    assert spec_fit.pad_length == (0.12 if "--pad-length" in options else 0.0)
    assert spec_fit.n_rows == 1
    assert spec_fit.name == ("soft" if "soft" in options else "site")
    # the library defaults (no base given) are the same base, the CLI's without options
    lib = base_spec(meas, af.model)
    assert lib == loop.base_of(prepare(meas), af.model)
    if not options or options[0] == "--model":
        assert lib == spec_fit
    # the CLI leaves --parameters to the job, which takes the base's on vertical data
    from railfem.jobs.fit import LATERAL_PARAMETERS

    assert af.parameters is None and DEFAULT_PARAMETERS == BASE_PARAMETERS
    assert LATERAL_PARAMETERS == tuple(f"{n}_lat" for n in BASE_PARAMETERS[:4])
    assert loop.BASE + ("eta_r",) == BASE_PARAMETERS  # what the diagnosis fits


def test_nested_effects_are_not_screened_as_a_pair():
    """two_rail's sleeper is sleeper_flexibility's (the same parameters): the pair is one
    mechanism twice; two voided-sleeper-like factors too; distinct mechanisms pair."""
    get = effects.get
    assert not loop.pairable(get("sleeper_flexibility"), get("two_rail"))
    assert not loop.pairable(get("two_rail"), get("sleeper_flexibility"))
    assert not loop.pairable(get("voided_sleeper"), get("random_support"))
    assert loop.pairable(get("sleeper_flexibility"), get("rail_damper"))
    assert loop.pairable(get("pad_frequency"), get("sensor_resonance"))
