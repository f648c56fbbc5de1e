"""Reference-track limits of EN ISO 3095:2013: the lower limits of the track decay rate
(Figure 3) and the upper limit of the rail roughness (Figure 2).

ISO 3095:2013 (Acoustics - Railway applications - Measurement of noise emitted by
railbound vehicles), 6.2, asks that the test track of a constant-speed pass-by test have
vertical and lateral track decay rates, measured by EN 15461, at least equal to the lower
limits of its Figure 3 in every one-third-octave band from 250 Hz to 5 kHz. The TSI Noise
(Commission Regulation (EU) No 1304/2014) takes its reference track from ISO 3095:2013.

Provenance (the standard's text was not available to us): the values below are the table
printed beside the curves of ISO 3095:2013 Figure 3 (curve A vertical, curve B lateral), as
transcribed from the ISO copy in the public repository jmrplens/phonometry, file
``tests/reference_data/rolling_stock_noise.py`` (``FIGURE_3_*``, read at commit
054957cc6b3d6ea306c8b1eb7d686668b0a069aa). They are consistent with limit curves drawn as
straight segments on log-log axes between corner bands (vertical: 6 dB/m at 630 Hz to
0.8 dB/m at 1 kHz gives the printed 2.19 dB/m at 800 Hz; lateral: a constant ratio of about
1.47 per band from 250 Hz to 1 kHz); tests/test_iso3095.py checks that consistency, which
a mistyped value would break. Check them against your copy of the standard before relying
on them for a test report.

Rail roughness (ISO 3095:2013, 6.2 and Figure 2): the one-third-octave wavelength spectrum
of the test track's rail roughness shall not exceed the limit curve of Figure 2, 40 cm to
0.315 cm (dB re 1 um). Provenance as above: the values printed beside each point of Figure 2
as transcribed in jmrplens/phonometry ``tests/reference_data/rolling_stock_noise.py``
(``FIGURE_2_*``, same commit), where EN 15610:2009 Annex B.9.2 (the "2007 TSI limit"
listing) is cited as a second, identical printing. NOT checked against the standard's text
by us. The curve is two straight lines on a log wavelength axis (steps of about 2 dB per
band from 40 cm to 3.15 cm, 0.6 dB per band below; tests/test_iso3095.py checks that).
"""
from __future__ import annotations

import numpy as np

__all__ = [
    "TRACK_DECAY_LIMIT_BANDS_HZ",
    "TRACK_DECAY_LIMIT_VERTICAL",
    "TRACK_DECAY_LIMIT_LATERAL",
    "TRACK_DECAY_LIMITS",
    "track_decay_limit",
    "below_limit",
    "ROUGHNESS_LIMIT_WAVELENGTHS_M",
    "ROUGHNESS_LIMIT_DB",
    "roughness_limit",
]

#: One-third-octave band centre frequencies (Hz) of ISO 3095:2013 Figure 3.
TRACK_DECAY_LIMIT_BANDS_HZ: tuple[float, ...] = (
    250.0, 315.0, 400.0, 500.0, 630.0, 800.0, 1000.0, 1250.0, 1600.0,
    2000.0, 2500.0, 3150.0, 4000.0, 5000.0,
)
#: Lower limit of the vertical track decay rate (dB/m), ISO 3095:2013 Figure 3, curve A.
TRACK_DECAY_LIMIT_VERTICAL: tuple[float, ...] = (
    2.00, 2.00, 6.00, 6.00, 6.00, 2.19, 0.80, 0.80, 0.80, 0.80, 0.80, 0.80, 0.80, 0.80,
)
#: Lower limit of the lateral track decay rate (dB/m), ISO 3095:2013 Figure 3, curve B.
TRACK_DECAY_LIMIT_LATERAL: tuple[float, ...] = (
    2.04, 1.38, 0.94, 0.64, 0.43, 0.29, 0.20, 0.20, 0.32, 0.50, 0.50, 0.50, 0.50, 0.50,
)
#: Direction -> limit values (dB/m) on TRACK_DECAY_LIMIT_BANDS_HZ.
TRACK_DECAY_LIMITS = {"vertical": TRACK_DECAY_LIMIT_VERTICAL,
                      "lateral": TRACK_DECAY_LIMIT_LATERAL}


def track_decay_limit(direction: str) -> tuple[np.ndarray, np.ndarray]:
    """(band centres in Hz, lower limit in dB/m) of the ISO 3095:2013 track decay rate for
    ``direction`` 'vertical' or 'lateral'."""
    if direction not in TRACK_DECAY_LIMITS:
        raise ValueError(f"direction must be one of {', '.join(TRACK_DECAY_LIMITS)}, "
                         f"got {direction!r}")
    return (np.array(TRACK_DECAY_LIMIT_BANDS_HZ),
            np.array(TRACK_DECAY_LIMITS[direction], dtype=float))


def below_limit(band_hz, decay_rate, direction: str) -> np.ndarray:
    """True for the bands whose decay rate (dB/m) is below the ISO 3095:2013 limit.

    band_hz: (nb,) nominal one-third-octave centres (Hz); decay_rate: (nb,) or (nb, nc).
    Bands outside 250 Hz - 5 kHz (where the standard sets no limit) and NaN rates are
    never below the limit.
    """
    bands, limit = track_decay_limit(direction)
    band_hz = np.asarray(band_hz, dtype=float)
    d = np.asarray(decay_rate, dtype=float)
    if d.shape[:1] != band_hz.shape:
        raise ValueError(f"decay_rate must have the band axis first, length {band_hz.size} "
                         f"like band_hz, got shape {d.shape}")
    lim = np.full(band_hz.shape, np.nan)
    for i, f in enumerate(band_hz):
        match = np.isclose(bands, f, rtol=0.03)  # nominal vs exact centres differ < 3 %
        if match.any():
            lim[i] = limit[np.argmax(match)]
    lim = lim.reshape(lim.shape + (1,) * (d.ndim - 1))
    with np.errstate(invalid="ignore"):
        return np.isfinite(lim) & np.isfinite(d) & (d < lim)


#: Nominal one-third-octave wavelengths (m) of ISO 3095:2013 Figure 2, 40 cm to 0.315 cm.
ROUGHNESS_LIMIT_WAVELENGTHS_M: tuple[float, ...] = tuple(x * 1e-2 for x in (
    40.0, 31.5, 25.0, 20.0, 16.0, 12.5, 10.0, 8.0, 6.3, 5.0, 4.0,
    3.15, 2.5, 2.0, 1.6, 1.25, 1.0, 0.8, 0.63, 0.5, 0.4, 0.315,
))
#: Upper limit of the rail roughness level (dB re 1 um) per band, ISO 3095:2013 Figure 2.
ROUGHNESS_LIMIT_DB: tuple[float, ...] = (
    17.1, 15.0, 13.0, 11.0, 9.0, 7.0, 4.9, 2.9, 0.9, -1.1, -3.2,
    -5.0, -5.6, -6.2, -6.8, -7.4, -8.0, -8.6, -9.2, -9.8, -10.4, -11.0,
)


def roughness_limit() -> tuple[np.ndarray, np.ndarray]:
    """(wavelength in m, longest first; limit in dB re 1 um) of the ISO 3095:2013 rail
    roughness limit (Figure 2)."""
    return np.array(ROUGHNESS_LIMIT_WAVELENGTHS_M), np.array(ROUGHNESS_LIMIT_DB)
