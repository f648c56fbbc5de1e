"""Closing the loop with measured data (METHOD.md section 9): the residual of a calibrated
model, a library of physical effects the model lacks, and the search that adds the
best-supported one and reports the error before and after.

* :mod:`railfem.diagnosis.residual` — the residual as an object; noise or structure;
* :mod:`railfem.diagnosis.effects` — the effect library (one module per effect);
* :mod:`railfem.diagnosis.data` — records, fitted and held-out parts;
* :mod:`railfem.diagnosis.evaluate` — the model at a record's geometry, cheaply;
* :mod:`railfem.diagnosis.problem` — the effect model of the least-squares problem
  (railfem.identify.problem);
* :mod:`railfem.diagnosis.refit` — least squares with effects, scores, intervals;
* :mod:`railfem.diagnosis.loop` — :func:`diagnose`.
"""
from railfem.diagnosis.data import DiagnosisData, prepare
from railfem.diagnosis.loop import Diagnosis, diagnose

__all__ = ["DiagnosisData", "Diagnosis", "diagnose", "prepare"]
