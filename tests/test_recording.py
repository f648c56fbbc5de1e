"""Recordings: write-read round trips, the truth kept apart, and synthesised pass-bys
whose band content follows the simulated band levels."""
import json

import numpy as np
import pytest

from railfem.io.recording import read_recording, truth_path, write_recording
from railfem.recording import Channel, Recording
from railfem.simulate import signals
from railfem.simulate.passby import PassbyResult
from railfem.simulate.train import TrainLayout
from railfem.standards import iec61260


@pytest.mark.parametrize("fmt", ["wav", "npz"])
def test_round_trip(tmp_path, fmt):
    rng = np.random.default_rng(3)
    sig = rng.standard_normal((1000, 2)) * 50.0
    rec = Recording(samples=sig, fs=25600.0,
                    channels=(Channel(name="a", location="foot", x_from_support=0.3),
                              Channel(name="b", quantity="velocity", location="head")),
                    speed=None, metadata={"sleeper_spacing_m": 0.6, "site": {"track": "B5"}})
    paths = write_recording(tmp_path / "run1", rec, data_format=fmt)
    back = read_recording(paths["data"])
    stored = sig.astype(np.float32).astype(float) if fmt == "wav" else sig
    assert np.array_equal(back.samples, stored)
    assert back.channels == rec.channels and back.speed is None
    assert back.fs == 25600.0 and back.metadata == rec.metadata
    assert json.loads(paths["meta"].read_text())["channels"][1]["unit"] == "m/s"
    assert read_recording(paths["meta"]).channels == rec.channels  # sidecar path works too


def test_reads_the_earlier_v1_sidecar(tmp_path):
    """Recordings written by 'railfem passby' before the formats were unified."""
    sig = np.arange(64, dtype=np.float32)
    np.savez(tmp_path / "old.npz", signal=sig[:, None])
    (tmp_path / "old.json").write_text(json.dumps({
        "format": "railfem-recording v1", "data_file": "old.npz", "sample_rate_hz": 1000.0,
        "n_samples": 64, "channels": [{"name": "rail_foot_z", "quantity": "acceleration",
                                       "unit": "m/s^2", "location": "foot", "direction": "z",
                                       "x_from_support_m": 0.3}],
        "speed_m_per_s": 60.0, "site": {"sleeper_spacing_m": 0.6}}))
    rec = read_recording(tmp_path / "old.npz")
    assert (rec.fs, rec.speed, rec.channel.location, rec.channel.x_from_support) == (
        1000.0, 60.0, "foot", 0.3)
    assert rec.metadata == {"sleeper_spacing_m": 0.6}
    np.testing.assert_array_equal(rec.trace, sig)


def test_bad_recordings_are_named(tmp_path):
    with pytest.raises(ValueError, match="one column per channel"):
        Recording(samples=np.zeros((100, 2)), fs=1000.0, channels=(Channel(name="a"),))
    with pytest.raises(ValueError, match="repeated names"):
        Recording(samples=np.zeros((100, 2)), fs=1000.0,
                  channels=(Channel(name="a"), Channel(name="a")))
    with pytest.raises(ValueError, match="non-finite value at sample 5 of channel 'a'"):
        Recording(samples=np.where(np.arange(100) == 5, np.nan, 0.0), fs=1000.0,
                  channels=(Channel(name="a"),))
    rec = Recording(samples=np.zeros(100), fs=1000.0, channels=(Channel(name="a"),))
    with pytest.raises(ValueError, match="reserved"):
        write_recording(tmp_path / "m", Recording(samples=np.zeros(100), fs=1000.0,
                                                  metadata={"speed_m_s": 3.0}))
    paths = write_recording(tmp_path / "x", rec)
    paths["meta"].write_text(paths["meta"].read_text().replace('"n_samples": 100',
                                                               '"n_samples": 101'))
    with pytest.raises(ValueError, match="truncated"):
        read_recording(paths["meta"])
    (tmp_path / "y.toml").write_text('quantity = "pressure"\nfs_hz = 100.0\n')
    np.savez(tmp_path / "y.npz", samples=np.zeros(100))
    with pytest.raises(ValueError, match="'quantity' must be one of"):
        read_recording(tmp_path / "y.npz")


def _flat_result(level_db=120.0):
    """A pass-by with one wheel and a flat band level vs position (a known truth)."""
    f = iec61260.ninth_octave_grid(200, 1000)
    bands = iec61260.third_octave_bands(200, 1000)
    X = np.round(np.arange(-20, 20.05, 0.1), 10)
    v2 = np.full((len(f), len(X)), (10 ** (level_db / 20) * 1e-9) ** 2)
    bv = iec61260.band_average(f, np.sqrt(v2), bands)
    return PassbyResult(frequency=f, position=X, velocity_sq=v2,
                        force_sq=np.zeros((len(f), len(X), 1)), bands=bands, band_velocity=bv,
                        roughness=np.zeros(len(f)), settings={"sensor_x_m": 0.3})


def test_synthesised_band_rms_follows_the_band_levels(tmp_path):
    res = _flat_result()
    sig, truth = signals.synthesise(res, TrainLayout(axle_offsets=(0.0,)), 40.0,
                                    quantity="velocity", seed=7)
    # band RMS of the record (FFT band power) against the simulated band velocity
    spec = np.abs(np.fft.rfft(sig)) ** 2
    freq = np.fft.rfftfreq(len(sig), 1 / truth["sample_rate_hz"])
    for b in range(len(res.bands)):
        inside = (freq >= res.bands.lower[b]) & (freq < res.bands.upper[b])
        rms = np.sqrt(2 * spec[inside].sum()) / len(sig)
        assert 20 * np.log10(rms / res.band_velocity[b, 0]) == pytest.approx(0.0, abs=0.05)
    rec = signals.passby_recording(sig, truth, spacing=0.6, location="foot")
    paths = write_recording(tmp_path / "p", rec, data_format="wav", truth=truth)
    assert paths["truth"] == truth_path(paths["data"])
    back = read_recording(paths["meta"])
    assert back.speed == 40.0 and back.channel.x_from_support == pytest.approx(0.3)
    meta = paths["meta"].read_text()
    assert "axle_offsets" not in meta and "band_level" not in meta  # truth kept apart
    assert json.loads(paths["truth"].read_text())["axle_offsets_m"] == [0.0]


def test_quasi_static_pulse_matches_the_winkler_beam():
    q = signals.QuasiStatic(load=80e3, EI=6.4e6, foundation=65e6)
    x = np.linspace(-10, 10, 40001)
    w = q.deflection(x)
    # static equilibrium: the foundation carries the load, int s w dx = P
    assert np.trapezoid(q.foundation * w, x) == pytest.approx(80e3, rel=1e-4)
    # the second derivative is the numerical one
    d2 = np.gradient(np.gradient(w, x), x)
    assert np.allclose(d2[100:-100], q.second_derivative(x)[100:-100], atol=1e-3 * abs(d2).max())
