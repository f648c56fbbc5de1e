"""Units of frequency response functions in files, and their factors to SI.

An FRF unit is '<response unit>/<force unit>', e.g. 'm/s/N', '(m/s)/N', 'mm/s/N', 'g/N',
'm/s^2/N', 'um/N', 'm/s/kN'. The response unit names the quantity (displacement:
receptance, velocity: mobility, acceleration: accelerance). 'g' is the standard gravity
9.80665 m/s^2. Anything else is unknown and is rejected, never guessed.
"""
from __future__ import annotations

__all__ = ["RESPONSE_UNITS", "FORCE_UNITS", "STANDARD_GRAVITY", "parse_frf_unit",
           "parse_response_unit", "parse_force_unit", "FREQUENCY_UNITS"]

STANDARD_GRAVITY = 9.80665  # m/s^2 (ISO 80000-3)

#: response unit -> (quantity, factor to SI)
RESPONSE_UNITS = {
    "m": ("receptance", 1.0), "mm": ("receptance", 1e-3), "um": ("receptance", 1e-6),
    "µm": ("receptance", 1e-6),
    "m/s": ("mobility", 1.0), "mm/s": ("mobility", 1e-3), "um/s": ("mobility", 1e-6),
    "µm/s": ("mobility", 1e-6),
    "m/s^2": ("accelerance", 1.0), "m/s2": ("accelerance", 1.0), "m/s²": ("accelerance", 1.0),
    "m/s**2": ("accelerance", 1.0), "mm/s^2": ("accelerance", 1e-3),
    "mm/s2": ("accelerance", 1e-3), "g": ("accelerance", STANDARD_GRAVITY),
}
#: force unit -> factor to N
FORCE_UNITS = {"n": 1.0, "kn": 1e3}
#: frequency unit -> factor to Hz
FREQUENCY_UNITS = {"hz": 1.0, "khz": 1e3}


def _clean(text: str) -> str:
    return str(text).strip().replace(" ", "").replace("(", "").replace(")", "")


def parse_response_unit(text: str) -> tuple[str, float] | None:
    """(quantity, factor to SI) of a response unit, or None if unknown."""
    t = _clean(text)
    return RESPONSE_UNITS.get(t) or RESPONSE_UNITS.get(t.lower())


def parse_force_unit(text: str) -> float | None:
    """Factor to N of a force unit, or None if unknown."""
    return FORCE_UNITS.get(_clean(text).lower())


def parse_frf_unit(text: str) -> tuple[str, float] | None:
    """(quantity, factor to SI) of an FRF unit like 'mm/s/N' or 'g/N', or None if unknown."""
    t = _clean(text)
    if "/" not in t:
        return None
    response, force = t.rsplit("/", 1)
    r, fu = parse_response_unit(response), parse_force_unit(force)
    if r is None or fu is None:
        return None
    return r[0], r[1] / fu
