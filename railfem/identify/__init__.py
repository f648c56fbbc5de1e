"""Identification: track parameters from measured data (METHOD.md section 7).

* :func:`fit` (railfem.identify.fit) — bounded nonlinear least squares in dB on point
  mobility (magnitude, phase), transfers and decay rates, multi-start, uncertainty and
  identifiability (railfem.identify.uncertainty);
* :mod:`railfem.identify.data` — what is fitted (Target) and the residuals;
* :mod:`railfem.identify.forward` — the model at the data's geometry, cheap to re-evaluate;
* :mod:`railfem.identify.problem` — the least-squares problem (residuals, Jacobians, the
  box, the kernel-parameter profile) of the fit and of the diagnosis;
* :mod:`railfem.identify.spectral` — the uniform discrete coupling as a rational function
  of the support stiffness;
* :func:`compare_models` (railfem.identify.compare) — the same data fitted with several
  models, :func:`comparison_table` its text;
* :func:`fit_campaign` (railfem.identify.campaign) — the rows of a decay-rate table
  fitted on a Dask cluster;
* :mod:`railfem.identify.roughness` — combined wheel-rail roughness from pass-by
  vibration, full and simplified methods (METHOD.md section 8, docs/roughness.md).
"""
from railfem.identify.data import QUANTITIES, Target, decay_rate_target, hammer_target
from railfem.identify.fit import DEFAULT_PARAMETERS, FIT_BOUNDS, FitResult, fit
from railfem.identify.campaign import fit_campaign
from railfem.identify.compare import compare_models, comparison_table

__all__ = ["QUANTITIES", "Target", "decay_rate_target", "hammer_target", "DEFAULT_PARAMETERS",
           "FIT_BOUNDS", "FitResult", "fit", "fit_campaign", "compare_models", "comparison_table"]
