"""Both rails on flexible sleepers: the hammer rail's response is the mean of the in-phase
and the anti-phase track (TrackSpec.rails = 2, railfem.models.two_rail_receptance).

The base model (one rail, its supports loaded as if both rails moved in phase) misses the
anti-phase track: a hammer on one rail excites both load cases, (Y_s + Y_a) / 2. On a rigid
sleeper the two are nearly equal (rocking at the bounce frequency); on a flexible one the
anti-phase track sees the sleeper's antisymmetric bending modes (301 Hz for the default
B90/B91-type sleeper) and the in-phase track its symmetric ones (113, 565 Hz), so the
hammer rail's response changes around all of them. The sleeper is the one of
sleeper_flexibility (the base model's mass 2 ms, the B90 shape, first free-free bending
frequency f1, loss factor eta_s, starting at the literature values; eta_s bounded to a
concrete sleeper's own damping, sleeper_flexibility.ETA_S_RANGE). Vertical tracks only
(the two-rail track is vertical)."""
from railfem.diagnosis.effects import Effect
from railfem.diagnosis.effects.sleeper_flexibility import PARAMETERS, flexible


def apply(spec, theta, record=None):
    return flexible(spec, theta).replace(rails=2)


EFFECT = Effect(
    name="two_rail", title="both rails on flexible sleepers (in- and anti-phase track)",
    kind="spec", apply=apply,
    meaning="the hammer excites both rails through the flexible sleepers: the response is "
            "the mean of the in-phase and the anti-phase track, the latter with the "
            "sleeper's antisymmetric bending modes; sleeper as in sleeper_flexibility",
    parameters=PARAMETERS)
