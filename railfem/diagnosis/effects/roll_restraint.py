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

**What a lateral decay rate can tell of it.** The grip and the pad's roll act in parallel
on the foot; once their sum is a few times the pad's, the foot's roll is nearly held and
the decay rate approaches that of a foot held rigidly: it depends on the roll compliance
1 / (K_pad + k_roll), which tends to 0, and hardly on k_roll itself (on the cross-model
blind data 0.2-0.9 dB per decade of k_roll above 5e6 N m/rad; the same on data of the
estimator's own form). A fit in log k_roll then has a flat valley towards infinity: its
95 % interval spanned 1e3-6e9 N m/rad and the grip was refused as unidentifiable although
it was seen (dBIC -118, held-out error -95 %). The parameter is therefore the grip's
share of a reference roll stiffness,

    grip = k_roll / (k_roll + K_REF),   k_roll = K_REF grip / (1 - grip),

K_REF = 1e6 N m/rad (the pad's own roll stiffness for a 600 MN/m pad across a 150 mm
foot): grip = 0 is no grip (the base), grip -> 1 a foot held rigidly. The roll
compliance (1 - grip) / (K_pad (1 - grip) + K_REF grip) is smooth in grip up to 1, its
slope there -1 / K_REF, so the linearised interval of grip is a real one; where that
interval reaches 1 the data fix k_roll from below only, and the result is one-sided:
"k_roll at least X N m/rad" (``derived``: the k_roll entry, its interval open at the top).
The keep rules apply to grip as to any linear parameter (railfem.diagnosis.gates): inside
its bounds by 1 % of the range, a 95 % half-width below half the range
(railfem.identify.uncertainty); the upper bound 0.9999 (k_roll 1e10 N m/rad) is a foot
held rigidly for every rail seat of the library. The BIC and held-out gates do not change.

**The loss factor is not fitted**: eta_roll is fixed at ETA_ROLL = 0.1 (assumed: the lower
end of the clips' 0.1-0.2 assumed in docs/model.md; a grip of steel clips and polyamide
guide plates is not a rubber pad), and its uncertainty enters the intervals
(Effect.assumed: ETA_ROLL_SD = 0.3 decades, a factor 2): as a linearised unfitted term
in the screening (railfem.diagnosis.problem.EffectModel.unfitted_tangents), as the
envelope over 0.025-0.4 in the chosen model's final intervals (railfem.diagnosis.
envelope: the grip is not linear in it, 0.011-0.019 up at 0.025 and 0.06-0.09 down at
0.4 on the blind lateral data). The SD: no measured roll loss factor of a
fastening is known to us; the loss factors published for whole fastenings differ by a
factor 5 from track to track (0.05-0.25 over the five tracks of the presets' Table 1,
docs/presets.md), elastomer pads are quoted at 0.08 (natural rubber) to 0.15-0.2 (damped
polyurethane; a fastening supplier's note, chinarailfastener.com, "Damping characteristics
and noise reduction design of rail pads", 2025), and steel clips and polyamide plates are
less damped than elastomers; 0.3 decades puts 95 % of the grip's loss factor between 0.025
and 0.4, a little wider than the pads' spread, since the grip's own has not been measured.
It moves the grip by about 0.11 per decade on the blind lateral data (a stiffer grip with
less loss stands in for a softer one with more; benchmarks/results/
results_roll_restraint.md), so the term matters. Free, it was not identifiable (it
drifted to a bound of 0.01-2 on blind and SBB data alike): the loss of a grip that
nearly holds the foot dissipates little, as the foot hardly moves against it. It is not
tied to the fitted pad's loss factor: on the SBB lateral rows the base's eta_p (0.6-2)
takes up damping the single-layer support lacks, and a grip with that loss fitted worse
than one near 0.01 (B3 2012-09-12: dBIC +0.2 against -11.5 with eta_roll free).

The lateral clip stiffness k_clip is not a parameter: it acts in parallel with the lateral
pad and in series with the same lateral sleeper-ballast chain, which on lateral rows the
base already calibrates (railfem.diagnosis.evaluate.lateral_spec: the lateral pad follows
the fitted vertical pad), so a lateral decay rate cannot tell it from a stiffer lateral
pad.

Values (docs/model.md, "The fastening's grip"): the elastic clips of a W14-type fastening
alone about 6e3 N m/rad (grip 0.006; derived from the Skl 14 clamp rate of about 0.8 MN/m
at |y| = 60 mm, assumed geometry); a grip above ~0.1 (k_roll above ~1e5 N m/rad) stands
for the foot edge bearing on the guide plates."""
import math
from dataclasses import replace

from railfem.diagnosis.effects import AssumedValue, Effect, EffectParameter

K_ROLL_CLIPS = 6e3  # N m/rad: the elastic clips of a W14-type fastening (docs/model.md)
K_REF = 1e6  # N m/rad: the reference roll stiffness of the grip's share (module docstring)
GRIP_MAX = 0.9999  # grip's upper bound: k_roll = 1e10 N m/rad, a foot held rigidly
ETA_ROLL = 0.1  # the grip's loss factor (assumed; module docstring)
#: decades: the SD of the assumed loss factor's log10 (pad loss factors 0.05-0.25 over
#: five tracks, docs/presets.md, the original study's Table 1; elastomer pads 0.08-0.2, a
#: supplier's note; no measured roll loss factor; module docstring)
ETA_ROLL_SD = 0.3


def k_roll(grip: float) -> float:
    """The roll stiffness (N m/rad) of a grip share (inf at 1 and above: held rigidly)."""
    return math.inf if grip >= 1.0 else K_REF * max(grip, 0.0) / (1.0 - grip)


def grip(k: float) -> float:
    """The grip share of a roll stiffness k (N m/rad): k / (k + K_REF)."""
    return 1.0 if math.isinf(k) else k / (k + K_REF)


def apply(spec, theta, record=None):
    return spec.replace(support=replace(spec.support, k_roll=k_roll(float(theta["grip"])),
                                        eta_roll=float(theta.get("eta_roll", ETA_ROLL))))


def derived(params: list[dict]) -> list[dict]:
    """The roll stiffness k_roll (N m/rad) of the fitted grip share, as a parameter entry:
    value and 95 % intervals mapped through ``k_roll``; an interval of grip that reaches 1
    is open at the top (inf): "at least X N m/rad" when it excludes no grip (0)."""
    out = []
    for p in params:
        if p["name"] != f"{EFFECT.name}.grip":
            continue
        lo, hi = p["ci95"]
        one_sided = hi >= 1.0 and lo > 0.0
        why = ("from the grip's 95 % interval" if hi < 1.0 else
               f"at least {k_roll(lo):.3g} N m/rad: the grip's 95 % interval reaches a "
               "foot held rigidly, open on the high side" if one_sided else
               "not fixed: the grip's 95 % interval spans no grip to a foot held rigidly")
        q = {"name": f"{EFFECT.name}.k_roll", "group": "derived", "unit": "N m/rad",
             "value": k_roll(p["value"]), "ci95": [k_roll(lo), k_roll(hi)],
             "identifiable": p.get("identifiable"), "one_sided": one_sided, "reason": why}
        if p.get("ci95_joint"):
            q["ci95_joint"] = [k_roll(v) for v in p["ci95_joint"]]
        out.append(q)
    return out


EFFECT = Effect(
    name="roll_restraint", title="the fastening's roll restraint on the rail foot",
    kind="spec", apply=apply, needs=("lateral",), quantities=("tdr", "point", "transfer"),
    derived=derived,
    assumed=(AssumedValue(name="eta_roll", unit="-", value=ETA_ROLL, sd=ETA_ROLL_SD,
                          source="assumed, the lower end of the clips' 0.1-0.2; its SD from "
                                 "the pad loss factors of published fastenings "
                                 "(0.05-0.25) and elastomer pads (0.08-0.2)"),),
    meaning="clips and guide plates resist the foot's roll beyond the vertical pad springs "
            "across it (the pad's own roll stiffness, on a seat that does not turn, is in "
            "the base): the rail's lateral and torsional waves decay faster; seen on "
            "lateral data only (by symmetry vertical data do not excite the roll)",
    parameters=(
        EffectParameter(name="grip", unit="-", lower=0.0, upper=GRIP_MAX, log=False,
                        start=0.5,
                        meaning="the grip's share k_roll / (k_roll + 1e6 N m/rad) of the "
                                "foot's roll restraint per support (0: no grip; 1: the "
                                "foot held; elastic clips of a W14-type fastening ~0.006, "
                                "above ~0.1 the foot bearing on the guide plates); its "
                                "loss factor 0.1 (assumed, SD 0.3 decades in the "
                                "intervals)"),
    ))
