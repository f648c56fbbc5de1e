"""A voided (hanging) sleeper at an unknown position: one support with its ballast
stiffness reduced by a factor (railfem.spec.SupportDeviation on kb).

A gap under a sleeper removes (most of) its ballast support: around the sensor the
rail-plus-sleeper resonance drops and the low-frequency transfers change near the void.
The support index (counted from the support at x = 0; the sensor sits at x = sensor_x) is a
grid parameter over the supports the hammer test sees best; the factor is fitted."""
from railfem.diagnosis.effects import Effect, EffectParameter
from railfem.spec import SupportDeviation

INDICES = tuple(range(-2, 9))


def apply(spec, theta, record=None):
    d = SupportDeviation(index=int(theta["index"]), kb=float(theta["kb_factor"]))
    others = tuple(x for x in spec.deviations if x.index != d.index)
    return spec.replace(deviations=others + (d,))


EFFECT = Effect(
    name="voided_sleeper", title="voided (hanging) sleeper at an unknown position",
    kind="spec", apply=apply,
    meaning="a gap under one sleeper: its ballast stiffness falls to a fraction",
    parameters=(
        EffectParameter(name="kb_factor", unit="-", lower=1e-3, upper=0.9, log=True,
                        start=0.1, meaning="ballast stiffness of the sleeper over the others'"),
        EffectParameter(name="index", unit="-", lower=-10, upper=100, log=False, start=0,
                        meaning="the support, counted from the one at x = 0"),
    ),
    grid={"index": INDICES}, needs=("discrete", "deviations"))
