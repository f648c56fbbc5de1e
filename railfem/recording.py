"""Recordings: time signals as a measurement system records them, with what is known about
the train. ONE model for field recordings and railfem's simulated ones.

A :class:`Recording` holds the samples of one or more sensors (one column per
:class:`Channel`, SI units), the sample rate, and what the engineer knows about the train:
at most the speed, the bogie axle spacing or the full axle layout (a single sensor measures
times, not lengths, so one of them is needed to get the speed; see
:func:`railfem.estimators.wheels.train_speed`). Anything else (site, rail, description) is
free ``metadata``. Nothing here knows where the signal came from: the estimators get what a
recorder gives. A simulator's truth (roughness, layout, band levels) is never part of a
Recording; :mod:`railfem.io.recording` writes it to a separate file that its reader never
opens.

The estimators work on one sensor at a time: :meth:`Recording.select` picks a channel,
:attr:`Recording.trace` and :attr:`Recording.channel` are the samples and the sensor of a
single-channel recording. Files: :mod:`railfem.io.recording`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

__all__ = ["QUANTITY_UNITS", "Channel", "Recording"]

#: quantity -> SI unit of its samples
QUANTITY_UNITS = {"acceleration": "m/s^2", "velocity": "m/s", "displacement": "m"}


def _positive_or_none(owner: str, name: str, value) -> None:
    if value is not None and not (isinstance(value, (int, float)) and not isinstance(value, bool)
                                  and math.isfinite(value) and value > 0):
        raise ValueError(f"{owner}.{name} must be a positive finite number or None, got "
                         f"{value!r}")


@dataclass(frozen=True, kw_only=True)
class Channel:
    """One sensor.

    name: label (unique within a recording). quantity: 'acceleration', 'velocity' or
    'displacement' (the samples are in its SI unit). location: where the sensor sits, e.g.
    'foot' or 'head' of the rail (free text, reported). direction: 'x', 'y' or 'z'
    (vertical). x_from_support: sensor position along the track from the nearest support
    towards the train's direction of travel (m), e.g. spacing/2 at mid-span; None if not
    known."""

    name: str = "ch0"
    quantity: str = "acceleration"
    location: str = "unknown"
    direction: str = "z"
    x_from_support: float | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"Channel.name = {self.name!r}: give a non-empty label")
        if self.quantity not in QUANTITY_UNITS:
            raise ValueError(f"Channel.quantity = {self.quantity!r}: choose one of "
                             f"{', '.join(QUANTITY_UNITS)}")
        if self.direction not in ("x", "y", "z"):
            raise ValueError(f"Channel.direction = {self.direction!r}: x, y or z")
        if self.x_from_support is not None and not (
                isinstance(self.x_from_support, (int, float))
                and math.isfinite(self.x_from_support)):
            raise ValueError(f"Channel.x_from_support = {self.x_from_support!r}: a position "
                             "in m or None")

    @property
    def unit(self) -> str:
        """SI unit of the samples."""
        return QUANTITY_UNITS[self.quantity]


@dataclass(frozen=True, kw_only=True, eq=False)
class Recording:
    """Time signals of one or more sensors and what is known about the train.

    samples: (n_samples,) or (n_samples, n_channels) in the channels' SI units, uniformly
    sampled (stored 2-D). fs: sample rate, Hz. channels: one Channel per column (default
    one acceleration channel 'ch0'). speed: train speed (m/s) if known. axle_spacing: the
    bogie axle spacing (wheelbase, the shortest axle spacing of the train), m, if known.
    axle_positions: positions of all axles along the train (m, increasing, any origin), if
    known. name: where it came from (file name), for reports. metadata: anything else
    (site, rail, description), kept as given."""

    samples: np.ndarray
    fs: float
    channels: tuple[Channel, ...] = (Channel(),)
    speed: float | None = None
    axle_spacing: float | None = None
    axle_positions: tuple[float, ...] | None = None
    name: str = ""
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        x = np.asarray(self.samples)
        if not np.issubdtype(x.dtype, np.number) or np.iscomplexobj(x):
            raise ValueError(f"Recording.samples must be real numbers, got dtype {x.dtype}"
                             f"{self._where()}")
        if x.ndim == 1:
            x = x[:, None]
        channels = tuple(self.channels)
        if x.ndim != 2 or x.shape[0] < 16:
            raise ValueError(f"Recording.samples must be (n_samples,) or (n_samples, "
                             f"n_channels) with at least 16 samples, got shape "
                             f"{np.shape(self.samples)}{self._where()}")
        if x.shape[1] != len(channels):
            raise ValueError(f"Recording.samples has {x.shape[1]} column(s) but there are "
                             f"{len(channels)} channel(s): one column per channel"
                             f"{self._where()}")
        if not all(isinstance(c, Channel) for c in channels):
            raise TypeError("Recording.channels must hold Channel objects")
        names = [c.name for c in channels]
        if len(set(names)) != len(names):
            raise ValueError(f"Recording.channels have repeated names {names}{self._where()}")
        if not np.all(np.isfinite(x)):
            bad = np.argwhere(~np.isfinite(x))[0]
            raise ValueError(f"Recording.samples has a non-finite value at sample {bad[0]} of "
                             f"channel {names[bad[1]]!r}{self._where()}; remove or repair it")
        if not (isinstance(self.fs, (int, float)) and math.isfinite(self.fs) and self.fs > 0):
            raise ValueError(f"Recording.fs (sample rate) must be positive and finite in Hz, "
                             f"got {self.fs!r}{self._where()}")
        _positive_or_none("Recording", "speed", self.speed)
        _positive_or_none("Recording", "axle_spacing", self.axle_spacing)
        if self.axle_positions is not None:
            a = np.asarray(self.axle_positions, dtype=float)
            if a.ndim != 1 or a.size < 2 or not np.all(np.isfinite(a)) or np.any(np.diff(a) <= 0):
                raise ValueError("Recording.axle_positions must be at least two finite axle "
                                 f"positions in m, strictly increasing, got "
                                 f"{self.axle_positions!r}{self._where()}")
            object.__setattr__(self, "axle_positions", tuple(float(v) for v in a))
        if not isinstance(self.metadata, dict):
            raise TypeError("Recording.metadata must be a dict")
        object.__setattr__(self, "samples", x.astype(float, copy=False))
        object.__setattr__(self, "fs", float(self.fs))
        object.__setattr__(self, "channels", channels)

    def _where(self) -> str:
        return f" (recording {self.name})" if self.name else ""

    @property
    def n_samples(self) -> int:
        return int(self.samples.shape[0])

    @property
    def duration(self) -> float:
        """Length of the record, s."""
        return self.n_samples / self.fs

    @property
    def time(self) -> np.ndarray:
        """(n_samples,) instants of the samples from the record start, s."""
        return np.arange(self.n_samples) / self.fs

    def _single(self) -> None:
        if len(self.channels) != 1:
            raise ValueError(f"recording {self.name or '(unnamed)'} has channels "
                             f"{[c.name for c in self.channels]}; choose one "
                             "(Recording.select(name), --channel NAME)")

    @property
    def trace(self) -> np.ndarray:
        """(n_samples,) samples of a single-channel recording."""
        self._single()
        return self.samples[:, 0]

    @property
    def channel(self) -> Channel:
        """The sensor of a single-channel recording."""
        self._single()
        return self.channels[0]

    def select(self, channel: str | int | None = None) -> "Recording":
        """The recording of one channel (by name or column index); None: the only channel
        (an error naming the channels if there are several)."""
        names = [c.name for c in self.channels]
        if channel is None:
            self._single()
            return self
        if isinstance(channel, int) and not isinstance(channel, bool):
            if not -len(names) <= channel < len(names):
                raise ValueError(f"recording {self.name or '(unnamed)'} has {len(names)} "
                                 f"channel(s); column {channel} does not exist")
            j = channel % len(names)
        elif channel in names:
            j = names.index(channel)
        else:
            raise ValueError(f"recording {self.name or '(unnamed)'} has no channel "
                             f"{channel!r}; it has {names}")
        name = self.name if len(names) == 1 or not self.name else f"{self.name}:{names[j]}"
        return replace(self, samples=self.samples[:, j], channels=(self.channels[j],),
                       name=name)
