"""Finite rail-pad length: each support spreads its force over the pad along the rail.

The base model puts each support on the rail at a point. A real pad (about 0.1-0.2 m of
rail foot) spreads it: the supports become softer towards the rail's short bending waves
and the pinned-pinned resonance (about 1 kHz at 0.6 m spacing) weakens. Enters the spec as
TrackSpec.pad_length in ROWS spring rows per support (railfem.track.wfe: each row spread
over its slice of the pad); a kernel parameter, so it is profiled over a small grid (a new
kernel per value).

Why two rows and not one: a single row spread over the whole pad ties the pad to the
rail's mean displacement over it, a footprint of another form than a pad that acts along
its length. On WFE hammer data of a 0.16 m pad in 4 rows from another discretisation
(benchmarks/blind, form 'cross') the one-row pad at the right length cut the held-out
error by 21 % (cost 2602; kp 3 % and eta_p 12 % off the truth), two rows by 78 % (cost
920), three by 82 % (cost 854); the kernel of a WFE pad costs about the square of the row
count (5, 18 and 49 s per value on one loaded core), so two rows are the compromise."""
from railfem.diagnosis.effects import Effect, EffectParameter

#: spring rows per support of the pad (each spread over its half of the pad length)
ROWS = 2


def apply(spec, theta, record=None):
    return spec.replace(pad_length=float(theta["pad_length"]), n_rows=ROWS)


EFFECT = Effect(
    name="pad_length", title="finite rail-pad length", kind="spec", apply=apply,
    meaning="the support force is spread over the pad length along the rail, not at a point",
    parameters=(EffectParameter(name="pad_length", unit="m", lower=0.02, upper=0.4, log=False,
                                start=0.15, meaning="length of rail over which a support acts"),),
    grid={"pad_length": (0.06, 0.12, 0.18, 0.24, 0.32)}, needs=("discrete",))
