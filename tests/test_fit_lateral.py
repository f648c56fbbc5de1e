"""Lateral decay-rate fits: the forward model picks the eigen form in the lateral stiffness
(railfem.identify.forward.DirectionalEngine) when the fitted support parameters change the
lateral springs only, and it gives the receptances and EN 15461 decay rates of the direct
engine (railfem.models.receptance, one coupling solve per evaluation: another code path)
for several parameter vectors; where the fitted parameters change two directions (the
sleeper's horizontal fields with longitudinal springs) the direct engine is kept."""
import numpy as np
import pytest

import railfem as rf
from railfem.identify.data import model_quantities
from railfem.identify.fit import prepare
from railfem.identify.forward import ForwardModel, varied_directions
from railfem.measurement import DecayRateMeasurement
from railfem.params import ParameterSpace
from railfem.spec import RailSpec

BANDS = np.array([250.0, 315.0, 400.0, 500.0])
LATERAL = ("kp_lat", "eta_p_lat", "kb_lat", "eta_b_lat")


def small_base(directions="zy"):
    """A short, coarse track (cheap kernels) with supports acting in ``directions``."""
    return rf.preset("site", support_directions=directions, n_supports=41, pad_length=0.0,
                     n_rows=1, rail=RailSpec(h=0.02))


def lateral_row():
    return DecayRateMeasurement(frequency=BANDS, decay_rate=[3.0, 2.5, 2.0, 1.5],
                                direction="h")


def forward_pair(directions, names):
    """(auto forward model, direct forward model, target) of the lateral row."""
    auto, target = prepare(lateral_row(), "wfe-discrete", parameters=names,
                           base=small_base(directions), bounds=None, use=None, cache=False,
                           forward=None, target_options=None)
    direct = ForwardModel(auto.space, auto.geometry, engine="direct", cache=False)
    return auto, direct, target


def test_auto_picks_the_eigen_form_where_one_direction_varies():
    def kind(directions, names):
        space = ParameterSpace(small_base(directions), names)
        return varied_directions(space), ForwardModel(space, _geometry()).kind

    assert kind("zy", LATERAL) == (("y",), "eigen")
    assert kind("zy", LATERAL + ("ms_lat", "eta_r")) == (("y",), "eigen")
    # the sleeper's horizontal fields carry the longitudinal springs as well
    assert kind("zyx", LATERAL) == (("y", "x"), "direct")
    assert kind("zyx", ("kp_lat", "eta_p_lat")) == (("y",), "eigen")
    # the vertical pad acts on the vertical springs' sum and on their difference (the
    # foot's roll against the seat): two stiffnesses, no eigen form in one
    assert kind("zy", ("kp", "eta_p", "kb")) == (("z", "z-"), "direct")
    # the vertical chain of a lateral load's kernel: the springs' roll part is not held
    assert kind("zy", ("kb", "eta_b")) == (("z",), "direct")
    with pytest.raises(ValueError, match="one direction only"):
        ForwardModel(ParameterSpace(small_base("zyx"), LATERAL), _geometry(), engine="eigen")


def _geometry():
    from railfem.identify.forward import Geometry

    return Geometry(frequency=[300.0], outputs=("head_lateral",), sensor_x=0.3,
                    force_x=[0.32, 0.9])


@pytest.mark.parametrize("directions,names", [("zy", LATERAL),
                                              ("zyx", ("kp_lat", "eta_p_lat"))])
def test_eigen_engine_equals_the_direct_engine(directions, names):
    auto, direct, target = forward_pair(directions, names)
    assert auto.kind == "eigen" and direct.kind == "direct"
    space = auto.space
    rng = np.random.default_rng(3)
    xs = [space.from_spec(space.base)] + [space.lower + (0.05 + 0.9 * rng.random(len(names)))
                                          * (space.upper - space.lower) for _ in range(3)]
    for x in xs:
        a, b = auto.receptance(x), direct.receptance(x)
        assert a.shape == b.shape == (len(target.frequency), 1, len(target.force_x))
        scale = np.abs(b).max(axis=(1, 2), keepdims=True)
        assert (np.abs(a - b) / scale).max() < 1e-8
        da, db = model_quantities(target, a)["tdr"], model_quantities(target, b)["tdr"]
        assert np.all(np.isfinite(db))
        np.testing.assert_allclose(da, db, rtol=1e-8)
    # the engine holds the other directions: a spec changing them is refused
    engine = auto.engine(space.base)
    with pytest.raises(ValueError, match="holds the support values"):
        engine.receptance(space.base.replace(kp=space.base.support.kp * 2))


def test_fit_cli_fits_a_lateral_row(tmp_path):
    """``railfem fit TABLE --directions y`` fits the table's lateral row (not its vertical
    one) for the lateral chain, on a track whose supports act laterally, and says so."""
    import json
    import subprocess
    import sys

    table = tmp_path / "tdr.csv"
    table.write_text("loc,sec,messdatum,temp,rail,dir,250,315,400,500\n"
                     "Ni,B1,2012-09-12,10.6,li,v,8.8,12.1,14.2,16.6\n"
                     "Ni,B1,2012-09-12,10.6,re,h,5.8,3.5,1.8,1.3\n")
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "railfem.cli", "-q", "fit", str(table), "--directions", "y",
           "--starts", "1", "--workers", "1", "--no-profiles", "--discrepancy", "none",
           "--out", str(out)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert "supports acting in zy" in r.stdout
    doc = json.loads((out / "fit.json").read_text())
    assert [p["name"] for p in doc["parameters"]] == list(LATERAL)
    assert doc["spec"]["track"]["support_directions"] == "zy"
    run = json.loads((out / "run.json").read_text())
    assert run["directions"] == "y" and run["metadata"]["rail_side"] == "re"
    assert set(doc["residual_rms_db"]) == {"tdr"}
    bad = subprocess.run(cmd[:5] + [str(table), "--directions", "y", "--select", "dir=v",
                                    "--out", str(tmp_path / "o2")],
                         capture_output=True, text=True)
    assert bad.returncode != 0 and "disagree" in bad.stderr
