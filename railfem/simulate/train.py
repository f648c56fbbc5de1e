"""Train layouts: where the wheels of one rail stand relative to the leading wheel.

A layout is a list of axle offsets o_n >= 0 (m) behind the leading wheel (o_0 = 0). Built
from cars (:func:`from_cars`: car length, bogie centres, axle spacing) or given explicitly;
read from a TOML or JSON file (railfem.io.train.read_train_layout)::

    name = "6-car train"
    [cars]
    count = 6
    length_m = 20.0
    bogie_centres_m = [3.0, 17.0]   # from the car front
    axle_spacing_m = 2.6

or ``axle_offsets_m = [0.0, 2.6, 14.0, ...]``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["TrainLayout", "from_cars", "default_train"]


@dataclass(frozen=True, kw_only=True)
class TrainLayout:
    """axle_offsets: wheel positions behind the leading wheel (m), starting at 0,
    increasing. name: free text."""

    axle_offsets: tuple[float, ...]
    name: str = ""

    def __post_init__(self):
        o = tuple(float(v) for v in self.axle_offsets)
        object.__setattr__(self, "axle_offsets", o)
        if len(o) < 1:
            raise ValueError("TrainLayout needs at least one wheel")
        if not np.all(np.isfinite(o)) or o[0] != 0.0 or np.any(np.diff(o) <= 0):
            raise ValueError(f"TrainLayout.axle_offsets must start at 0 and increase strictly "
                             f"(m behind the leading wheel), got {o}")

    @property
    def offsets(self) -> np.ndarray:
        return np.asarray(self.axle_offsets)

    @property
    def n_wheels(self) -> int:
        return len(self.axle_offsets)

    @property
    def length(self) -> float:
        """Distance from the leading to the last wheel (m)."""
        return self.axle_offsets[-1]


def from_cars(count: int = 6, length_m: float = 20.0, bogie_centres_m=(3.0, 17.0),
              axle_spacing_m: float = 2.6, name: str = "") -> TrainLayout:
    """count identical cars of length_m with two-axle bogies at bogie_centres_m (from the
    car front) and axle spacing axle_spacing_m."""
    if int(count) != count or count < 1:
        raise ValueError(f"cars.count = {count!r}: give an integer >= 1")
    if not (length_m > 0 and axle_spacing_m > 0):
        raise ValueError("cars.length_m and cars.axle_spacing_m must be > 0 m")
    wheels = []
    for c in range(int(count)):
        for b in bogie_centres_m:
            wheels += [c * length_m + b - axle_spacing_m / 2, c * length_m + b + axle_spacing_m / 2]
    w = np.round(np.sort(wheels), 9)
    if np.any(np.diff(w) <= 0):
        raise ValueError("the car geometry puts two axles at the same place: check bogie "
                         "centres and axle spacing")
    return TrainLayout(axle_offsets=tuple(w - w[0]),
                       name=name or f"{int(count)} cars x {len(bogie_centres_m)} bogies")


def default_train() -> TrainLayout:
    """METHOD.md section 5: 24 wheels (one rail) over 120 m, a 6-car train: cars 20 m
    long, bogie centres 14 m apart, axles 2.6 m apart in a bogie (assumed dimensions of a
    typical coach, chosen on the 0.1 m grid)."""
    return from_cars(6, 20.0, (3.0, 17.0), 2.6, name="6-car train, 24 wheels")
