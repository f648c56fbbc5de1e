"""Train layouts from a TOML (.toml) or JSON (.json) file::

    name = "6-car train"
    [cars]
    count = 6
    length_m = 20.0
    bogie_centres_m = [3.0, 17.0]   # from the car front
    axle_spacing_m = 2.6

or ``axle_offsets_m = [0.0, 2.6, 14.0, ...]`` (railfem.simulate.train.TrainLayout).
"""
from __future__ import annotations

import json
from pathlib import Path

from railfem.io.config import read_toml
from railfem.io.errors import MalformedFileError, file_error
from railfem.io.text import read_text
from railfem.simulate.train import TrainLayout, from_cars

__all__ = ["read_train_layout"]

_CARS = {"count", "length_m", "bogie_centres_m", "axle_spacing_m"}


def _read(path: Path) -> dict:
    if path.suffix.lower() != ".json":
        return read_toml(path)
    try:
        data = json.loads(read_text(path))
    except json.JSONDecodeError as exc:
        raise file_error(MalformedFileError, path, f"line {exc.lineno}, column {exc.colno}",
                         f"invalid JSON ({exc.msg})", "fix the JSON syntax") from None
    if not isinstance(data, dict):
        raise file_error(MalformedFileError, path, None, "not a JSON object",
                         "give axle_offsets_m or a cars object")
    return data


def read_train_layout(path) -> TrainLayout:
    """Read a layout from TOML (.toml) or JSON (.json); see the module docstring."""
    path = Path(path)
    data = _read(path)
    name = str(data.get("name", path.stem))
    if "axle_offsets_m" in data:
        return TrainLayout(axle_offsets=tuple(data["axle_offsets_m"]), name=name)
    if "cars" in data:
        c = data["cars"]
        if set(c) - _CARS:
            raise ValueError(f"{path}: unknown [cars] keys {sorted(set(c) - _CARS)}; "
                             f"use {sorted(_CARS)}")
        return from_cars(c.get("count", 6), c.get("length_m", 20.0),
                         tuple(c.get("bogie_centres_m", (3.0, 17.0))),
                         c.get("axle_spacing_m", 2.6), name=name)
    raise ValueError(f"{path}: give either axle_offsets_m = [...] or a [cars] table")
