"""Random support inhomogeneity: every support's pad and ballast stiffness scatter from
the track's mean (railfem.spec.SupportDeviation on kp and kb at each support the hammer
test sees).

Real tracks are not periodic: pads differ within their production tolerance and the
ballast bed under each sleeper is compacted differently. A hammer test sees one
realisation of that scatter, mostly at the supports between the sensor and a few metres
away: the rail-on-pad resonance is split and smeared, the near transfers change from
position to position. The effect fits the realisation at the supports INDICES (a factor
on kp and on kb each) as random effects: a Gaussian prior on ln(factor) with standard
deviation PRIOR_SD (Effect.prior) shrinks the supports the data hardly see towards the
mean, so the fit stays well posed.

The far transfers (EN 15461 goes to 66 spans) also pass supports outside that window.
Left at the mean, their scatter has nowhere to go but the window's outermost supports,
whose factors then carry it and miss their own values (found by the blind study: the
supports -2 and 8 missed their intervals in most runs). The supports beyond the window are
therefore fitted in BLOCKS (one factor on kp and kb for all supports of a block, the
block's mean stiffness, its prior SD that of a mean of n supports, PRIOR_SD/sqrt(n));
supports beyond the last block keep the mean. The scatter itself is the RMS of the fitted
single-support ln-factors (report it as the track's coefficient of variation, a lower
bound: shrinkage pulls weakly seen supports in). With 34 parameters it is the costliest
candidate and the least specific: the default search leaves it out (screened=False); name
it (effects=[..., "random_support"], ``--effects``) to screen it."""
import numpy as np

from railfem.diagnosis.effects import Effect, EffectParameter
from railfem.spec import SupportDeviation

INDICES = tuple(range(-3, 11))  # single supports; the sensor sits between 0 and 1
BLOCKS = ((-10, -4), (11, 16), (17, 24))  # (first, last) support of each block
PRIOR_SD = {"kp": 0.3, "kb": 0.5}  # ln units: pads within production tolerance, ballast


def _tag(i: int) -> str:
    return f"{'m' if i < 0 else ''}{abs(i)}"


def name(which: str, index: int) -> str:
    """Parameter name of one support's factor (e.g. kp_m2, kb_5)."""
    return f"{which}_{_tag(index)}"


def block_name(which: str, block: tuple) -> str:
    """Parameter name of a block's factor (e.g. kp_11to16, kb_m10tom4)."""
    return f"{which}_{_tag(block[0])}to{_tag(block[1])}"


def _members() -> dict:
    """{parameter name without kp_/kb_: the support indices it sets}."""
    out = {_tag(i): (i,) for i in INDICES}
    out.update({f"{_tag(a)}to{_tag(b)}": tuple(range(a, b + 1)) for a, b in BLOCKS})
    return out


MEMBERS = _members()


def apply(spec, theta, record=None):
    devs = tuple(SupportDeviation(index=i, kp=float(theta[f"kp_{t}"]),
                                  kb=float(theta[f"kb_{t}"]))
                 for t, ids in MEMBERS.items() for i in ids)
    fitted = {d.index for d in devs}
    others = tuple(d for d in spec.deviations if d.index not in fitted)
    return spec.replace(deviations=others + devs)


def deviation_of(parameter: str) -> tuple[tuple, str]:
    """(the support indices a parameter sets, 'kp' | 'kb')."""
    which, tag = parameter.split("_", 1)
    return MEMBERS[tag], which


def prior(theta):
    return np.array([np.log(theta[f"{w}_{t}"]) / (PRIOR_SD[w] / np.sqrt(len(ids)))
                     for w in ("kp", "kb") for t, ids in MEMBERS.items()])


def scatter(theta) -> dict:
    """RMS of the fitted single-support ln-factors per stiffness (the realised scatter,
    shrunk)."""
    return {w: float(np.sqrt(np.mean([np.log(theta[name(w, i)]) ** 2 for i in INDICES])))
            for w in ("kp", "kb")}


def _parameter(which: str, tag: str, ids: tuple) -> EffectParameter:
    what = "pad" if which == "kp" else "ballast"
    where = (f"support {ids[0]}" if len(ids) == 1 else
             f"supports {ids[0]} to {ids[-1]} (their mean)")
    return EffectParameter(name=f"{which}_{tag}", unit="-", lower=0.1, upper=10.0, log=True,
                           start=1.0, meaning=f"{what} stiffness of {where} over the mean")


EFFECT = Effect(
    name="random_support", title="random support inhomogeneity (pad and ballast scatter)",
    kind="spec", apply=apply, prior=prior, screened=False, deviation_of=deviation_of,
    meaning="pad and ballast stiffness differ from support to support; the hammer test "
            "sees the realisation near the sensor",
    parameters=tuple(_parameter(w, t, ids) for w in ("kp", "kb") for t, ids in MEMBERS.items()),
    needs=("discrete", "deviations"))
