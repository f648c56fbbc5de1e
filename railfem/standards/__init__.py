"""Procedures from measurement standards: IEC 61260-1 bands, EN 15461 track decay rate."""

from railfem.standards.en15461 import (
    DecayRateResult,
    decay_rate,
    decay_rate_from_band_power,
    hammer_positions,
    lowest_measurable_decay_rate,
    weighted_intervals,
)
from railfem.standards.iec61260 import (
    ThirdOctaveBands,
    band_average,
    ninth_octave_grid,
    third_octave_bands,
)

__all__ = [
    "DecayRateResult",
    "ThirdOctaveBands",
    "band_average",
    "decay_rate",
    "decay_rate_from_band_power",
    "hammer_positions",
    "lowest_measurable_decay_rate",
    "ninth_octave_grid",
    "third_octave_bands",
    "weighted_intervals",
]
