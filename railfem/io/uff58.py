"""FRFs from universal files (UFF), dataset type 58 — the usual export of hammer-test software.

Read with ``pyuff``. Every type-58 record must be a frequency response function
(function type 4) of displacement, velocity or acceleration (ordinate data type 8, 11 or 12)
per excitation force (denominator data type 13) on one frequency axis (abscissa data type
18). The FRF unit comes from the ordinate and denominator unit labels (e.g. 'g' and 'N');
a file that states none needs ``unit=...``. Other record types (nodes, units, ...) are
skipped; anything else is rejected with a named error.

Records become an :class:`railfem.response.FRF` with response labels ``node<rsp_node>:<axis>``
and force labels ``node<ref_node>:<axis>``. UFF directions carry a sign (-3 = -z); values
are multiplied by ``sign(rsp_dir) * sign(ref_dir)`` so that both point along the positive
axis, as railfem's FRFs do. Hammer geometry is not part of a type-58 record: give it with
:func:`railfem.io.hammer.hammer_measurement`.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from railfem import validators as v
from railfem.conventions import QUANTITIES
from railfem.response import FRF
from railfem.io.errors import (FrequencyAxisError, MalformedFileError, MissingPositionError,
                               NonFiniteValueError, UnknownQuantityError, UnknownUnitError,
                               file_error)
from railfem.io.units import parse_force_unit, parse_frf_unit, parse_response_unit

__all__ = ["read_uff58", "FUNCTION_TYPES", "ORDINATE_TYPES", "node_label"]

#: UFF 58 function types (field 'func_type'); only 4 is an FRF
FUNCTION_TYPES = {0: "general or unknown", 1: "time response", 2: "auto spectrum",
                  3: "cross spectrum", 4: "frequency response function", 5: "transmissibility",
                  6: "coherence", 7: "auto correlation", 8: "cross correlation",
                  9: "power spectral density", 10: "energy spectral density",
                  11: "probability density function", 12: "spectrum",
                  13: "cumulative frequency distribution", 14: "peaks valley",
                  15: "stress/cycles", 16: "strain/cycles", 17: "orbit", 18: "mode indicator",
                  19: "force pattern", 20: "partial power", 21: "partial coherence",
                  22: "eigenvalue", 23: "eigenvector", 24: "shock response spectrum",
                  25: "finite impulse response filter", 26: "multiple coherence",
                  27: "order function"}
#: UFF specific data types of the ordinate numerator that make an FRF quantity
ORDINATE_TYPES = {8: "receptance", 11: "mobility", 12: "accelerance"}
_FORCE_TYPE = 13  # excitation force
_FREQUENCY_TYPE = 18
_NO_LABEL = ("", "none")
_AXES = "xyz"


def node_label(node: int, direction: int) -> str:
    """'node<n>:<axis>' for a UFF node and direction code (1..3, signs dropped)."""
    return f"node{int(node)}:{_AXES[abs(int(direction)) - 1]}"


def _sets(path: Path) -> list[dict]:
    import pyuff

    if not path.is_file():
        raise file_error(MalformedFileError, path, None, "file not found", "check the path")
    try:
        sets = pyuff.UFF(str(path)).read_sets()
    except Exception as err:  # pyuff raises bare Exceptions for malformed files
        raise file_error(MalformedFileError, path, None, f"not a readable UFF file ({err})",
                         "export the FRFs as universal file type 58") from err
    sets = [sets] if isinstance(sets, dict) else list(sets)
    out = [s for s in sets if s.get("type") == 58]
    if not out:
        kinds = sorted({s.get("type") for s in sets})
        raise file_error(MalformedFileError, path, None, f"no type-58 records (types {kinds})",
                         "export the FRFs as universal file type 58")
    return out


def _record_unit(path, k: int, s: dict, unit: str | None) -> tuple[str, float]:
    where = f"record {k} (response node {s.get('rsp_node')}, reference node {s.get('ref_node')})"
    func = int(s.get("func_type", -1))
    if func != 4:
        raise file_error(UnknownQuantityError, path, where,
                         f"function type {func} ({FUNCTION_TYPES.get(func, 'unknown')}) is not "
                         "a frequency response function", "export FRFs (function type 4)")
    num, den = int(s.get("ordinate_spec_data_type", -1)), int(s.get("orddenom_spec_data_type", -1))
    if num not in ORDINATE_TYPES or den != _FORCE_TYPE:
        raise file_error(UnknownQuantityError, path, where,
                         f"ordinate data type {num} per {den} is not displacement (8), "
                         "velocity (11) or acceleration (12) per excitation force (13)",
                         "export receptance, mobility or accelerance FRFs")
    if int(s.get("abscissa_spec_data_type", _FREQUENCY_TYPE)) != _FREQUENCY_TYPE:
        raise file_error(UnknownQuantityError, path, where,
                         f"abscissa data type {s.get('abscissa_spec_data_type')} is not "
                         "frequency (18)", "export FRFs over frequency")
    quantity = ORDINATE_TYPES[num]
    lab_n = str(s.get("ordinate_axis_units_lab", "")).strip()
    lab_d = str(s.get("orddenom_axis_units_lab", "")).strip()
    if unit is not None:
        parsed, text = parse_frf_unit(unit), unit
        if parsed is None:
            raise UnknownUnitError(f"unit = {unit!r} is unknown; use e.g. 'm/s^2/N' or 'g/N'.")
    elif lab_n.lower() in _NO_LABEL or lab_d.lower() in _NO_LABEL:
        raise file_error(UnknownUnitError, path, where, "the file states no ordinate unit",
                         "pass unit='...' (e.g. 'm/s^2/N') if you know it",
                         value=f"{lab_n}/{lab_d}")
    else:
        r, fu = parse_response_unit(lab_n), parse_force_unit(lab_d)
        if r is None or fu is None:
            raise file_error(UnknownUnitError, path, where, "unknown ordinate unit",
                             "use m, mm, m/s, mm/s, m/s^2, g per N or kN, or pass unit='...'",
                             value=f"{lab_n}/{lab_d}")
        parsed, text = (r[0], r[1] / fu), f"{lab_n}/{lab_d}"
    if parsed[0] != quantity:
        raise file_error(UnknownQuantityError, path, where,
                         f"ordinate data type says {quantity} but the unit {text!r} is a "
                         f"{parsed[0]}", "make the data type and the unit agree")
    return quantity, parsed[1]


def read_uff58(path: str | os.PathLike, *, unit: str | None = None,
               quantity: str | None = None) -> FRF:
    """Read every type-58 FRF record of a universal file into one FRF (SI values).

    unit : FRF unit to assume when the file states none (e.g. 'm/s^2/N'); overrides labels.
    quantity : convert to this quantity ('receptance', 'mobility', 'accelerance').
    """
    path = Path(path)
    if quantity is not None:
        v.one_of("quantity", quantity, QUANTITIES)
    records = _sets(path)
    first = None
    data: dict = {}
    kinds = set()
    for k, s in enumerate(records):
        q, scale = _record_unit(path, k, s, unit)
        kinds.add((q, scale))
        where = f"record {k} (response node {s['rsp_node']}, reference node {s['ref_node']})"
        x = np.asarray(s["x"], dtype=float)
        y = np.asarray(s["data"])
        if not np.all(np.isfinite(x)):
            raise file_error(NonFiniteValueError, path, where, "NaN/inf frequency",
                             "export finite frequencies")
        bad = ~np.isfinite(y)
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise file_error(NonFiniteValueError, path, where,
                             f"{int(bad.sum())} NaN/inf value(s), first at {x[i]!r} Hz",
                             "remove or repair the bad points before export", value=complex(y[i]))
        if x.size == 0 or x[0] <= 0 or np.any(np.diff(x) <= 0):
            raise file_error(FrequencyAxisError, path, where,
                             "frequencies not positive and strictly increasing",
                             "drop 0 Hz and export an increasing axis")
        if first is None:
            first = (k, x)
        elif x.shape != first[1].shape or not np.allclose(x, first[1], rtol=1e-9, atol=0.0):
            raise file_error(FrequencyAxisError, path, where,
                             f"frequency axis differs from record {first[0]}'s "
                             f"({x.size} vs {first[1].size} points)",
                             "export all FRFs on one frequency axis")
        rsp, ref = int(s["rsp_dir"]), int(s["ref_dir"])
        if rsp == 0 or ref == 0 or abs(rsp) > 3 or abs(ref) > 3:
            raise file_error(MalformedFileError, path, where,
                             f"direction codes {rsp}, {ref} are not translations (+-1..3)",
                             "export translational FRFs")
        key = (node_label(s["rsp_node"], rsp), node_label(s["ref_node"], ref))
        if key in data:
            raise file_error(MalformedFileError, path, where, f"second record for {key}",
                             "keep one FRF per response and reference")
        data[key] = y * scale * np.sign(rsp) * np.sign(ref)
    if len(kinds) != 1:
        raise file_error(UnknownQuantityError, path, None,
                         f"records mix quantities/units {sorted(kinds)}",
                         "export one quantity in one unit")
    responses = list(dict.fromkeys(r for r, _ in data))
    forces = list(dict.fromkeys(f for _, f in data))
    values = np.empty((first[1].size, len(responses), len(forces)), dtype=complex)
    for i, r in enumerate(responses):
        for j, fo in enumerate(forces):
            if (r, fo) not in data:
                raise file_error(MissingPositionError, path, None,
                                 f"no record for response {r} and reference {fo}",
                                 "export every response for every hammer position")
            values[:, i, j] = data[(r, fo)]
    frf = FRF(frequency=first[1], values=values, quantity=kinds.pop()[0],
              response=tuple(responses), force=tuple(forces))
    return frf if quantity is None else frf.to(quantity)
