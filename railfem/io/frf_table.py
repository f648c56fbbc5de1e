"""Complex FRFs from any delimited table, with a declared column mapping.

The mapping says which column holds the frequency, which columns hold each (response,
force) pair — real and imaginary part, or level in dB and phase — and the FRF unit of the
file ('m/s/N', 'mm/s/N', 'g/N', 'm/N', ...; see :mod:`railfem.io.units`), which names the
quantity (receptance, mobility or accelerance). Values are scaled to SI on reading and, if
asked, converted to another quantity. Example::

    mapping = ColumnMapping(unit="g/N", form="db_phase", phase_unit="deg",
                            frequency="f [Hz]",
                            channels=(Channel(response="head", force="p0",
                                              columns=("H1 dB", "H1 phase")), ...))
    frf = read_frf_table("export.csv", mapping, quantity="mobility")
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from railfem import validators as v
from railfem.conventions import QUANTITIES
from railfem.response import FRF
from railfem.io.errors import MissingPositionError, UnknownUnitError, file_error
from railfem.io.text import check_frequency_axis, column, read_table
from railfem.io.units import FREQUENCY_UNITS, parse_frf_unit

__all__ = ["Channel", "ColumnMapping", "read_frf_table", "FORMS", "PHASE_UNITS"]

FORMS = ("re_im", "db_phase")
PHASE_UNITS = ("deg", "rad")


@dataclass(frozen=True, kw_only=True)
class Channel:
    """One FRF in the table: which columns hold the response ``response`` to force ``force``."""

    response: str
    """Response label, e.g. the sensor name 'head'."""
    force: str
    """Force label, e.g. 'hammer_0.150' or a hammer node name."""
    columns: tuple[str, str]
    """(real part, imaginary part) or (level in dB, phase) column names."""

    def __post_init__(self) -> None:
        for name in ("response", "force"):
            if not isinstance(getattr(self, name), str) or not getattr(self, name):
                raise ValueError(f"Channel.{name} = {getattr(self, name)!r}: give a label.")
        cols = tuple(self.columns)
        if len(cols) != 2 or not all(isinstance(c, str) and c for c in cols):
            raise ValueError(f"Channel.columns = {self.columns!r}: give two column names "
                             "(re, im) or (dB, phase).")
        object.__setattr__(self, "columns", cols)


@dataclass(frozen=True, kw_only=True)
class ColumnMapping:
    """How to read FRFs from a table (see the module docstring)."""

    channels: tuple[Channel, ...]
    """One per FRF; together a full grid of responses x forces."""
    unit: str
    """FRF unit of the values in the file (or the dB reference unit), e.g. 'm/s/N', 'g/N'."""
    frequency: str = "frequency_hz"
    """Name of the frequency column."""
    frequency_unit: str = "Hz"
    """'Hz' or 'kHz'."""
    form: str = "re_im"
    """'re_im' (real, imaginary) or 'db_phase' (level, phase)."""
    phase_unit: str = "deg"
    """'deg' or 'rad' (db_phase only)."""
    db_reference: float = 1.0
    """Level 0 dB corresponds to this many ``unit`` (db_phase only)."""
    time_convention: str = "+"
    """'+' for exp(+i omega t) (railfem's), '-' for exp(-i omega t): values are conjugated."""
    delimiter: str = ","

    def __post_init__(self) -> None:
        channels = tuple(self.channels)
        if not channels or any(not isinstance(c, Channel) for c in channels):
            raise ValueError("ColumnMapping.channels must hold at least one Channel.")
        pairs = [(c.response, c.force) for c in channels]
        if len(set(pairs)) != len(pairs):
            raise ValueError(f"ColumnMapping.channels repeat a (response, force) pair: {pairs}.")
        object.__setattr__(self, "channels", channels)
        if parse_frf_unit(self.unit) is None:
            raise UnknownUnitError(f"ColumnMapping.unit = {self.unit!r} is unknown; use a response "
                                   "unit (m, mm, m/s, mm/s, m/s^2, g) per N or kN, e.g. 'm/s/N'.")
        if self.frequency_unit.lower() not in FREQUENCY_UNITS:
            raise UnknownUnitError(f"ColumnMapping.frequency_unit = {self.frequency_unit!r} is "
                                   "unknown; use 'Hz' or 'kHz'.")
        v.one_of("ColumnMapping.form", self.form, FORMS)
        v.one_of("ColumnMapping.phase_unit", self.phase_unit, PHASE_UNITS)
        v.one_of("ColumnMapping.time_convention", self.time_convention, ("+", "-"))
        v.positive("ColumnMapping.db_reference", self.db_reference, self.unit)

    @property
    def quantity(self) -> str:
        """Quantity of the file's values, from ``unit``."""
        return parse_frf_unit(self.unit)[0]


def _grid(path, mapping: ColumnMapping):
    responses = list(dict.fromkeys(c.response for c in mapping.channels))
    forces = list(dict.fromkeys(c.force for c in mapping.channels))
    have = {(c.response, c.force): c for c in mapping.channels}
    for r in responses:
        for f in forces:
            if (r, f) not in have:
                raise file_error(MissingPositionError, path, "column mapping",
                                 f"no channel for response {r!r} and force {f!r}",
                                 "map every response to every force (a full grid)")
    return responses, forces, have


def read_frf_table(path: str | os.PathLike, mapping: ColumnMapping, *,
                   quantity: str | None = None) -> FRF:
    """Read the FRFs that ``mapping`` declares; SI values, converted to ``quantity`` if given."""
    path = Path(path)
    if not isinstance(mapping, ColumnMapping):
        raise ValueError("read_frf_table needs a ColumnMapping that declares the columns.")
    if quantity is not None:
        v.one_of("quantity", quantity, QUANTITIES)
    table = read_table(path, mapping.delimiter)
    responses, forces, have = _grid(path, mapping)
    lines = [n for n, _ in table.rows]
    scale_f = FREQUENCY_UNITS[mapping.frequency_unit.lower()]
    f = check_frequency_axis(path, f"column {mapping.frequency!r}",
                             column(table, mapping.frequency) * scale_f, lines)
    q, scale = parse_frf_unit(mapping.unit)
    values = np.empty((f.size, len(responses), len(forces)), dtype=complex)
    for i, r in enumerate(responses):
        for j, fo in enumerate(forces):
            a, b = (column(table, c) for c in have[(r, fo)].columns)
            if mapping.form == "re_im":
                y = a + 1j * b
            else:
                phase = np.radians(b) if mapping.phase_unit == "deg" else b
                y = mapping.db_reference * 10.0 ** (a / 20.0) * np.exp(1j * phase)
            values[:, i, j] = np.conj(y) if mapping.time_convention == "-" else y
    frf = FRF(frequency=f, values=values * scale, quantity=q, response=tuple(responses),
              force=tuple(forces))
    return frf if quantity is None else frf.to(quantity)
