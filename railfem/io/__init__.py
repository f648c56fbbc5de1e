"""Reading and writing measurements (an edge of the package: the core never imports it).

* :func:`data_kind` / :func:`read_data` — what a DATA path is (hammer measurement, decay-rate
  table, pass-by recordings) and reading it; :func:`read_measurement` — a dataset folder or
  a TOML descriptor (:mod:`.data`);
* :func:`read_toml` — every TOML file, errors naming file and line (:mod:`.config`);
* :func:`read_dataset` / :func:`write_dataset` — dataset folders, ``frf.csv`` + ``meta.json``
  (:mod:`.dataset`);
* :func:`read_frf_table` with a :class:`ColumnMapping` — complex FRFs from any table, re/im or
  dB/phase, any FRF unit (:mod:`.frf_table`);
* :func:`read_uff58` — universal file type 58 (:mod:`.uff58`, via pyuff);
* :func:`hammer_measurement` — hammer geometry for FRFs from a file that has none;
* :func:`read_decay_rate_table` / :func:`write_decay_rate_table` — wide decay-rate tables
  (:mod:`.tdr_table`);
* :func:`read_frf_csv` / :func:`write_frf_csv` — railfem's own tagged FRF CSV
  (:mod:`railfem.io.frf_csv`);
* :mod:`.recording` — one-sensor pass-by recordings for the decay-rate estimators.

Malformed input raises a subclass of :class:`MeasurementFileError` (a ``ValueError``) that
names the file, the line/column/key, the value and the fix.
"""
from railfem.io.frf_csv import FRFFileError, read_frf_csv, write_frf_csv
from railfem.io.config import read_descriptor, read_toml, read_track_config
from railfem.io.data import data_kind, read_data, read_measurement
from railfem.io.dataset import read_dataset, write_dataset
from railfem.io.errors import (FrequencyAxisError, MalformedFileError, MeasurementFileError,
                               MissingPositionError, NonFiniteValueError, UnknownQuantityError,
                               UnknownUnitError)
from railfem.io.frf_table import Channel, ColumnMapping, read_frf_table
from railfem.io.hammer import hammer_measurement
from railfem.io.tdr_table import (SBB_NIEDERWANGEN_COLUMNS, read_decay_rate_table,
                                  write_decay_rate_table)
from railfem.io.uff58 import read_uff58
from railfem.io.roughness_table import read_roughness, read_spectrum_csv, write_spectrum_csv
from railfem.io.wheel_frf import read_wheel_frf, write_wheel_frf

__all__ = [
    "read_measurement", "read_descriptor", "read_toml", "read_track_config", "data_kind",
    "read_data", "read_dataset", "write_dataset", "read_frf_table",
    "Channel", "ColumnMapping", "read_uff58", "hammer_measurement", "read_decay_rate_table",
    "write_decay_rate_table", "SBB_NIEDERWANGEN_COLUMNS", "read_frf_csv", "write_frf_csv",
    "FRFFileError", "MeasurementFileError", "MalformedFileError", "NonFiniteValueError",
    "FrequencyAxisError", "MissingPositionError", "UnknownQuantityError", "UnknownUnitError",
    "read_roughness", "read_spectrum_csv", "write_spectrum_csv", "read_wheel_frf",
    "write_wheel_frf",
]
