"""Named errors for measurement files.

Every error is a ``ValueError`` (the command line turns it into a one-line message and exit
code 2) and says where (file, and line/column/key), what value was found, and the fix.
Catch :class:`MeasurementFileError` for all of them.
"""
from __future__ import annotations

import os

__all__ = [
    "MeasurementFileError",
    "MalformedFileError",
    "NonFiniteValueError",
    "FrequencyAxisError",
    "MissingPositionError",
    "UnknownQuantityError",
    "UnknownUnitError",
    "file_error",
]


class MeasurementFileError(ValueError):
    """A measurement file that cannot be read as it is."""

    def __init__(self, message: str, *, path=None, key=None, value=None):
        super().__init__(message)
        self.path, self.key, self.value = path, key, value


class MalformedFileError(MeasurementFileError):
    """Missing file, key or column; not a number; wrong shape; invalid JSON/TOML/CSV."""


class NonFiniteValueError(MeasurementFileError):
    """NaN or inf where a number is required."""


class FrequencyAxisError(MeasurementFileError):
    """A frequency axis that is not positive and strictly increasing, or axes that differ."""


class MissingPositionError(MeasurementFileError):
    """A hammer position without data, or data without a hammer position."""


class UnknownQuantityError(MeasurementFileError):
    """A quantity (e.g. 'impedance', UFF function type) railfem does not read."""


class UnknownUnitError(MeasurementFileError):
    """A unit railfem cannot convert to SI."""


_NO_VALUE = object()


def file_error(cls: type[MeasurementFileError], path: str | os.PathLike, where: str | None,
               what: str, fix: str, *, value=_NO_VALUE) -> MeasurementFileError:
    """``cls('<path>, <where>: <what> (value <value>); <fix>')`` with the parts as attributes."""
    place = f"{path}" + (f", {where}" if where else "")
    shown = "" if value is _NO_VALUE else f" (value {value!r})"
    return cls(f"{place}: {what}{shown}; {fix}", path=str(path), key=where,
               value=None if value is _NO_VALUE else value)
