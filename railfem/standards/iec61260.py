"""One-third-octave bands after IEC 61260-1:2014 (base-10 system) and band averaging.

Base-10 octave ratio ``G = 10^(3/10)``; for fractional-octave bandwidth ``1/b`` with
``b = 3`` the exact mid-band frequencies are ``f_m = f_r * G^(x/b) = 1000 * 10^(x/10)`` Hz
(``f_r = 1000`` Hz, ``x`` an integer) and the band edges are ``f_m * G^(±1/(2b)) =
f_m * 10^(±1/20)`` (IEC 61260-1:2014, clause 5.2 - 5.4). Adjacent bands share their edges.

The 1/9-octave narrow-band grid ``f = 1000 * 10^(m/30)`` puts exactly three points inside
every one-third-octave band (``m = 3x - 1, 3x, 3x + 1``); the band edges fall at half-integer
``m`` so no grid point ever sits on an edge.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "BASE10_OCTAVE_RATIO",
    "REFERENCE_FREQUENCY_HZ",
    "NOMINAL_THIRD_OCTAVE_CENTRES_HZ",
    "ThirdOctaveBands",
    "exact_centre",
    "nominal_centre",
    "third_octave_bands",
    "band_average",
    "ninth_octave_grid",
]

log = logging.getLogger(__name__)

BASE10_OCTAVE_RATIO = 10.0 ** (3.0 / 10.0)  # G, IEC 61260-1:2014 clause 5.2
REFERENCE_FREQUENCY_HZ = 1000.0  # f_r, IEC 61260-1:2014 clause 5.3

# Nominal one-third-octave mid-band frequencies, 10 Hz ... 20 kHz, as tabulated in
# IEC 61260-1:2014 Annex E (which takes them from the ISO 266:1997 preferred-number series
# R10). Keyed by the band index x of f_m = 1000 * 10^(x/10): x = -20 (10 Hz) ... 13 (20 kHz).
NOMINAL_THIRD_OCTAVE_CENTRES_HZ: tuple[float, ...] = (
    10.0, 12.5, 16.0, 20.0, 25.0, 31.5, 40.0, 50.0, 63.0, 80.0,
    100.0, 125.0, 160.0, 200.0, 250.0, 315.0, 400.0, 500.0, 630.0, 800.0,
    1000.0, 1250.0, 1600.0, 2000.0, 2500.0, 3150.0, 4000.0, 5000.0, 6300.0, 8000.0,
    10000.0, 12500.0, 16000.0, 20000.0,
)
_NOMINAL_FIRST_INDEX = -20  # band index x of NOMINAL_THIRD_OCTAVE_CENTRES_HZ[0]

# The nominal values repeat every decade (ISO 266 R10 mantissae); used outside the table.
_R10_MANTISSAE = (1.0, 1.25, 1.6, 2.0, 2.5, 3.15, 4.0, 5.0, 6.3, 8.0)

# Snapping tolerance in band-index units when a user passes a nominal frequency as a
# range limit: nominal and exact centres differ by < 0.07 index units (2.5 % at 12.5 Hz),
# while neighbouring bands are 1 unit apart.
_INDEX_TOLERANCE = 0.1


def exact_centre(index: int | np.ndarray) -> np.ndarray:
    """Exact base-10 mid-band frequency ``1000 * 10^(x/10)`` (Hz) of band index ``x``."""
    return REFERENCE_FREQUENCY_HZ * 10.0 ** (np.asarray(index, dtype=float) / 10.0)


def nominal_centre(index: int) -> float:
    """Nominal mid-band frequency (Hz) of band index ``x`` (IEC 61260-1 Annex E / ISO 266).

    Inside 10 Hz ... 20 kHz the tabulated value is returned; outside, the R10 mantissa of
    the same position in the decade (e.g. 8 Hz, 25 kHz).
    """
    index = int(index)
    k = index - _NOMINAL_FIRST_INDEX
    if 0 <= k < len(NOMINAL_THIRD_OCTAVE_CENTRES_HZ):
        return NOMINAL_THIRD_OCTAVE_CENTRES_HZ[k]
    decade, position = divmod(index, 10)
    return round(_R10_MANTISSAE[position] * 10.0 ** (decade + 3), 10)


@dataclass(frozen=True, kw_only=True, eq=False)
class ThirdOctaveBands:
    """A contiguous set of one-third-octave bands (all arrays shape (n_bands,))."""

    index: np.ndarray
    """Band index x in f_m = 1000 * 10^(x/10) (integer)."""
    nominal: np.ndarray
    """Nominal mid-band frequency, Hz (for labels only; never compute with it)."""
    centre: np.ndarray
    """Exact base-10 mid-band frequency f_m, Hz."""
    lower: np.ndarray
    """Lower band edge f_m * 10^(-1/20), Hz."""
    upper: np.ndarray
    """Upper band edge f_m * 10^(+1/20), Hz."""

    def __post_init__(self) -> None:
        n = np.shape(self.index)
        for name in ("nominal", "centre", "lower", "upper"):
            if np.shape(getattr(self, name)) != n:
                raise ValueError(
                    f"ThirdOctaveBands.{name} has shape {np.shape(getattr(self, name))}, "
                    f"expected {n} like index; build bands with third_octave_bands()."
                )

    def __len__(self) -> int:
        return int(np.size(self.index))


def _index_range(f_low: float, f_high: float) -> tuple[int, int]:
    if not (np.isfinite(f_low) and np.isfinite(f_high) and 0.0 < f_low <= f_high):
        raise ValueError(
            f"third-octave band range needs 0 < f_low <= f_high (Hz), got f_low={f_low!r}, "
            f"f_high={f_high!r}; pass positive finite frequencies in increasing order."
        )
    x_low = 10.0 * math.log10(f_low / REFERENCE_FREQUENCY_HZ)
    x_high = 10.0 * math.log10(f_high / REFERENCE_FREQUENCY_HZ)
    n_low = math.ceil(x_low - _INDEX_TOLERANCE)
    n_high = math.floor(x_high + _INDEX_TOLERANCE)
    if n_high < n_low:
        raise ValueError(
            f"no one-third-octave mid-band frequency lies in [{f_low}, {f_high}] Hz; "
            "widen the range to include at least one band centre."
        )
    return n_low, n_high


def third_octave_bands(f_low: float, f_high: float) -> ThirdOctaveBands:
    """The one-third-octave bands whose mid-band frequency lies in ``[f_low, f_high]`` Hz.

    Either nominal or exact centres may be passed as limits (``third_octave_bands(25, 20e3)``
    gives the 25 Hz ... 20 kHz bands although the exact 20 kHz centre is 19 952.6 Hz).
    """
    n_low, n_high = _index_range(f_low, f_high)
    index = np.arange(n_low, n_high + 1)
    centre = exact_centre(index)
    half = 10.0 ** (1.0 / 20.0)  # G^(1/(2b)) with b = 3
    return ThirdOctaveBands(
        index=index,
        nominal=np.array([nominal_centre(i) for i in index]),
        centre=centre,
        lower=centre / half,
        upper=centre * half,
    )


def ninth_octave_grid(f_low: float, f_high: float) -> np.ndarray:
    """Narrow-band 1/9-octave grid ``f = 1000 * 10^(m/30)`` (Hz) covering whole bands.

    The grid spans every one-third-octave band of ``third_octave_bands(f_low, f_high)``
    completely, i.e. three points per band, from the lowest point of the first band to
    the highest point of the last, so ``band_average`` never sees a partial band.
    """
    n_low, n_high = _index_range(f_low, f_high)
    m = np.arange(3 * n_low - 1, 3 * n_high + 2)
    return REFERENCE_FREQUENCY_HZ * 10.0 ** (m / 30.0)


def band_average(
    frequency: np.ndarray,
    values: np.ndarray,
    bands: ThirdOctaveBands,
    *,
    on_empty: str = "nan",
) -> np.ndarray:
    """Band RMS ``sqrt(mean |q|^2)`` of the narrow-band points inside each band.

    Parameters
    ----------
    frequency : (n_freq,) narrow-band frequencies, Hz.
    values : (n_freq, ...) real or complex narrow-band values; frequency on axis 0, any
        trailing shape.
    bands : the bands to average into.
    on_empty : ``"nan"`` (default) returns NaN for a band without narrow-band points and
        logs a warning; ``"raise"`` raises ``ValueError`` instead.

    A point belongs to a band when ``lower <= f < upper`` (half-open, so a point exactly on
    a shared edge is counted once). The mean of ``|q|^2`` is unweighted: it stands for the
    band power only if the points are evenly spaced on a log axis (1/9 octave or finer, see
    ``ninth_octave_grid``).

    Returns
    -------
    (n_bands, ...) real band RMS values, same units as ``values``.
    """
    if on_empty not in ("nan", "raise"):
        raise ValueError(f"on_empty must be 'nan' or 'raise', got {on_empty!r}.")
    frequency = np.asarray(frequency, dtype=float)
    values = np.asarray(values)
    if frequency.ndim != 1:
        raise ValueError(
            f"band_average: frequency must be 1-D (n_freq,), got shape {frequency.shape}."
        )
    if values.ndim == 0 or values.shape[0] != frequency.size:
        raise ValueError(
            f"band_average: values shape {values.shape} does not have frequency on axis 0 "
            f"(expected first dimension {frequency.size}); move the frequency axis first."
        )
    power = np.abs(values) ** 2
    out = np.empty((len(bands),) + values.shape[1:], dtype=float)
    empty = []
    for k, (lo, hi) in enumerate(zip(bands.lower, bands.upper)):
        inside = (frequency >= lo) & (frequency < hi)
        if not inside.any():
            out[k] = np.nan
            empty.append(float(bands.nominal[k]))
            continue
        out[k] = np.sqrt(power[inside].mean(axis=0))
    if empty:
        span = (
            f"{frequency.min():.4g} ... {frequency.max():.4g} Hz" if frequency.size else "empty"
        )
        msg = (
            f"band_average: no narrow-band points in the one-third-octave band(s) with "
            f"nominal centre {empty} Hz (data span {span}); use a 1/9-octave grid covering "
            "whole bands (ninth_octave_grid) or restrict the bands."
        )
        if on_empty == "raise":
            raise ValueError(msg)
        log.warning(msg + " Those bands are NaN.")
    return out
