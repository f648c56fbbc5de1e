"""Hammer-test dataset folders: ``frf.csv`` + ``meta.json`` (the layout of the shared datasets).

``meta.json`` (what a measurement team knows)::

    {"rail": "UIC60 (60E1) ...", "sleeper_spacing_m": 0.6,
     "sensor": {"x_m": 0.3, "position": "mid-span ...",
                "head": {"y_m": 0.0, "z_m": 0.172, "note": "rail head, top centre"},
                "foot": {"y_m": 0.0328, "z_m": 0.0173, "note": "..."}},
     "hammer_positions_m": [0.02, 0.15, ...],      # distances from the sensor; first = point
     "quantity": "vertical mobility = velocity / force [m/s/N], time convention exp(+i omega t)",
     "date": "2024-05-01", "temperature_c": 12.5, "section": "B5", "rail_side": "left",
     ... any other keys (kept as notes) ...}

``frf.csv``: header ``frequency_hz`` then ``<sensor>_x<position with 3 decimals>_re/_im``
column pairs (any order), one row per frequency (Hz), values in the unit of ``quantity``.

The quantity text must name one of receptance / mobility / accelerance, a direction
(vertical / lateral / longitudinal) and the unit in brackets. The reader never opens any
other file of the folder (a simulated dataset's ``truth.json`` stays unread).
"""
from __future__ import annotations

import json
import os
import re
from dataclasses import replace
from pathlib import Path

import numpy as np

from railfem.conventions import QUANTITIES, QUANTITY_UNITS
from railfem.response import FRF
from railfem.io.errors import (MalformedFileError, MissingPositionError, NonFiniteValueError,
                               UnknownQuantityError, UnknownUnitError, file_error)
from railfem.io.text import check_frequency_axis, column, fmt, number, read_table, read_text
from railfem.io.units import parse_frf_unit
from railfem.measurement import HammerMeasurement, Metadata, Sensor

__all__ = ["read_dataset", "write_dataset", "FRF_FILE", "META_FILE", "parse_quantity_text",
           "quantity_text"]

FRF_FILE = "frf.csv"
META_FILE = "meta.json"
_METADATA_KEYS = ("date", "temperature_c", "section", "rail_side")
_CONSUMED = {"rail", "sleeper_spacing_m", "sensor", "hammer_positions_m", "quantity",
             *_METADATA_KEYS}
_DIRECTION_WORDS = {"vertical": "z", "lateral": "y", "longitudinal": "x"}
_RESPONSE_WORDS = {"receptance": "displacement", "mobility": "velocity",
                   "accelerance": "acceleration"}
_COLUMN = re.compile(r"^(?P<sensor>.+)_x(?P<x>[-+0-9.eE]+)_(?P<part>re|im)$")
_POSITION_TOLERANCE = 5e-4  # m: column names carry 3 decimals


def quantity_text(quantity: str, direction: str) -> str:
    """The ``quantity`` entry written to meta.json, e.g. 'vertical mobility = velocity / ...'."""
    word = {d: w for w, d in _DIRECTION_WORDS.items()}[direction]
    return (f"{word} {quantity} = {_RESPONSE_WORDS[quantity]} / force "
            f"[{QUANTITY_UNITS[quantity]}], time convention exp(+i omega t)")


def parse_quantity_text(path, text) -> tuple[str, float, str]:
    """(quantity, factor to SI, direction) from a meta.json quantity text."""
    if not isinstance(text, str):
        raise file_error(UnknownQuantityError, path, "key 'quantity'", "not a text",
                         "write e.g. 'vertical mobility = velocity / force [m/s/N]'", value=text)
    low = text.lower()
    fix = "write e.g. 'vertical mobility = velocity / force [m/s/N]'"
    words = [q for q in QUANTITIES if q in low]
    if len(words) != 1:
        raise file_error(UnknownQuantityError, path, "key 'quantity'",
                         f"names {words or 'none'} of {list(QUANTITIES)}",
                         f"name exactly one; {fix}", value=text)
    units = re.findall(r"\[([^\]]+)\]", text)
    if len(units) != 1:
        raise file_error(UnknownUnitError, path, "key 'quantity'", "no single unit in brackets",
                         f"state the unit once, e.g. [m/s/N]; {fix}", value=text)
    parsed = parse_frf_unit(units[0])
    if parsed is None:
        raise file_error(UnknownUnitError, path, "key 'quantity'",
                         f"unknown unit [{units[0]}]",
                         "use a response unit (m, mm, m/s, mm/s, m/s^2, g) per N", value=text)
    if parsed[0] != words[0]:
        raise file_error(UnknownQuantityError, path, "key 'quantity'",
                         f"says {words[0]} but the unit [{units[0]}] is a {parsed[0]}",
                         "make the quantity and the unit agree", value=text)
    dirs = [d for w, d in _DIRECTION_WORDS.items() if w in low]
    if len(dirs) != 1:
        raise file_error(MalformedFileError, path, "key 'quantity'",
                         "does not name one direction (vertical, lateral or longitudinal)",
                         f"name it; {fix}", value=text)
    return words[0], parsed[1], dirs[0]


def _read_meta(path: Path) -> dict:
    try:
        meta = json.loads(read_text(path))
    except json.JSONDecodeError as err:
        raise file_error(MalformedFileError, path, f"line {err.lineno}",
                         f"invalid JSON ({err.msg})", "fix the JSON syntax") from None
    if not isinstance(meta, dict):
        raise file_error(MalformedFileError, path, None, "not a JSON object",
                         "write the metadata as {\"key\": value, ...}")
    return meta


def _need(path, meta: dict, key: str, cls=MalformedFileError, fix: str = ""):
    if key not in meta or meta[key] is None:
        raise file_error(cls, path, f"key {key!r}", "missing",
                         fix or f"add {key!r} to {META_FILE}")
    return meta[key]


def _float(path, key: str, value) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise file_error(MalformedFileError, path, f"key {key!r}", "not a number",
                         "write a JSON number", value=value)
    if not np.isfinite(value):
        raise file_error(NonFiniteValueError, path, f"key {key!r}", "not finite",
                         "write a finite number", value=value)
    return float(value)


def _positions(path, meta: dict) -> np.ndarray:
    raw = _need(path, meta, "hammer_positions_m", MissingPositionError,
                "list the hammer distances from the sensor (m), point FRF first")
    if not isinstance(raw, list) or len(raw) < 2:
        raise file_error(MissingPositionError, path, "key 'hammer_positions_m'",
                         "needs a list of at least 2 distances",
                         "list the hammer distances from the sensor (m), point FRF first",
                         value=raw)
    x = np.array([_float(path, f"hammer_positions_m[{i}]", p) for i, p in enumerate(raw)])
    bad = np.flatnonzero(np.diff(x) <= 0)
    if bad.size or x[0] < 0:
        k = int(bad[0]) if bad.size else -1
        what = (f"positions not strictly increasing: [{k}] = {x[k]!r}, [{k + 1}] = {x[k + 1]!r}"
                if bad.size else f"negative first position {x[0]!r}")
        raise file_error(MalformedFileError, path, "key 'hammer_positions_m'", what,
                         "give distances from the sensor in increasing order")
    return x


def _sensors(path, meta: dict, direction: str) -> tuple[float | None, dict, dict]:
    """(sensor x, {name: Sensor}, other sensor entries kept as notes)."""
    s = _need(path, meta, "sensor",
              fix=f"add 'sensor': {{'x_m': ..., 'head': {{...}}}} to {META_FILE}")
    if not isinstance(s, dict):
        raise file_error(MalformedFileError, path, "key 'sensor'", "not a JSON object",
                         "describe the sensor as an object", value=s)
    x = None if s.get("x_m") is None else _float(path, "sensor.x_m", s["x_m"])
    sensors, rest = {}, {}
    for name, entry in s.items():
        if name == "x_m":
            continue
        if isinstance(entry, dict):
            kw = {c: _float(path, f"sensor.{name}.{c}_m", entry[f"{c}_m"])
                  for c in ("y", "z") if entry.get(f"{c}_m") is not None}
            extra = set(entry) - {"y_m", "z_m", "note"}
            if extra:
                raise file_error(MalformedFileError, path, f"key 'sensor.{name}'",
                                 f"unknown entries {sorted(extra)}",
                                 "a sensor location holds y_m, z_m and note")
            sensors[name] = Sensor(name=name, direction=direction, note=str(entry.get("note", "")),
                                   **kw)
        else:
            rest[name] = entry
    return x, sensors, rest


def _columns(path, header: list[str], positions: np.ndarray, sensors: dict):
    """{(sensor, position index): (re column, im column)} and sensor order of the header."""
    if not header or header[0] != "frequency_hz":
        raise file_error(MalformedFileError, path, "header", "first column is not 'frequency_hz'",
                         "name the frequency column frequency_hz (Hz)",
                         value=header[0] if header else "")
    found: dict = {}
    order: list[str] = []
    for j, name in enumerate(header[1:], start=1):
        m = _COLUMN.match(name)
        if m is None:
            raise file_error(MalformedFileError, path, f"column {j + 1}",
                             "not '<sensor>_x<position>_re' or '_im'",
                             "name the columns e.g. head_x0.150_re, head_x0.150_im", value=name)
        sensor, part = m["sensor"], m["part"]
        if sensor not in sensors:
            raise file_error(MalformedFileError, path, f"column {name!r}",
                             f"sensor {sensor!r} is not described in {META_FILE}",
                             f"add 'sensor': {{'{sensor}': {{'y_m': ..., 'z_m': ...}}}} "
                             f"or rename the column; described: {sorted(sensors)}")
        try:
            xv = float(m["x"])
        except ValueError:
            raise file_error(MalformedFileError, path, f"column {name!r}",
                             "position is not a number", "write it like x0.150") from None
        near = np.flatnonzero(np.abs(positions - xv) <= _POSITION_TOLERANCE)
        if near.size != 1:
            raise file_error(MissingPositionError, path, f"column {name!r}",
                             f"position {xv!r} m is not one of {META_FILE} hammer_positions_m",
                             "add the position to hammer_positions_m or fix the column name",
                             value=xv)
        key = (sensor, int(near[0]))
        slot = found.setdefault(key, [None, None])
        if slot[part == "im"] is not None:
            raise file_error(MalformedFileError, path, f"column {name!r}", "appears twice",
                             "give each sensor and position one _re and one _im column")
        slot[part == "im"] = j
        if sensor not in order:
            order.append(sensor)
    for sensor in order:
        for i, x in enumerate(positions):
            slot = found.get((sensor, i), [None, None])
            for part, j in zip(("re", "im"), slot):
                if j is None:
                    raise file_error(MissingPositionError, path, "header",
                                     f"no column {sensor}_x{x:.3f}_{part} for sensor {sensor!r} "
                                     f"at hammer position {x!r} m",
                                     f"add the column or drop the position from {META_FILE}")
    return found, order


def read_dataset(folder: str | os.PathLike, *, quantity: str | None = None) -> HammerMeasurement:
    """Read a dataset folder (``frf.csv`` + ``meta.json``) as a :class:`HammerMeasurement`.

    Values are scaled to SI; ``quantity`` converts them (e.g. 'receptance'), default the
    file's quantity. Keys of meta.json that railfem does not use are kept in
    ``measurement.metadata.notes`` (and written back by :func:`write_dataset`).
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise file_error(MalformedFileError, folder, None, "not a folder",
                         f"give the dataset folder holding {FRF_FILE} and {META_FILE}")
    meta_path, frf_path = folder / META_FILE, folder / FRF_FILE
    meta = _read_meta(meta_path)
    q, scale, direction = parse_quantity_text(meta_path, _need(meta_path, meta, "quantity"))
    positions = _positions(meta_path, meta)
    sensor_x, sensors, sensor_rest = _sensors(meta_path, meta, direction)
    spacing = _float(meta_path, "sleeper_spacing_m", _need(meta_path, meta, "sleeper_spacing_m"))

    table = read_table(frf_path)
    found, order = _columns(frf_path, table.header, positions, sensors)
    lines = [n for n, _ in table.rows]
    f = check_frequency_axis(frf_path, "column 'frequency_hz'", column(table, "frequency_hz"),
                             lines)
    values = np.empty((f.size, len(order), positions.size), dtype=complex)
    for s, sensor in enumerate(order):
        for i in range(positions.size):
            jr, ji = found[(sensor, i)]
            for k, (n, cells) in enumerate(table.rows):
                where = f"line {n}, column {table.header[jr]!r}"
                re_ = number(frf_path, where, cells[jr])
                im_ = number(frf_path, f"line {n}, column {table.header[ji]!r}", cells[ji])
                values[k, s, i] = complex(re_, im_)
    notes = {k: val for k, val in meta.items() if k not in _CONSUMED}
    if sensor_rest:
        notes["sensor"] = sensor_rest
    try:
        metadata = Metadata(notes=notes, **{k: meta[k] for k in _METADATA_KEYS if k in meta})
        frf = FRF(frequency=f, values=values * scale, quantity=q, response=tuple(order),
                  force=_force_labels(positions),
                  response_x=None if sensor_x is None else np.full(len(order), sensor_x),
                  force_x=None if sensor_x is None else sensor_x + positions)
        m = HammerMeasurement(frf=frf, positions=positions,
                              sensors=tuple(sensors[s] for s in order), sleeper_spacing=spacing,
                              sensor_x=sensor_x, excitation=_excitation(meta, direction),
                              rail=str(meta.get("rail", "")), metadata=metadata)
    except ValueError as err:
        raise file_error(MalformedFileError, folder, None, f"not a valid measurement ({err})",
                         f"fix {META_FILE} or {FRF_FILE}") from err
    return m if quantity is None else _convert(m, quantity)


def _convert(m: HammerMeasurement, quantity: str) -> HammerMeasurement:
    return replace(m, frf=m.frf.to(quantity))


def _excitation(meta: dict, direction: str) -> str:
    text = str(meta.get("excitation", "")).lower()
    dirs = [d for w, d in _DIRECTION_WORDS.items() if w in text]
    return dirs[0] if len(dirs) == 1 else direction


def _force_labels(positions: np.ndarray) -> tuple[str, ...]:
    labels = tuple(f"hammer_{x:.3f}" for x in positions)
    return labels if len(set(labels)) == len(labels) else tuple(f"hammer_{i}" for i in
                                                                 range(positions.size))


def write_dataset(folder: str | os.PathLike, measurement: HammerMeasurement) -> Path:
    """Write ``measurement`` as ``folder/frf.csv`` + ``folder/meta.json`` (each atomically).

    Numbers are written so that :func:`read_dataset` gives back the same values. Returns the folder.
    """
    from railfem.atomic import write_text_atomic

    m = measurement
    folder = Path(folder)
    labels = [f"{x:.3f}" for x in m.positions]
    if len(set(labels)) != len(labels):
        raise ValueError(f"hammer positions {m.positions.tolist()} m are not distinct at 1 mm, "
                         "which the frf.csv column names need; merge or drop positions.")
    directions = {s.direction for s in m.sensors}
    if len(directions) != 1:
        raise ValueError(f"sensors measure in several directions {sorted(directions)}; a dataset "
                         "folder holds one: write one folder per direction.")
    notes = dict(m.metadata.notes)
    clash = _CONSUMED & set(notes) - {"sensor"}
    if clash:
        raise ValueError(f"metadata notes {sorted(clash)} would overwrite keys railfem writes; "
                         "rename them.")
    sensor = dict(notes.pop("sensor", {}) or {})
    sensor = {"x_m": m.sensor_x, **sensor}
    for s in m.sensors:
        entry = {f"{c}_m": getattr(s, c) for c in ("y", "z") if getattr(s, c) is not None}
        if s.note:
            entry["note"] = s.note
        sensor[s.name] = entry
    meta = {"rail": m.rail, "sleeper_spacing_m": m.sleeper_spacing, "sensor": sensor,
            "hammer_positions_m": [float(x) for x in m.positions],
            "quantity": quantity_text(m.frf.quantity, directions.pop()),
            **{k: v for k, v in m.metadata.as_dict().items() if k != "notes"}, **notes}
    header = ["frequency_hz"] + [f"{s.name}_x{lab}_{p}" for lab in labels
                                 for s in m.sensors for p in ("re", "im")]
    n = m.frequency.size
    vals = np.transpose(m.frf.values, (0, 2, 1)).reshape(n, -1)  # position-major, sensor-minor
    table = np.empty((n, 1 + 2 * vals.shape[1]))
    table[:, 0], table[:, 1::2], table[:, 2::2] = m.frequency, vals.real, vals.imag
    rows = [",".join(fmt(x) for x in row) for row in table]
    folder.mkdir(parents=True, exist_ok=True)
    write_text_atomic(folder / FRF_FILE, ",".join(header) + "\n" + "\n".join(rows) + "\n")
    write_text_atomic(folder / META_FILE, json.dumps(meta, indent=2) + "\n")
    return folder
