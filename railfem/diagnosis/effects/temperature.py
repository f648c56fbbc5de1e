"""Temperature dependence of the pad across measurements on different dates.

Polymer pads stiffen in the cold: kp(T) = kp_ref exp(-a (T - T_ref)), with T each record's
temperature (metadata) and T_ref the campaign's mean temperature (a reference, not a fitted
parameter: kp_ref and T_ref cannot both be fitted). kp of the base model is then kp_ref.
Needs records at different temperatures."""
import math

from railfem.diagnosis.effects import Effect, EffectParameter


def apply(spec, theta, record):
    T, T_ref = record.covariate("temperature_c")
    return spec.replace(kp=spec.support.kp * math.exp(-float(theta["a"]) * (T - T_ref)))


EFFECT = Effect(
    name="temperature", title="temperature-dependent pad stiffness",
    kind="campaign", apply=apply,
    meaning="the pad stiffens when cold: kp = kp_ref exp(-a (T - T_ref))",
    parameters=(EffectParameter(name="a", unit="1/K", lower=-0.1, upper=0.2, log=False,
                                start=0.02,
                                meaning="relative change of pad stiffness per kelvin"),),
    needs=("covariate:temperature_c",))
