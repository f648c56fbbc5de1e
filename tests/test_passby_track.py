"""The pass-by takes its track as a TrackSpec: a custom track's supports reach the rail
tables (library, job and command).

Reference: rail tables assembled here straight from the model door
(railfem.models.receptance) for the custom spec, then the pass-by solver on them; the job
and the command must give the same levels, and levels different from the preset's."""
import json

import numpy as np
import pytest

from railfem.cli import main
from railfem.jobs.passby import run_passby
from railfem.models import receptance
from railfem.simulate import passby as P
from railfem.simulate.train import TrainLayout
from railfem.spec import preset
from railfem.standards import iec61260
from railfem.wheelrail import contact, roughness, wheels

F = iec61260.ninth_octave_grid(200.0, 400.0)
MODEL = "timoshenko-discrete"
TRAIN = TrainLayout(axle_offsets=(0.0, 2.6))
STEP, N_P, N_S = 0.1, 6, 40  # grid step, steps per 0.6 m span, steps within 4 m
SPEED = 60.0  # m/s, the job's default 216 km/h


def door_tables(spec) -> P.RailTables:
    rx = np.round(np.arange(-N_S, N_S + N_P) * STEP, 10)
    fx = np.round(np.arange(N_P) * STEP, 10)
    a = receptance(spec, F, fx, rx, outputs=("head", "foot"))
    return P.RailTables(frequency=F, step=STEP, period=0.6, response_x=rx, force_x=fx,
                        receptance=a)


def reference_levels(spec) -> np.ndarray:
    """Pass-by average (dB) on door tables: rigid wheel, no contact filter, default
    roughness, the job's defaults otherwise (sensor mid-span, +-3 m around the train)."""
    hz = contact.hertz()
    r = roughness.amplitude_at(roughness.sloped_spectrum(0.0, 10.0), F, SPEED)
    res = P.simulate_passby(door_tables(spec), TRAIN, wheels.RigidWheel().receptance(F),
                            contact.contact_receptance(hz, F), r, before=3.0, after=3.0)
    return res.average_level()


@pytest.fixture(scope="module")
def custom():
    return preset("site", model=MODEL, kp=300e6)


def test_rail_tables_follow_the_spec(custom):
    tab = P.rail_tables(custom, F, max_distance=4.0)
    ref = door_tables(custom)
    for i, j in ((N_S, 0), (N_S + 3, 3), (N_S + 15, 2), (5, 4)):
        assert np.allclose(tab.receptance[:, :, i, j], ref.receptance[:, :, i, j],
                           rtol=1e-9, atol=0)
    site = P.rail_tables(preset("site", model=MODEL), F, max_distance=4.0)
    assert not np.allclose(site.receptance[:, 0, N_S, 0], tab.receptance[:, 0, N_S, 0],
                           rtol=0.05, atol=0)
    with pytest.raises(TypeError, match="TrackSpec"):
        P.rail_tables("site", F)


def test_passby_job_uses_the_custom_track(tmp_path, custom):
    kw = dict(f_low=200.0, f_high=400.0, before=3.0, after=3.0, max_distance=4.0,
              train=TRAIN, contact_filter="none")
    s = run_passby(tmp_path / "custom", track=custom, **kw)
    ref = reference_levels(custom)
    assert np.allclose(s["passby_level_db"], ref, atol=2e-3)
    site = run_passby(tmp_path / "site", model=MODEL, **kw)
    assert np.max(np.abs(np.subtract(site["passby_level_db"], ref))) > 0.5
    assert s["track"]["support"]["kp"] == 300e6 and s["options"]["model"] == MODEL


def test_passby_command_takes_the_track_options(tmp_path):
    """railfem passby --kp 300 (MN/m, as railfem track): the rail tables of that track."""
    (tmp_path / "train.toml").write_text("axle_offsets_m = [0.0, 2.6]\n")
    cfg = tmp_path / "run.toml"
    cfg.write_text('before = 3.0\nafter = 3.0\ntrain = "train.toml"\n')
    out = tmp_path / "out"
    code = main(["-q", "passby", "--config", str(cfg), "--model", MODEL, "--kp", "300",
                 "--f-low", "200", "--f-high", "400", "--max-distance", "4",
                 "--contact-filter", "none", "--out", str(out)])
    assert code == 0
    run = json.loads((out / "run.json").read_text())
    assert run["track"]["support"]["kp"] == 300e6
    ref = reference_levels(preset("site", model=MODEL).replace(kp=300e6))
    assert np.allclose(run["passby_level_db"], ref, atol=2e-3)
