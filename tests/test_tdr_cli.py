"""``railfem tdr hammer`` and the model-vs-measurement plots."""
import csv
import json

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from railfem import plotting  # noqa: E402
from railfem.cli import main  # noqa: E402
from railfem.response import FRF  # noqa: E402
from railfem.estimators import tdr  # noqa: E402
from railfem.io import read_dataset, write_dataset  # noqa: E402
from railfem.measurement import HammerMeasurement, Metadata, Sensor  # noqa: E402
from railfem.standards.en15461 import hammer_positions  # noqa: E402
from railfem.standards.iec61260 import ninth_octave_grid  # noqa: E402


@pytest.fixture(autouse=True)
def close_figures():
    yield
    import matplotlib.pyplot as plt

    plt.close("all")


def dataset(tmp_path, d_true=4.0, floor_db=-25.0, seed=0):
    """A measured-like dataset: exponential decay, point at 0.02 m, a noise floor."""
    x = hammer_positions(0.6)
    x[0] = 0.02
    f = ninth_octave_grid(100, 1000)
    beta = d_true / 8.685889638
    y = np.exp(-(beta + 1j * 2 * np.pi * f[:, None] / 300) * x[None, :])
    rng = np.random.default_rng(seed)
    noise = (rng.normal(size=y.shape) + 1j * rng.normal(size=y.shape)) / np.sqrt(2)
    y = y + 10 ** (floor_db / 20) * noise
    frf = FRF(frequency=f, values=1e-5 * y[:, None, :], quantity="mobility", response=("head",),
              force=tuple(f"p{i}" for i in range(29)))
    m = HammerMeasurement(frf=frf, positions=x, sensors=(Sensor(name="head"),),
                          sleeper_spacing=0.6, sensor_x=None, metadata=Metadata(section="T"))
    return write_dataset(tmp_path / "data", m)


def test_cli_tdr_hammer_writes_csv_plot_json(tmp_path, capsys):
    data = dataset(tmp_path)
    out = tmp_path / "out"
    assert main(["-q", "tdr", "hammer", str(data), "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["decay_rate.csv", "decay_rate.png",
                                                     "run.json"]
    run = json.loads((out / "run.json").read_text())
    d = np.array(run["decay_rate"]["head"]["db_per_m"])
    assert run["measurement"]["metadata"] == {"section": "T"}
    assert run["options"]["exclusion"]["threshold_db"] == -15.0
    direct = tdr.hammer(read_dataset(data), "head")  # the library call the CLI wraps
    np.testing.assert_allclose(d, direct.decay_rate, rtol=1e-12)
    # the floor at -25 dB is excluded (3 points per band leave about +-15 % band scatter)
    assert abs(np.mean(d) / 4.0 - 1) < 0.03
    lines = (out / "decay_rate.csv").read_text().splitlines()
    assert lines[0].startswith("# EN 15461")
    rows = list(csv.DictReader(lines[1:]))
    np.testing.assert_allclose([float(r["head_db_per_m"]) for r in rows], d, atol=1e-4)
    assert [float(r["band_hz"]) for r in rows] == run["decay_rate"]["head"]["band_hz"]
    assert "head: 11 of 11 bands suitable" in capsys.readouterr().out
    # same data, no exclusion: the floor pulls D down
    main(["-q", "tdr", "hammer", str(data), "--out", str(tmp_path / "raw"), "--no-exclusion"])
    raw = json.loads((tmp_path / "raw" / "run.json").read_text())["decay_rate"]["head"]
    assert np.mean(raw["db_per_m"]) < 0.95 * np.mean(d)


def test_cli_tdr_bad_input(tmp_path, capsys):
    assert main(["tdr", "hammer", str(tmp_path / "missing"), "--out", str(tmp_path)]) == 2
    assert "not found" in capsys.readouterr().err
    data = dataset(tmp_path)
    assert main(["tdr", "hammer", str(data), "--sensor", "foot", "--out", str(tmp_path)]) == 2
    assert "no sensor 'foot'" in capsys.readouterr().err


def test_overlay_and_residual_plots(tmp_path):
    centres = np.array([100.0, 125.0, 160.0, 200.0])
    meas = np.array([3.0, 4.5, 5.4, 7.6])
    model = np.array([3.2, 4.1, 5.9, 7.0])
    ax = plotting.plot_band_overlay(centres, meas, model, valid=[True, True, False, True])
    labels = ax.get_legend_handles_labels()[1]
    assert labels == ["measured", "measured, band failed its checks", "model"]
    assert ax.lines[1].get_xdata().tolist() == [160.0]  # the failed band, open marker
    plotting.save_figure(ax, tmp_path / "overlay.png")
    res = 20 * np.log10(model / meas)
    ax = plotting.plot_band_residual(centres, np.column_stack([res, -res]), ["a", "b"])
    heights = [p.get_height() for p in ax.patches]
    np.testing.assert_allclose(heights, np.concatenate([res, -res]))
    assert (tmp_path / "overlay.png").exists()
    with pytest.raises(ValueError, match="centres"):
        plotting.plot_band_residual(centres, np.ones(3))
