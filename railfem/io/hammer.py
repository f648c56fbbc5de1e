"""A :class:`HammerMeasurement` from FRFs whose file holds no geometry (plain CSV, UFF 58).

The caller says where each force was applied (``positions``: force label -> distance from
the sensor, m) and what each response is (``sensors``: response label -> Sensor or name).
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from railfem.response import FRF
from railfem.io.errors import MissingPositionError
from railfem.measurement import HammerMeasurement, Metadata, Sensor

__all__ = ["hammer_measurement"]


def hammer_measurement(frf: FRF, *, positions: Mapping[str, float], sleeper_spacing: float,
                       sensors: Mapping[str, Sensor | str] | None = None,
                       sensor_x: float | None = None, excitation: str = "z", rail: str = "",
                       metadata: Metadata | None = None, source: str = "FRF") -> HammerMeasurement:
    """Attach hammer geometry to ``frf`` (forces are sorted by distance from the sensor).

    positions : {force label: hammer distance from the sensor, m}; every force needs one
        and every entry needs a force (:class:`MissingPositionError` names the label).
    sensors : {response label: Sensor or sensor name}; default: each response label is a
        sensor name measuring in the excitation direction.
    source : named in error messages (e.g. the file path).
    """
    missing = [f for f in frf.force if f not in positions]
    if missing:
        raise MissingPositionError(
            f"{source}: force(s) {missing} have no hammer position; add them to positions "
            f"(force label -> distance from the sensor in m); given: {sorted(positions)}.",
            path=source, key=str(missing[0]))
    extra = [f for f in positions if f not in frf.force]
    if extra:
        raise MissingPositionError(
            f"{source}: no FRF for hammer position(s) {extra}; the forces are {list(frf.force)}; "
            "fix the labels or drop the positions.", path=source, key=str(extra[0]))
    order = sorted(frf.force, key=lambda f: float(positions[f]))
    x = np.array([float(positions[f]) for f in order])
    sensors = dict(sensors or {})
    unknown = [r for r in sensors if r not in frf.response]
    if unknown:
        raise ValueError(f"{source}: sensors given for response(s) {unknown} not in the data; "
                         f"the responses are {list(frf.response)}.")
    objs = []
    for r in frf.response:
        s = sensors.get(r, r)
        objs.append(s if isinstance(s, Sensor) else Sensor(name=str(s), direction=excitation))
    sub = frf.select(force=order)
    values_frf = FRF(frequency=sub.frequency, values=sub.values, quantity=sub.quantity,
                     response=tuple(s.name for s in objs), force=sub.force,
                     response_x=None if sensor_x is None else np.full(len(objs), sensor_x),
                     force_x=None if sensor_x is None else sensor_x + x)
    return HammerMeasurement(frf=values_frf, positions=x, sensors=tuple(objs),
                             sleeper_spacing=sleeper_spacing, sensor_x=sensor_x,
                             excitation=excitation, rail=rail,
                             metadata=metadata if metadata is not None else Metadata())
