"""The base model of a calibration: one definition for ``railfem fit`` and ``railfem
diagnose`` (railfem.identify.fit, railfem.diagnosis.loop), so both start from the same
track and report the same words for it.

    from railfem.identify.base import default_base, describe_base
    spec = default_base("wfe-discrete", spacing=0.6)   # the site preset, point supports
    describe_base(spec, BASE_PARAMETERS)
    # 'wfe-discrete, point supports, site preset, spacing 0.6 m, 131 supports; fitted: ...'

The base is the site preset (Table 1) on **point supports** (pad_length = 0, one spring
row), the model's own defaults otherwise; the fitted parameters are BASE_PARAMETERS (pad
and ballast stiffness and loss factors, the rail loss factor) inside
railfem.identify.fit.FIT_BOUNDS.

Why point supports and not the 0.15 m pad in 3 rows of ``preset('site')``: the footprint
is part of the calibration, and only one of the two defaults lets the data say so. Point
supports are the end (pad_length = 0) of the pad-length family, so a finite pad is one
more parameter tested against them: the diagnosis's pad_length effect (a profiled grid)
must win on held-out data to be kept, and ``fit --parameters ...,pad_length`` profiles it.
A 0.15 m pad as the default asserts a footprint the data were never asked about, and the
data cannot tell it apart from a stiffer or softer pad with another rail loss: on clean
data of point supports the pad default put kp 29 % and the rail loss factor 69 % low with
95 % intervals excluding the truth, both reported identifiable, whereas a real pad missed
by a point base shows up as a pad-length candidate (or as model-form discrepancy) instead
of being folded silently into kp and eta_r. Point supports are also the published
configuration the independent implementations use. The point load's mesh dependence of the
rail-on-pad resonance is a discretisation choice, accounted for as model-form discrepancy,
not hidden behind a fixed footprint.

**The rail loss factor's prior range** (ETA_R_RANGE, entered by eta_r_prior as a prior
entry of every diagnosis problem): a supported rail without added damping has a loss
factor between 0.005 and 0.05. Sources:

* Thompson, D. J. (2009), *Railway Noise and Vibration: Mechanisms, Modelling and Means
  of Control*, Elsevier: the material damping of rail steel alone is of order 1e-4; the
  track models use a rail loss factor of order 0.01-0.02 for a rail on its supports, the
  rest of the damping coming from the fastenings (clips, pad contact).
* Vincent, N., Bouvet, P., Thompson, D. J., Gautier, P. E. (1996), Theoretical
  optimization of track components to reduce rolling noise, J. Sound Vib. 193(1),
  161-171, and Thompson, D. J., Jones, C. J. C., Waters, T. P., Farrington, D. (2007), A
  tuned damping device for reducing noise from railway track, Applied Acoustics 68(1),
  43-57: added rail damping (tuned absorbers) raises the decay rates several-fold above a
  few hundred Hz; a base without a damper effect would report it as a rail loss factor
  several times the untreated rail's.
* Wu, T. X., Thompson, D. J. (1999), A double Timoshenko beam model for vertical
  vibration analysis of railway track at high frequencies, J. Sound Vib. 224(2), 329-348:
  a rail loss factor of the same order (0.01-0.02) in a fitted track model.
* The Table 1 tracks of railfem (railfem.track.supports.TABLE1): 0.01-0.05.

Inside the range the data alone decide (the prior entry is 0); outside it the entry
grows by one per ETA_R_PRIOR_WIDTH decades (0.001: a step of the rail-loss profile's
lattice, 0.05 decades, beyond the range costs 2500, what a strong damper's misfit gains;
with 0.02 decades a base on data of heavy lossy dampers still went to 0.079): a bound
with smooth edges. Extra damping must be credited to an effect (rail_damper,
foot_damping) instead of being folded into eta_r.
"""
from __future__ import annotations

import math

import numpy as np

from railfem.params import BASE_PARAMETERS
from railfem.spec import TrackSpec, model_kind, preset

BASE_MODEL = "wfe-discrete"
BASE_PRESET = "site"
BASE_PAD_LENGTH = 0.0  # m: point supports (see the module docstring)
#: plausible rail loss factor of a supported rail without added damping (module docstring)
ETA_R_RANGE = (0.005, 0.05)
ETA_R_PRIOR_WIDTH = 0.001  # decades outside ETA_R_RANGE per unit of the prior entry


def eta_r_prior(eta_r: float, bounds=ETA_R_RANGE,
                width: float = ETA_R_PRIOR_WIDTH) -> np.ndarray:
    """The prior entry of the rail loss factor ``eta_r`` (dimensionless, one residual entry
    of the fit): 0 inside ``bounds`` (the data decide alone), else the distance to the
    range in decades over ``width`` (a flat-bottomed prior with steep Gaussian tails). One
    entry always, so that fits at different rail loss factors have residuals of one
    length."""
    lo, hi = (math.log10(b) for b in bounds)
    le = math.log10(float(eta_r))
    d = lo - le if le < lo else (le - hi if le > hi else 0.0)
    return np.array([d / width])


def default_base(model: str = BASE_MODEL, *, preset_name: str = BASE_PRESET,
                 pad_length: float | None = None, spacing: float | None = None) -> TrackSpec:
    """The base spec of a calibration: preset ``preset_name`` with ``model``, supports of
    ``pad_length`` m (default BASE_PAD_LENGTH: point supports; a pad is one spring row
    spread over its length, as the diagnosis's pad_length effect makes it) and the data's
    sleeper ``spacing`` when given. A continuous model has no footprint (pad_length must
    then be 0 or None)."""
    pad = BASE_PAD_LENGTH if pad_length is None else float(pad_length)
    if model_kind(model).is_continuous:
        if pad > 0:
            raise ValueError(f"pad_length = {pad:g} m with model {model!r}: a continuous "
                             "support is already spread along the rail; use 0")
        spec = preset(preset_name, model=model)
    else:
        spec = preset(preset_name, model=model, pad_length=pad)
    if spacing is not None and abs(float(spacing) - spec.spacing) > 1e-12:
        spec = spec.replace(spacing=float(spacing))
    return spec


def footprint(spec: TrackSpec) -> str:
    """The support footprint in words: 'point supports', 'pads of 0.15 m in 3 rows', ..."""
    if spec.kind.is_continuous:
        return "continuous support"
    if spec.pad_length == 0:
        return "point supports"
    rows = "one row spread over it" if spec.n_rows == 1 else f"{spec.n_rows} rows"
    return f"pads of {spec.pad_length:g} m ({rows})"


def describe_base(spec: TrackSpec, parameters=BASE_PARAMETERS) -> str:
    """One line for a report: model, footprint, preset, spacing, supports, what is fitted."""
    parts = [spec.model, footprint(spec), f"{spec.name} preset",
             f"spacing {spec.spacing:g} m"]
    if spec.kind.is_discrete:
        parts.append(f"{spec.n_supports} supports")
    return ", ".join(parts) + f"; fitted: {', '.join(parameters)}"
