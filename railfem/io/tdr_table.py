"""Decay-rate tables in wide form: one row per measurement, one column per band.

A row holds metadata columns (direction, date, temperature, section, rail side, sensor and
any others) and one decay rate (dB/m) per one-third-octave band; a band column is named by
its centre frequency in Hz (e.g. ``100``, ``1250``). Empty or ``NA`` cells are "not
measured" (NaN). Lines starting with ``#`` before the header are comments; a comment
``unit=...`` must say ``dB/m``.

The reader maps railfem's metadata names to the file's column names with ``columns``; by
default the file uses railfem's names (what :func:`write_decay_rate_table` writes):
``direction, sensor, date, temperature_c, section, rail_side``. Other non-band columns are
kept, as text, in each row's ``metadata.notes``. For example the SBB Niederwangen file
(columns ``loc,sec,pad,FX,tdr_id,Author,messdatum,padCalc,calcQ,temp,rail,dir,100,...``)
is read with ``columns=SBB_NIEDERWANGEN_COLUMNS``.
"""
from __future__ import annotations

import os
import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from railfem.io.errors import MalformedFileError, UnknownUnitError, file_error
from railfem.io.text import MISSING, check_frequency_axis, fmt, number, read_table
from railfem.measurement import DecayRateTable, Metadata, direction_name

__all__ = ["read_decay_rate_table", "write_decay_rate_table", "METADATA_COLUMNS",
           "SBB_NIEDERWANGEN_COLUMNS", "FORMAT_TAG"]

FORMAT_TAG = "railfem decay-rate table v1"
#: railfem's metadata column names, in the order they are written
METADATA_COLUMNS = ("direction", "sensor", "date", "temperature_c", "section", "rail_side")
#: column names of measured_data/sbb_niederwangen/tdr_niederwangen_wide.csv (see its README)
SBB_NIEDERWANGEN_COLUMNS = {"direction": "dir", "date": "messdatum", "temperature_c": "temp",
                            "section": "sec", "rail_side": "rail"}
_BAND = re.compile(r"^[0-9]+(\.[0-9]*)?([eE][-+]?[0-9]+)?$")


def _unit_check(path: Path, comments: list[str]) -> None:
    for c in comments:
        for item in c.split(";"):
            key, _, value = item.partition("=")
            if key.strip().lower() in ("unit", "units") and value.strip() != "dB/m":
                raise file_error(UnknownUnitError, path, "comment 'unit'",
                                 "decay rates must be in dB/m", "convert the table to dB/m",
                                 value=value.strip())


def read_decay_rate_table(path: str | os.PathLike, *, columns: Mapping[str, str] | None = None,
                          direction: str | None = None, delimiter: str = ",") -> DecayRateTable:
    """Read a wide decay-rate table.

    columns : {railfem name: file column} for any of ``METADATA_COLUMNS``; names not given
        are looked up under railfem's own name and are optional, except the direction.
    direction : the direction of every row when the file has no direction column
        ('z'/'v'/'vertical', 'y'/'h'/'lateral').
    """
    path = Path(path)
    table = read_table(path, delimiter)
    _unit_check(path, table.comments)
    mapping = dict(columns or {})
    unknown = set(mapping) - set(METADATA_COLUMNS)
    if unknown:
        raise ValueError(f"columns has unknown key(s) {sorted(unknown)}; use "
                         f"{', '.join(METADATA_COLUMNS)}.")
    for name, col in mapping.items():
        table.index(col, role=name)
    meta_cols = {n: mapping.get(n, n) for n in METADATA_COLUMNS
                 if mapping.get(n, n) in table.header}
    if "direction" not in meta_cols and direction is None:
        raise file_error(MalformedFileError, path, "header", "no direction column",
                         "map it with columns={'direction': '<column>'} or pass direction='z'")
    bands, notes = [], []
    for j, name in enumerate(table.header):
        if name in meta_cols.values():
            continue
        (bands if _BAND.match(name) else notes).append(j)
    if not bands:
        raise file_error(MalformedFileError, path, "header",
                         "no band columns (named by their centre frequency in Hz)",
                         "name the band columns 100, 125, ... (Hz)")
    f = check_frequency_axis(path, "header (band columns)",
                             np.array([float(table.header[j]) for j in bands]))
    values = np.empty((f.size, len(table.rows)))
    dirs, metas, sensors = [], [], []
    for r, (n, cells) in enumerate(table.rows):
        for b, j in enumerate(bands):
            where = f"line {n}, column {table.header[j]!r}"
            x = number(path, where, cells[j], missing_ok=True)
            if x <= 0.0:
                raise file_error(MalformedFileError, path, where, "decay rate <= 0",
                                 "a decay rate is > 0 dB/m; leave the cell empty if unknown",
                                 value=cells[j])
            values[b, r] = x
        cell = {k: cells[table.index(c)] for k, c in meta_cols.items()}
        dirs.append(_direction(path, n, meta_cols.get("direction"), cell.get("direction"),
                               direction))
        sensors.append(cell.get("sensor") or None)
        metas.append(_metadata(path, n, meta_cols, cell,
                               {table.header[j]: cells[j] for j in notes}))
    return DecayRateTable(frequency=f, decay_rate=values, direction=tuple(dirs),
                          metadata=tuple(metas), sensor=tuple(sensors))


def direction_labels(path: str | os.PathLike, *, columns: Mapping[str, str] | None = None,
                     delimiter: str = ",") -> dict[str, list[str]]:
    """{axis name: the labels the table's own direction column uses for it} (e.g. {'z':
    ['v'], 'y': ['h']}), for messages in the data's words; {} without a direction column."""
    table = read_table(Path(path), delimiter)
    col = dict(columns or {}).get("direction", "direction")
    if col not in table.header:
        return {}
    out: dict[str, set] = {}
    for _, cells in table.rows:
        label = cells[table.index(col)].strip()
        try:
            out.setdefault(direction_name(label), set()).add(label)
        except ValueError:
            continue
    return {axis: sorted(labels) for axis, labels in sorted(out.items())}


def _direction(path, n, col, text, default) -> str:
    value = text if col is not None else default
    try:
        return direction_name(value)
    except ValueError as err:
        raise file_error(MalformedFileError, path, f"line {n}, column {col!r}",
                         "unknown direction", f"{err}", value=value) from None


def _metadata(path, n, meta_cols, cell, notes) -> Metadata:
    kw = {}
    for key in ("section", "rail_side"):
        if cell.get(key):
            kw[key] = cell[key]
    if cell.get("date"):
        kw["date"] = cell["date"]
    t = cell.get("temperature_c", "")
    if t.strip().lower() not in MISSING:
        kw["temperature_c"] = number(path, f"line {n}, column {meta_cols['temperature_c']!r}", t)
    try:
        return Metadata(notes=notes, **kw)
    except ValueError as err:
        raise file_error(MalformedFileError, path, f"line {n}", f"invalid metadata ({err})",
                         "fix the cell") from None


def write_decay_rate_table(path: str | os.PathLike, table: DecayRateTable) -> Path:
    """Write ``table`` atomically in railfem's column names (numbers read back exactly).

    Notes are written as text, so they come back as text. Returns the path.
    """
    from railfem.atomic import write_text_atomic

    note_keys: list[str] = []
    for m in table.metadata:
        for k, value in m.notes.items():
            if isinstance(value, (Mapping, tuple)):
                raise ValueError(f"metadata note {k!r} = {value!r} is not a single value; "
                                 "a table cell holds text or a number.")
            if k not in note_keys:
                note_keys.append(k)
    clash = set(note_keys) & set(METADATA_COLUMNS)
    if clash:
        raise ValueError(f"metadata notes {sorted(clash)} clash with railfem's columns; "
                         "rename them.")
    bands = [fmt(x) for x in table.frequency]
    header = list(METADATA_COLUMNS) + note_keys + bands
    for name in header:
        if "," in name or "\n" in name:
            raise ValueError(f"column name {name!r} contains a comma or line break.")
    lines = [f"# {FORMAT_TAG}; unit=dB/m; band columns: one-third-octave centre frequency (Hz)",
             ",".join(header)]
    for r, m in enumerate(table.metadata):
        cells = [table.direction[r], table.sensor[r] or "", m.date or "",
                 "" if m.temperature_c is None else fmt(m.temperature_c),
                 m.section or "", m.rail_side or ""]
        cells += ["" if m.notes.get(k) is None else str(m.notes[k]) for k in note_keys]
        cells += ["" if not np.isfinite(x) else fmt(x) for x in table.decay_rate[:, r]]
        for c in cells:
            if "," in c or "\n" in c:
                raise ValueError(f"row {r}: cell {c!r} contains a comma or line break.")
        lines.append(",".join(cells))
    return write_text_atomic(Path(path), "\n".join(lines) + "\n")
