"""Sensor position error: the accelerometer is not where the data say relative to the
sleepers (e.g. stated mid-span, really nearer a sleeper).

All positions keep their distances from the sensor but the whole test shifts along the
rail against the supports: the point mobility and the near transfers change, most around
the pinned-pinned resonance. A geometry effect (a new kernel per shift, profiled on a grid
of shifts; the sign is not identifiable from the point alone)."""
from railfem.diagnosis.effects import Effect, EffectParameter

SHIFTS = (-0.20, -0.12, -0.06, 0.06, 0.12, 0.20)


def geometry(theta, record=None):
    return float(theta["sensor_shift"]), 0.0


EFFECT = Effect(
    name="sensor_position", title="sensor position error along the rail",
    kind="geometry", geometry=geometry,
    meaning="the sensor sits elsewhere relative to the sleepers than stated",
    parameters=(EffectParameter(name="sensor_shift", unit="m", lower=-0.3, upper=0.3,
                                log=False, start=0.06,
                                meaning="true minus stated sensor position"),),
    grid={"sensor_shift": SHIFTS}, needs=("hammer", "discrete"),
    quantities=("point", "phase", "transfer", "tdr"))
