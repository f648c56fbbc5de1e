"""The ``railfem passby`` command end to end: files, config, bad input."""
import csv
import json

import numpy as np
import pytest

from railfem.cli import main
from railfem.io.recording import read_recording


def test_passby_command_writes_everything(tmp_path, capsys):
    cfg = tmp_path / "run.toml"
    cfg.write_text('model = "timoshenko-discrete"\nf_low = 200.0\nf_high = 1000.0\n'
                   'before = 5.0\nafter = 5.0\ntrain = "train.toml"\n')
    (tmp_path / "train.toml").write_text("axle_offsets_m = [0.0, 2.6, 17.0, 19.6]\n")
    out = tmp_path / "out"
    code = main(["passby", "--config", str(cfg), "--speed-kmh", "180", "--signal",
                 "--no-speed", "--out", str(out)])
    assert code == 0
    run = json.loads((out / "run.json").read_text())
    assert run["train"]["n_wheels"] == 4 and run["speed_m_per_s"] == pytest.approx(50.0)
    assert run["options"]["model"] == "timoshenko-discrete"
    for name in ("band_levels.csv", "passby_spectrum.csv", "contact_force.csv",
                 "level_vs_position.png", "passby_spectrum.png", "passby.wav",
                 "passby.json", "passby.truth.json"):
        assert (out / name).stat().st_size > 0, name
    rows = list(csv.reader(l for l in (out / "passby_spectrum.csv").read_text().splitlines()
                           if not l.startswith("#")))
    assert rows[0] == ["band_hz", "exact_db", "paper_db", "exact_minus_paper_db"]
    assert len(rows) - 1 == len(run["band_hz"]) == 8  # 200 ... 1000 Hz
    diff = np.array([float(r[3]) for r in rows[1:]])
    assert np.allclose(diff, run["exact_minus_paper_db"], atol=1e-3)
    rec = read_recording(out / "passby.wav")
    assert rec.speed is None and rec.fs == 25600.0  # --no-speed
    truth = json.loads((out / "passby.truth.json").read_text())
    assert truth["speed_m_per_s"] == pytest.approx(50.0)
    assert "wrote" in capsys.readouterr().out


@pytest.mark.parametrize("args, message", [
    (["--wheel", "wooden"], "wheel"),
    (["--f-low", "3000", "--f-high", "1000"], "f_low"),
])
def test_bad_input_exits_2(tmp_path, capsys, args, message):
    code = main(["passby", "--model", "timoshenko-discrete", *args, "--out", str(tmp_path)])
    assert code == 2
    assert message in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


def test_config_unknown_key(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text("speed = 200\n")
    assert main(["passby", "--config", str(cfg), "--out", str(tmp_path / "o")]) == 2
    assert "unknown keys" in capsys.readouterr().err


def test_sbb_roughness_table_and_hold(tmp_path, capsys):
    """The SBB wide table as the roughness input: too short for 100 Hz at 216 km/h
    (lambda = 0.6 m > 0.32 m) unless the end levels are held."""
    table = tmp_path / "sbb.csv"
    lam_cm = [31.6228, 25.1189, 19.9526, 15.8489, 12.5893, 10, 7.9433, 6.3096, 5.0119,
              3.9811, 3.1623, 2.5119, 1.9953, 1.5849, 1.2589, 1]
    table.write_text("loc,sec,r_id,Author,kampagne,messdatum,rail," + ",".join(map(str, lam_cm))
                     + "\nNi,B5,1.0,MBBM,1,2015-01-01,L," + ",".join(["-5.0"] * 16) + "\n")
    args = ["passby", "--model", "timoshenko-discrete", "--roughness", str(table),
            "--f-low", "100", "--f-high", "500", "--max-distance", "5"]
    assert main([*args, "--out", str(tmp_path / "a")]) == 2
    assert "--roughness-hold" in capsys.readouterr().err
    assert main([*args, "--roughness-hold", "--out", str(tmp_path / "b")]) == 0
    run = json.loads((tmp_path / "b" / "run.json").read_text())
    assert run["roughness"].startswith("SBB")
