import logging

import numpy as np
import pytest

from railfem.standards.iec61260 import (
    NOMINAL_THIRD_OCTAVE_CENTRES_HZ,
    band_average,
    band_index,
    nominal_centre,
    ninth_octave_grid,
    third_octave_bands,
)

# ISO 266 / IEC 61260-1 nominal centres typed out independently of the module
NOMINAL_25_TO_20K = [
    25, 31.5, 40, 50, 63, 80, 100, 125, 160, 200, 250, 315, 400, 500, 630, 800,
    1000, 1250, 1600, 2000, 2500, 3150, 4000, 5000, 6300, 8000, 10000, 12500, 16000, 20000,
]


def test_nominal_table_and_band_selection():
    bands = third_octave_bands(25, 20000)
    assert bands.nominal.tolist() == NOMINAL_25_TO_20K
    assert len(bands) == 30
    assert set(NOMINAL_25_TO_20K) <= set(NOMINAL_THIRD_OCTAVE_CENTRES_HZ)


def test_exact_centres_and_edges_follow_base10_formula():
    bands = third_octave_bands(10, 20000)
    G = 10 ** (3 / 10)
    for x, fm, lo, hi in zip(bands.index, bands.centre, bands.lower, bands.upper):
        assert fm == pytest.approx(1000 * G ** (x / 3), rel=1e-13)
        assert lo == pytest.approx(fm * G ** (-1 / 6), rel=1e-13)
        assert hi == pytest.approx(fm * G ** (1 / 6), rel=1e-13)
    # 1 kHz band: 891.25 ... 1122.0 Hz
    k = int(np.flatnonzero(bands.nominal == 1000)[0])
    assert bands.centre[k] == 1000.0
    assert bands.lower[k] == pytest.approx(891.2509, rel=1e-6)
    assert bands.upper[k] == pytest.approx(1122.0185, rel=1e-6)
    # contiguous: upper edge of one band is the lower edge of the next
    np.testing.assert_allclose(bands.upper[:-1], bands.lower[1:], rtol=1e-14)
    # nominal values are the exact ones rounded: within 2.5 % (largest at 12.5 Hz)
    assert np.all(np.abs(bands.nominal / bands.centre - 1) < 0.025)


def test_nominal_outside_table_repeats_by_decade():
    assert nominal_centre(-21) == 8.0
    assert nominal_centre(14) == 25000.0
    assert nominal_centre(-30) == 1.0


def test_band_range_accepts_nominal_limits():
    # exact centre of the 3150 Hz band is 3162 Hz > 3150: still included
    assert third_octave_bands(31.5, 3150).nominal[[0, -1]].tolist() == [31.5, 3150]
    with pytest.raises(ValueError, match="f_low"):
        third_octave_bands(100, 50)
    with pytest.raises(ValueError, match="no one-third-octave"):
        third_octave_bands(1050, 1100)


def test_ninth_octave_grid_three_points_per_band():
    f = ninth_octave_grid(25, 5000)
    bands = third_octave_bands(25, 5000)
    np.testing.assert_allclose(np.diff(np.log10(f)), 1 / 30, rtol=1e-12)
    counts = [np.sum((f >= lo) & (f < hi)) for lo, hi in zip(bands.lower, bands.upper)]
    assert counts == [3] * len(bands)
    # every grid point lies inside one of the bands (complete bands, nothing outside)
    assert f[0] > bands.lower[0] and f[-1] < bands.upper[-1]
    # the middle point of every band is the exact centre
    np.testing.assert_allclose(f[1::3], bands.centre, rtol=1e-12)


def test_band_average_is_rms_of_points_in_band_trailing_shape_complex():
    f = ninth_octave_grid(100, 400)
    bands = third_octave_bands(100, 400)
    rng = np.random.default_rng(1)
    q = rng.normal(size=(f.size, 2, 3)) + 1j * rng.normal(size=(f.size, 2, 3))
    out = band_average(f, q, bands)
    assert out.shape == (len(bands), 2, 3)
    for k in range(len(bands)):
        pts = q[3 * k:3 * k + 3]
        expected = np.sqrt(np.mean(pts.real**2 + pts.imag**2, axis=0))
        np.testing.assert_allclose(out[k], expected, rtol=1e-14)


def test_band_average_of_constant_magnitude_is_that_magnitude():
    f = np.linspace(10, 1000, 5000)
    bands = third_octave_bands(20, 800)
    out = band_average(f, 2.5 * np.exp(1j * f), bands)
    np.testing.assert_allclose(out, 2.5, rtol=1e-12)


def test_empty_band_nan_with_warning_or_raise(caplog):
    f = np.array([100.0, 101.0, 400.0])
    bands = third_octave_bands(100, 400)
    with caplog.at_level(logging.WARNING, logger="railfem.standards.iec61260"):
        out = band_average(f, np.ones(3), bands)
    assert np.isnan(out[1]) and np.isnan(out[2])
    assert out[0] == 1.0 and out[-1] == 1.0
    assert "125.0" in caplog.text and "ninth_octave_grid" in caplog.text
    with pytest.raises(ValueError, match="no narrow-band points"):
        band_average(f, np.ones(3), bands, on_empty="raise")


def test_band_average_shape_errors():
    bands = third_octave_bands(100, 400)
    with pytest.raises(ValueError, match="axis 0"):
        band_average(np.arange(1, 11.0), np.ones((3, 10)), bands)


def test_band_index_agrees_with_band_average_membership():
    """A band's lower edge belongs to it (half-open, as band_average); points outside
    every band get -1; the index is where band_average puts a point."""
    bands = third_octave_bands(100.0, 1000.0)
    f = np.array([10.0, bands.lower[0], bands.lower[1], 500.0, 5000.0])
    k = band_index(f, bands)
    assert k[0] == -1 and k[-1] == -1
    assert k[1] == 0 and k[2] == 1
    one = np.zeros((len(f), 1))
    one[3] = 1.0
    avg = band_average(f, one, bands, on_empty="nan")[:, 0]
    assert np.nanargmax(avg) == k[3]
