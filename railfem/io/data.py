"""What a DATA path is, and reading it: the one place that decides.

A DATA path given to ``railfem fit``, ``railfem diagnose`` (or their Python jobs) is one of

* ``'hammer'`` — a hammer measurement: a dataset folder (``frf.csv`` + ``meta.json``,
  :mod:`.dataset`) or a TOML descriptor of a CSV/UFF file (``.toml``, :mod:`.config`);
* ``'passby'`` — pass-by recordings (``.npz``/``.wav``, :mod:`.recording`), one or several;
* ``'table'`` — anything else: a decay-rate table (CSV, :mod:`.tdr_table`), whose SBB
  Niederwangen column names are recognised.

:func:`data_kind` says which; :func:`read_measurement` reads a hammer measurement;
:func:`read_data` reads a hammer measurement or the selected rows of a table.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from railfem.io.config import read_descriptor
from railfem.io.dataset import META_FILE, read_dataset
from railfem.io.errors import MalformedFileError, file_error
from railfem.measurement import HammerMeasurement

__all__ = ["KINDS", "RECORDING_SUFFIXES", "SELECT_KEYS", "data_kind", "read_measurement",
           "read_data", "parse_select", "table_columns"]

KINDS = ("hammer", "passby", "table")
RECORDING_SUFFIXES = (".npz", ".wav")
#: spellings of the metadata keys a table selection may use -> the metadata field
SELECT_KEYS = {"dir": "direction", "direction": "direction", "sec": "section",
               "section": "section", "date": "date", "rail": "rail_side",
               "rail_side": "rail_side", "side": "rail_side"}


def data_kind(path) -> str:
    """'hammer', 'passby' or 'table' for one DATA path, or for a list of them (several are
    allowed for pass-by recordings only; mixing recordings with other data is an error)."""
    if isinstance(path, (list, tuple)):
        paths = [Path(p) for p in path]
        if not paths:
            raise ValueError("no DATA given")
        kinds = [data_kind(p) for p in paths]
        recs = [p for p, k in zip(paths, kinds) if k == "passby"]
        if recs and len(recs) != len(paths):
            raise ValueError(f"DATA mixes pass-by recordings ({', '.join(map(str, recs))}) "
                             "with other data; diagnose them separately")
        if not recs and len(paths) != 1:
            raise ValueError(f"{len(paths)} DATA given: several are allowed for pass-by "
                             "recordings (.npz/.wav) only; give one dataset folder, "
                             "descriptor or decay-rate table")
        return kinds[0]
    path = Path(path)
    suffix = path.suffix.lower()
    if path.is_dir() or suffix == ".toml":
        return "hammer"
    if suffix in RECORDING_SUFFIXES:
        return "passby"
    return "table"


def read_measurement(path: str | os.PathLike, **options) -> HammerMeasurement:
    """A hammer measurement from a dataset folder or a TOML descriptor (``.toml``).

    ``options`` go to :func:`railfem.io.dataset.read_dataset` (e.g. ``quantity``).
    """
    path = Path(path)
    if data_kind(path) == "hammer":
        return read_dataset(path, **options) if path.is_dir() else read_descriptor(
            path, **options)
    hint = (f"a dataset folder (frf.csv + {META_FILE}) or a .toml descriptor that points to "
            "the file and gives the hammer positions (see railfem.io.config)")
    if not path.exists():
        raise file_error(MalformedFileError, path, None, "not found", f"give {hint}")
    raise file_error(MalformedFileError, path, None,
                     "holds FRFs but no hammer geometry", f"give {hint}")


def parse_select(text: str | None) -> dict:
    """'dir=v,sec=B5' -> {'direction': 'v', 'section': 'B5'} (values may be a|b lists)."""
    out: dict = {}
    for item in (text or "").split(","):
        if not item.strip():
            continue
        key, sep, value = item.partition("=")
        key = key.strip().lower()
        if not sep or key not in SELECT_KEYS or not value.strip():
            raise ValueError(f"--select item {item!r}: write KEY=VALUE with KEY one of "
                             f"{', '.join(sorted(SELECT_KEYS))}, e.g. dir=v,sec=B5")
        vals = [v.strip() for v in value.split("|")]
        out[SELECT_KEYS[key]] = vals[0] if len(vals) == 1 else vals
    return out


def table_columns(path):
    """The column mapping of a decay-rate table: the SBB Niederwangen one when its head
    names 'messdatum', else None (railfem's own columns)."""
    from railfem.io.tdr_table import SBB_NIEDERWANGEN_COLUMNS

    head = Path(path).read_text(encoding="utf-8", errors="replace")[:4096]
    return SBB_NIEDERWANGEN_COLUMNS if "messdatum" in head else None


def _check_direction(path, table, crit: dict) -> None:
    """A --select direction no row has is refused in the table's own words (its direction
    column may say v/h where railfem's axes are z/y)."""
    from railfem.io.tdr_table import direction_labels
    from railfem.measurement import direction_name

    want = crit.get("direction")
    if not isinstance(want, str):
        return
    labels = direction_labels(path, columns=table_columns(path))
    try:
        axis = direction_name(want)
    except ValueError:
        axis = None
    if axis is None or axis not in set(table.direction):
        have = ", ".join(f"{'/'.join(v)}" for v in labels.values()) or ", ".join(
            sorted(set(table.direction)))
        raise ValueError(f"--select dir={want}: no row of {path} has that direction; its "
                         f"rows have dir = {have}")


def read_data(path, *, select=None, row=None, campaign=False):
    """(kind, items): ('hammer', [measurement]) or ('table', [(row index, measurement)]).

    select: a dict of metadata values or its text ('dir=v,sec=B5', :func:`parse_select`);
    row: one row of the selection (0-based); campaign: every selected row (else the
    selection must hold one). select, row and campaign apply to tables only."""
    from railfem.io.tdr_table import read_decay_rate_table

    path = Path(path)
    if not path.exists():
        raise ValueError(f"DATA {path} does not exist; give a dataset folder, a .toml "
                         "descriptor or a decay-rate table (.csv)")
    kind = data_kind(path)
    if kind == "passby":
        raise ValueError(f"DATA {path} is a pass-by recording; give a dataset folder, a .toml "
                         "descriptor or a decay-rate table (.csv)")
    if kind == "hammer":
        if select or row is not None or campaign:
            raise ValueError("--select, --row and --campaign apply to decay-rate tables; "
                             f"{path} is a hammer measurement")
        return "hammer", [read_measurement(path)]
    table = read_decay_rate_table(path, columns=table_columns(path))
    index = np.arange(len(table))
    crit = parse_select(select) if isinstance(select, str) else dict(select or {})
    if crit:
        _check_direction(path, table, crit)
        keep = table.select(**crit)
        index = np.array([i for i in range(len(table))
                          if any(table.metadata[i] is m for m in keep.metadata)])
    if row is not None:
        if not 0 <= row < len(index):
            raise ValueError(f"--row {row}: the selection has {len(index)} rows (0.."
                             f"{len(index) - 1})")
        index = index[[row]]
    if not campaign and len(index) != 1:
        raise ValueError(f"the selection holds {len(index)} rows; pick one with --row N or "
                         "--select, or fit them all with --campaign")
    return "table", [(int(i), table.row(int(i))) for i in index]
