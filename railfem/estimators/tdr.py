"""Track decay rate from a hammer measurement, the same for measured and simulated FRFs.

:func:`hammer` takes a :class:`railfem.measurement.HammerMeasurement` — read from a file
(:mod:`railfem.io`) or built from a model's FRFs — and returns the EN 15461 decay rate per
one-third-octave band (:class:`railfem.standards.en15461.DecayRateResult`). Nothing here
knows where the FRFs came from, so a model-vs-measurement comparison compares like with
like.

What is EN 15461 and what is railfem's (see also :mod:`railfem.standards.en15461`):

* EN 15461: the decay-rate formula ``D = 4.343 / sum (|Y_i|^2/|Y_0|^2) dx_i`` on
  one-third-octave band averages, the hammer positions (here: whatever list the
  measurement holds — the standard's 29 positions for a standard test), and that the
  result is reported per band.
* railfem (derived or chosen here, not quoted from the standard, whose text we could not
  check): the half-interval weights ``dx_i``; the 10 dB far-field check and the lowest
  measurable decay rate ``D_min = 10 dB / x_last``; ``point="realised"`` (weights from the
  distance at which the point FRF was really struck, e.g. 0.02 m, instead of 0); and the
  noise-floor exclusion of METHOD.md section 6 (:class:`NoiseFloorExclusion`):

  (a) a threshold relative to the point FRF (default -15 dB) with a flat-tail test
      (default 3 dB): positions below the threshold are dropped only from where the levels
      of the rest of the band have stopped falling, which is what a noise floor does and an
      exponential decay does not; so clean data lose nothing however steep their decay,
      while the METHOD.md rule without the test (``floor_drop_db=None``) also cuts real
      positions beyond -15 dB in strongly decaying bands (an upward bias of +4 to +5 % for
      clean exponentials of 10 - 30 dB/m on the standard grid);
  (b) optionally, an implied-attenuation range (e.g. 3 - 30 dB/m below 400 Hz): positions
      farther than 1 m whose ``20 lg|Y_0/Y_i| / x_i`` is outside it are dropped. Off by
      default: measured tracks decay by less than 3 dB/m at 100 Hz (the SBB Niederwangen
      table has 2.7 dB/m), and a true decay below the range rejects real data.

  The sum is truncated where positions are dropped (no tail is added), so an exclusion
  biases D upwards by about the share of the integral beyond the last kept position.
  Bands that fail are marked in ``result.suitable`` and explained in ``result.status``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from railfem import validators as v
from railfem.measurement import DecayRateMeasurement, HammerMeasurement
from railfem.standards import en15461
from railfem.standards.iec61260 import ThirdOctaveBands

__all__ = ["NoiseFloorExclusion", "NO_EXCLUSION", "POINT_CHOICES", "hammer", "hammer_all",
           "as_decay_rate_measurement"]

POINT_CHOICES = ("nominal", "realised")


@dataclass(frozen=True, kw_only=True)
class NoiseFloorExclusion:
    """Which far-field transfers to leave out of the decay-rate sum (railfem, METHOD.md §6)."""

    threshold_db: float | None = -15.0
    """Level re the point FRF (dB) below which a position may be noise; None: rule (a) off."""
    floor_drop_db: float | None = 3.0
    """Flat-tail test of rule (a): drop positions below the threshold only from where the
    remaining levels' fitted line falls by less than this (dB); None: drop everything from
    the first position below the threshold (the plain METHOD.md rule)."""
    min_tail: int = 3
    """Fewest positions that can make a noise floor (flat-tail test)."""
    attenuation_range: tuple[float, float] | None = None
    """Rule (b): plausible implied attenuation (low, high), dB/m, e.g. (3.0, 30.0); None: off."""
    attenuation_max_frequency: float = 400.0
    """Rule (b) applies in bands whose centre is below this, Hz."""
    attenuation_min_distance: float = 1.0
    """Rule (b) applies to positions at least this far from the sensor, m."""

    def __post_init__(self) -> None:
        if self.threshold_db is not None:
            t = v.finite("NoiseFloorExclusion.threshold_db", self.threshold_db, "dB")
            if t >= 0.0:
                raise ValueError(f"NoiseFloorExclusion.threshold_db = {t!r} dB: give a level "
                                 "below the point FRF, e.g. -15.")
            object.__setattr__(self, "threshold_db", t)
        if self.floor_drop_db is not None:
            object.__setattr__(self, "floor_drop_db", v.positive(
                "NoiseFloorExclusion.floor_drop_db", self.floor_drop_db, "dB", "e.g. 3"))
        if int(self.min_tail) != self.min_tail or self.min_tail < 2:
            raise ValueError(f"NoiseFloorExclusion.min_tail = {self.min_tail!r}: give a whole "
                             "number >= 2.")
        if self.attenuation_range is not None:
            low, high = (v.non_negative("NoiseFloorExclusion.attenuation_range", a, "dB/m")
                         for a in self.attenuation_range)
            if not low < high:
                raise ValueError(f"NoiseFloorExclusion.attenuation_range = "
                                 f"{self.attenuation_range!r} dB/m: give (low, high) with "
                                 "low < high, e.g. (3.0, 30.0).")
            object.__setattr__(self, "attenuation_range", (low, high))
        v.positive("NoiseFloorExclusion.attenuation_max_frequency",
                   self.attenuation_max_frequency, "Hz")
        v.non_negative("NoiseFloorExclusion.attenuation_min_distance",
                       self.attenuation_min_distance, "m")

    def options(self) -> dict:
        """Keyword arguments of :func:`railfem.standards.en15461.decay_rate`."""
        return {"threshold_db": self.threshold_db,
                "floor_drop_db": self.floor_drop_db if self.threshold_db is not None else None,
                "min_tail": int(self.min_tail),
                "attenuation_range": self.attenuation_range,
                "attenuation_max_frequency": float(self.attenuation_max_frequency),
                "attenuation_min_distance": float(self.attenuation_min_distance)}


#: Every position enters the sum: the plain EN 15461 estimate.
NO_EXCLUSION = NoiseFloorExclusion(threshold_db=None, floor_drop_db=None, attenuation_range=None)


def hammer(measurement: HammerMeasurement, sensor: str | None = None, *,
           exclusion: NoiseFloorExclusion = NoiseFloorExclusion(),
           bands: ThirdOctaveBands | None = None, point: str = "nominal",
           far_field_drop_db: float = en15461.FAR_FIELD_DROP_DB) -> en15461.DecayRateResult:
    """EN 15461 decay rate per one-third-octave band of one sensor of ``measurement``.

    sensor : sensor name (e.g. 'head'); may be omitted when the measurement has one sensor.
    exclusion : noise-floor exclusion (railfem); ``NO_EXCLUSION`` for the plain estimate.
    bands : bands to report; default every band whose centre lies in the frequency range.
    point : 'nominal' puts the point FRF at x = 0 as EN 15461 does; 'realised' weights it
        at the distance where it was struck (``measurement.point_offset``).
    far_field_drop_db : fall of the level required at the farthest used position, dB.
    """
    if not isinstance(measurement, HammerMeasurement):
        raise ValueError(f"hammer() needs a HammerMeasurement, got {type(measurement).__name__}; "
                         "build one from the FRFs and the hammer positions.")
    if not isinstance(exclusion, NoiseFloorExclusion):
        raise ValueError("exclusion must be a NoiseFloorExclusion (or NO_EXCLUSION).")
    v.one_of("point", point, POINT_CHOICES)
    if sensor is None:
        if len(measurement.sensors) != 1:
            raise ValueError(f"the measurement has sensors {measurement.sensor_names}; say which "
                             "one with sensor=..., or use hammer_all().")
        sensor = measurement.sensors[0].name
    transfer = measurement.transfer(sensor)
    nominal = measurement.positions.copy()
    nominal[0] = 0.0
    offset = measurement.point_offset if point == "realised" else 0.0
    return en15461.decay_rate(measurement.frequency, transfer, nominal, bands=bands,
                              point_offset=offset, far_field_drop_db=far_field_drop_db,
                              **exclusion.options())


def hammer_all(measurement: HammerMeasurement, **options) -> dict[str, en15461.DecayRateResult]:
    """:func:`hammer` for every sensor of the measurement, keyed by sensor name."""
    return {s.name: hammer(measurement, s.name, **options) for s in measurement.sensors}


def as_decay_rate_measurement(result: en15461.DecayRateResult, measurement: HammerMeasurement,
                              sensor: str) -> DecayRateMeasurement:
    """The estimate as a :class:`DecayRateMeasurement` (valid = the suitable bands), with the
    measurement's direction and metadata, so estimates and measured tables compare alike."""
    s = measurement.sensor(sensor)
    return DecayRateMeasurement(frequency=np.asarray(result.frequency, dtype=float),
                                decay_rate=result.decay_rate, valid=result.suitable,
                                direction=s.direction, sensor=s.name,
                                metadata=measurement.metadata)
