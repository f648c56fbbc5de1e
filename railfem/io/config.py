"""TOML files: the one reader (:func:`read_toml`), hammer-measurement descriptors and track
configs.

:func:`read_toml` reads any TOML file railfem takes (descriptors, configs, recording
sidecars) with errors that name the file, the line and the column. :func:`read_descriptor`
reads a TOML descriptor that points to a plain CSV table or a UFF 58 file and adds what
those files do not hold (geometry, sensors, metadata); :func:`railfem.io.data.read_measurement`
takes a descriptor or a dataset folder::

    file = "export.uff"          # relative to the descriptor
    format = "uff58"             # or "csv"; default from the suffix (.uff/.unv, .csv/.txt)
    sleeper_spacing_m = 0.6
    sensor_x_m = 0.3             # optional: sensor position with sleepers at n * spacing
    excitation = "z"             # hammer direction (default z)
    rail = "60E1"
    unit = "g/N"                 # csv: the values' unit (required); uff: if the file has none

    [positions_m]                # force label -> hammer distance from the sensor (m)
    "node1:z" = 0.02             # UFF labels are node<ref_node>:<axis>
    "node2:z" = 0.15

    [sensors.head]               # sensor name -> its data label and place on the section
    response = "node100:z"       # UFF: node<rsp_node>:<axis>; csv: the channels' sensor
    direction = "z"
    y_m = 0.0
    z_m = 0.172

    [metadata]                   # optional: date, temperature_c, section, rail_side, notes
    date = "2024-05-01"

    [csv]                        # csv only: railfem.io.frf_table.ColumnMapping fields
    frequency = "f"
    form = "re_im"
    channels = [{sensor = "head", force = "p0", columns = ["H0 re", "H0 im"]}]

:func:`read_track_config` reads the config of ``railfem track`` (a TOML file, or the
``config`` section of the ``run.json`` of an earlier run).
"""
from __future__ import annotations

import json
import os
import re
import tomllib
from pathlib import Path

from railfem.io.errors import MalformedFileError, file_error
from railfem.io.frf_table import Channel, ColumnMapping, read_frf_table
from railfem.io.hammer import hammer_measurement
from railfem.io.text import read_text
from railfem.io.uff58 import read_uff58
from railfem.measurement import HammerMeasurement, Metadata, Sensor

__all__ = ["read_toml", "read_descriptor", "read_track_config", "FORMATS"]

FORMATS = {".uff": "uff58", ".unv": "uff58", ".csv": "csv", ".txt": "csv"}
_TOP = {"file", "format", "sleeper_spacing_m", "sensor_x_m", "excitation", "rail", "unit",
        "positions_m", "sensors", "metadata", "csv"}
_TABLES = {"sensors", "metadata", "csv"}  # the tables among _TOP
_SENSOR = {"response", "direction", "y_m", "z_m", "note"}
_CSV = {"frequency", "frequency_unit", "form", "phase_unit", "db_reference", "time_convention",
        "delimiter", "channels"}


_AT = re.compile(r"\s*\(at line (\d+), column (\d+)\)\s*$")


def read_toml(path: str | os.PathLike) -> dict:
    """The TOML file ``path`` as a dict. Errors (:class:`MalformedFileError`, a ValueError)
    name the file and, for a syntax error, the line and column."""
    path = Path(path)
    try:
        return tomllib.loads(read_text(path))
    except tomllib.TOMLDecodeError as err:
        msg = str(err)
        at = _AT.search(msg)
        where = f"line {at.group(1)}, column {at.group(2)}" if at else None
        raise file_error(MalformedFileError, path, where,
                         f"invalid TOML ({_AT.sub('', msg) if at else msg})",
                         "fix the TOML syntax") from None


def read_track_config(path) -> tuple[dict, dict]:
    """(spec dict, job dict) of a ``railfem track`` config: a TOML file (its ``[job]`` table
    is the job dict), the ``run.json`` of an earlier run, or the folder holding it."""
    path = Path(path)
    if path.is_dir():
        path = path / "run.json"
    if path.suffix != ".json":
        data = read_toml(path)
        _check_track_names(path, data)
        job = data.pop("job", {})
        return data, job
    try:
        data = json.loads(read_text(path))["config"]
        return data["spec"], data.get("job", {})
    except (json.JSONDecodeError, KeyError, TypeError):
        raise file_error(MalformedFileError, path, "key 'config'",
                         "not a run.json of 'railfem track' (no 'config' section)",
                         "give the run.json of a 'railfem track' run or a TOML config"
                         ) from None


def _line_of(path, name: str) -> str:
    """'line N' where ``name`` is set or opened as a table in the file at ``path``."""
    pattern = re.compile(rf"^\s*(\[+\s*)?{re.escape(name)}\s*(=|\]|\.)")
    try:
        lines = read_text(path).splitlines()
    except (OSError, ValueError):
        return ""
    return next((f"line {i}, " for i, ln in enumerate(lines, 1) if pattern.match(ln)), "")


def _unknown_names(path, extra, keys, tables, where: str = "top level") -> MalformedFileError:
    """The error for unknown names: both the valid keys and the valid tables."""
    first = sorted(extra)[0]
    fix = f"valid keys: {', '.join(sorted(keys)) or 'none'}"
    if tables:
        arrays = {"deviations", "channels"}  # arrays of tables: [[deviations]]
        fix += "; valid tables: " + ", ".join(f"[[{t}]]" if t in arrays else f"[{t}]"
                                              for t in sorted(tables))
    return file_error(MalformedFileError, path, f"{_line_of(path, first)}{where}",
                      f"unknown key(s) {sorted(extra)}", fix)


def _check_track_names(path, data: dict) -> None:
    """The top-level names of a track config are spec keys or tables (railfem.spec.SCHEMA)
    or the [job] table."""
    from railfem.spec import SCHEMA

    tables = {k for k in SCHEMA if k and k != "deviation"} | {"deviations", "job"}
    extra = set(data) - set(SCHEMA[""]) - tables
    if extra:
        raise _unknown_names(path, extra, SCHEMA[""], tables)


def _section(path, d: dict, name: str, allowed: set) -> dict:
    if not isinstance(d, dict):
        raise file_error(MalformedFileError, path, f"[{name}]", "not a table",
                         f"write [{name}] as a TOML table")
    extra = set(d) - allowed
    if extra:
        tables = {k for k in allowed if k in _TABLES}
        raise _unknown_names(path, extra, allowed - tables, tables,
                             "top level" if name == "top level" else f"[{name}]")
    return d


def read_descriptor(path: str | os.PathLike, *, quantity: str | None = None) -> HammerMeasurement:
    """Read the measurement a TOML descriptor describes (see the module docstring)."""
    path = Path(path)
    d = read_toml(path)
    _section(path, d, "top level", _TOP)
    for key in ("file", "sleeper_spacing_m", "positions_m"):
        if key not in d:
            raise file_error(MalformedFileError, path, f"key {key!r}", "missing",
                             f"add {key} (see railfem.io.config)")
    data = (path.parent / d["file"]).resolve()
    fmt = d.get("format") or FORMATS.get(data.suffix.lower())
    if fmt not in ("csv", "uff58"):
        raise file_error(MalformedFileError, path, "key 'format'", "unknown file format",
                         "say format = 'csv' or 'uff58'", value=d.get("format", data.suffix))
    sensors_d = _section(path, d.get("sensors", {}), "sensors", set(d.get("sensors", {})))
    sensors = {}
    for name, s in sensors_d.items():
        s = _section(path, s, f"sensors.{name}", _SENSOR)
        sensors[s.get("response", name)] = Sensor(
            name=name, direction=s.get("direction", d.get("excitation", "z")),
            y=s.get("y_m"), z=s.get("z_m"), note=s.get("note", ""))
    try:
        if fmt == "csv":
            c = _section(path, d.get("csv", {}), "csv", _CSV)
            if "unit" not in d:
                raise file_error(MalformedFileError, path, "key 'unit'", "missing",
                                 "state the unit of the table's values, e.g. unit = 'm/s/N'")
            channels = tuple(Channel(response=ch["sensor"], force=ch["force"],
                                     columns=tuple(ch["columns"]))
                             for ch in c.get("channels", ()))
            mapping = ColumnMapping(channels=channels, unit=d["unit"],
                                    **{k: val for k, val in c.items() if k != "channels"})
            frf = read_frf_table(data, mapping, quantity=quantity)
        else:
            frf = read_uff58(data, unit=d.get("unit"), quantity=quantity)
        metadata = Metadata(**d.get("metadata", {}))
    except (KeyError, TypeError) as err:
        raise file_error(MalformedFileError, path, None, f"incomplete description ({err})",
                         "see railfem.io.config for the keys") from err
    return hammer_measurement(frf, positions=d["positions_m"],
                              sleeper_spacing=d["sleeper_spacing_m"], sensors=sensors or None,
                              sensor_x=d.get("sensor_x_m"), excitation=d.get("excitation", "z"),
                              rail=d.get("rail", ""), metadata=metadata, source=str(path))
