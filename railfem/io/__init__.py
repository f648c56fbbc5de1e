"""Reading and writing measurements (an edge of the package: the core never imports it).

* :func:`read_dataset` / :func:`write_dataset` — dataset folders (``frf.csv`` + ``meta.json``);
* :func:`read_frf_csv` / :func:`write_frf_csv` — railfem's own tagged FRF CSV
  (:mod:`railfem.frfio`);
"""
from railfem.frfio import FRFFileError, read_frf_csv, write_frf_csv
from railfem.io.dataset import read_dataset, write_dataset
from railfem.io.errors import (FrequencyAxisError, MalformedFileError, MeasurementFileError,
                               MissingPositionError, NonFiniteValueError, UnknownQuantityError,
                               UnknownUnitError)

__all__ = [
    "read_dataset", "write_dataset", "read_frf_csv", "write_frf_csv", "FRFFileError",
    "MeasurementFileError", "MalformedFileError", "NonFiniteValueError", "FrequencyAxisError",
    "MissingPositionError", "UnknownQuantityError", "UnknownUnitError",
]
