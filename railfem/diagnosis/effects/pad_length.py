"""Finite rail-pad length: each support spreads its force over the pad along the rail.

The base model puts each support on the rail at a point. A real pad (about 0.1-0.2 m of
rail foot) spreads it: the supports become softer towards the rail's short bending waves
and the pinned-pinned resonance (about 1 kHz at 0.6 m spacing) weakens. Enters the spec as
TrackSpec.pad_length (one spring row per support spread over the pad, railfem.track.wfe); a
kernel parameter, so it is profiled over a small grid (a new kernel per value)."""
from railfem.diagnosis.effects import Effect, EffectParameter


def apply(spec, theta, record=None):
    return spec.replace(pad_length=float(theta["pad_length"]))


EFFECT = Effect(
    name="pad_length", title="finite rail-pad length", kind="spec", apply=apply,
    meaning="the support force is spread over the pad length along the rail, not at a point",
    parameters=(EffectParameter(name="pad_length", unit="m", lower=0.02, upper=0.4, log=False,
                                start=0.15, meaning="length of rail over which a support acts"),),
    grid={"pad_length": (0.06, 0.12, 0.18, 0.24, 0.32)}, needs=("discrete",))
