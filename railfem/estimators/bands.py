"""One-third-octave band energy of a time signal, with the IEC 61260-1 class 1 filters.

Each band is filtered with :func:`railfem.standards.iec61260.band_filter_sos` run forward
and backward (zero phase, no delay of the band envelope against the wheel instants). What
the pass-by estimators need from a band is its energy between arbitrary instants (window
energies around wheels, block levels at 0.1 m steps of train travel), so a band is kept as
its cumulative energy ``C(t) = ∫_0^t y^2 dt'`` and energies are differences of ``C``.

The filter smears the band envelope in time: for an input whose mean-square varies
slowly, ``σ_x^2(t)`` (modulated noise, broadband within the band), the output mean square
is ``E[y^2](t) = Σ_τ h(τ)^2 σ_x^2(t − τ)`` with ``h`` the (two-pass) impulse response, so
the band power is the true power convolved with the *power kernel* ``h^2 / Σ h^2``
(:func:`power_kernel`). The energy-iteration model uses it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from railfem.standards.iec61260 import band_filter_sos

__all__ = ["BandEnergy", "band_energy", "power_kernel", "energy_between", "block_levels"]

# the power kernel is cut where its tails hold less than this fraction of its energy
_KERNEL_TAIL = 1e-5


@dataclass(frozen=True, kw_only=True, eq=False)
class BandEnergy:
    """Cumulative energy of one band of one signal."""

    centre: float
    """Exact mid-band frequency, Hz."""
    fs: float
    """Sample rate, Hz."""
    cumulative: np.ndarray
    """(n + 1,) C(t_k) = Σ_{j<k} y_j^2 / fs: the energy up to sample k, (unit)^2 s."""
    kernel_t: np.ndarray
    """(m,) times of the power kernel, s (symmetric about 0)."""
    kernel: np.ndarray
    """(m,) power kernel h^2 / Σ h^2 (sums to 1)."""


def power_kernel(sos: np.ndarray, fs: float) -> tuple[np.ndarray, np.ndarray]:
    """Times (s) and weights of the forward-backward filter's power kernel ``h^2/Σh^2``.

    The two-pass impulse response is symmetric about 0; it is computed by filtering a unit
    impulse in the middle of a zero record long enough for the response to die out.
    """
    from scipy import signal

    n = 1024
    while True:
        x = np.zeros(2 * n + 1)
        x[n] = 1.0
        h = signal.sosfiltfilt(sos, x, padtype=None)
        p = h**2
        total = p.sum()
        edge = p[: n // 8].sum() + p[-(n // 8):].sum()
        if edge < 1e-12 * total or n > 2**22:
            break
        n *= 2
    c = np.cumsum(p) / total
    lo = int(np.searchsorted(c, _KERNEL_TAIL / 2))
    hi = int(np.searchsorted(c, 1.0 - _KERNEL_TAIL / 2))
    half = max(n - lo, hi - n)  # keep it symmetric
    k = p[n - half: n + half + 1]
    t = np.arange(-half, half + 1) / fs
    return t, k / k.sum()


def band_energy(samples: np.ndarray, fs: float, centre: float) -> BandEnergy:
    """Filter ``samples`` into the one-third-octave band at exact ``centre`` (Hz) and return
    its cumulative energy (one band at a time: a long record times many bands would not
    fit in memory at once)."""
    from scipy import signal

    x = np.asarray(samples, dtype=float)
    x = x - np.mean(x)
    sos = band_filter_sos(float(centre), fs)  # raises for bands too close to fs/2
    y = signal.sosfiltfilt(sos, x)
    cum = np.concatenate([[0.0], np.cumsum(y * y)]) / fs
    kt, k = power_kernel(sos, fs)
    return BandEnergy(centre=float(centre), fs=fs, cumulative=cum, kernel_t=kt, kernel=k)


def energy_between(band: BandEnergy, t_start, t_end) -> np.ndarray:
    """Band energy between instants ``t_start`` and ``t_end`` (s, arrays broadcast).

    Instants are clipped to the record; the energy is interpolated linearly between
    samples of the cumulative energy, so windows need not fall on samples.
    """
    n = band.cumulative.size - 1
    t_grid_end = n / band.fs

    def c(t):
        t = np.clip(np.asarray(t, dtype=float), 0.0, t_grid_end)
        return np.interp(t * band.fs, np.arange(n + 1), band.cumulative)

    return c(t_end) - c(t_start)


def block_levels(band: BandEnergy, t_centres, duration: float, *,
                 reference: float = 1.0) -> np.ndarray:
    """Band level ``10 lg(mean y^2 / reference^2)`` in blocks of ``duration`` s centred at
    ``t_centres``; blocks reaching outside the record are NaN."""
    t = np.asarray(t_centres, dtype=float)
    t0, t1 = t - duration / 2, t + duration / 2
    e = energy_between(band, t0, t1)
    inside = (t0 >= 0) & (t1 <= (band.cumulative.size - 1) / band.fs)
    with np.errstate(divide="ignore"):
        level = 10.0 * np.log10(np.maximum(e / duration, 1e-300) / reference**2)
    return np.where(inside, level, np.nan)
