"""ISO 3095:2013 limits: track decay rate (Figure 3) and rail roughness (Figure 2)."""
import numpy as np
import pytest

from railfem.standards import iso3095


def test_table_shape_and_bands():
    bands, vertical = iso3095.track_decay_limit("vertical")
    assert bands.tolist() == [250, 315, 400, 500, 630, 800, 1000, 1250, 1600, 2000, 2500,
                              3150, 4000, 5000]
    assert vertical.shape == bands.shape == iso3095.track_decay_limit("lateral")[1].shape
    with pytest.raises(ValueError, match="vertical, lateral"):
        iso3095.track_decay_limit("longitudinal")


def test_values_lie_on_the_straight_log_log_segments_of_the_figure():
    """Independent of the transcription: Figure 3 draws straight lines on log-log axes
    between corner bands, so an intermediate band is the geometric mean of its neighbours
    on a segment (to the two decimals printed). A mistyped value breaks this."""
    v = np.array(iso3095.TRACK_DECAY_LIMIT_VERTICAL)
    lat = np.array(iso3095.TRACK_DECAY_LIMIT_LATERAL)
    assert v[5] == pytest.approx(np.sqrt(v[4] * v[6]), abs=0.005)      # 800 Hz
    assert lat[8] == pytest.approx(np.sqrt(lat[7] * lat[9]), abs=0.005)  # 1600 Hz
    ratios = lat[:6] / lat[1:7]  # 250 Hz - 1 kHz: one straight segment
    assert ratios == pytest.approx(np.full(6, (lat[0] / lat[6]) ** (1 / 6)), rel=0.03)


def test_below_limit():
    bands = np.array([200.0, 250.0, 800.0, 5000.0, 6300.0])
    d = np.array([0.1, 1.9, 2.5, 0.79, 0.1])
    assert iso3095.below_limit(bands, d, "vertical").tolist() == [False, True, False, True,
                                                                  False]
    two = iso3095.below_limit(bands, np.column_stack([d, d * 10]), "lateral")
    assert two.shape == (5, 2) and not two[:, 1].any()
    with pytest.raises(ValueError, match="band axis first"):
        iso3095.below_limit(bands, d[:3], "vertical")


def test_roughness_limit_is_two_straight_lines_on_log_wavelength():
    """A mistyped value breaks the shape: about 2 dB per band from 40 cm to 3.15 cm
    (20 dB/decade), 0.6 dB per band below (6 dB/decade), the corner at 3.15 cm."""
    from railfem.standards.iso3095 import roughness_limit

    lam, lim = roughness_limit()
    assert lam.size == lim.size == 22
    np.testing.assert_allclose(np.diff(np.log10(lam)), -0.1, atol=8e-3)  # nominal 1/3 oct.
    assert lam[0] == pytest.approx(0.40) and lam[-1] == pytest.approx(0.00315)
    step = -np.diff(lim)
    corner = int(np.argmin(np.abs(lam - 0.0315)))
    np.testing.assert_allclose(step[:corner - 1], 2.0, atol=0.11)
    np.testing.assert_allclose(step[corner:], 0.6, atol=1e-9)
