"""Frequency-dependent pad stiffness and damping: a fractional Zener (standard linear
solid) law for the rail pad (railfem.track.supports.FractionalZener).

Polymer pads stiffen with frequency: the static stiffness kp (what the base model fits as a
constant) rises to ratio * kp above the transition frequency fc, with a loss peak around
fc. The fractional order is fixed at alpha = 0.5 (a broad transition, typical of
elastomers) so the law adds two parameters."""
from dataclasses import replace

from railfem.diagnosis.effects import Effect, EffectParameter
from railfem.track.supports import FractionalZener

ALPHA = 0.5


def law(theta) -> FractionalZener:
    return FractionalZener(ratio=float(theta["ratio"]), fc=float(theta["fc"]), alpha=ALPHA)


def apply(spec, theta, record=None):
    sup = spec.support
    return spec.replace(support=replace(sup, pad_laws=sup.pad_laws + (law(theta),)))


EFFECT = Effect(
    name="pad_frequency", title="frequency-dependent pad stiffness (fractional Zener)",
    kind="spec", apply=apply,
    meaning="the rail pad stiffens with frequency and its loss peaks at the transition "
            "(viscoelastic polymer pad)",
    parameters=(
        EffectParameter(name="ratio", unit="-", lower=1.02, upper=30.0, log=True, start=2.0,
                        meaning="high- over low-frequency pad stiffness k_inf / k_0"),
        EffectParameter(name="fc", unit="Hz", lower=10.0, upper=8000.0, log=True,
                        start=300.0, meaning="transition frequency of the pad law"),
    ))
