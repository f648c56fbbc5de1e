"""Model-free estimators: the same code for measured and simulated data.

``tdr`` — track decay rate by the EN 15461 hammer method from a
:class:`railfem.measurement.HammerMeasurement`.

``passby`` — track decay rate from pass-by recordings (energy iteration, slope fitting),
with ``bands`` (IEC 61260-1 band energy), ``wheels`` (wheel instants, speed),
``passby_energy`` (the energy-iteration equation); recordings are
:class:`railfem.recording.Recording` (one sensor each, ``Recording.select``).
"""
