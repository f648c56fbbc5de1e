"""Wheel instants, train speed and axle layout from one sensor's pass-by signal.

**Wheel instants.** Below ~100 Hz the rail vibration is dominated by the quasi-static
deflection under each wheel and by strongly decaying waves, so the low-passed signal peaks
sharply when a wheel is over the sensor. The signal is turned into an acceleration (a
velocity is differentiated: the quasi-static acceleration pulse is symmetric about the
wheel, the velocity pulse is antisymmetric and vanishes there), low-passed (4th-order
Butterworth, zero phase) and smoothed by a centred moving average. Method ``'signed'``
(default) looks for peaks of one polarity — the quasi-static acceleration under a wheel
has a definite sign and its side lobes the opposite one (between the two axles of a bogie
the side lobes add up to about -8 dB of the main peak, too close to be told apart by
height alone); the polarity with the stronger peaks is taken. Method ``'envelope'``
(squared signal) suits records whose low band is random vibration without a quasi-static
pulse. Peaks are found with ``scipy.signal.find_peaks`` under three robust conditions:
(1) a peak stands ``snr_db`` (20 dB) above the median of the signal (the record's
background: wheel pulses occupy a small part of the record); (2) its prominence is at
least ``rel_prominence`` (1/2) of its height (the signal dips between wheels); (3) it is
within ``range_db`` (10 dB) of a typical wheel peak (the 90th percentile of the peaks
passing (1) and (2)), so that wheel loads differing by a factor of 3 pass and bursts do not
set the scale; peaks closer than the shortest possible axle spacing at the highest
possible speed are merged by ``distance``. Levels are in dB of power in both methods.

**Speed.** A single sensor measures times, not lengths: the speed needs one known length.
Supported (:func:`train_speed`): the speed itself; the bogie axle spacing (wheelbase),
taken to be the shortest and most common axle interval of the train — the median of the
shorter half of the wheel intervals picks it out, and every interval within 15 % of it is
averaged; or the full axle layout (positions of all axles), fitted by least squares
``t_n = t_0 + a_n / V`` when the number of detected wheels matches.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from railfem.recording import Recording

__all__ = ["WheelPassage", "detect_wheel_times", "train_speed", "wheel_passage"]

log = logging.getLogger(__name__)

#: defaults of the detector
LOWPASS_HZ = 100.0
MIN_AXLE_SPACING_M = 1.2     # shorter than any real axle spacing
MAX_SPEED_M_S = 100.0        # 360 km/h
BOGIE_INTERVAL_TOLERANCE = 0.15
EDGE_PERIODS = 3.0           # low-pass periods at each record end left out of the search


@dataclass(frozen=True, kw_only=True, eq=False)
class WheelPassage:
    """When the wheels passed the sensor, how fast, and where they sit on the train."""

    times: np.ndarray
    """(N,) instants at which each wheel was over the sensor, s from the record start."""
    speed: float
    """Train speed, m/s (constant over the pass-by)."""
    speed_source: str
    """'given', 'axle_spacing' or 'axle_positions'."""
    speed_scatter: float
    """Standard deviation of the individual speed estimates, m/s (0 when given)."""
    positions: np.ndarray
    """(N,) wheel positions along the train, m, ``V (t_n - t_0)``: 0 at the first wheel."""

    @property
    def count(self) -> int:
        return int(self.times.size)


def _to_acceleration(samples: np.ndarray, fs: float, quantity: str) -> np.ndarray:
    x = np.asarray(samples, dtype=float)
    x = x - np.mean(x)
    if quantity == "velocity":
        x = np.gradient(x) * fs
    return x


def _peaks(env: np.ndarray, distance: int, background: float, snr_db: float,
           rel_prominence: float, range_db: float):
    """Peaks of ``env`` passing the three conditions (module docstring); returns the peak
    indices, ``env`` and a typical peak height (0 without peaks)."""
    from scipy import signal

    peaks, props = signal.find_peaks(env, distance=distance, prominence=0.0)
    if peaks.size == 0:
        return peaks, env, 0.0
    heights = env[peaks]
    keep = heights >= background * 10 ** (snr_db / 10)
    keep &= props["prominences"] >= rel_prominence * heights
    if not keep.any():
        return peaks[keep], env, 0.0
    # a typical wheel peak, robust to a few bursts
    reference = float(np.percentile(heights[keep], 90))
    keep &= heights >= reference * 10 ** (-range_db / 10)
    return peaks[keep], env, reference


def detect_wheel_times(samples: np.ndarray, fs: float, *, quantity: str = "acceleration",
                       lowpass_hz: float = LOWPASS_HZ, speed: float | None = None,
                       min_axle_spacing: float = MIN_AXLE_SPACING_M,
                       max_speed: float = MAX_SPEED_M_S, smooth_s: float | None = None,
                       snr_db: float = 20.0, range_db: float = 10.0,
                       rel_prominence: float = 0.5, method: str = "signed") -> np.ndarray:
    """Instants (s) at which wheels were over the sensor, from the low-passed signal.

    ``speed`` (m/s), when known, narrows the minimum peak distance to
    ``min_axle_spacing / speed`` and the smoothing to 0.2 m of travel; otherwise the
    distance is ``min_axle_spacing / max_speed`` and the smoothing 10 ms. Returns an
    empty array when no peak passes the thresholds (the caller decides what that means).
    """
    from scipy import signal

    if not (0 < lowpass_hz < fs / 2):
        raise ValueError(f"wheel detection low-pass {lowpass_hz!r} Hz must lie between 0 and "
                         f"half the sample rate ({fs / 2:g} Hz)")
    x = _to_acceleration(samples, fs, quantity)
    sos = signal.butter(4, lowpass_hz, btype="lowpass", fs=fs, output="sos")
    y = signal.sosfiltfilt(sos, x)
    # a sensor offset is removed after the low-pass: the median of the raw record is a
    # poor estimate of it when strong high-frequency vibration fills the record (it was
    # off by 1.2 m/s^2, a third of the wheel pulses, on a simulated 216 km/h pass-by)
    y -= np.median(y)
    # the filter's start-up transients at the record ends are not wheels: a record that
    # starts on strong high-frequency vibration rings there far above the wheel pulses
    # and, taken as the typical peak, would hide every wheel
    edge = min(int(EDGE_PERIODS * fs / lowpass_hz), x.size // 4)
    y[:edge] = 0.0
    y[y.size - edge:] = 0.0
    v_ref = speed if speed is not None else max_speed
    if smooth_s is None:
        smooth_s = 0.2 / speed if speed is not None else 0.01
    w = max(1, int(round(smooth_s * fs)) | 1)  # odd: the centred average does not shift
    kernel = np.ones(w) / w
    distance = max(1, int(min_axle_spacing / v_ref * fs))
    if method == "signed":
        smooth = np.convolve(y, kernel, mode="same")
        background = float(np.median(np.abs(smooth)))
        candidates = [_peaks(sign * smooth, distance, background, snr_db / 2.0,
                             rel_prominence, range_db / 2.0) for sign in (1.0, -1.0)]
        # the polarity of the quasi-static pulse is the one with the stronger peaks
        peaks, env = max(candidates, key=lambda c: c[2])[:2]
    elif method == "envelope":
        env = np.convolve(y * y, kernel, mode="same")
        peaks, env, _ = _peaks(env, distance, float(np.median(env)), snr_db,
                               rel_prominence, range_db)
    else:
        raise ValueError(f"wheel detection method must be 'signed' or 'envelope', got "
                         f"{method!r}")
    if peaks.size == 0:
        return np.empty(0)
    # refine each peak to sub-sample accuracy with a parabola through its three samples
    t = peaks.astype(float)
    inner = (peaks > 0) & (peaks < env.size - 1)
    p = peaks[inner]
    a, b, c = env[p - 1], env[p], env[p + 1]
    denom = a - 2 * b + c
    with np.errstate(divide="ignore", invalid="ignore"):
        shift = np.where(denom < 0, 0.5 * (a - c) / denom, 0.0)
    t[inner] += np.clip(shift, -0.5, 0.5)
    log.debug("wheel detection (%s): %d peaks, smoothing %d samples", method, peaks.size, w)
    return t / fs


def train_speed(times, *, speed: float | None = None, axle_spacing: float | None = None,
                axle_positions=None) -> tuple[float, float, str]:
    """Train speed (m/s), its scatter (m/s) and its source from the wheel instants.

    Exactly one known quantity is used, in this order: ``speed`` (m/s), ``axle_positions``
    (m, all axles), ``axle_spacing`` (m, the bogie wheelbase). Raises ValueError when
    none is given, naming what is needed.
    """
    times = np.sort(np.asarray(times, dtype=float))
    if speed is not None:
        return float(speed), 0.0, "given"
    if times.size < 2:
        raise ValueError(f"found {times.size} wheel(s); the speed needs at least two")
    if axle_positions is not None:
        a = np.asarray(axle_positions, dtype=float)
        if a.size != times.size:
            raise ValueError(
                f"the axle layout has {a.size} axles but {times.size} wheels were detected; "
                "check the layout (one entry per axle of the whole train) or give the speed "
                "or the bogie axle spacing instead")
        # t_n = t_0 + a_n / V, least squares in (t_0, 1/V)
        A = np.column_stack([np.ones_like(a), a - a[0]])
        (t0, slowness), *_ = np.linalg.lstsq(A, times, rcond=None)
        if slowness <= 0:
            raise ValueError("the wheel instants do not fit the axle layout (negative speed)")
        v = 1.0 / slowness
        resid = times - t0 - (a - a[0]) * slowness
        n = a.size
        se = (math.sqrt(np.sum(resid**2) / (n - 2) / np.sum((a - a.mean()) ** 2))
              if n > 2 else 0.0)
        return float(v), float(v * v * se), "axle_positions"
    if axle_spacing is not None:
        dt = np.diff(times)
        short = np.sort(dt)[: max(1, (dt.size + 1) // 2)]
        t_bogie = float(np.median(short))
        group = dt[np.abs(dt - t_bogie) <= BOGIE_INTERVAL_TOLERANCE * t_bogie]
        v_each = axle_spacing / group
        return float(axle_spacing / np.mean(group)), float(np.std(v_each)), "axle_spacing"
    raise ValueError(
        "the train speed is unknown: a single sensor measures times, not lengths, so one "
        "known length is needed. Give the speed (m/s), the bogie axle spacing (m) or the "
        "positions of all axles (m) in the recording's metadata or on the command line.")


def wheel_passage(recording: Recording, *, speed: float | None = None,
                  axle_spacing: float | None = None, axle_positions=None,
                  **detect_options) -> WheelPassage:
    """Detect the wheels of ``recording`` and find the speed and axle layout.

    ``speed``, ``axle_spacing``, ``axle_positions`` override the recording's metadata.
    Raises ValueError when fewer than two wheels are found.
    """
    speed = recording.speed if speed is None else speed
    axle_spacing = recording.axle_spacing if axle_spacing is None else axle_spacing
    axle_positions = recording.axle_positions if axle_positions is None else axle_positions
    times = detect_wheel_times(recording.trace, recording.fs, quantity=recording.channel.quantity,
                               speed=speed, **detect_options)
    if times.size < 2:
        raise ValueError(
            f"found {times.size} wheel(s) in recording {recording.name or '(unnamed)'}: no "
            "train pass-by with distinct wheel pulses below the low-pass frequency; check "
            "the recording (does it contain the train?) or the detector's thresholds")
    v, scatter, source = train_speed(times, speed=speed, axle_spacing=axle_spacing,
                                     axle_positions=axle_positions)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"train speed came out as {v!r} m/s; check the metadata")
    positions = v * (times - times[0])
    log.info("%s: %d wheels, speed %.2f m/s (%s)", recording.name or "recording", times.size,
             v, source)
    return WheelPassage(times=times, speed=v, speed_source=source, speed_scatter=scatter,
                        positions=positions)
