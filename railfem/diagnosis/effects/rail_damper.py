"""Attachments on the rail: a tuned rail damper, a mass-spring-damper per support
(railfem.track.supports.RailAbsorber).

Rail dampers add a tuned resonator to each span; around its tuning frequency the decay
rate rises and the transfers far away drop. Modelled at each support's footprint (in
parallel with the support), not at mid-span: below ~2 kHz the bending wavelength is long
against the 0.3 m between the two places; this simplification is stated in every report."""
from dataclasses import replace

from railfem.diagnosis.effects import Effect, EffectParameter
from railfem.track.supports import RailAbsorber


def apply(spec, theta, record=None):
    a = RailAbsorber(mass=float(theta["mass"]), fa=float(theta["fa"]),
                     eta=float(theta["eta_a"]))
    return spec.replace(support=replace(spec.support, absorber=a))


EFFECT = Effect(
    name="rail_damper", title="tuned rail damper (mass-spring-damper per support)",
    kind="spec", apply=apply,
    meaning="a resonator attached to the rail in every span absorbs vibration around its "
            "tuning frequency (modelled at the support positions)",
    parameters=(
        EffectParameter(name="mass", unit="kg", lower=0.2, upper=40.0, log=True, start=3.0,
                        meaning="absorber mass per support"),
        EffectParameter(name="fa", unit="Hz", lower=100.0, upper=4000.0, log=True,
                        start=800.0, meaning="tuning frequency"),
        EffectParameter(name="eta_a", unit="-", lower=0.03, upper=2.0, log=True, start=0.3,
                        meaning="loss factor of the absorber's elastic layer"),
    ))
