"""The pass-by band level of a recording: the mean square in each one-third-octave band
while the train passes the sensor (model-free; the measured side of the roughness methods).

The averaging window runs from the first wheel over the sensor to the last one (instants
from :func:`railfem.estimators.wheels.wheel_passage`), i.e. over the train length between
its first and last axle, ``L = V (t_N - t_1)``: this is the length ``L`` of the roughness
formulas (METHOD.md section 8, docs/roughness.md). Bands are the IEC 61260-1 class 1
filters of :mod:`railfem.estimators.bands`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from railfem.recording import Recording
from railfem.standards.iec61260 import (MAX_UPPER_EDGE_FRACTION, ThirdOctaveBands,
                                        third_octave_bands)

from .bands import band_energy, energy_between
from .wheels import WheelPassage, wheel_passage

__all__ = ["PassbyLevel", "passby_level"]

V_REF = 1e-9  # m/s, the velocity level reference of railfem's outputs


@dataclass(frozen=True, kw_only=True, eq=False)
class PassbyLevel:
    """Band mean squares of one pass-by recording over its train-passage window."""

    name: str
    """The recording's name."""
    bands: ThirdOctaveBands
    quantity: str
    """'acceleration' or 'velocity': the unit of ``mean_square`` is its SI unit squared."""
    mean_square: np.ndarray
    """(n_bands,) band mean square over the window, (SI unit)^2."""
    wheels: WheelPassage
    """Detected wheels, speed and axle positions."""
    window: tuple[float, float]
    """(start, end) of the window, s from the record start: first and last wheel."""
    fs: float | None = None
    """Sample rate of the recording (its band filters depend on it), Hz; None for band
    values that did not come through the IEC 61260 filters (ideal bands)."""

    @property
    def speed(self) -> float:
        return self.wheels.speed

    @property
    def length(self) -> float:
        """Train length covered by the window, m (first to last axle)."""
        return float(self.wheels.positions[-1])

    def velocity_level(self, v_ref: float = V_REF) -> np.ndarray:
        """(n_bands,) band velocity level, dB re v_ref (1e-9 m/s); an acceleration band is
        converted with the band's centre frequency, v = a / (2 pi f_m)."""
        ms = self.mean_square
        if self.quantity == "acceleration":
            ms = ms / (2 * np.pi * self.bands.centre) ** 2
        with np.errstate(divide="ignore"):
            return 10 * np.log10(ms / v_ref**2)


def passby_level(recording: Recording, f_low: float, f_high: float, *,
                 wheels: WheelPassage | None = None, speed: float | None = None,
                 axle_spacing: float | None = None, axle_positions=None,
                 detect: dict | None = None) -> PassbyLevel:
    """Band mean squares of ``recording`` (one channel) from the first to the last wheel.

    wheels: the wheel passage if already known (e.g. from
    :func:`railfem.estimators.passby.passby_decay_rate`), else detected here with
    ``detect`` options; speed, axle_spacing, axle_positions override the metadata."""
    ch = recording.channel
    if ch.quantity not in ("acceleration", "velocity"):
        raise ValueError(f"recording {recording.name or '(unnamed)'} holds a {ch.quantity}; "
                         "the pass-by level needs an acceleration or a velocity")
    bands = third_octave_bands(f_low, f_high)
    if bands.upper[-1] > MAX_UPPER_EDGE_FRACTION * recording.fs:
        raise ValueError(f"recording {recording.name or '(unnamed)'} is sampled at "
                         f"{recording.fs:g} Hz: the {bands.nominal[-1]:g} Hz band's upper edge "
                         f"must lie below {MAX_UPPER_EDGE_FRACTION:g} fs; lower f_high")
    if wheels is None:
        wheels = wheel_passage(recording, speed=speed, axle_spacing=axle_spacing,
                               axle_positions=axle_positions, **(detect or {}))
    t0, t1 = float(wheels.times[0]), float(wheels.times[-1])
    if not t1 > t0:
        raise ValueError(f"recording {recording.name}: the wheels span no time")
    ms = np.array([float(energy_between(band_energy(recording.trace, recording.fs, c), t0, t1))
                   for c in bands.centre]) / (t1 - t0)
    return PassbyLevel(name=recording.name, bands=bands, quantity=ch.quantity,
                       mean_square=ms, wheels=wheels, window=(t0, t1), fs=recording.fs)
