"""Track decay rate from pass-by recordings: energy iteration and slope fitting.

Model-free (METHOD.md §6, docs/passby_tdr.md): a recording (time signal + sample rate +
what is known about the train) goes in, per one-third-octave band decay rates come out.
The same code runs on field recordings and on railfem's simulated ones, and nothing here
reads a simulator's truth.

Steps, per recording: wheels and speed from the low-passed signal
(:mod:`railfem.estimators.wheels`); per band, the IEC 61260-1 class 1 band energy
(:mod:`railfem.estimators.bands`); then

* **energy iteration** — the energy within ``±L1/2`` of every wheel over the energy of
  the analysed stretch, solved for β with the exact model ratio of
  :mod:`railfem.estimators.passby_energy` (own wheel, other wheels inside each window,
  finite stretch, filter smear), once with all wheels pooled (the pass-by's estimate)
  and once per wheel (for the scatter over wheels). A band whose filter smears the power
  over more than ``L1/2`` (rms, in train travel: low bands at high speed) is flagged
  'smeared': the smear model holds for noise broadband within the band and is no longer
  trusted when the smear is that long. A ratio within three standard errors (scatter of
  the per-wheel ratios) of the no-decay ratio is 'not_resolved': stationary vibration;
* **slope fitting** — band levels in blocks at 0.1 m steps of train travel behind each
  wheel, a straight line over ``L3`` (``L3_low`` = 0.6 m below ``l3_split_hz``, where the
  decay is high, ``L3_high`` = 1.2 m above), ``D = −slope``; averaged over wheels and
  pass-bys. Blocks with a bandwidth-time product below 1 (low bands at speed) are
  'low_bt'; a mean less than ``slope_min_se`` (4) standard errors from zero — a
  relative standard error above 25 % — is 'not_resolved'. The same
  incoherent-wheel model predicts what the fit would return on this
  train if the decay rate were the estimate; a predicted bias beyond ``max_slope_bias``
  (other wheels inside the fit window when the decay is low and wheels are close, filter
  smear in low bands at high speed) flags the band instead of reporting a biased value, and
  so does a fit window that ends within 10 dB of the band's background ('noise_floor').

Failures are reported per band with a status, never replaced by a guess.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace

import numpy as np

from railfem.standards.iec61260 import MAX_UPPER_EDGE_FRACTION, ThirdOctaveBands, \
    third_octave_bands

from .bands import band_energy, block_levels, energy_between
from .passby_energy import (DB_PER_NEPER_POWER, coarse_kernel, energy_ratio, phi,
                            solve_energy_ratio)
from railfem.recording import Recording
from .wheels import WheelPassage, wheel_passage

__all__ = ["PassbyOptions", "DecayEstimate", "PassbyDecayRate", "passby_decay_rate",
           "slope_fit", "slope_model_bias"]

log = logging.getLogger(__name__)

NOISE_FLOOR_HEADROOM_DB = 10.0  # slope fits ending closer to the background are rejected
BETA_FLAT = 1e-6  # 1/m: the "no decay" limit of the energy ratio (8.7e-6 dB/m)


@dataclass(frozen=True, kw_only=True)
class PassbyOptions:
    """Settings of the pass-by decay-rate estimators (lengths in m, frequencies in Hz)."""

    f_low: float = 100.0
    """Lowest band (nominal or exact centre), Hz."""
    f_high: float = 5000.0
    """Highest band, Hz (its upper edge must lie below 0.4 fs)."""
    l1: float = 1.0
    """Energy window around each wheel, m (METHOD.md §6 default 1 m)."""
    l2_margin: float = 20.0
    """The energy E_L2 is taken from this far before the first wheel to this far after the
    last (clipped to the record), m: enough for the decay, little background noise."""
    step: float = 0.1
    """Train travel per level block, m."""
    l3_low: float = 0.6
    """Slope-fit length below ``l3_split_hz`` (high decay), m."""
    l3_high: float = 1.2
    """Slope-fit length from ``l3_split_hz`` up (low decay), m."""
    l3_split_hz: float = 1000.0
    """Bands with a centre below this use ``l3_low``, Hz."""
    plausible: tuple[float, float] = (0.1, 40.0)
    """Decay rates outside this range (dB/m) are reported as implausible."""
    kappa_max: float = 10.0
    """Energy roots whose condition number |d ln β / d ln ratio| exceeds this are rejected."""
    max_slope_bias: float = 0.2
    """Slope-fit bands whose model-predicted relative bias exceeds this are rejected."""
    min_block_bt: float = 1.0
    """Slope fitting needs level blocks of at least this bandwidth-time product
    (bandwidth x step / speed); below it block levels scatter by more than ~4 dB and the
    few wheels that pass the resolution test are mostly upward fluctuations."""
    slope_min_se: float = 4.0
    """Slope-fit means fewer standard errors (over wheels) from zero are 'not_resolved'."""

    def __post_init__(self) -> None:
        for name in ("f_low", "f_high", "l1", "l2_margin", "step", "l3_low", "l3_high",
                     "l3_split_hz", "kappa_max", "max_slope_bias", "slope_min_se",
                     "min_block_bt"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"PassbyOptions.{name} must be a positive number, got {v!r}")
        if self.f_high < self.f_low:
            raise ValueError(f"PassbyOptions: f_high ({self.f_high} Hz) is below f_low "
                             f"({self.f_low} Hz); swap them")
        for name in ("l3_low", "l3_high"):
            if getattr(self, name) < 2 * self.step:
                raise ValueError(f"PassbyOptions.{name} = {getattr(self, name)} m gives fewer "
                                 f"than three level blocks of {self.step} m; make it at "
                                 f"least {2 * self.step:g} m")
        lo, hi = self.plausible
        if not (0 < lo < hi):
            raise ValueError(f"PassbyOptions.plausible must be (low, high) dB/m with "
                             f"0 < low < high, got {self.plausible!r}")

    def l3(self, centre: float) -> float:
        return self.l3_low if centre < self.l3_split_hz else self.l3_high


@dataclass(frozen=True, kw_only=True, eq=False)
class DecayEstimate:
    """One estimator's result per band (all arrays (n_bands,) unless stated)."""

    method: str
    decay_rate: np.ndarray
    """Accepted decay rate, dB/m; NaN where the band failed (see ``status``)."""
    raw: np.ndarray
    """The value before acceptance checks, dB/m (NaN without any value)."""
    status: tuple[str, ...]
    """'ok' or why not (codes explained in docs/passby_tdr.md)."""
    std_wheels: np.ndarray
    """Standard deviation over individual wheels (all pass-bys), dB/m."""
    n_wheels: np.ndarray
    """Number of wheels with a value."""
    std_passbys: np.ndarray
    """Standard deviation of the pass-by values, dB/m (NaN with one pass-by)."""
    n_passbys: np.ndarray
    """Number of pass-bys with an accepted value."""
    per_passby: np.ndarray
    """(n_recordings, n_bands) each pass-by's value, dB/m: energy iteration, the pass-by's
    accepted root (NaN if rejected); slope fitting, the mean over the pass-by's wheels."""
    per_passby_status: tuple[tuple[str, ...], ...]
    """Status per recording and band."""


@dataclass(frozen=True, kw_only=True, eq=False)
class PassbyDecayRate:
    """Both estimators on a set of pass-by recordings."""

    bands: ThirdOctaveBands
    energy: DecayEstimate
    slope: DecayEstimate
    wheels: tuple[WheelPassage, ...]
    names: tuple[str, ...]
    levels_x: tuple[np.ndarray, ...]
    """Per recording, train positions of the level blocks (m, 0 at the first wheel)."""
    levels: tuple[np.ndarray, ...]
    """Per recording, (n_bands, n_x) band levels in dB re 1 (SI unit)^2 at ``levels_x``."""
    options: PassbyOptions


# ---------------------------------------------------------------------------- slope
def slope_fit(levels_db: np.ndarray, u: np.ndarray) -> float:
    """Decay rate −slope (dB/m) of a straight line through finite ``levels_db`` vs ``u``."""
    ok = np.isfinite(levels_db)
    if ok.sum() < 3:
        return float("nan")
    slope = np.polyfit(u[ok], levels_db[ok], 1)[0]
    return float(-slope)


def _fit_offsets(step: float, l3: float) -> np.ndarray:
    return np.arange(0.0, l3 + 1e-9 * step, step)


def slope_model_bias(decay_rate: float, positions, step: float, l3: float, tau=None,
                     k=None) -> float:
    """Relative bias ``D_fit/D − 1`` the slope fit would show on this train if the decay
    rate were ``decay_rate`` (incoherent equal wheels, blocks of ``step`` smeared by the
    filter kernel ``(tau, k)``), averaged over the wheels."""
    beta = decay_rate / DB_PER_NEPER_POWER
    a = np.asarray(positions, dtype=float)
    u = _fit_offsets(step, l3)
    tau = np.zeros(1) if tau is None else tau
    k = np.ones(1) if k is None else k
    # block around a_m + u: energy of wheel n is Φ(d + u + step/2) - Φ(d + u - step/2)
    d = (a[:, None] - a[None, :])[:, :, None] + u  # (m, n, u)
    up = np.tensordot(phi(d[..., None] + step / 2 - tau, beta), k, axes=([-1], [0]))
    lo = np.tensordot(phi(d[..., None] - step / 2 - tau, beta), k, axes=([-1], [0]))
    power = (up - lo).sum(axis=1)  # (m, u)
    fits = [slope_fit(10 * np.log10(np.maximum(p, 1e-300)), u) for p in power]
    return float(np.mean(fits) / decay_rate - 1.0)


# ---------------------------------------------------------------------- per recording
def _analysis_stretch(w: WheelPassage, duration: float, edge: float, margin: float):
    """Train-position interval [S_a, S_b] of E_L2 and its instants."""
    t_a = max(w.times[0] - margin / w.speed, edge)
    t_b = min(w.times[-1] + margin / w.speed, duration - edge)
    return t_a, t_b


def _one_band(rec: Recording, w: WheelPassage, centre: float, opts: PassbyOptions):
    """Energy-iteration and slope-fit results of one band of one recording."""
    be = band_energy(rec.trace, rec.fs, centre)
    v = w.speed
    tau, k = coarse_kernel(be.kernel_t * v, be.kernel)
    edge = float(be.kernel_t[-1])  # filter transients at the record ends
    t_a, t_b = _analysis_stretch(w, rec.duration, edge, opts.l2_margin)
    s_a, s_b = v * (t_a - w.times[0]), v * (t_b - w.times[0])
    half = opts.l1 / (2 * v)
    e1 = energy_between(be, w.times - half, w.times + half)
    e2 = float(energy_between(be, t_a, t_b))
    n = w.count
    pooled = solve_energy_ratio(
        float(e1.sum() / e2),
        lambda b: energy_ratio(b, w.positions, opts.l1, s_a, s_b, tau, k),
        plausible=opts.plausible, kappa_max=opts.kappa_max)
    smear = float(np.sqrt(np.sum(k * tau**2)))  # rms smear of the band power, m of travel
    if pooled.status == "ok" and smear > opts.l1 / 2:
        pooled = replace(pooled, decay_rate=float("nan"), status="smeared")
    # stationary vibration (no decay) gives the ratio of beta -> 0; a ratio within three
    # standard errors (from the scatter over wheels) of it is not a measured decay
    ratios = n * e1 / e2
    se = float(np.std(ratios, ddof=1) / math.sqrt(n)) if n > 1 else math.inf
    r_flat = energy_ratio(BETA_FLAT, w.positions, opts.l1, s_a, s_b, tau, k)
    if pooled.status == "ok" and float(e1.sum() / e2) - r_flat < 3 * se:
        pooled = replace(pooled, decay_rate=float("nan"), status="not_resolved")
    per_wheel = []
    for m in range(n):
        root = solve_energy_ratio(
            float(n * e1[m] / e2),
            lambda b, m=m: energy_ratio(b, w.positions, opts.l1, s_a, s_b, tau, k, wheel=m),
            bracket=(0.01, 300.0), plausible=(0.0, math.inf), kappa_max=math.inf)
        per_wheel.append(root.raw)
    # slope fitting: blocks of `step` behind each wheel
    l3 = opts.l3(centre)
    u = _fit_offsets(opts.step, l3)
    slopes = np.array([
        slope_fit(block_levels(be, t + u / v, opts.step / v), u) for t in w.times])
    # band levels along the train for reports
    x = np.arange(math.floor(-opts.l2_margin / opts.step), math.ceil(
        (w.positions[-1] + opts.l2_margin) / opts.step) + 1) * opts.step
    levels = block_levels(be, w.times[0] + x / v, opts.step / v)
    # headroom of the fit: level at the end of the fit window above the band's background
    # (the quietest 5 % of the blocks along the record)
    end = block_levels(be, w.times + l3 / v, opts.step / v)
    headroom = float(np.nanmean(end) - np.nanpercentile(levels, 5))
    context = (w.positions, opts.step, l3, tau, k)  # for the model-bias check of the slope fit
    bt = (be.centre * (10 ** 0.05 - 10 ** -0.05)) * opts.step / v  # band x block duration
    return pooled, np.array(per_wheel), slopes, (context, headroom, bt), x, levels


def _combine(method: str, per_pass, per_status, per_wheel_values, raw) -> DecayEstimate:
    per_pass = np.asarray(per_pass, dtype=float)   # (n_rec, nb), NaN where not ok
    nb = per_pass.shape[1]
    status, value, std_p, n_p, std_w, n_w = [], [], [], [], [], []
    for b in range(nb):
        codes = [per_status[r][b] for r in range(per_pass.shape[0])]
        ok = np.isfinite(per_pass[:, b])
        bad = sorted({c for c in codes if c != "ok"})
        if ok.all():
            status.append("ok")
        elif ok.any():
            status.append("partial:" + "+".join(bad))
        else:
            status.append("+".join(bad))
        value.append(np.mean(per_pass[ok, b]) if ok.any() else np.nan)
        n_p.append(int(ok.sum()))
        std_p.append(np.std(per_pass[ok, b], ddof=1) if ok.sum() > 1 else np.nan)
        wv = np.concatenate([np.asarray(x[b], dtype=float) for x in per_wheel_values])
        wv = wv[np.isfinite(wv)]
        n_w.append(int(wv.size))
        std_w.append(np.std(wv, ddof=1) if wv.size > 1 else np.nan)
    return DecayEstimate(method=method, decay_rate=np.array(value), raw=np.asarray(raw),
                         status=tuple(status), std_wheels=np.array(std_w),
                         n_wheels=np.array(n_w), std_passbys=np.array(std_p),
                         n_passbys=np.array(n_p), per_passby=per_pass,
                         per_passby_status=tuple(tuple(s) for s in per_status))


def passby_decay_rate(recordings, options: PassbyOptions | None = None, *,
                      speed: float | None = None, axle_spacing: float | None = None,
                      axle_positions=None, detect: dict | None = None) -> PassbyDecayRate:
    """Per-band track decay rate of one or more pass-by recordings, by both estimators.

    ``speed`` (m/s), ``axle_spacing`` (m) or ``axle_positions`` (m) override what the
    recordings' metadata say; ``detect`` passes options to
    :func:`railfem.estimators.wheels.detect_wheel_times`. Every check on the input runs
    before any filtering.
    """
    opts = options or PassbyOptions()
    recordings = list(recordings)
    if not recordings:
        raise ValueError("no recordings given; pass at least one pass-by Recording")
    for r in recordings:
        if not isinstance(r, Recording):
            raise TypeError(f"expected Recording objects, got {type(r).__name__}")
        quantity = r.channel.quantity  # one sensor per recording (else names the channels)
        if quantity not in ("acceleration", "velocity"):
            raise ValueError(f"recording {r.name or '(unnamed)'} holds a {quantity}; "
                             "the estimators take an acceleration or a velocity")
    bands = third_octave_bands(opts.f_low, opts.f_high)
    top = float(bands.upper[-1])
    for r in recordings:
        if top > MAX_UPPER_EDGE_FRACTION * r.fs:
            raise ValueError(
                f"recording {r.name or '(unnamed)'} is sampled at {r.fs:g} Hz: the highest "
                f"band's upper edge {top:.0f} Hz must lie below {MAX_UPPER_EDGE_FRACTION:g} "
                f"fs = {MAX_UPPER_EDGE_FRACTION * r.fs:.0f} Hz; lower f_high to "
                f"{MAX_UPPER_EDGE_FRACTION * r.fs / 10 ** 0.05:.0f} Hz or less")
    if speed is None and axle_spacing is None and axle_positions is None:
        unknown = [r.name or f"#{i}" for i, r in enumerate(recordings)
                   if r.speed is None and r.axle_spacing is None and r.axle_positions is None]
        if unknown:
            raise ValueError(
                f"the train speed of recording(s) {', '.join(unknown)} is unknown: a single "
                "sensor measures times, not lengths, so one known length is needed. Give the "
                "speed (m/s), the bogie axle spacing (m) or the positions of all axles (m) in "
                "the metadata or as an argument")
    wheels = tuple(wheel_passage(r, speed=speed, axle_spacing=axle_spacing,
                                 axle_positions=axle_positions, **(detect or {}))
                   for r in recordings)
    nb, nr = len(bands), len(recordings)
    e_pass = np.full((nr, nb), np.nan)
    e_stat = [["" for _ in range(nb)] for _ in range(nr)]
    e_raw = np.full((nr, nb), np.nan)
    e_wheel = [[np.array([])] * nb for _ in range(nr)]
    s_wheel = [[np.array([])] * nb for _ in range(nr)]
    s_context = [[None] * nb for _ in range(nr)]
    levels_x, levels = [], []
    for r, (rec, w) in enumerate(zip(recordings, wheels)):
        lv = []
        for b, centre in enumerate(bands.centre):
            pooled, per_wheel, slopes, context, x, lev = _one_band(
                rec, w, float(centre), opts)
            e_pass[r, b] = pooled.decay_rate
            e_raw[r, b] = pooled.raw
            e_stat[r][b] = pooled.status
            e_wheel[r][b] = per_wheel
            s_wheel[r][b] = slopes
            s_context[r][b] = context
            lv.append(lev)
        levels_x.append(x)
        levels.append(np.array(lv))
        log.info("%s: bands done", rec.name or f"recording {r}")
    energy = _combine("energy iteration", e_pass, e_stat, e_wheel, _nanmean(e_raw))
    slope = _slope_estimate(s_wheel, s_context, opts)
    return PassbyDecayRate(bands=bands, energy=energy, slope=slope, wheels=wheels,
                           names=tuple(r.name for r in recordings),
                           levels_x=tuple(levels_x), levels=tuple(levels), options=opts)


def _nanmean(values: np.ndarray) -> np.ndarray:
    """Column means over the finite entries (NaN for a column without any)."""
    values = np.asarray(values, dtype=float)
    ok = np.isfinite(values)
    total = np.where(ok, values, 0.0).sum(axis=0)
    count = ok.sum(axis=0)
    return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def _slope_estimate(slopes, contexts, opts: PassbyOptions) -> DecayEstimate:
    """METHOD.md §6: the slopes averaged over all wheels of all pass-bys, then checked.

    A mean less than ``opts.slope_min_se`` standard errors from zero is not a measured
    decay ('not_resolved'; the scatter of single-wheel slopes is large, and a looser
    threshold accepts mostly the wheels' upward fluctuations); a mean that the
    incoherent-wheel model says this slope fit would misread by more than
    ``max_slope_bias`` on any of the pass-bys ('model_bias') is not reported either.
    ``slopes[r][b]``: per-wheel values; ``contexts[r][b]``: (positions, step, L3, smear
    positions, smear weights) of recording r in band b.
    """
    nr, nb = len(slopes), len(slopes[0])
    value, raw, status, std_w, n_w, std_p, n_p = [], [], [], [], [], [], []
    per_pass = np.full((nr, nb), np.nan)
    per_status = [["" for _ in range(nb)] for _ in range(nr)]
    for b in range(nb):
        groups = [np.asarray(slopes[r][b], dtype=float) for r in range(nr)]
        groups = [g[np.isfinite(g)] for g in groups]
        v = np.concatenate(groups)
        for r, g in enumerate(groups):
            per_pass[r, b] = g.mean() if g.size else np.nan
        mean = float(v.mean()) if v.size else float("nan")
        se = float(v.std(ddof=1) / math.sqrt(v.size)) if v.size > 1 else math.inf
        if v.size < 3:
            code, codes = "too_few_points", ["too_few_points"] * nr
        elif min(contexts[r][b][2] for r in range(nr)) < opts.min_block_bt:
            code, codes = "low_bt", ["low_bt"] * nr
        elif not mean > opts.slope_min_se * se:
            code, codes = "not_resolved", ["not_resolved"] * nr
        else:
            bias = [slope_model_bias(mean, *contexts[r][b][0]) for r in range(nr)]
            codes = ["model_bias" if abs(x) > opts.max_slope_bias else
                     "noise_floor" if contexts[r][b][1] < NOISE_FLOOR_HEADROOM_DB else "ok"
                     for r, x in enumerate(bias)]
            code = "ok" if all(c == "ok" for c in codes) else "+".join(
                sorted({c for c in codes if c != "ok"}))
        for r in range(nr):
            per_status[r][b] = codes[r]
        status.append(code)
        raw.append(mean)
        value.append(mean if code == "ok" else np.nan)
        std_w.append(v.std(ddof=1) if v.size > 1 else np.nan)
        n_w.append(int(v.size))
        finite = per_pass[np.isfinite(per_pass[:, b]), b]
        n_p.append(int(finite.size))
        std_p.append(finite.std(ddof=1) if finite.size > 1 else np.nan)
    return DecayEstimate(method="slope fitting", decay_rate=np.array(value),
                         raw=np.array(raw), status=tuple(status), std_wheels=np.array(std_w),
                         n_wheels=np.array(n_w), std_passbys=np.array(std_p),
                         n_passbys=np.array(n_p), per_passby=per_pass,
                         per_passby_status=tuple(tuple(x) for x in per_status))
