"""Time signals of a simulated pass-by, as a recorder would take them.

The train runs at constant speed V towards +x; time t maps to the leading-wheel position
X(t) = X_0 + V t. The rail acceleration (or velocity) at the sensor is the sum of

* **band content**: in each one-third-octave band, Gaussian noise (seeded) limited to the
  band's edges (IEC 61260 exact edges, brick-wall in the DFT of the whole record) and
  scaled to unit RMS, times an envelope that follows the simulated band RMS vs position
  (interpolated linearly in time). The band noise is independent between bands.
* **quasi-static wheel pulses**: the static deflection of the rail under each wheel load
  P, from the Euler-Bernoulli beam on a Winkler foundation of the static support
  stiffness s = K_s(0)/d (Timoshenko / Hetenyi):
  w(xi) = P beta/(2 s) exp(-beta |xi|) (cos beta xi + sin beta |xi|), beta = (s/4EI)^(1/4),
  xi the distance from sensor to wheel. Upward displacement u_z = -w(xi(t)), so
  a_z = -V^2 w''(xi) = V^2 P beta^3/s exp(-beta|xi|) (cos beta xi - sin beta|xi|) and
  v_z = V w'(xi).
* **background noise** (optional): in each band, stationary band noise whose RMS is
  ``noise_fraction`` times the band's largest RMS during the pass-by (METHOD.md section 5).
* **wheel-position error** (optional): each wheel's quasi-static pulse is displaced by
  e_n ~ N(0, sigma) from where the band content puts that wheel, so an estimator that
  finds the wheels from the low-frequency pulses locates them with that error.

The truth (layout, speed, errors, band levels vs position) is returned separately
(:func:`synthesise`) and :func:`passby_recording` leaves it out of the Recording;
railfem.io.recording writes it to ``<stem>.truth.json``, which its reader never opens.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from ..recording import Channel, Recording
from .passby import PassbyResult
from .train import TrainLayout

log = logging.getLogger(__name__)

__all__ = ["QuasiStatic", "quasi_static", "synthesise", "passby_recording",
           "DEFAULT_SAMPLE_RATE"]

DEFAULT_SAMPLE_RATE = 25600.0  # Hz


@dataclass(frozen=True, kw_only=True)
class QuasiStatic:
    """Winkler-beam quasi-static rail deflection. load: static wheel load P (N).
    EI: rail bending stiffness (N m^2). foundation: static support stiffness per length
    s (N/m^2)."""

    load: float
    EI: float
    foundation: float

    def __post_init__(self):
        for name in ("load", "EI", "foundation"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"QuasiStatic.{name} = {v!r}: give a positive value (SI)")

    @property
    def beta(self) -> float:
        return (self.foundation / (4 * self.EI)) ** 0.25

    def deflection(self, xi) -> np.ndarray:
        """Downward deflection w (m) at distance xi (m) from the wheel."""
        b, x = self.beta, np.asarray(xi, dtype=float)
        return self.load * b / (2 * self.foundation) * np.exp(-b * np.abs(x)) * (
            np.cos(b * x) + np.sin(b * np.abs(x)))

    def second_derivative(self, xi) -> np.ndarray:
        b, x = self.beta, np.asarray(xi, dtype=float)
        return -self.load * b**3 / self.foundation * np.exp(-b * np.abs(x)) * (
            np.cos(b * x) - np.sin(b * np.abs(x)))

    def first_derivative(self, xi) -> np.ndarray:
        b, x = self.beta, np.asarray(xi, dtype=float)
        return -self.load * b**2 / self.foundation * np.exp(-b * np.abs(x)) * np.sin(b * x)


def quasi_static(spec, load: float, EI: float | None = None) -> QuasiStatic:
    """QuasiStatic for a track (a railfem.spec.TrackSpec: its support and sleeper spacing,
    static K_s(0) = kp kb/(kp + kb) per spacing) and wheel load (N); EI defaults to the
    EN 13674-1 60E1 value (E = 210 GPa, I = 3038.3 cm^4)."""
    from dataclasses import replace

    from ..spec import TrackSpec
    from ..track.supports import dynamic_stiffness

    if not isinstance(spec, TrackSpec):
        raise TypeError(f"quasi_static takes a railfem.spec.TrackSpec, got "
                        f"{type(spec).__name__}")
    # static stiffness: pad and ballast in series without their loss factors
    elastic = replace(spec.support, eta_p=0.0, eta_b=0.0)
    ks = float(np.real(dynamic_stiffness(elastic, np.array([0.0]))[0]))
    return QuasiStatic(load=load, EI=EI or 2.1e11 * 3038.3e-8, foundation=ks / spec.spacing)


def _db(v: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore"):
        return 20 * np.log10(v / 1e-9)


def _band_noise(rng, n: int, fs: float, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """(nb, n) unit-RMS Gaussian noise limited to each band [lower, upper)."""
    spec = np.fft.rfft(rng.standard_normal(n))
    freq = np.fft.rfftfreq(n, 1 / fs)
    out = np.empty((len(lower), n))
    for b, (lo, hi) in enumerate(zip(lower, upper)):
        s = np.where((freq >= lo) & (freq < hi), spec, 0.0)
        x = np.fft.irfft(s, n)
        rms = math.sqrt(np.mean(x**2))
        if rms == 0:
            raise ValueError(f"the record is too short to hold the {lo:.0f}-{hi:.0f} Hz band")
        out[b] = x / rms
    return out


def synthesise(result: PassbyResult, train: TrainLayout, speed: float, *,
               sample_rate: float = DEFAULT_SAMPLE_RATE, quantity: str = "acceleration",
               quasi: QuasiStatic | None = None, noise_fraction: float = 0.0,
               position_error: float = 0.0, seed: int = 0) -> tuple[np.ndarray, dict]:
    """The sensor signal (n_samples,) of a pass-by and its truth (dict)."""
    if not (np.isfinite(speed) and speed > 0):
        raise ValueError(f"speed = {speed!r} m/s: give the train speed > 0 m/s")
    if quantity not in ("acceleration", "velocity"):
        raise ValueError(f"quantity = {quantity!r}: 'acceleration' or 'velocity'")
    if not (noise_fraction >= 0 and position_error >= 0):
        raise ValueError("noise_fraction and position_error must be >= 0")
    bands = result.bands
    if bands.upper[-1] >= sample_rate / 2:
        raise ValueError(f"sample rate {sample_rate:g} Hz is too low for the "
                         f"{bands.nominal[-1]:g} Hz band: use > {2 * bands.upper[-1]:.0f} Hz")
    rng = np.random.default_rng(seed)
    X = result.position
    n = int(math.floor((X[-1] - X[0]) / speed * sample_rate)) + 1
    t = np.arange(n) / sample_rate
    Xt = X[0] + speed * t
    # band RMS of the chosen quantity vs position: v, or a = i omega v per narrow band
    from ..standards.iec61260 import band_average

    w = 2 * np.pi * result.frequency
    weight = w[:, None] if quantity == "acceleration" else 1.0
    amp = band_average(result.frequency, np.sqrt(result.velocity_sq) * weight, bands)
    env = np.array([np.interp(Xt, X, a) for a in amp])            # (nb, n)
    noise = _band_noise(rng, n, sample_rate, bands.lower, bands.upper)
    signal = np.sum(env * noise, axis=0)
    if noise_fraction > 0:
        floor = _band_noise(rng, n, sample_rate, bands.lower, bands.upper)
        signal += np.sum(noise_fraction * amp.max(axis=1)[:, None] * floor, axis=0)
    errors = rng.normal(0.0, position_error, train.n_wheels) if position_error > 0 else \
        np.zeros(train.n_wheels)
    sensor_x = result.settings["sensor_x_m"]
    if quasi is not None:
        for o, e in zip(train.offsets, errors):
            xi = sensor_x - (Xt - o + e)
            signal += (-speed**2 * quasi.second_derivative(xi) if quantity == "acceleration"
                       else speed * quasi.first_derivative(xi))
    truth = {
        "speed_m_per_s": speed, "sample_rate_hz": sample_rate, "quantity": quantity,
        "seed": seed, "noise_fraction": noise_fraction, "position_error_sigma_m": position_error,
        "axle_offsets_m": list(train.offsets), "wheel_position_errors_m": errors.tolist(),
        "sensor_x_m": sensor_x, "leading_wheel_x_at_t0_m": float(X[0]),
        "wheel_over_sensor_time_s": ((sensor_x - X[0] + train.offsets) / speed).tolist(),
        "quasi_static": None if quasi is None else {
            "load_n": quasi.load, "EI_nm2": quasi.EI, "foundation_n_per_m2": quasi.foundation},
        "settings": result.settings,
        "band_centre_hz": bands.nominal.tolist(),
        "position_m": X.tolist(),
        # null where no wheel is within the rail tables' reach (band velocity 0)
        "band_level_db_re_1e-9": [[round(float(v), 3) if np.isfinite(v) else None for v in row]
                                  for row in _db(result.band_velocity)],
    }
    log.info("synthesised %.2f s at %.0f Hz (%d samples), %d bands, %d wheels", n / sample_rate,
             sample_rate, n, len(bands), train.n_wheels)
    return signal, truth


def passby_recording(signal: np.ndarray, truth: dict, *, spacing: float, location: str,
                     speed_known: bool = True) -> Recording:
    """The Recording a field team would have of a synthesised pass-by: the samples, the
    sensor (rail ``location``, vertical, its position in the span) and the speed if
    ``speed_known``; nothing of the truth. Write it with
    ``railfem.io.recording.write_recording(path, rec, truth=truth)``, which keeps the truth
    in a separate file."""
    sensor_x = truth["sensor_x_m"]
    return Recording(samples=signal, fs=truth["sample_rate_hz"],
                     channels=(Channel(name=f"rail_{location}_z", quantity=truth["quantity"],
                                       location=location, direction="z",
                                       x_from_support=round(float(sensor_x % spacing), 9)),),
                     speed=truth["speed_m_per_s"] if speed_known else None,
                     metadata={"sleeper_spacing_m": spacing, "rail": "60E1",
                               "description": "simulated pass-by (railfem)"})
