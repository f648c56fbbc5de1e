"""A pass-by recording as the estimators see it: one sensor's time signal and its metadata.

Nothing here knows where the signal came from (a field measurement or railfem's
simulator): the estimators get exactly what a recorder gives, plus what the engineer knows
about the train. A single sensor cannot give the train speed without one known length, so
a recording carries at most one of: the speed, the bogie axle spacing (wheelbase), or the
full axle layout; with none of them the speed cannot be found (see
:func:`railfem.estimators.wheels.train_speed`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["QUANTITIES", "Recording"]

#: quantity -> SI unit of the samples
QUANTITIES = {"acceleration": "m/s^2", "velocity": "m/s"}


def _positive_or_none(name: str, value) -> None:
    if value is not None and not (isinstance(value, (int, float)) and math.isfinite(value)
                                  and value > 0):
        raise ValueError(f"Recording.{name} must be a positive finite number or None, got "
                         f"{value!r}")


@dataclass(frozen=True, kw_only=True, eq=False)
class Recording:
    """One sensor's pass-by time signal (SI units) and what is known about the train."""

    samples: np.ndarray
    """(n,) rail vibration, m/s^2 (acceleration) or m/s (velocity), uniformly sampled."""
    fs: float
    """Sample rate, Hz."""
    quantity: str = "acceleration"
    """'acceleration' or 'velocity' (the unit of ``samples`` is the SI unit of it)."""
    sensor: str = "unknown"
    """Where the sensor sits, free text (e.g. 'foot', 'head'); reported, not interpreted."""
    direction: str = "z"
    """Measured direction: 'x', 'y' or 'z' (vertical)."""
    speed: float | None = None
    """Train speed, m/s, if known."""
    axle_spacing: float | None = None
    """Known spacing of the two axles of a bogie (the shortest axle spacing of the train), m."""
    axle_positions: tuple[float, ...] | None = None
    """Known positions of all axles along the train, m, increasing (any origin)."""
    name: str = ""
    """Where the recording came from (file name), for reports."""
    metadata: dict = field(default_factory=dict)
    """Any other metadata of the source, kept as given."""

    def __post_init__(self) -> None:
        samples = np.asarray(self.samples)
        if samples.ndim != 1 or samples.size < 16:
            raise ValueError(f"Recording.samples must be a 1-D array of at least 16 samples, "
                             f"got shape {samples.shape}{self._where()}")
        if not np.issubdtype(samples.dtype, np.number) or np.iscomplexobj(samples):
            raise ValueError(f"Recording.samples must be real numbers, got dtype "
                             f"{samples.dtype}{self._where()}")
        if not np.all(np.isfinite(samples)):
            bad = int(np.flatnonzero(~np.isfinite(samples))[0])
            raise ValueError(f"Recording.samples has a non-finite value at index {bad}"
                             f"{self._where()}; remove or repair it before estimating")
        if not (isinstance(self.fs, (int, float)) and math.isfinite(self.fs) and self.fs > 0):
            raise ValueError(f"Recording.fs (sample rate) must be positive and finite in Hz, "
                             f"got {self.fs!r}{self._where()}")
        if self.quantity not in QUANTITIES:
            raise ValueError(f"Recording.quantity must be one of {sorted(QUANTITIES)}, got "
                             f"{self.quantity!r}{self._where()}")
        if self.direction not in ("x", "y", "z"):
            raise ValueError(f"Recording.direction must be 'x', 'y' or 'z', got "
                             f"{self.direction!r}{self._where()}")
        _positive_or_none("speed", self.speed)
        _positive_or_none("axle_spacing", self.axle_spacing)
        if self.axle_positions is not None:
            a = np.asarray(self.axle_positions, dtype=float)
            if a.ndim != 1 or a.size < 2 or not np.all(np.isfinite(a)) or np.any(np.diff(a) <= 0):
                raise ValueError("Recording.axle_positions must be at least two finite axle "
                                 f"positions in m, strictly increasing, got "
                                 f"{self.axle_positions!r}{self._where()}")
            object.__setattr__(self, "axle_positions", tuple(float(v) for v in a))
        object.__setattr__(self, "samples", samples.astype(float, copy=False))
        object.__setattr__(self, "fs", float(self.fs))

    def _where(self) -> str:
        return f" (recording {self.name})" if self.name else ""

    @property
    def unit(self) -> str:
        """SI unit of the samples."""
        return QUANTITIES[self.quantity]

    @property
    def duration(self) -> float:
        """Length of the record, s."""
        return self.samples.size / self.fs
