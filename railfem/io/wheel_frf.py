"""Tabulated wheels (railfem.wheelrail.wheels.TabulatedWheel) in railfem's FRF CSV format
(:mod:`railfem.io.frf_csv`).

:func:`read_wheel_frf` takes any quantity (receptance, mobility, accelerance) and keeps the
radial receptance at the contact; :func:`write_wheel_frf` writes a wheel's receptance on
its own frequencies (or on given ones for any wheel model)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..response import FRF
from ..wheelrail.wheels import TabulatedWheel
from .frf_csv import read_frf_csv, write_frf_csv

__all__ = ["read_wheel_frf", "write_wheel_frf"]


def read_wheel_frf(path, *, response: str | None = None,
                   force: str | None = None) -> TabulatedWheel:
    """A measured/tabulated wheel FRF from a railfem FRF CSV file (any quantity; the
    first response and force unless named)."""
    frf = read_frf_csv(path)
    r = frf.response.index(response) if response else 0
    k = frf.force.index(force) if force else 0
    rec = frf.to("receptance")
    return TabulatedWheel(frequency=np.asarray(frf.frequency),
                          values=np.asarray(rec.values[:, r, k]), name=str(path))


def write_wheel_frf(path, wheel, frequency=None) -> Path:
    """Write the radial contact receptance of ``wheel`` (m/N) as an FRF CSV: at
    ``frequency`` (Hz), by default a TabulatedWheel's own frequencies."""
    if frequency is None:
        if not isinstance(wheel, TabulatedWheel):
            raise ValueError(f"write_wheel_frf: give the frequencies for a "
                             f"{type(wheel).__name__}")
        f, values = np.asarray(wheel.frequency, dtype=float), wheel.values
    else:
        f = np.asarray(frequency, dtype=float)
        values = wheel.receptance(f)
    frf = FRF(frequency=f, values=np.asarray(values, dtype=complex),
              quantity="receptance", response=("wheel",), force=("contact",))
    return write_frf_csv(path, frf, comments=(
        f"radial point receptance at the wheel-rail contact: "
        f"{getattr(wheel, 'name', type(wheel).__name__)}",))
