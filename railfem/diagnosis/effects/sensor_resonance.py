"""Sensor mounting resonance: the accelerometer on a compliant mount (magnet, glue layer,
adapter) moves with the rail only below the mount's resonance.

Base excitation of the sensor's mass through the mount (stiffness and damping) gives the
transmissibility T = (1 + i eta r) / (1 - r^2 + i eta r), r = f / fs, that multiplies every
FRF of that sensor: a peak near fs, the same at all hammer positions (so it cancels in the
decay rate). Which sensor carries it is a categorical grid choice."""
import numpy as np

from railfem.diagnosis.effects import Effect, EffectParameter


def transmissibility(f, fs, eta):
    r = np.asarray(f, dtype=float) / fs
    return (1 + 1j * eta * r) / (1 - r ** 2 + 1j * eta * r)


def apply_measurement(receptance, theta, record):
    t = record.fit
    out = np.array(receptance, dtype=complex)
    T = transmissibility(t.frequency, float(theta["fs"]), float(theta["eta_s"]))
    which = theta.get("sensor", "all")
    for o, name in enumerate(t.outputs):
        if which in ("all", name):
            out[:, o, :] *= T[:, None]
    return out


EFFECT = Effect(
    name="sensor_resonance", title="sensor mounting resonance",
    kind="measurement", apply_measurement=apply_measurement,
    meaning="the accelerometer's mount is compliant: a resonance multiplies all its FRFs",
    parameters=(
        EffectParameter(name="fs", unit="Hz", lower=500.0, upper=40000.0, log=True,
                        start=6000.0, meaning="mounted resonance frequency of the sensor"),
        EffectParameter(name="eta_s", unit="-", lower=0.01, upper=2.0, log=True, start=0.2,
                        meaning="loss factor of the mount (2 x damping ratio)"),
    ),
    grid={"sensor": ("all", "head", "foot")}, needs=("hammer",),
    quantities=("point", "phase", "transfer"))
