"""Read and write ``FRF`` objects as CSV.

File layout (UTF-8, comma separated, one frequency per data row)::

    # railfem-frf v1; quantity=mobility; units=m/s/N
    # response_x=0.3,0.0            (optional, metres, one per response in column order)
    # force_x=0.0                   (optional, metres, one per force in column order)
    frequency_hz,<response>|<force>_re,<response>|<force>_im,...
    1.0000000000000000e+01,...

* Lines starting with ``#`` before the header are comments; the first one names the
  quantity and its units (both are checked on reading). Free-text comment lines (e.g. a
  description of the columns, ``write_frf_csv(..., comments=...)``) follow it.
* The header has ``frequency_hz`` followed by one ``_re`` and one ``_im`` column per
  (response, force) pair, responses outer, forces inner. Labels must not contain
  ``, | # ;`` or line breaks.
* Numbers are written with 17 significant digits, so write-then-read is bit-identical.

Writes are atomic (:func:`railfem.atomic.atomic_path`: a temporary file in the same
directory moved into place when complete), so a reader never sees a half-written file.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from railfem.atomic import atomic_path
from railfem.conventions import QUANTITIES, QUANTITY_UNITS
from railfem.response import FRF

__all__ = ["write_frf_csv", "read_frf_csv", "FRFFileError", "FORMAT_TAG"]

FORMAT_TAG = "railfem-frf v1"
_FORBIDDEN = (",", "|", "#", ";", "\n", "\r")


def _check_label(kind: str, label: str) -> None:
    bad = [c for c in _FORBIDDEN if c in label]
    if bad or label != label.strip():
        raise ValueError(
            f"cannot write FRF {kind} label {label!r} to CSV: it contains "
            f"{bad or 'edge spaces'}; rename it without "
            f"{' '.join(repr(c) for c in _FORBIDDEN)} or surrounding spaces."
        )


def write_frf_csv(path: str | os.PathLike, frf: FRF, *, comments=()) -> Path:
    """Write ``frf`` to ``path`` atomically; returns the path.

    ``comments``: lines of free text written as ``# ...`` after the format line (one
    line each, no line breaks), e.g. what the columns and labels mean.
    """
    path = Path(path)
    for lab in frf.response:
        _check_label("response", lab)
    for lab in frf.force:
        _check_label("force", lab)
    lines = [f"# {FORMAT_TAG}; quantity={frf.quantity}; units={frf.units}"]
    for text in comments:
        if "\n" in text or "\r" in text:
            raise ValueError(f"FRF CSV comment {text!r} spans several lines; give one per line")
        if text.lstrip().startswith(("response_x=", "force_x=", FORMAT_TAG)):
            raise ValueError(f"FRF CSV comment {text!r} would be read as metadata")
        lines.append(f"# {text}" if text else "#")
    if frf.response_x is not None:
        lines.append("# response_x=" + ",".join(repr(float(v)) for v in frf.response_x))
    if frf.force_x is not None:
        lines.append("# force_x=" + ",".join(repr(float(v)) for v in frf.force_x))
    columns = ["frequency_hz"]
    for r in frf.response:
        for f in frf.force:
            columns += [f"{r}|{f}_re", f"{r}|{f}_im"]
    lines.append(",".join(columns))

    n = frf.frequency.size
    flat = frf.values.reshape(n, -1)
    table = np.empty((n, 1 + 2 * flat.shape[1]))
    table[:, 0] = frf.frequency
    table[:, 1::2] = flat.real
    table[:, 2::2] = flat.imag

    # an existing file keeps its permissions; a new one gets the usual ones
    mode = path.stat().st_mode & 0o777 if path.exists() else None
    with atomic_path(path, mode=mode) as tmp:
        with open(tmp, "w", encoding="utf-8", newline="\n") as fh:
            fh.write("\n".join(lines) + "\n")
            np.savetxt(fh, table, fmt="%.17g", delimiter=",")
            fh.flush()
            os.fsync(fh.fileno())
    return path


class FRFFileError(ValueError):
    """A CSV file that is not a valid railfem FRF file."""


def _fail(path: Path, line: int | None, what: str, fix: str) -> FRFFileError:
    where = f"{path}" + (f", line {line}" if line is not None else "")
    return FRFFileError(f"{where}: {what}; {fix}")


def _read_lines(path: Path) -> list[str]:
    try:
        return path.read_text(encoding="utf-8").splitlines()
    except OSError as err:
        what = f"cannot read the file ({err.strerror or err})"
        raise _fail(path, None, what, "check the path and permissions") from err
    except UnicodeDecodeError as err:
        what = f"not UTF-8 text ({err.reason})"
        raise _fail(path, None, what, "give a CSV file written by write_frf_csv") from err


def _parse_meta(path: Path, lineno: int, text: str) -> dict[str, str]:
    meta = {}
    for item in text.split(";")[1:]:
        if "=" not in item:
            what = f"malformed metadata item {item.strip()!r}"
            raise _fail(path, lineno, what, "write items as key=value")
        key, value = item.split("=", 1)
        meta[key.strip()] = value.strip()
    return meta


def _parse_floats(path: Path, lineno: int, text: str, name: str) -> np.ndarray:
    try:
        return np.array([float(v) for v in text.split(",")])
    except ValueError:
        what = f"{name} values {text!r} are not numbers"
        raise _fail(path, lineno, what, "give comma-separated metres") from None


def _read_comments(path: Path, lines: list[str]) -> tuple[int, str, dict]:
    """Parse the leading comment block; returns (header index, quantity, positions)."""
    meta: dict[str, str] | None = None
    positions: dict[str, np.ndarray] = {}
    k = 0
    while k < len(lines) and lines[k].startswith("#"):
        body = lines[k][1:].strip()
        if body.startswith(FORMAT_TAG):
            meta = _parse_meta(path, k + 1, body)
        for name in ("response_x", "force_x"):
            if body.startswith(name + "="):
                positions[name] = _parse_floats(path, k + 1, body.split("=", 1)[1], name)
        k += 1
    if meta is None:
        what = f"no '# {FORMAT_TAG}; quantity=...; units=...' comment line before the header"
        raise _fail(path, 1, what, "write the file with railfem.io.frf_csv.write_frf_csv or add it")
    quantity = meta.get("quantity")
    if quantity not in QUANTITIES:
        raise _fail(path, 1, f"quantity {quantity!r} is unknown", f"use one of {QUANTITIES}")
    if meta.get("units") != QUANTITY_UNITS[quantity]:
        raise _fail(
            path, 1, f"units {meta.get('units')!r} do not match quantity {quantity!r}",
            f"{quantity} is stored in {QUANTITY_UNITS[quantity]}; convert or fix the line",
        )
    if k >= len(lines):
        raise _fail(path, k, "the header line is missing", "add 'frequency_hz,<r>|<f>_re,...'")
    return k, quantity, positions


def _read_header(path: Path, lineno: int, line: str) -> tuple[int, list[str], list[str]]:
    """Parse the column header; returns (n_columns, responses, forces)."""
    columns = [c.strip() for c in line.split(",")]
    if columns[0] != "frequency_hz" or len(columns) < 3 or len(columns) % 2 == 0:
        what = f"header {line!r} is not 'frequency_hz' followed by _re/_im column pairs"
        raise _fail(path, lineno, what, "see railfem.io.frf_csv for the layout")
    pairs = []
    for c_re, c_im in zip(columns[1::2], columns[2::2]):
        if not (c_re.endswith("_re") and c_im.endswith("_im") and c_re[:-3] == c_im[:-3]
                and "|" in c_re):
            what = f"columns {c_re!r}, {c_im!r} are not a '<response>|<force>_re/_im' pair"
            raise _fail(path, lineno, what, "name them '<r>|<f>_re,<r>|<f>_im'")
        pairs.append(tuple(c_re[:-3].split("|", 1)))
    responses = list(dict.fromkeys(r for r, _ in pairs))
    forces = list(dict.fromkeys(f for _, f in pairs))
    expected = [(r, f) for r in responses for f in forces]
    if pairs != expected:
        what = "the (response, force) columns are not a full grid in response-major order"
        fix = f"write the columns in the order {['|'.join(p) for p in expected][:4]}..."
        raise _fail(path, lineno, what, fix)
    return len(columns), responses, forces


def _read_rows(path: Path, lines: list[str], first: int, n_columns: int) -> np.ndarray:
    rows = []
    for j in range(first, len(lines)):
        if not lines[j].strip():
            continue
        cells = lines[j].split(",")
        if len(cells) != n_columns:
            what = f"{len(cells)} values but the header has {n_columns} columns"
            raise _fail(path, j + 1, what, "every row needs the frequency and all _re/_im values")
        try:
            rows.append([float(c) for c in cells])
        except ValueError:
            bad = next(c for c in cells if not _is_float(c))
            what = f"value {bad.strip()!r} is not a number"
            raise _fail(path, j + 1, what, "write plain decimal numbers") from None
    if not rows:
        raise _fail(path, first, "no data rows after the header", "the file holds no frequencies")
    return np.array(rows)


def read_frf_csv(path: str | os.PathLike) -> FRF:
    """Read an FRF written by ``write_frf_csv`` (see the module docstring for the layout)."""
    path = Path(path)
    lines = _read_lines(path)
    k, quantity, positions = _read_comments(path, lines)
    n_columns, responses, forces = _read_header(path, k + 1, lines[k])
    table = _read_rows(path, lines, k + 1, n_columns)
    values = table[:, 1::2] + 1j * table[:, 2::2]
    try:
        return FRF(
            frequency=table[:, 0],
            values=values.reshape(table.shape[0], len(responses), len(forces)),
            quantity=quantity,
            response=tuple(responses),
            force=tuple(forces),
            response_x=positions.get("response_x"),
            force_x=positions.get("force_x"),
        )
    except ValueError as err:
        raise _fail(path, None, f"the data are not a valid FRF ({err})", "fix the data") from err


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
