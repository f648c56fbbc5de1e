"""Identification: track parameters from measured data (METHOD.md section 7).

* :func:`fit` (railfem.identify.fit) — bounded nonlinear least squares in dB on point
  mobility (magnitude, phase), transfers and decay rates, multi-start, uncertainty and
  identifiability (railfem.identify.uncertainty);
* :mod:`railfem.identify.data` — what is fitted (Target) and the residuals;
* :mod:`railfem.identify.forward` — the model at the data's geometry, cheap to re-evaluate;
* :mod:`railfem.identify.spectral` — the uniform discrete coupling as a rational function
  of the support stiffness;
* :func:`compare_models` — the same data fitted with several models.
"""
from railfem.identify.data import QUANTITIES, Target, decay_rate_target, hammer_target
from railfem.identify.fit import DEFAULT_PARAMETERS, FIT_BOUNDS, FitResult, fit

__all__ = ["QUANTITIES", "Target", "decay_rate_target", "hammer_target", "DEFAULT_PARAMETERS",
           "FIT_BOUNDS", "FitResult", "fit"]
