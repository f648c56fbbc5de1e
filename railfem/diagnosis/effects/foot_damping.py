"""Extra dissipation at the rail foot / fastening: a viscous dashpot in parallel with the
pad (railfem.track.supports.FootDashpot).

Friction and micro-slip between foot, pad and clips dissipate energy that a constant pad
loss factor does not describe: its loss grows with frequency. Parameter: the loss factor
it adds to the pad at 1 kHz (a dashpot c = kp eta_1k / (2 pi 1 kHz))."""
from dataclasses import replace

from railfem.diagnosis.effects import Effect, EffectParameter
from railfem.track.supports import FootDashpot


def apply(spec, theta, record=None):
    sup = spec.support
    return spec.replace(support=replace(
        sup, pad_laws=sup.pad_laws + (FootDashpot(eta_1k=float(theta["eta_1k"])),)))


EFFECT = Effect(
    name="foot_damping", title="extra dissipation at the rail foot / fastening",
    kind="spec", apply=apply,
    meaning="viscous dissipation between rail foot, pad and fastening, growing with frequency",
    parameters=(EffectParameter(name="eta_1k", unit="-", lower=0.005, upper=5.0, log=True,
                                start=0.1, meaning="loss factor added to the pad at 1 kHz"),))
