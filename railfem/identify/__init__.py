"""Identification: model-based inversions of measured data.

* :mod:`railfem.identify.roughness` — combined wheel-rail roughness from pass-by
  vibration, full and simplified methods (METHOD.md section 8, docs/roughness.md).
"""
