"""Added rail damping: rail dampers, tuned mass-spring-dampers on the rail in every span
(railfem.track.supports.RailAbsorber), one or several tuned over a band.

Real rail dampers are steel masses in an elastomer clipped to the rail web and foot; one
tuned resonator damps around its frequency, several masses tuned apart spread the added
loss over a band (typically a few hundred Hz to 2 kHz), and a lossy elastomer (eta_a of
0.3 and more) makes that a smooth, frequency-dependent added loss. The effect describes
both: ``count`` (AbsorberBand.count, 3) absorbers of mass/count each at fa/s, fa, fa s,
s = ``spread`` (a grid: 1 is the single tuned absorber; 1.5, 2.25: bands of a ratio s^2
between the lowest and the highest tuning) with one loss factor. It competes with the base
rail loss factor, whose prior range (railfem.identify.base.ETA_R_RANGE) keeps the extra
damping from being folded into it.

Modelled at each support's footprint (in parallel with the support), not at mid-span:
below ~2 kHz the bending wavelength is long against the 0.3 m between the two places; this
simplification is stated in every report.

A rail damper is heavy: its mass starts at MASS_MIN (product data, below). A lighter
"damper" is a small correction of the model's dynamics that any discretisation difference
can mimic (on clean data of another WFE implementation the effect once fitted 0.4 kg per
support at 258 Hz and improved the held-out error by 16 %); it ends at the bound and is not
kept."""
from dataclasses import dataclass, replace

import numpy as np

from railfem.diagnosis.effects import Effect, EffectParameter
from railfem.track.supports import RailAbsorber

SPREADS = (1.0, 1.5, 2.25)  # ratio between neighbouring tunings (1: one tuned absorber)
COUNT = 3
#: the lowest loss factor of a rail damper's elastic layer: dampers are built with a
#: high-loss elastomer so that each mass damps a broad band (Thompson, Jones, Waters and
#: Farrington, Applied Acoustics 68, 2007: "multiple tuning frequencies are used along with
#: a material with a high damping loss factor"). An absorber of loss factor eta acts over
#: about eta fa around its tuning; below 0.1 that is a lightly damped resonance of the
#: track itself (a flexible sleeper's bending mode seen through the pad is such a tuned
#: mass: on data from another model with a 160 Hz sleeper the effect fitted one absorber at
#: 914 Hz with eta_a 0.05-0.07), not a rail damper
ETA_A_MIN = 0.1
#: the least tuned mass of rail dampers per support (one rail, one sleeper bay), kg. Real
#: dampers carry kilograms of steel: on the Middle Rhine line DB fitted 330 000 rail web
#: dampers, one per sleeper bay and rail, on 110 km of track with 5 500 t of material,
#: about 17 kg a damper (eb - Elektrische Bahnen, "Laermsanierung des Mittelrheintals",
#: 2020, eb-info.eu); the Corus/Tata SilentTrack damper is two steel masses in elastomer
#: on each side of the web in every bay (Thompson, Jones, Waters and Farrington, Applied
#: Acoustics 68, 2007), and a large absorber mass is what raises the rail's decay rate
#: (Wu, "On the railway track dynamics with rail vibration absorber for noise reduction",
#: J. Sound Vib. 309, 2008). 2 kg is an eighth of that damper: room for one damper every
#: second bay (so fitted on a Zurich test section: jabez.hk, project Zurich) and for the
#: clips and elastomer, which do not oscillate. Against the rail (60 kg/m, 36 kg a bay)
#: 2 kg is a mass ratio of 6 %; 0.4 kg (1 %) adds too little loss to be what dampers are
#: fitted for, and is the size of change another discretisation of the same track makes
MASS_MIN = 2.0


@dataclass(frozen=True, kw_only=True)
class AbsorberBand(RailAbsorber):
    """``count`` tuned absorbers of mass/count each (kg), tuned at fa s^k (Hz), k from
    -(count-1)/2 to (count-1)/2, s = ``spread`` >= 1 (1: one tuned absorber of the whole
    mass), one loss factor eta; in parallel with the support as a RailAbsorber."""

    spread: float = 1.0
    count: int = COUNT

    def __post_init__(self):
        super().__post_init__()
        if not (np.isfinite(self.spread) and self.spread >= 1.0):
            raise ValueError(f"AbsorberBand.spread = {self.spread!r}: give a ratio >= 1")
        if int(self.count) != self.count or self.count < 1:
            raise ValueError(f"AbsorberBand.count = {self.count!r}: give an integer >= 1")

    @property
    def tunings(self) -> np.ndarray:
        """The absorbers' tuning frequencies (Hz)."""
        k = np.arange(self.count) - (self.count - 1) / 2
        return self.fa * self.spread ** k

    def band(self) -> tuple[float, float]:
        """(low, high) Hz where the added damping acts: the lowest and highest tuning, each
        widened by its half-power width (fa (1 -+ eta/2))."""
        f = self.tunings
        return float(f[0] * (1 - self.eta / 2)), float(f[-1] * (1 + self.eta / 2))

    def stiffness(self, omega: np.ndarray) -> np.ndarray:
        if self.spread == 1.0:
            return RailAbsorber(mass=self.mass, fa=self.fa, eta=self.eta).stiffness(omega)
        m = self.mass / self.count
        return sum(RailAbsorber(mass=m, fa=float(fk), eta=self.eta).stiffness(omega)
                   for fk in self.tunings)


def absorber(theta) -> AbsorberBand:
    """The AbsorberBand of a parameter set {mass, fa, eta_a, spread}."""
    return AbsorberBand(mass=float(theta["mass"]), fa=float(theta["fa"]),
                        eta=float(theta["eta_a"]), spread=float(theta.get("spread", 1.0)))


def band(theta) -> tuple[float, float]:
    """(low, high) Hz of the added damping of a parameter set (AbsorberBand.band)."""
    return absorber(theta).band()


def apply(spec, theta, record=None):
    return spec.replace(support=replace(spec.support, absorber=absorber(theta)))


EFFECT = Effect(
    name="rail_damper",
    title="added rail damping (rail dampers: tuned absorbers per span, one or a band)",
    kind="spec", apply=apply,
    meaning="rail dampers add damping to the rail over a band: one tuned resonator or "
            f"{COUNT} tuned apart (mass/{COUNT} each at fa/s, fa, fa s) per span, one loss "
            "factor; the decay rate rises over that band, the transfers far away drop "
            "(modelled at the support positions)",
    parameters=(
        EffectParameter(name="mass", unit="kg", lower=MASS_MIN, upper=40.0, log=True,
                        start=3.0, meaning="absorber mass per support (all the absorbers of "
                                           f"a span; a real damper's: >= {MASS_MIN:g} kg)"),
        EffectParameter(name="fa", unit="Hz", lower=100.0, upper=4000.0, log=True,
                        start=800.0, meaning="centre tuning frequency (geometric mean of "
                                             "the tunings)"),
        EffectParameter(name="eta_a", unit="-", lower=ETA_A_MIN, upper=2.0, log=True,
                        start=0.3, meaning="loss factor of the absorbers' elastic layer "
                                           f"(a damper's elastomer: >= {ETA_A_MIN:g})"),
    ),
    grid={"spread": SPREADS})
