"""Reading delimited text tables with errors that name the file, line and column."""
from __future__ import annotations

import csv
import math
import os
from pathlib import Path

import numpy as np

from railfem.io.errors import (FrequencyAxisError, MalformedFileError, NonFiniteValueError,
                               file_error)

__all__ = ["Table", "read_table", "number", "column", "check_frequency_axis", "read_text",
           "fmt"]

#: cells read as "not measured" where missing values are allowed
MISSING = ("", "na", "nan", "n/a", "-")


def read_text(path: Path) -> str:
    """The file as text (UTF-8, a byte-order mark is dropped)."""
    try:
        return path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise file_error(MalformedFileError, path, None, "file not found",
                         "check the path") from None
    except OSError as err:
        raise file_error(MalformedFileError, path, None, f"cannot read ({err.strerror or err})",
                         "check the path and permissions") from err
    except UnicodeDecodeError as err:
        raise file_error(MalformedFileError, path, None, f"not UTF-8 text ({err.reason})",
                         "save the table as UTF-8 CSV") from err


class Table:
    """Header and rows of a delimited text file; ``rows[i] = (line number, cells)``."""

    def __init__(self, path: Path, header: list[str], rows: list, comments: list[str]):
        self.path, self.header, self.rows, self.comments = path, header, rows, comments

    def index(self, name: str, role: str = "") -> int:
        """Position of column ``name``; a named error lists the columns there are."""
        if name not in self.header:
            shown = self.header if len(self.header) <= 12 else self.header[:12] + ["..."]
            raise file_error(MalformedFileError, self.path, "header",
                             f"no {role + ' ' if role else ''}column {name!r}",
                             f"the columns are {shown}; fix the column name or the mapping")
        return self.header.index(name)


def read_table(path: str | os.PathLike, delimiter: str = ",") -> Table:
    """Lines starting with '#' before the header are comments; blank lines are skipped."""
    path = Path(path)
    lines = read_text(path).splitlines()
    comments, k = [], 0
    while k < len(lines) and (not lines[k].strip() or lines[k].lstrip().startswith("#")):
        if lines[k].strip():
            comments.append(lines[k].lstrip()[1:].strip())
        k += 1
    if k == len(lines):
        raise file_error(MalformedFileError, path, None, "no header line",
                         "the first line that is not a '#' comment must name the columns")
    reader = csv.reader(lines[k:], delimiter=delimiter)
    header = [c.strip() for c in next(reader)]
    rows = []
    for n, cells in enumerate(reader, start=k + 2):
        if not any(c.strip() for c in cells):
            continue
        if len(cells) != len(header):
            raise file_error(MalformedFileError, path, f"line {n}",
                             f"{len(cells)} cells but the header has {len(header)} columns",
                             "give every row one value per column")
        rows.append((n, [c.strip() for c in cells]))
    if not rows:
        raise file_error(MalformedFileError, path, None, "no data rows after the header",
                         "the file holds no measurements")
    return Table(path, header, rows, comments)


def number(path, where: str, text: str, *, missing_ok: bool = False) -> float:
    """``text`` as a float; NaN for an empty/NA cell only when ``missing_ok``."""
    if text.strip().lower() in MISSING:
        if missing_ok:
            return math.nan
        raise file_error(NonFiniteValueError, path, where, "missing or NaN value",
                         "give a finite number (or remove the row)", value=text)
    try:
        x = float(text)
    except ValueError:
        raise file_error(MalformedFileError, path, where, "not a number",
                         "write plain decimal numbers", value=text) from None
    if not math.isfinite(x):
        raise file_error(NonFiniteValueError, path, where, "non-finite value",
                         "give a finite number"
                         + (" or leave the cell empty" if missing_ok else ""),
                         value=text)
    return x


def column(table: Table, name: str, *, missing_ok: bool = False) -> np.ndarray:
    """Column ``name`` as floats (errors name line and column)."""
    j = table.index(name)
    return np.array([number(table.path, f"line {n}, column {name!r}", cells[j],
                            missing_ok=missing_ok) for n, cells in table.rows])


def check_frequency_axis(path, where: str, f: np.ndarray, lines=None) -> np.ndarray:
    """Raise :class:`FrequencyAxisError` unless ``f`` is positive and strictly increasing."""
    if f.size == 0:
        raise file_error(FrequencyAxisError, path, where, "no frequencies", "give data rows")
    if f[0] <= 0.0:
        raise file_error(FrequencyAxisError, path, where, "first frequency is not positive",
                         "drop 0 Hz (and negative frequencies)", value=float(f[0]))
    steps = np.flatnonzero(np.diff(f) <= 0.0)
    if steps.size:
        k = int(steps[0])
        at = f" (lines {lines[k]} and {lines[k + 1]})" if lines is not None else ""
        raise file_error(FrequencyAxisError, path, where,
                         f"frequencies not strictly increasing{at}: {f[k]!r} then {f[k + 1]!r}",
                         "sort the rows by frequency and remove duplicates")
    return f


def fmt(x: float) -> str:
    """Shortest text that reads back as the same float ('100', '5.4', '1.58e-06')."""
    s = repr(float(x))
    return s[:-2] if s.endswith(".0") else s
