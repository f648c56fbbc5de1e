"""The fastening's grip on the rail foot: a roll (rotational) restraint of the clips per
support, k_roll* = k_roll (1 + i eta_roll) on the foot's roll (SupportParameters.k_roll,
eta_roll; railfem.track.footprints.roll_reads), beyond the roll stiffness the vertical pad
springs across the foot already give.

The base model restrains the foot's roll through the vertical pad springs across its
width, on a rail seat that does not turn (SupportParameters.seat 'rigid', the default: the
pad's own roll stiffness kp* W^2 / 12, about 1.1e6 N m/rad for a 600 MN/m pad; on the seat
'per_spring' of the published chain that restraint is mass-like above the sleeper's
resonance and this effect had to stand in for the pad's roll; docs/supports.md). Clips and
the foot edge against the guide plates add a moment that resists the roll:
the lateral and torsional waves of the rail (the antisymmetric family: roll of the foot,
lateral bending of the head and web) then lose more energy per metre, so the lateral decay
rate rises, most below a few hundred Hz. A vertical load on the mirror plane excites the
symmetric family only, which the roll does not enter: vertical data cannot see this effect
(on them it is not tried).

Parameters (docs/model.md, "The fastening's grip"): the roll stiffness per support,
1e3-1e8 N m/rad (log; the elastic clips of a W14-type fastening alone about 6e3 N m/rad,
derived from the Skl 14 clamp rate of about 0.8 MN/m at |y| = 60 mm, assumed geometry;
the vertical pad springs of a 600 MN/m pad across a 150 mm foot give about 1.1e6 N m/rad,
already in the base; a value above ~1e5 N m/rad stands for the foot edge bearing on the
guide plates), start
1e5 N m/rad (assumed); its loss factor 0.01-2 (assumed, as the clips' 0.1-0.2 and the
pads' 0.1-0.3), start 0.2.

The lateral clip stiffness k_clip is not a parameter: it acts in parallel with the lateral
pad and in series with the same lateral sleeper-ballast chain, which on lateral rows the
base already calibrates (railfem.diagnosis.evaluate.lateral_spec: the lateral pad follows
the fitted vertical pad), so a lateral decay rate cannot tell it from a stiffer lateral
pad."""
from dataclasses import replace

from railfem.diagnosis.effects import Effect, EffectParameter

K_ROLL_CLIPS = 6e3  # N m/rad: the elastic clips of a W14-type fastening (docs/model.md)



def apply(spec, theta, record=None):
    return spec.replace(support=replace(spec.support, k_roll=float(theta["k_roll"]),
                                        eta_roll=float(theta["eta_roll"])))


EFFECT = Effect(
    name="roll_restraint", title="the fastening's roll restraint on the rail foot",
    kind="spec", apply=apply, needs=("lateral",), quantities=("tdr", "point", "transfer"),
    meaning="clips and guide plates resist the foot's roll beyond the vertical pad springs "
            "across it (the pad's own roll stiffness, on a seat that does not turn, is in "
            "the base): the rail's lateral and torsional waves decay faster; seen on "
            "lateral data only (by symmetry vertical data do not excite the roll)",
    parameters=(
        EffectParameter(name="k_roll", unit="N m/rad", lower=1e3, upper=1e8, log=True,
                        start=1e5,
                        meaning="roll stiffness of the fastening per support (elastic clips "
                                "of a W14-type fastening ~6e3 N m/rad; above ~1e5 the foot "
                                "bearing on the guide plates; assumed range)"),
        EffectParameter(name="eta_roll", unit="-", lower=0.01, upper=2.0, log=True,
                        start=0.2,
                        meaning="loss factor of the roll restraint (assumed range)"),
    ))
