"""Roughness spectrum files (railfem.wheelrail.roughness.RoughnessSpectrum).

* :func:`write_spectrum_csv` / :func:`read_spectrum_csv` — railfem's two-column
  ``wavelength_m,level_db_re_1um`` table ('#' lines are comments);
* :func:`read_sbb_roughness` — the wide table of the SBB Niederwangen measurements (one row
  per measurement, wavelengths in cm as column names, levels dB re 1 um);
* :func:`read_roughness` — either of them, recognised by its header.
"""
from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from ..atomic import write_text_atomic
from ..wheelrail.roughness import RoughnessSpectrum

__all__ = ["write_spectrum_csv", "read_spectrum_csv", "read_sbb_roughness", "read_roughness"]

HEADER = ["wavelength_m", "level_db_re_1um"]


def write_spectrum_csv(path, spectrum: RoughnessSpectrum) -> Path:
    """Write ``wavelength_m,level_db_re_1um`` rows atomically."""
    lines = [f"# roughness spectrum: {spectrum.name}",
             "# RMS roughness per one-third-octave wavelength band, dB re 1 um",
             ",".join(HEADER)]
    lines += [f"{w:.6g},{v:.4f}" for w, v in zip(spectrum.wavelength, spectrum.level)]
    return write_text_atomic(path, "\n".join(lines) + "\n")


def read_spectrum_csv(path) -> RoughnessSpectrum:
    """Read a ``wavelength_m,level_db_re_1um`` file ('#' lines are comments)."""
    path = Path(path)
    rows = [r for r in csv.reader(io.StringIO(path.read_text()))
            if r and not r[0].lstrip().startswith("#")]
    if not rows or rows[0][:2] != HEADER:
        raise ValueError(f"{path}: expected a header 'wavelength_m,level_db_re_1um' "
                         "(wavelength in m, level in dB re 1 um per one-third-octave band)")
    try:
        data = np.array([[float(r[0]), float(r[1])] for r in rows[1:]])
    except (ValueError, IndexError):
        raise ValueError(f"{path}: every data row needs two numbers: wavelength_m,level_db"
                         ) from None
    return RoughnessSpectrum(wavelength=data[:, 0], level=data[:, 1], name=path.stem)


def read_sbb_roughness(path, *, select: dict | None = None,
                       average: bool = True) -> list[RoughnessSpectrum] | RoughnessSpectrum:
    """Read the SBB Niederwangen rail roughness table (one row per measurement; columns
    named by the band-centre wavelength in cm; levels dB re 1 um; empty cells = no data).

    select: keep rows whose columns equal the given values, e.g. {"sec": "B2", "rail": "L"}.
    average: return one spectrum, the energy average of the selected rows over the bands
    all of them cover; otherwise a list (one per row, each over its own bands)."""
    path = Path(path)
    with path.open(newline="") as fh:
        reader = csv.DictReader(fh)
        lam_cols = [c for c in reader.fieldnames or [] if _is_number(c)]
        if not lam_cols:
            raise ValueError(f"{path}: no wavelength columns (numeric names in cm) found")
        rows = [r for r in reader
                if all(str(r.get(k, "")) == str(v) for k, v in (select or {}).items())]
    if not rows:
        raise ValueError(f"{path}: no row matches {select}")
    lam = np.array([float(c) * 1e-2 for c in lam_cols])
    table = np.array([[float(r[c]) if r[c].strip() else np.nan for c in lam_cols]
                      for r in rows])
    label = ", ".join(f"{k}={v}" for k, v in (select or {}).items()) or "all rows"
    if average:
        ok = np.all(np.isfinite(table), axis=0)
        if ok.sum() < 2:
            raise ValueError(f"{path}: the selected rows share fewer than two bands")
        lev = 10 * np.log10(np.mean(10 ** (table[:, ok] / 10), axis=0))
        return RoughnessSpectrum(wavelength=lam[ok], level=lev,
                                 name=f"SBB {path.stem} ({label}, {len(rows)} rows)")
    out = []
    for r, vals in zip(rows, table):
        ok = np.isfinite(vals)
        out.append(RoughnessSpectrum(wavelength=lam[ok], level=vals[ok],
                                     name=f"SBB {r.get('sec', '')} {r.get('rail', '')} "
                                          f"{r.get('messdatum', '')} {r.get('Author', '')}"))
    return out


def read_roughness(path, select: dict | None = None) -> RoughnessSpectrum:
    """A roughness spectrum file: the SBB wide table (recognised by its 'loc' or 'rail'
    column; ``select`` picks its rows, averaged) or a railfem spectrum CSV."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"roughness file {path} does not exist")
    head = path.read_text().splitlines()[0]
    if head.startswith("loc,") or ",rail," in head:
        return read_sbb_roughness(path, select=select)
    return read_spectrum_csv(path)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True
