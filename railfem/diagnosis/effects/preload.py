"""Load-dependent (pre-loaded) pad and ballast stiffness across measurements under
different static loads.

Pads and ballast are stiffer under load: k(P) = k_ref ((1 + P / P_s) / (1 + P_ref / P_s))^n,
with P each record's static load per fastener (metadata notes 'static_load_kn', kN),
P_ref the campaign mean and P_s = 20 kN (the clip toe load, stated here, not fitted).
Exponents for the pad (n_p) and the ballast (n_b). Needs records at different loads (e.g.
an unloaded hammer test and one under a parked vehicle)."""
from railfem.diagnosis.effects import Effect, EffectParameter

P_S = 20.0  # kN: clip toe load, the scale of the load dependence


def factor(P, P_ref, n):
    return ((1 + P / P_S) / (1 + P_ref / P_S)) ** n


def apply(spec, theta, record):
    P, P_ref = record.covariate("static_load_kn")
    return spec.replace(kp=spec.support.kp * factor(P, P_ref, float(theta["n_p"])),
                        kb=spec.support.kb * factor(P, P_ref, float(theta["n_b"])))


EFFECT = Effect(
    name="preload", title="load-dependent pad and ballast stiffness",
    kind="campaign", apply=apply,
    meaning="pad and ballast stiffen under static load (records at different loads)",
    parameters=(
        EffectParameter(name="n_p", unit="-", lower=-0.5, upper=3.0, log=False, start=0.5,
                        meaning="exponent of the pad stiffness in (1 + P / 20 kN)"),
        EffectParameter(name="n_b", unit="-", lower=-0.5, upper=3.0, log=False, start=0.5,
                        meaning="exponent of the ballast stiffness in (1 + P / 20 kN)"),
    ),
    needs=("covariate:static_load_kn",))
