"""A flexible sleeper instead of the rigid sleeper mass: the monobloc sleeper as a
free-free Timoshenko beam on the ballast (railfem.track.sleeper), loaded in phase by the
two rails (one rail modelled, TrackSpec.rails = 1).

The base model puts each rail on a rigid mass ms on the ballast. A concrete sleeper bends:
its free-free bending modes (about 100-200 Hz for the first one on measured monobloc
sleepers, 113 Hz for the default B90/B91-type sleeper of railfem.track.sleeper) make the
rail seat soft near the symmetric modes and stiff between them, so the support stiffness,
the decay rate and the transfers change between about 80 Hz and 1 kHz.

The effect's sleeper has the base model's mass (2 ms for the two rail seats, so a very
stiff sleeper is the base model) and the B90 shape (length 2.6 m, rail seats 1.5 m apart,
the equivalent rectangular section); its bending and shear stiffness are scaled together
so that its first free-free bending frequency is ``f1`` (the free frequencies then scale
exactly with the square root of the stiffness). Both parameters start at the literature
defaults of railfem.track.sleeper (f1 = 113 Hz of the B90/B91-type sleeper, eta = 0.02).
f1 is bounded to a wide range around its default (40-800 Hz: measured monobloc concrete
sleepers have their first mode at ~100-200 Hz); the fit starts f1 from values 10 % apart
over its bounds (F1_SCAN: a mode's misfit basin is narrow).

The loss factor eta_s is the sleeper's own bending damping, bounded to what a concrete
sleeper can have (ETA_S_RANGE, 0.005-0.1): free-free modal tests of prestressed concrete
monobloc sleepers find modal damping of the order of 1 % of critical (loss factor ~0.02;
Remennikov & Kaewunruen, ASEC 2005; Kaewunruen & Remennikov, "Dynamic properties of
railway track and its components: a state-of-the-art review", 2008), and the track models
with flexible sleepers (Grassie & Cox, Proc. IMechE 198D, 1984; Knothe & Grassie, Vehicle
System Dynamics 22, 1993; Thompson, Railway Noise and Vibration, 2009, ch. 3) give the
sleeper a loss factor of that order. The much larger damping a sleeper shows in the
track is the ballast's, which the base already has (eta_b). The bound leaves 5 times the
literature value for a cracked sleeper or its contact with the pad; an open bound (0.5)
let a heavily damped sleeper (eta_s ~0.3, every mode smeared out) stand in for added rail
damping on data from another model (a rail damper's band). No Gaussian prior: in this
library a prior marks a random effect, whose screening leaves the rail loss factor
unprofiled (a sleeper's damping trades against the rail's)."""
from __future__ import annotations

from dataclasses import replace
from functools import lru_cache

import numpy as np

from railfem.diagnosis.effects import Effect, EffectParameter
from railfem.track.sleeper import B90, Sleeper

#: the default sleeper's first free-free bending frequency (Hz) and loss factor (-)
F1_LITERATURE = float(B90.free_frequencies(1)[0])
ETA_LITERATURE = B90.eta
#: bounds of the sleeper's own loss factor (-): a concrete sleeper's bending damping, not
#: the ballast's (see the module docstring for the sources)
ETA_S_RANGE = (0.005, 0.1)
#: start values of f1 (Hz) for the refit's multi-start: 10 % apart over its bounds. A
#: sleeper mode of loss factor ~0.03 is a sharp feature of every transfer: the misfit has a
#: basin only about +-10 % wide around the true f1 and is flat or rising between such
#: basins, so three starts across the range (73, 113, 440 Hz) all missed a first mode at
#: 160 Hz on data from another model and the fit ended worse than the rigid sleeper
F1_SCAN = tuple(float(v) for v in np.geomspace(40.0, 800.0, 33))


@lru_cache(maxsize=256)
def sleeper_of(ms: float, f1: float, eta: float) -> Sleeper:
    """The B90-shaped sleeper of mass 2 ms (kg, ms per rail seat) whose first free-free
    bending frequency is f1 (Hz), with loss factor eta (-)."""
    mass = B90.scaled(2 * ms / B90.mass)  # stiffness and mass scaled: same frequencies
    k = (f1 / F1_LITERATURE) ** 2
    return replace(mass, EI=mass.EI * k, kGA=mass.kGA * k, eta=eta)


def equivalent_ei(ms: float, f1: float) -> float:
    """The bending stiffness EI (N m^2) of sleeper_of(ms, f1, .)."""
    return sleeper_of(float(ms), float(f1), ETA_LITERATURE).EI


def flexible(spec, theta):
    """``spec`` with its support on the flexible sleeper of theta['f1'], theta['eta_s']."""
    sl = sleeper_of(float(spec.support.ms), float(theta["f1"]), float(theta["eta_s"]))
    return spec.replace(support=replace(spec.support, sleeper=sl))


def apply(spec, theta, record=None):
    return flexible(spec, theta)


PARAMETERS = (
    EffectParameter(name="f1", unit="Hz", lower=40.0, upper=800.0, log=True,
                    start=F1_LITERATURE, scan=F1_SCAN,
                    meaning="first free-free bending frequency of the sleeper (its bending "
                            "stiffness; B90/B91 literature value 113 Hz, measured monobloc "
                            "sleepers ~100-200 Hz)"),
    EffectParameter(name="eta_s", unit="-", lower=ETA_S_RANGE[0], upper=ETA_S_RANGE[1],
                    log=True, start=ETA_LITERATURE,
                    meaning="loss factor of the sleeper's own bending (concrete sleepers: "
                            "~0.02, about 1 % of critical damping; the ballast's damping "
                            "is the base's eta_b)"),
)

EFFECT = Effect(
    name="sleeper_flexibility", title="flexible sleeper (Timoshenko beam, rails in phase)",
    kind="spec", apply=apply,
    meaning="the sleeper bends: its free-free bending modes (first at f1) make the rail "
            "seat soft or stiff between ~80 Hz and 1 kHz instead of a rigid mass on the "
            "ballast; the sleeper keeps the base model's mass (2 ms), length 2.6 m and rail "
            "seats 1.5 m apart; starts at the B90/B91 literature values",
    parameters=PARAMETERS)
