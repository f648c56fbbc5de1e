"""A noise floor: ambient vibration adds to weak far-field transfers.

Ambient vibration adds a random complex term n of RMS sigma = g |Y_0| (Y_0 the point
mobility, g = 10^(L/20) the floor level relative to it) to every transfer: far transfers
at low frequency, where the track attenuates most, level off at the floor instead of
decaying. The residuals are in dB, so the operator returns the expected log magnitude:
for complex Gaussian n, E[ln |Y + n|^2] = ln |Y|^2 + E1(|Y|^2 / sigma^2) (E1 the
exponential integral; it tends to ln sigma^2 - 0.577 when the floor dominates, 2.5 dB
below the RMS). The phase is the model's. (The EN 15461 estimate of the data excludes
some of those positions already.)"""
import numpy as np
from scipy.special import exp1

from railfem.diagnosis.effects import Effect, EffectParameter


def apply_measurement(receptance, theta, record):
    a = np.array(receptance, dtype=complex)
    g = 10 ** (float(theta["floor_db"]) / 20)
    floor = g * np.abs(a[:, :, :1])
    mag2 = np.abs(a) ** 2
    ratio = mag2 / np.maximum(floor ** 2, 1e-300)
    # |Y_m| = exp(E[ln|Y + n|^2] / 2) = |Y| exp(E1(ratio) / 2); E1 overflows for tiny ratio
    scale = np.exp(np.minimum(exp1(np.maximum(ratio, 1e-300)), 600.0) / 2)
    scale[:, :, 0] = 1.0  # the point FRF is the reference, far above the floor
    return a * scale


EFFECT = Effect(
    name="noise_floor", title="noise floor (ambient vibration)",
    kind="measurement", apply_measurement=apply_measurement,
    meaning="ambient vibration sets a floor under the weak far-field transfers",
    parameters=(EffectParameter(name="floor_db", unit="dB re point", lower=-90.0,
                                upper=-10.0, log=False, start=-45.0,
                                meaning="floor level relative to the point mobility"),),
    needs=("hammer",), quantities=("transfer", "tdr"))
