"""A noise floor: ambient vibration adds to weak far-field transfers.

Ambient vibration adds a random complex term n of RMS sigma = g |Y_0| (Y_0 the point
mobility, g = 10^(L/20) the floor level relative to it) to every transfer: far transfers
at low frequency, where the track attenuates most, level off at the floor instead of
decaying. The residuals are in dB, so the operator returns the expected log magnitude:
for complex Gaussian n, E[ln |Y + n|^2] = ln |Y|^2 + E1(|Y|^2 / sigma^2) (E1 the
exponential integral; it tends to ln sigma^2 - 0.577 when the floor dominates, 2.5 dB
below the RMS). The EN 15461 decay rate of the data sums band power instead, whose
expectation is |Y|^2 + sigma^2 (``apply_power``): fitting the decay rate with the dB face
would push the floor up to 2.5 dB too high. The phase is the model's. (The EN 15461
estimate of the data excludes some of those positions already.)"""
import numpy as np
from scipy.special import exp1

from railfem.diagnosis.effects import Effect, EffectParameter


def _floor(a, theta):
    """sigma^2 of the floor per point FRF (nf, n_out, 1)."""
    return (10 ** (float(theta["floor_db"]) / 20) * np.abs(a[:, :, :1])) ** 2


def apply_measurement(receptance, theta, record):
    a = np.array(receptance, dtype=complex)
    ratio = np.abs(a) ** 2 / np.maximum(_floor(a, theta), 1e-300)
    # |Y_m| = exp(E[ln|Y + n|^2] / 2) = |Y| exp(E1(ratio) / 2); E1 overflows for tiny ratio
    scale = np.exp(np.minimum(exp1(np.maximum(ratio, 1e-300)), 600.0) / 2)
    scale[:, :, 0] = 1.0  # the point FRF is the reference, far above the floor
    return a * scale


def apply_power(receptance, theta, record):
    """The band-power face: |Y_m|^2 = E|Y + n|^2 = |Y|^2 + sigma^2."""
    a = np.array(receptance, dtype=complex)
    mag2 = np.abs(a) ** 2
    scale = np.sqrt((mag2 + _floor(a, theta)) / np.maximum(mag2, 1e-300))
    scale[:, :, 0] = 1.0
    return a * scale


def variance(receptance, theta, record):
    """Variance (dB^2) of 20 lg |Y + n|: for rho = |Y|^2 / sigma^2, var ln|Y + n|^2 is
    pi^2/6 under the floor (rho -> 0) and 2/rho above it; the interpolation
    (pi^2/6) / sqrt(1 + (pi^2 rho / 12)^2) joins them within 17 % (Monte Carlo, tested)."""
    a = np.asarray(receptance)
    rho = np.abs(a) ** 2 / np.maximum(_floor(a, theta), 1e-300)
    v = (np.pi ** 2 / 6) / np.sqrt(1 + (np.pi ** 2 * rho / 12) ** 2)
    v[:, :, 0] = 0.0
    return (10 / np.log(10)) ** 2 * v  # (20 lg e / 2)^2: ln|.|^2 -> dB


EFFECT = Effect(
    name="noise_floor", title="noise floor (ambient vibration)",
    kind="measurement", apply_measurement=apply_measurement, apply_power=apply_power,
    variance=variance,
    meaning="ambient vibration sets a floor under the weak far-field transfers",
    parameters=(EffectParameter(name="floor_db", unit="dB re point", lower=-90.0,
                                upper=-10.0, log=False, start=-45.0,
                                meaning="floor level relative to the point mobility"),),
    needs=("hammer",), quantities=("transfer", "tdr"))
