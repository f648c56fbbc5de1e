"""Model-free estimators: the same code for measured and simulated data.

``tdr`` — track decay rate by the EN 15461 hammer method from a
:class:`railfem.measurement.HammerMeasurement`.
"""
