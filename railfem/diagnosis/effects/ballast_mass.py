"""A participating ballast mass under each sleeper: the two-layer support (ballast spring,
ballast mass mb, subgrade spring kf* = kf (1 + i eta_f); SupportParameters.mb, kf, eta_f).

The base model's ballast is a massless spring kb* under the sleeper mass. Ballast moving
with the sleeper adds a second support resonance (the ballast mass on the subgrade, below
~150 Hz for a few hundred kg) and lowers the static stiffness (kb and kf in series): the
low-frequency point mobility and the decay rate below ~300 Hz change. The base model's kb
becomes the ballast layer alone. The parameters start at the assumed values of
railfem.track.sleeper.TWO_LAYER_ASSUMED (mb 400 kg, kf 80 MN/m, eta_f 0.5); no Gaussian
prior (in this library a prior marks a random effect)."""
from dataclasses import replace

from railfem.diagnosis.effects import Effect, EffectParameter
from railfem.track.sleeper import TWO_LAYER_ASSUMED



def apply(spec, theta, record=None):
    return spec.replace(support=replace(spec.support, mb=float(theta["mb"]),
                                        kf=float(theta["kf"]), eta_f=float(theta["eta_f"])))


EFFECT = Effect(
    name="ballast_mass", title="participating ballast mass on the subgrade (two-layer support)",
    kind="spec", apply=apply,
    meaning="ballast under the sleeper moves with it: a ballast mass between the ballast "
            "spring and a damped subgrade spring adds a second support resonance and "
            "softens the support statically; starts at the assumed values (mb 400 kg, "
            "kf 80 MN/m, eta_f 0.5)",
    parameters=(
        EffectParameter(name="mb", unit="kg", lower=20.0, upper=3000.0, log=True,
                        start=TWO_LAYER_ASSUMED["mb"],
                        meaning="participating ballast mass per rail seat"),
        EffectParameter(name="kf", unit="N/m", lower=5e6, upper=2e9, log=True,
                        start=TWO_LAYER_ASSUMED["kf"],
                        meaning="subgrade stiffness per rail seat"),
        EffectParameter(name="eta_f", unit="-", lower=0.02, upper=3.0, log=True,
                        start=TWO_LAYER_ASSUMED["eta_f"],
                        meaning="loss factor of the subgrade"),
    ))
