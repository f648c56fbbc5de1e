"""``railfem roughness`` and ``railfem study passby``: files, track sources, bad input."""
import json

import numpy as np
import pytest

from railfem.wheelrail import contact
from railfem.wheelrail import roughness as R
from railfem.wheelrail import wheels
from railfem.cli import main
from railfem.io.recording import write_recording
from railfem.jobs.roughness import resolve_track
from railfem.simulate import passby as P, signals
from railfem.simulate.train import from_cars
from railfem.spec import preset, spec_to_dict
from railfem.standards.iec61260 import ninth_octave_grid


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    """Two simulated pass-bys (Timoshenko discrete site track, 8 wheels) as files."""
    folder = tmp_path_factory.mktemp("rec")
    spec = preset("site", model="timoshenko-discrete")
    f = ninth_octave_grid(250.0, 2000.0)
    tables = P.rail_tables(spec, f, cache=False)
    hz = contact.hertz()
    train = from_cars(2)
    paths = []
    for k, v in enumerate((30.0, 40.0)):
        r = R.amplitude_at(R.sloped_spectrum(0.0, 10.0), f, v) * np.sqrt(
            contact.filter_power("analytical", f, v, hz))
        res = P.simulate_passby(tables, train, wheels.RigidWheel(mass=600.0).receptance(f),
                                contact.contact_receptance(hz, f), r, before=20.0, after=20.0)
        sig, truth = signals.synthesise(res, train, v, sample_rate=12800.0, seed=k,
                                        quasi=signals.quasi_static(preset("site"),
                                                                   hz.load))
        rec = signals.passby_recording(sig, truth, spacing=0.6, location="foot")
        paths.append(str(write_recording(folder / f"pb{k}", rec, truth=truth)["data"]))
    return paths


def test_roughness_command_full_and_simplified(tmp_path, recordings, capsys):
    common = ["--track", "site", "--model", "timoshenko-discrete", "--f-low", "250",
              "--f-high", "2000"]
    out = tmp_path / "full"
    assert main(["roughness", *recordings, *common, "--out", str(out)]) == 0
    run = json.loads((out / "run.json").read_text())
    assert run["command"] == "roughness" and run["method"] == "full"
    assert [p["n_wheels"] for p in run["passbys"]] == [8, 8]
    lam = np.array(run["wavelength_m"])
    lev = np.array([np.nan if v is None else v for v in run["roughness_db_re_1um"]])
    ok = np.isfinite(lev)
    assert ok.sum() >= 6
    # the known roughness: 0 dB at 10 mm, +10 dB/decade (8 wheels, 2 pass-bys: +-1.5 dB)
    assert np.abs(lev[ok] - 10 * np.log10(lam[ok] / 0.01)).max() < 1.5
    for name in ("roughness.csv", "roughness.png"):
        assert (out / name).stat().st_size > 0
    out2 = tmp_path / "simplified"
    assert main(["roughness", *recordings, *common, "--method", "simplified", "--tdr",
                 "model", "--out", str(out2)]) == 0
    assert (out2 / "decay_rate_used.csv").read_text().startswith("# decay rate used")
    assert "wrote" in capsys.readouterr().out


@pytest.mark.parametrize("args, message", [
    (["--method", "simplified"], "needs a decay rate"),
    (["--tdr", "nonsense", "--method", "simplified"], "--tdr"),
    (["--track", "no_such_track"], "not a preset"),
])
def test_roughness_bad_input_exits_2_before_writing(tmp_path, recordings, capsys, args,
                                                    message):
    argv = ["roughness", *recordings, "--track", "site", "--model", "timoshenko-discrete",
            "--f-low", "250", "--f-high", "2000", *args, "--out", str(tmp_path / "o")]
    if args[:1] == ["--track"]:
        argv = ["roughness", *recordings, *args, "--out", str(tmp_path / "o")]
    assert main(argv) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_track_sources(tmp_path):
    spec = preset("soft").replace(kp=123e6)
    (tmp_path / "fit.json").write_text(json.dumps({"model": "wfe-discrete",
                                                   "spec": spec_to_dict(spec)}))
    assert resolve_track(str(tmp_path / "fit.json")).support.kp == pytest.approx(123e6)
    (tmp_path / "run.json").write_text(json.dumps({"config": {"spec": spec_to_dict(spec)}}))
    got = resolve_track(str(tmp_path / "run.json"), model="timoshenko-continuous")
    assert got.model == "timoshenko-continuous" and got.support.kp == pytest.approx(123e6)
    (tmp_path / "t.toml").write_text('preset = "stiff"\n[support]\nkb = "50 MN/m"\n')
    assert resolve_track(str(tmp_path / "t.toml")).support.kb == pytest.approx(50e6)
    (tmp_path / "x.json").write_text("{}")
    with pytest.raises(ValueError, match="neither"):
        resolve_track(str(tmp_path / "x.json"))


@pytest.mark.slow
def test_study_command_writes_its_tables_and_figures(tmp_path):
    out = tmp_path / "study"
    assert main(["study", "passby", "--model", "timoshenko-discrete", "--tracks", "site",
                 "--speeds-kmh", "216", "--workers", "1", "--out", str(out)]) == 0
    run = json.loads((out / "run.json").read_text())
    assert run["command"] == "study passby" and run["timing_s"]["total"] > 0
    for name in ("tables/tdr_errors.csv", "tables/roughness_errors.csv",
                 "tables/sensitivity.csv", "tables/simplified_causes.csv", "report.md",
                 "figures/tdr_site.png", "figures/roughness_site.png",
                 "figures/sensitivity.png"):
        assert (out / name).stat().st_size > 0, name


def test_simplified_with_the_decay_rate_of_a_hammer_dataset(tmp_path, recordings):
    """--tdr hammer:DATA: a simulated EN 15461 hammer test of the same track written as a
    dataset folder; its decay rate is the one the simplified method uses (equal to the
    model's EN 15461 decay rate, '--tdr model', on the same positions)."""
    from railfem import models
    from railfem.io import write_dataset
    from railfem.io.hammer import hammer_measurement
    from railfem.jobs.roughness import run_roughness

    spec = preset("site", model="timoshenko-discrete")
    f = ninth_octave_grid(250.0, 2000.0)
    xs, pos, hx = models.hammer_x(spec)
    frf = models.frf(spec, f, force=[models.head(x) for x in hx],
                     response=[models.foot(xs)])
    labels = {name: float(p) for name, p in zip(frf.force, pos)}
    m = hammer_measurement(frf.to("mobility"), positions=labels, sleeper_spacing=0.6,
                           sensors={frf.response[0]: "foot"})
    data = write_dataset(tmp_path / "hammer", m)
    common = dict(track="site", model="timoshenko-discrete", method="simplified",
                  f_low=250.0, f_high=2000.0)
    a = run_roughness(recordings, tmp_path / "a", tdr=f"hammer:{data}", **common)
    b = run_roughness(recordings, tmp_path / "b", tdr="model", **common)
    assert a["tdr_used"].startswith("EN 15461 of")
    la = np.array([np.nan if v is None else v for v in a["roughness_db_re_1um"]])
    lb = np.array([np.nan if v is None else v for v in b["roughness_db_re_1um"]])
    ok = np.isfinite(la) & np.isfinite(lb)
    assert ok.sum() >= 6
    np.testing.assert_allclose(la[ok], lb[ok], atol=0.05)
