"""One-third-octave bands after IEC 61260-1:2014 (base-10 system) and band averaging.

Base-10 octave ratio ``G = 10^(3/10)``; for fractional-octave bandwidth ``1/b`` with
``b = 3`` the exact mid-band frequencies are ``f_m = f_r * G^(x/b) = 1000 * 10^(x/10)`` Hz
(``f_r = 1000`` Hz, ``x`` an integer) and the band edges are ``f_m * G^(±1/(2b)) =
f_m * 10^(±1/20)`` (IEC 61260-1:2014, clause 5.2 - 5.4). Adjacent bands share their edges.

Band-pass filters (railfem's design, checked against the standard's class 1 mask): each
band is a Butterworth band-pass in second-order sections, run forward and backward
(zero phase); see :func:`band_filter_sos`. The class 1 acceptance limits of Table 1 are
cited constants below and :func:`relative_attenuation` evaluates a design against them.

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
    "empty_bands",
    "ninth_octave_grid",
    "CLASS1_PASSBAND_MIN_DB",
    "CLASS1_PASSBAND_MAX_DB",
    "CLASS1_STOPBAND_MIN_DB",
    "CLASS1_EFFECTIVE_BANDWIDTH_DB",
    "breakpoint_ratio",
    "class1_breakpoints",
    "band_edges",
    "band_filter_sos",
    "relative_attenuation",
    "effective_bandwidth_deviation",
    "MAX_UPPER_EDGE_FRACTION",
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


def band_index(frequency: np.ndarray, bands: ThirdOctaveBands) -> np.ndarray:
    """The index of the band each narrow-band frequency belongs to (``lower <= f < upper``,
    as in band_average), -1 outside every band."""
    f = np.asarray(frequency, dtype=float)
    k = np.full(f.shape, -1)
    for i, (lo, hi) in enumerate(zip(bands.lower, bands.upper)):
        k[(f >= lo) & (f < hi)] = i
    return k


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
    member = band_index(frequency, bands)
    empty = empty_bands(frequency, bands, on_empty=on_empty, member=member)
    for k in range(len(bands)):
        if empty[k]:
            out[k] = np.nan
            continue
        out[k] = np.sqrt(power[member == k].mean(axis=0))
    return out


def empty_bands(frequency: np.ndarray, bands: ThirdOctaveBands, *, on_empty: str = "nan",
                member: np.ndarray | None = None) -> np.ndarray:
    """(n_bands,) True for each band without narrow-band points (band_average makes those
    NaN), with band_average's warning (``on_empty="nan"``) or error (``"raise"``) if any;
    ``member``: band_index(frequency, bands) if already at hand."""
    frequency = np.asarray(frequency, dtype=float)
    member = band_index(frequency, bands) if member is None else member
    empty = ~np.isin(np.arange(len(bands)), member)
    if empty.any():
        span = (
            f"{frequency.min():.4g} ... {frequency.max():.4g} Hz" if frequency.size else "empty"
        )
        msg = (
            f"band_average: no narrow-band points in the one-third-octave band(s) with "
            f"nominal centre {[float(c) for c in np.asarray(bands.nominal)[empty]]} Hz (data "
            f"span {span}); use a 1/9-octave grid covering whole bands (ninth_octave_grid) "
            "or restrict the bands."
        )
        if on_empty == "raise":
            raise ValueError(msg)
        log.warning(msg + " Those bands are NaN.")
    return empty


# ----------------------------------------------------------------------------- filters
# IEC 61260-1:2014 Table 1, acceptance limits on the relative attenuation (dB) of class 1
# filters, at the octave-band normalised frequencies Omega = G^x (x >= 0; the low side
# mirrors them at 1/Omega, clause 5.10). Fractional-octave breakpoints follow from Formula
# (9), see breakpoint_ratio(). Transcribed from two independent published
# transcriptions of Table 1 (the phonometry and lasp/ASCEE filter-verification code) that
# agree on every class 1 value; railfem could not check the standard's own page.
CLASS1_PASSBAND_MIN_DB = -0.4
"""Lowest relative attenuation allowed anywhere in the pass band (|x| < 1/2), dB."""
CLASS1_PASSBAND_MAX_DB: tuple[tuple[float, float], ...] = (
    (0.0, 0.4), (1 / 8, 0.5), (1 / 4, 0.7), (3 / 8, 1.4), (1 / 2, 5.3),
)
"""(x, highest relative attenuation allowed at G^x) in the pass band; x = 1/2 is the band
edge approached from inside."""
CLASS1_STOPBAND_MIN_DB: tuple[tuple[float, float], ...] = (
    (1 / 2, 1.2), (1.0, 16.6), (2.0, 40.5), (3.0, 60.0), (4.0, 70.0),
)
"""(x, lowest relative attenuation required at G^x) in the stop band; x = 1/2 is the band
edge approached from outside; beyond G^4 the 70 dB of G^4 applies."""
CLASS1_EFFECTIVE_BANDWIDTH_DB = 0.4
"""Largest |ΔB| = |10 lg(B_e / B_r)| of a class 1 filter (IEC 61260-1:2014, 5.12)."""

MAX_UPPER_EDGE_FRACTION = 0.4
"""Bands are filtered only when their upper edge is below this fraction of the sample
rate: the bilinear transform distorts the band shape near the Nyquist frequency (the
design of band_filter_sos meets the class 1 mask up to an upper edge of ~0.43 fs)."""


def breakpoint_ratio(x: float, b: int = 3) -> float:
    """Normalised frequency f/f_m of the octave breakpoint G^x for bandwidth 1/b, x >= 0.

    IEC 61260-1:2014 Formula (9): ``1 + (G^(1/(2b)) - 1) / (G^(1/2) - 1) * (G^x - 1)``; the
    band edge ``x = 1/2`` maps to ``G^(1/(2b))``. The low-side breakpoint is the reciprocal.
    """
    if x < 0:
        raise ValueError(f"breakpoint exponent x must be >= 0 (high side), got {x}")
    G = BASE10_OCTAVE_RATIO
    return float(1.0 + (G ** (1.0 / (2 * b)) - 1.0) / (G**0.5 - 1.0) * (G**x - 1.0))


def class1_breakpoints(b: int = 3) -> list[tuple[float, float, float]]:
    """The class 1 checkpoints for bandwidth 1/b: (f/f_m, lowest, highest attenuation), dB.

    Both sides of the mid-band frequency; the band-edge rows appear twice, once as the
    pass-band limit (just inside the edge) and once as the stop-band limit (just outside),
    with ratios nudged by one part in 1e9 to say on which side they apply.
    """
    points = []
    for x, high in CLASS1_PASSBAND_MAX_DB:
        r = breakpoint_ratio(x, b)
        nudge = 1.0 - 1e-9 if x == 0.5 else 1.0
        points.append((r * nudge, CLASS1_PASSBAND_MIN_DB, high))
        if x > 0:
            points.append((1.0 / (r * nudge), CLASS1_PASSBAND_MIN_DB, high))
    for x, low in CLASS1_STOPBAND_MIN_DB:
        r = breakpoint_ratio(x, b)
        nudge = 1.0 + 1e-9 if x == 0.5 else 1.0
        points.append((r * nudge, low, math.inf))
        points.append((1.0 / (r * nudge), low, math.inf))
    return sorted(points)


def band_edges(centre: float) -> tuple[float, float]:
    """Exact one-third-octave band edges ``f_m * 10^(-+1/20)`` (Hz) of an exact centre."""
    half = 10.0 ** (1.0 / 20.0)
    return centre / half, centre * half


# Forward-backward filtering squares the magnitude response. For the squared response of
# an order-n Butterworth prototype to be 3.01 dB down at the exact band edges (as a single
# pass is at its design edges), the prototype is designed wider: its normalised frequency
# at the true edges is c = (sqrt(2) - 1)^(1/(2n)) (from (1 + c^(2n))^2 = 2).
_PROTOTYPE_ORDER = 3  # a 6th-order band-pass per pass


def band_filter_sos(centre: float, fs: float) -> np.ndarray:
    """Second-order sections of the zero-phase one-third-octave band-pass at ``centre`` (Hz).

    Run it forward and backward (``scipy.signal.sosfiltfilt``); the effective response is
    ``|H|^2``. ``H`` is a Butterworth band-pass of order 6 (third-order prototype) from
    ``scipy.signal.butter`` (bilinear transform, edges pre-warped), its edges placed
    geometrically around the exact mid-band frequency and widened so that the two passes
    together are 3.01 dB down at the exact base-10 band edges.

    Why zero phase: a causal band-pass delays the band envelope by its group delay (tens of
    ms in the low bands, i.e. metres of train travel) and smears it towards later times,
    which would misplace the band energy relative to the wheel instants and bias the decay
    after each wheel; run forward and backward the smear is symmetric and there is no
    delay. (The causal order-6 design also misses the class 1 limit at G^-3 once the band
    lies above about fs/4, where the bilinear transform compresses its low side.)

    The design meets the class 1 mask of IEC 61260-1:2014 Table 1 at every breakpoint and
    its effective-bandwidth deviation is ~0.05 dB, for upper band edges up to
    ``MAX_UPPER_EDGE_FRACTION * fs`` (tests/test_iec61260_filters.py); a band above that
    raises ValueError.
    """
    from scipy import signal

    if not (np.isfinite(fs) and fs > 0):
        raise ValueError(f"sample rate fs must be positive and finite (Hz), got {fs!r}")
    lower, upper = band_edges(float(centre))
    if not (centre > 0 and upper <= MAX_UPPER_EDGE_FRACTION * fs):
        raise ValueError(
            f"the one-third-octave band at {centre:.6g} Hz (upper edge {upper:.6g} Hz) cannot "
            f"be filtered at fs = {fs:g} Hz: its upper edge must lie below "
            f"{MAX_UPPER_EDGE_FRACTION:g} fs = {MAX_UPPER_EDGE_FRACTION * fs:g} Hz; choose "
            "a lower highest band or record at a higher sample rate."
        )
    c = (math.sqrt(2.0) - 1.0) ** (1.0 / (2 * _PROTOTYPE_ORDER))
    width = (upper - lower) / c
    lower = 0.5 * (-width + math.sqrt(width**2 + 4.0 * centre**2))
    upper = lower + width
    return signal.butter(_PROTOTYPE_ORDER, [lower, upper], btype="bandpass", fs=fs,
                         output="sos")


def relative_attenuation(sos: np.ndarray, frequency, fs: float, centre: float, *,
                         zero_phase: bool = True) -> np.ndarray:
    """Attenuation (dB) at ``frequency`` (Hz) relative to that at the mid-band ``centre``.

    This is the quantity the class limits apply to (IEC 61260-1:2014, 5.10). For a
    zero-phase (forward-backward) filter the effective response is ``|H|^2``.
    """
    from scipy import signal

    f = np.atleast_1d(np.asarray(frequency, dtype=float))
    _, h = signal.sosfreqz(sos, worN=np.concatenate([[centre], f]), fs=fs)
    a = -20.0 * np.log10(np.maximum(np.abs(h), 1e-300))
    if zero_phase:
        a = 2.0 * a
    return a[1:] - a[0]


def effective_bandwidth_deviation(sos: np.ndarray, fs: float, centre: float, *,
                                  zero_phase: bool = True, b: int = 3,
                                  per_band: int = 96) -> float:
    """ΔB = 10 lg(B_e / B_r) in dB (IEC 61260-1:2014, 5.11-5.12).

    ``B_e = ∫ 10^(-ΔA(Ω)/10) dΩ/Ω`` over the normalised frequency (trapezoidal rule on
    ``per_band`` log-spaced points per bandwidth, over the range where the filter can
    respond: up to the Nyquist frequency), ``B_r = ln(G)/b``.
    """
    G = BASE10_OCTAVE_RATIO
    step = math.log(G) / (b * per_band)
    lo = math.log(1e-3)
    hi = math.log(0.5 * fs / centre) - 1e-9
    u = np.arange(lo, hi, step)
    att = relative_attenuation(sos, centre * np.exp(u), fs, centre, zero_phase=zero_phase)
    integrand = 10.0 ** (-att / 10.0)
    b_e = float(np.sum(0.5 * (integrand[1:] + integrand[:-1])) * step)
    return 10.0 * math.log10(b_e / (math.log(G) / b))
