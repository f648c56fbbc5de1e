"""Roughness spectra per one-third-octave wavelength band (METHOD.md section 4).

A spectrum is a level L_r(lambda) in dB re 1 um (railfem.conventions.R_REF) per
one-third-octave wavelength band: the RMS roughness in that band. At train speed V a
wavelength maps to the frequency f = V / lambda, so a one-third-octave wavelength band maps
to a one-third-octave frequency band (not, in general, one of the IEC nominal bands).

Narrow-band use: :func:`amplitude_at` interpolates the level linearly in log(lambda) and
returns, at each narrow-band frequency, the RMS roughness of a one-third-octave band
centred there (m). A response computed per unit roughness at the 1/9-octave points and
multiplied by these amplitudes gives band levels after averaging |.|^2 over the three
points of each band (METHOD.md section 0); for a spectrum flat within the band this equals
the band RMS response exactly.

Files: railfem.io.roughness_table reads and writes spectra (railfem's two-column CSV, the
SBB Niederwangen wide table).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..conventions import R_REF

__all__ = ["RoughnessSpectrum", "amplitude_at", "frequency_of", "wavelength_of",
           "wavelength_bands", "sloped_spectrum", "combine"]


@dataclass(frozen=True, kw_only=True, eq=False)
class RoughnessSpectrum:
    """Roughness levels per one-third-octave wavelength band.

    wavelength: (nb,) band centre wavelengths (m), strictly decreasing or increasing.
    level: (nb,) RMS roughness level in each band, dB re 1 um.
    name: free text (source).
    """

    wavelength: np.ndarray
    level: np.ndarray
    name: str = ""

    def __post_init__(self):
        lam = np.asarray(self.wavelength, dtype=float).ravel()
        lev = np.asarray(self.level, dtype=float).ravel()
        if lam.size < 2 or lam.size != lev.size:
            raise ValueError(f"RoughnessSpectrum needs >= 2 bands with one level each; got "
                             f"{lam.size} wavelengths and {lev.size} levels")
        if np.any(~np.isfinite(lam)) or np.any(lam <= 0):
            raise ValueError(f"RoughnessSpectrum.wavelength must be positive metres, got {lam}")
        if np.any(~np.isfinite(lev)):
            raise ValueError("RoughnessSpectrum.level contains NaN/inf: drop the empty bands "
                             "before building the spectrum")
        order = np.argsort(lam)[::-1]  # long wavelengths first, as roughness tables are
        if np.any(np.diff(lam[order]) == 0):
            raise ValueError("RoughnessSpectrum.wavelength has repeated bands")
        for name, arr in (("wavelength", lam[order]), ("level", lev[order])):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def amplitude(self) -> np.ndarray:
        """Band RMS roughness (m)."""
        return R_REF * 10 ** (self.level / 20)


def wavelength_of(frequency, speed: float) -> np.ndarray:
    """lambda = V / f (m) for frequency (Hz) at speed V (m/s)."""
    _check_speed(speed)
    return speed / np.asarray(frequency, dtype=float)


def frequency_of(wavelength, speed: float) -> np.ndarray:
    """f = V / lambda (Hz)."""
    _check_speed(speed)
    return speed / np.asarray(wavelength, dtype=float)


def _check_speed(speed):
    if not (np.isfinite(speed) and speed > 0):
        raise ValueError(f"train speed = {speed!r} m/s: give a positive speed in m/s")


def amplitude_at(spectrum: RoughnessSpectrum, frequency, speed: float, *,
                 outside: str = "raise") -> np.ndarray:
    """RMS roughness (m) of a one-third-octave band centred at each narrow-band frequency.

    The level is interpolated linearly against log(lambda). outside: 'raise' (a frequency
    whose wavelength lies beyond the spectrum's bands by more than half a band is an
    error), or 'hold' (the end level is held)."""
    lam = wavelength_of(frequency, speed)
    x = np.log(spectrum.wavelength[::-1])
    y = spectrum.level[::-1]
    half_band = math.log(10 ** 0.05)
    if outside == "raise":
        bad = (np.log(lam) < x[0] - half_band) | (np.log(lam) > x[-1] + half_band)
        if np.any(bad):
            f = np.asarray(frequency, dtype=float)
            raise ValueError(
                f"roughness spectrum {spectrum.name!r} covers wavelengths "
                f"{spectrum.wavelength[-1] * 1e3:.3g}-{spectrum.wavelength[0] * 1e3:.4g} mm; at "
                f"{speed:.4g} m/s the frequencies {f[bad].min():.4g}-{f[bad].max():.4g} Hz "
                "fall outside: narrow the frequency range, change the speed or hold the end "
                "levels (outside='hold'; railfem passby --roughness-hold)")
    elif outside != "hold":
        raise ValueError(f"outside = {outside!r}: choose 'raise' or 'hold'")
    level = np.interp(np.log(lam), x, y)
    return R_REF * 10 ** (level / 20)


def wavelength_bands(lam_min: float, lam_max: float) -> np.ndarray:
    """Base-10 one-third-octave wavelength band centres 10^(i/10) m in [lam_min, lam_max]
    (m), longest first."""
    i = np.arange(math.ceil(10 * math.log10(lam_min) - 1e-9),
                  math.floor(10 * math.log10(lam_max) + 1e-9) + 1)
    return 10.0 ** (i[::-1] / 10)


def sloped_spectrum(level_at_10mm: float = 0.0, slope_db_per_decade: float = 10.0,
                    lambda_min: float = 0.001, lambda_max: float = 1.0,
                    name: str = "") -> RoughnessSpectrum:
    """A straight-line spectrum: L = level_at_10mm + slope * lg(lambda / 10 mm) over the
    base-10 one-third-octave wavelength bands from lambda_min to lambda_max (m)."""
    lam = wavelength_bands(lambda_min, lambda_max)
    return RoughnessSpectrum(wavelength=lam,
                             level=level_at_10mm + slope_db_per_decade * np.log10(lam / 0.01),
                             name=name or f"{level_at_10mm:g} dB at 10 mm, "
                                          f"{slope_db_per_decade:g} dB/decade")


def combine(*spectra: RoughnessSpectrum, name: str = "combined") -> RoughnessSpectrum:
    """Energy sum of spectra on the bands of the first (e.g. wheel + rail roughness);
    the others are interpolated in log(lambda) and must cover the first's bands."""
    first = spectra[0]
    power = np.zeros(first.wavelength.size)
    for s in spectra:
        lo, hi = s.wavelength.min(), s.wavelength.max()
        if first.wavelength.min() < lo * 0.99 or first.wavelength.max() > hi * 1.01:
            raise ValueError(f"spectrum {s.name!r} does not cover the bands of {first.name!r}")
        lev = np.interp(np.log(first.wavelength), np.log(s.wavelength[::-1]), s.level[::-1])
        power += 10 ** (lev / 10)
    return RoughnessSpectrum(wavelength=first.wavelength, level=10 * np.log10(power),
                             name=name)
