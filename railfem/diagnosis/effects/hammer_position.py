"""Hammer position error: the hammer positions are offset by a common distance (the tape's
zero not at the sensor), the point FRF excepted.

The transfers then belong to other distances than stated: near the sensor, where the
level changes fastest with distance, the error shows most. A geometry effect profiled on a
grid of offsets."""
from railfem.diagnosis.effects import Effect, EffectParameter

OFFSETS = (-0.08, -0.05, -0.025, 0.025, 0.05, 0.08)


def geometry(theta, record=None):
    return 0.0, float(theta["hammer_offset"])


EFFECT = Effect(
    name="hammer_position", title="hammer position offset",
    kind="geometry", geometry=geometry,
    meaning="every transfer was struck a fixed distance off its stated position",
    parameters=(EffectParameter(name="hammer_offset", unit="m", lower=-0.12, upper=0.12,
                                log=False, start=0.025,
                                meaning="true minus stated hammer distance"),),
    grid={"hammer_offset": OFFSETS}, needs=("hammer",),
    quantities=("transfer", "tdr"))
