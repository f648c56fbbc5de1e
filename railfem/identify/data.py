"""What a fit compares: measured quantities, their geometry, and residuals in dB.

A ``Target`` holds the measured quantities a fit uses and the geometry the model must be
evaluated at; ``residuals(target, receptance)`` turns a model receptance at that geometry
into one residual array per quantity:

* ``point``: 20 lg |Y_model / Y_meas| of the point mobility per frequency and sensor (dB);
* ``phase``: the phase difference of the point mobility, wrapped to (-pi, pi], times
  20 lg(e) = 8.69 dB per radian: ln Y = ln|Y| + i arg Y, so a radian of phase weighs as
  much as a neper of magnitude;
* ``transfer``: 20 lg |Y_model / Y_meas| of the transfers at the chosen positions (dB);
* ``tdr``: 10 lg (D_model / D_meas) of the EN 15461 decay rate per band (dB). The model's
  decay rate goes through the same code (railfem.standards.en15461) with the positions the
  data's own estimate used (its noise-floor exclusion mask) and the same point weighting,
  so the estimator's own truncation bias is in both.

Band weights multiply the residuals of a band (FRF points inside the band's edges and the
band's decay rate); a weight 0 leaves the band out.
"""
from __future__ import annotations

import weakref
from dataclasses import dataclass, field

import numpy as np

from railfem import models
from railfem.estimators import tdr as tdr_estimator
from railfem.measurement import DecayRateMeasurement, HammerMeasurement
from railfem.standards import en15461, iec61260

QUANTITIES = ("point", "phase", "transfer", "tdr")
DB_PER_NEPER = 20.0 / np.log(10.0)


@dataclass(frozen=True, kw_only=True, eq=False)
class Target:
    """Measured quantities and the geometry to evaluate the model at (SI, frequency axis 0).

    frequency: (nf,) narrow-band Hz. outputs: the sensors ('head'/'foot'). sensor_x: m.
    positions: (n_pos,) hammer distances from the sensor, m, positions[0] the point (its
    realised offset, > 0 allowed). use: the quantities fitted (QUANTITIES).
    point: (nf, n_out) complex mobility at positions[0] or None. transfer: (nf, n_out, n_sel)
    complex mobilities at positions[transfer_index]. frf_weight: (nf,) weight of each
    frequency point (0 = not fitted). bands: ThirdOctaveBands of the decay rate; tdr:
    (n_bands, n_out) measured decay rates (dB/m, NaN = not used); tdr_used: (n_bands, n_out,
    n_pos) positions the data's estimate used, or None (all); tdr_point_offset: the x_0 of
    the EN 15461 weights (0 = nominal); band_weight: (n_bands,).
    description: free text for reports.
    """

    frequency: np.ndarray
    outputs: tuple[str, ...]
    sensor_x: float
    positions: np.ndarray
    use: tuple[str, ...]
    point: np.ndarray | None = None
    transfer: np.ndarray | None = None
    transfer_index: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    frf_weight: np.ndarray | None = None
    bands: iec61260.ThirdOctaveBands | None = None
    tdr: np.ndarray | None = None
    tdr_used: np.ndarray | None = None
    tdr_point_offset: float = 0.0
    band_weight: np.ndarray | None = None
    description: str = ""

    def __post_init__(self):
        unknown = set(self.use) - set(QUANTITIES)
        if unknown or not self.use:
            raise ValueError(f"use = {self.use!r}: choose among {', '.join(QUANTITIES)}")
        need = {"point": self.point, "phase": self.point, "transfer": self.transfer,
                "tdr": self.tdr}
        for q in self.use:
            if need[q] is None:
                raise ValueError(f"the data have no {q!r} quantity (a decay-rate table has "
                                 "only 'tdr'; a hammer dataset has all four)")
        if "transfer" in self.use and len(self.transfer_index) == 0:
            raise ValueError("use includes 'transfer' but no transfer positions are chosen")

    @property
    def force_x(self) -> np.ndarray:
        """Absolute hammer positions (m): the point at its realised offset."""
        return self.sensor_x + self.positions

    @property
    def nominal_positions(self) -> np.ndarray:
        """EN 15461 positions with the point at 0."""
        x = self.positions.copy()
        x[0] = 0.0
        return x

    def measured(self) -> dict:
        """The measured values per quantity (for reports and plots)."""
        out = {}
        if "point" in self.use or "phase" in self.use:
            out["point"] = self.point
        if "transfer" in self.use:
            out["transfer"] = self.transfer
        if "tdr" in self.use:
            out["tdr"] = self.tdr
        return out


def model_quantities(target: Target, receptance: np.ndarray, power=None) -> dict:
    """The model's point/transfer mobilities and decay rates at the target's geometry from
    its receptance (nf, n_out, n_pos). ``power``: the receptance whose band power the decay
    rate is taken from, where it differs from the level in dB (a random additive term:
    railfem.diagnosis.effects.noise_floor); default ``receptance``."""
    f = target.frequency
    Y = 2j * np.pi * f[:, None, None] * receptance
    out = {}
    if target.point is not None:
        out["point"] = Y[:, :, 0]
    if target.transfer is not None:
        out["transfer"] = Y[:, :, target.transfer_index]
    if target.tdr is not None:
        Yp = Y if power is None else 2j * np.pi * f[:, None, None] * power
        out["tdr"] = model_decay_rate(target, Yp)
    return out


def model_decay_rate(target: Target, Y: np.ndarray) -> np.ndarray:
    """(n_bands, n_out) EN 15461 decay rate of the model mobilities Y (nf, n_out, n_pos),
    on the data's bands with the positions the data used."""
    fast = _fast_decay_rate(target, Y)
    if fast is not None:
        return fast
    power = iec61260.band_average(target.frequency, Y, target.bands) ** 2  # (b, o, pos)
    if target.tdr_used is not None:
        power = np.where(target.tdr_used, power, np.nan)
    D = np.empty(power.shape[:2])
    for o in range(power.shape[1]):
        D[:, o] = en15461.decay_rate_from_band_power(
            target.bands.nominal, power[:, o, :], target.nominal_positions,
            point_offset=target.tdr_point_offset).decay_rate
    return D


class _DecayPlan:
    """What the model decay rate of a target needs besides the model (computed once per
    target): the narrow-band points of each band in frequency order, and the (band,
    sensor) rows grouped by the positions the data used, with their interval weights.
    A band without narrow-band points has no power (NaN), hence no decay rate, as in
    band_average; its warning is logged once, when the plan is made."""

    def __init__(self, target: Target):
        member = iec61260.band_index(target.frequency, target.bands)
        members = [np.flatnonzero(member == k) for k in range(len(target.bands))]
        x = np.asarray(target.nominal_positions, dtype=float)
        offset = float(target.tdr_point_offset)
        self.full = np.array([len(m) > 0 for m in members])
        # no band with points, or positions en15461 refuses: the slow path (it raises)
        self.ok = bool(self.full.any() and x.ndim == 1 and x.size >= 2
                       and np.all(np.isfinite(x)) and x[0] == 0.0
                       and (offset == 0.0 or (np.isfinite(offset) and 0.0 <= offset < x[1])))
        if not self.ok:
            return
        iec61260.empty_bands(target.frequency, target.bands, member=member)  # its warning, once
        x_w = x.copy()
        x_w[0] = offset if offset != 0.0 else x[0]
        # the j-th point of every band that has one: band mean = ((p0 + p1) + p2) / n,
        # added in the order band_average's mean adds them
        self.steps = [(np.array([k for k, m in enumerate(members) if len(m) > j]),
                       np.array([m[j] for m in members if len(m) > j]))
                      for j in range(max(len(m) for m in members))]
        self.count = np.array([max(len(m), 1) for m in members], dtype=float)[:, None, None]
        n_b, n_o, n_p = len(members), len(target.outputs), x.size
        used = (np.ones((n_b, n_o, n_p), bool) if target.tdr_used is None
                else np.asarray(target.tdr_used, dtype=bool))
        # the positions en15461 sums over for a finite model: the data's, the point
        # always; none where the data left the point out (its power is then NaN)
        keep = np.where(used[:, :, :1], used, False).reshape(n_b * n_o, n_p)
        keep[:, 0] = True
        self.groups = []
        patterns, which = np.unique(keep, axis=0, return_inverse=True)
        for g, pattern in enumerate(patterns):
            if pattern.sum() < 2:
                continue
            xu = x_w[pattern]
            gaps = np.diff(xu)
            dx = np.empty_like(xu)
            dx[0], dx[-1] = gaps[0] / 2.0, gaps[-1] / 2.0
            dx[1:-1] = (gaps[:-1] + gaps[1:]) / 2.0
            rows = np.flatnonzero(np.asarray(which).ravel() == g)
            self.groups.append((rows, np.flatnonzero(pattern), dx))

    def band_power(self, Y: np.ndarray) -> np.ndarray:
        """iec61260.band_average(f, Y, bands) ** 2 to the last bit, Y (nf, o, pos): (b, o,
        pos)."""
        power = np.abs(Y) ** 2
        acc = np.full((len(self.full),) + power.shape[1:], np.nan)  # an empty band: NaN
        acc[self.steps[0][0]] = power[self.steps[0][1]]
        for k, i in self.steps[1:]:
            acc[k] += power[i]
        return np.sqrt(acc / self.count) ** 2


_DECAY_PLANS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _fast_decay_rate(target: Target, Y: np.ndarray) -> np.ndarray | None:
    """model_decay_rate without a Python loop over bands and sensors (a fit evaluates it
    for every Jacobian column): the same operations in the same order as
    iec61260.band_average and en15461.decay_rate_from_band_power (equal to the last bit);
    None where that path would take a branch this one does not (a model band power that
    is not finite or not positive in a band with points): the caller then takes it."""
    plan = _DECAY_PLANS.get(target)
    if plan is None:
        plan = _DECAY_PLANS[target] = _DecayPlan(target)
    if not plan.ok or Y.ndim != 3:
        return None
    power = plan.band_power(Y)
    full = power[plan.full]
    if not (np.all(np.isfinite(full)) and np.all(full[:, :, 0] > 0.0)):
        return None
    n_b, n_o, n_p = power.shape
    P = power.reshape(n_b * n_o, n_p)
    D = np.full(n_b * n_o, np.nan)
    drop = np.full(n_b * n_o, np.nan)
    for rows, idx, dx in plan.groups:
        terms = P[rows[:, None], idx[None, :]] / P[rows, :1] * dx  # ratio[used] * dx
        D[rows] = en15461.DB_PER_NEPER_POWER / terms.sum(axis=1)
        with np.errstate(divide="ignore"):  # a zero far power: the drop is infinite
            drop[rows] = -10.0 * np.log10(P[rows, idx[-1]] / P[rows, 0])
    D, drop = D.reshape(n_b, n_o), drop.reshape(n_b, n_o)
    with np.errstate(invalid="ignore"):  # the far-field note of the slow path, per sensor
        failing = ~(np.isfinite(D) & (drop >= en15461.FAR_FIELD_DROP_DB))
    for o in range(n_o):
        en15461.note_far_field(np.asarray(target.bands.nominal, float)[failing[:, o]])
    return D


def residuals(target: Target, receptance: np.ndarray) -> dict:
    """Residual arrays in dB per quantity (model - measurement), weighted by the band and
    frequency weights; entries with weight 0 or no data are dropped (flattened arrays)."""
    q = model_quantities(target, receptance)
    out = {}
    w = target.frf_weight
    if "point" in target.use:
        r = DB_PER_NEPER * np.log(np.abs(q["point"]) / np.abs(target.point))
        out["point"] = (w[:, None] * r)[w > 0].ravel()
    if "phase" in target.use:
        d = np.angle(q["point"] / target.point)
        out["phase"] = (w[:, None] * DB_PER_NEPER * d)[w > 0].ravel()
    if "transfer" in target.use:
        r = DB_PER_NEPER * np.log(np.abs(q["transfer"]) / np.abs(target.transfer))
        out["transfer"] = (w[:, None, None] * r)[w > 0].ravel()
    if "tdr" in target.use:
        ok = np.isfinite(target.tdr) & (target.band_weight[:, None] > 0)
        r = 10 * np.log10(q["tdr"] / target.tdr)
        r = np.where(np.isfinite(r), r, 30.0)  # a model band without a decay rate: far off
        out["tdr"] = (target.band_weight[:, None] * r)[ok]
    return out


def residual_table(target: Target, receptance: np.ndarray, power=None) -> dict:
    """Unweighted residuals (dB) per quantity on their axes, NaN where not fitted, for
    reports: point/phase (nf, n_out), transfer (nf, n_out, n_sel), tdr (n_bands, n_out);
    ``power`` as in model_quantities."""
    q = model_quantities(target, receptance, power)
    out = {}
    fit_f = target.frf_weight > 0
    if "point" in target.use:
        r = DB_PER_NEPER * np.log(np.abs(q["point"]) / np.abs(target.point))
        out["point"] = np.where(fit_f[:, None], r, np.nan)
    if "phase" in target.use:
        r = DB_PER_NEPER * np.angle(q["point"] / target.point)
        out["phase"] = np.where(fit_f[:, None], r, np.nan)
    if "transfer" in target.use:
        r = DB_PER_NEPER * np.log(np.abs(q["transfer"]) / np.abs(target.transfer))
        out["transfer"] = np.where(fit_f[:, None, None], r, np.nan)
    if "tdr" in target.use:
        ok = np.isfinite(target.tdr) & (target.band_weight[:, None] > 0)
        out["tdr"] = np.where(ok, 10 * np.log10(q["tdr"] / target.tdr), np.nan)
    return out


def _band_weights(bands, band_weights) -> np.ndarray:
    w = np.ones(len(bands))
    for centre, value in (band_weights or {}).items():
        k = np.flatnonzero(np.isclose(bands.nominal, float(centre), rtol=0.03))
        if k.size == 0:
            raise ValueError(f"band weight for {centre!r} Hz: no such one-third-octave band "
                             f"in the data ({bands.nominal.tolist()} Hz)")
        if not (np.isfinite(value) and value >= 0):
            raise ValueError(f"band weight for {centre} Hz is {value!r}: give a number >= 0")
        w[k] = float(value)
    return w


def _frf_weights(frequency, bands, band_w, f_range) -> np.ndarray:
    k = iec61260.band_index(frequency, bands)
    w = np.where(k >= 0, np.asarray(band_w, dtype=float)[k], 0.0)
    if f_range is not None:
        lo, hi = f_range
        w[(frequency < lo) | (frequency > hi)] = 0.0
    return w


def nearest_positions(positions: np.ndarray, wanted) -> np.ndarray:
    """Indices of the measured positions nearest to ``wanted`` (m), point excluded."""
    idx = sorted({int(np.argmin(np.abs(positions[1:] - float(x)))) + 1 for x in wanted})
    return np.array(idx, dtype=int)


def hammer_target(meas: HammerMeasurement, *, use=("point", "transfer", "tdr"),
                  sensors=None, transfer_positions=None, f_range=None, band_weights=None,
                  exclusion=tdr_estimator.NoiseFloorExclusion(), point: str = "nominal",
                  sensor_map=None, tdr_positions=None) -> Target:
    """A Target from a hammer measurement.

    sensors: sensor names used (default all); sensor_map: {name: 'head'|'foot'} where the
    names are not head/foot already. transfer_positions: distances (m) whose nearest
    measured transfers are fitted (default d/2, d, 2d, 4d with d the sleeper spacing).
    f_range: (low, high) Hz of the FRF points fitted. exclusion, point: the EN 15461
    options of the data's decay rate (railfem.estimators.tdr.hammer); the model's decay
    rate uses the same positions and weights. tdr_positions: indices of the positions the
    decay rate sums over (the point always; default all), e.g. to keep held-out transfers
    out of it."""
    names = list(meas.sensor_names if sensors is None else
                 ([sensors] if isinstance(sensors, str) else sensors))
    smap = dict(sensor_map or {})
    outputs = tuple(smap.get(n, n) for n in names)
    if meas.sensor_x is None:
        raise ValueError("the measurement has no sensor_x (sensor position along the rail "
                         "with sleepers at multiples of the spacing); give it, e.g. d/2 for "
                         "mid-span")
    if meas.frf.quantity != "mobility":
        meas = HammerMeasurement(frf=meas.frf.to("mobility"), positions=meas.positions,
                                 sensors=meas.sensors, sleeper_spacing=meas.sleeper_spacing,
                                 sensor_x=meas.sensor_x, excitation=meas.excitation,
                                 rail=meas.rail, metadata=meas.metadata)
    f = meas.frequency
    bands = iec61260.third_octave_bands(float(f.min()), float(f.max()))
    band_w = _band_weights(bands, band_weights)
    Y = np.stack([meas.transfer(n) for n in names], axis=1)  # (nf, n_out, n_pos)
    d = meas.sleeper_spacing
    wanted = (d / 2, d, 2 * d, 4 * d) if transfer_positions is None else transfer_positions
    t_idx = nearest_positions(meas.positions, wanted)
    tdr = used = None
    if "tdr" in use:
        keep = (np.arange(len(meas.positions)) if tdr_positions is None else
                np.unique(np.concatenate([[0], np.asarray(tdr_positions, dtype=int)])))
        sub = meas.with_positions(keep)
        res = [tdr_estimator.hammer(sub, n, exclusion=exclusion, bands=bands, point=point)
               for n in names]
        tdr = np.stack([np.where(r.suitable, r.decay_rate, np.nan) for r in res], axis=1)
        used = np.zeros((len(bands.nominal), len(names), len(meas.positions)), dtype=bool)
        used[:, :, keep] = np.stack([r.used for r in res], axis=1)
    return Target(frequency=f, outputs=outputs, sensor_x=float(meas.sensor_x),
                  positions=np.asarray(meas.positions, dtype=float), use=tuple(use),
                  point=Y[:, :, 0], transfer=Y[:, :, t_idx], transfer_index=t_idx,
                  frf_weight=_frf_weights(f, bands, band_w, f_range), bands=bands, tdr=tdr,
                  tdr_used=used,
                  tdr_point_offset=meas.point_offset if point == "realised" else 0.0,
                  band_weight=band_w,
                  description=f"hammer test, sensors {names}, {len(meas.positions)} positions")


def decay_rate_target(meas: DecayRateMeasurement, spacing: float, *, sensor: str = "head",
                      positions=None, point_offset: float = models.POINT_OFFSET,
                      band_weights=None) -> Target:
    """A Target from a measured decay rate per band (e.g. a row of a decay-rate table): the
    model is evaluated as an EN 15461 test on it (sensor at mid-span, the standard's
    positions for ``spacing`` unless given, the point struck ``point_offset`` m away) on a
    1/9-octave grid covering the bands; bands not valid in the data are left out. A lateral
    decay rate (direction 'y') is modelled with the lateral channel 'head_lateral' (lateral
    hammer and sensor on the side of the head, railfem.models), which needs a base spec
    whose supports act laterally (support_directions with 'y')."""
    if meas.direction not in ("z", "y"):
        raise ValueError(f"this decay rate is direction {meas.direction!r}: the models give "
                         "vertical ('z'/'v') and lateral ('y'/'h') decay rates")
    if meas.direction == "y" and sensor in models.WHERE:
        sensor = "head_lateral"  # lateral hammer and sensor on the side of the head
    centres = np.asarray(meas.frequency, dtype=float)
    f = iec61260.ninth_octave_grid(float(centres.min()), float(centres.max()))
    bands = iec61260.third_octave_bands(float(centres.min()), float(centres.max()))
    if len(bands) != len(centres) or np.any(np.abs(bands.nominal / centres - 1) > 0.03):
        raise ValueError(f"the decay-rate bands {centres.tolist()} Hz are not a contiguous "
                         "run of one-third-octave bands")
    pos = en15461.hammer_positions(spacing) if positions is None else np.asarray(positions)
    pos = pos.astype(float).copy()
    pos[0] = point_offset
    tdr = np.where(meas.valid, meas.decay_rate, np.nan)[:, None]
    return Target(frequency=f, outputs=(sensor,), sensor_x=spacing / 2, positions=pos,
                  use=("tdr",), bands=bands, tdr=tdr, tdr_point_offset=0.0,
                  band_weight=_band_weights(bands, band_weights),
                  frf_weight=np.zeros(len(f)),
                  description="decay rate per band" + (f", {meas.metadata.section} "
                                                        f"{meas.metadata.date}"
                                                        if meas.metadata.section else ""))
