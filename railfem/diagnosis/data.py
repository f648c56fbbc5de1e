"""What a diagnosis works on: records (one measurement each) split into fitted and held-out
parts, with the covariates (temperature, static load) campaign effects need.

* a hammer test (railfem.measurement.HammerMeasurement): the point mobility, the decay rate
  and two thirds of the transfer positions are fitted; every third transfer position
  (positions 2, 5, 8, ... counting the point as 0) is held out. Transfers whose band level
  is more than 60 dB below the point mobility's are not compared. The decay rate uses all
  positions (EN 15461), so the held-out transfers enter the fit only through it;
* a decay rate per band (DecayRateMeasurement, a row of a table): every third band
  (the 2nd, 5th, 8th, ...) is held out; vertical rows (direction 'z') and lateral rows
  (direction 'y', a table's 'h'; railfem.identify.data.decay_rate_target models them with
  the lateral hammer and sensor on the side of the head, 'head_lateral'), alone or
  together (``directions``, select_directions);
* pass-by decay rates (railfem.estimators.passby.PassbyDecayRate, the estimators' result
  on recordings): one decay-rate record per pass-by (``passby_decay_rates``), repeats of
  each other, every third band held out as for a table row;
* several records (a DecayRateTable, or a list of measurements): one track fitted to all
  of them at once; campaign effects (railfem.diagnosis.effects.temperature, .preload) let
  a parameter follow each record's covariate.

The fitted and held-out parts of a record are railfem.identify.data.Targets on the same
geometry, so one model evaluation serves both.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from railfem import models
from railfem.estimators.passby import PassbyDecayRate
from railfem.identify import data as fdata
from railfem.measurement import (DecayRateMeasurement, DecayRateTable, HammerMeasurement,
                                 Metadata)
from railfem.standards import iec61260

HOLD_EVERY = 3
DYNAMIC_RANGE_DB = 60.0
LINE_RANGE_DB = 100.0  # single lines below this (dB re point) are never compared
COVARIATES = ("temperature_c", "static_load_kn")


@dataclass(frozen=True, kw_only=True, eq=False)
class Record:
    """One measurement: name, kind ('hammer' or 'tdr'), the fitted and held-out Targets
    (same geometry), its metadata and its covariates {name: (value, campaign mean)}."""

    name: str
    kind: str
    fit: fdata.Target
    held: fdata.Target | None
    metadata: Metadata = field(default_factory=Metadata)
    covariates: dict = field(default_factory=dict)
    held_positions: tuple = ()
    held_bands: tuple = ()

    def covariate(self, name: str) -> tuple[float, float]:
        if name not in self.covariates:
            raise ValueError(f"record {self.name!r} has no {name!r} (metadata); campaign "
                             f"effects need it on every record")
        return self.covariates[name]

    @property
    def geometry_key(self) -> tuple:
        t = self.fit
        return (tuple(np.round(t.frequency, 9)), t.outputs, round(float(t.sensor_x), 9),
                tuple(np.round(t.force_x, 9)))


@dataclass(frozen=True, kw_only=True, eq=False)
class DiagnosisData:
    """The records diagnosed together, the sleeper spacing and a description."""

    records: tuple[Record, ...]
    spacing: float
    description: str = ""

    def __post_init__(self):
        if not self.records:
            raise ValueError("a diagnosis needs at least one record")
        object.__setattr__(self, "records", tuple(self.records))

    @property
    def kinds(self) -> set:
        return {r.kind for r in self.records}

    @property
    def lateral(self) -> bool:
        """Whether any record is lateral (a lateral decay rate: channel 'head_lateral')."""
        return any(is_lateral(r) for r in self.records)

    @property
    def lateral_only(self) -> bool:
        """Whether every record is lateral."""
        return all(is_lateral(r) for r in self.records)

    def has_covariate(self, name: str, spread: float) -> bool:
        """Every record has the covariate and it varies by at least ``spread``."""
        vals = [r.covariates.get(name, (None,))[0] for r in self.records]
        if any(v is None for v in vals) or len(vals) < 2:
            return False
        return max(vals) - min(vals) >= spread


def is_lateral(record: Record) -> bool:
    """Whether ``record`` is lateral (its channel is lateral, railfem.models.LATERAL: a
    lateral hammer and sensor on the side of the head)."""
    return any(o in models.LATERAL for o in record.fit.outputs)


#: why an effect of the rail's roll and lateral motion is not tried on vertical data
LATERAL_ONLY = ("acts on the rail's roll and lateral motion, which vertical data cannot "
                "see (a vertical load on the mirror plane excites the symmetric waves "
                "only): give lateral decay rates (direction 'y')")
DIRECTIONS = ("z", "y")


def select_directions(rows: list, directions: str | None = None) -> list:
    """The decay-rate rows of ``directions`` ('z' vertical, 'y' lateral, 'zy' both); None:
    the vertical rows when there are any (a table's lateral rows are then left out, as
    before lateral rows were diagnosed), else the lateral ones."""
    if directions is None:
        vertical = [r for r in rows if r.direction == "z"]
        directions = "z" if vertical or not rows else "y"
    if not directions or not set(directions) <= set(DIRECTIONS):
        raise ValueError(f"directions = {directions!r}: give 'z' (vertical rows), 'y' "
                         "(lateral rows) or 'zy' (both)")
    out = [r for r in rows if r.direction in directions]
    if not out:
        have = sorted({r.direction for r in rows})
        raise ValueError(f"the decay rates hold no rows of direction(s) {directions!r} "
                         f"(they have {have}): 'z' vertical ('v' in a table), 'y' lateral "
                         "('h')")
    return out


def _covariate_values(metadata: Metadata) -> dict:
    out = {}
    if metadata.temperature_c is not None:
        out["temperature_c"] = float(metadata.temperature_c)
    load = metadata.notes.get("static_load_kn") if metadata.notes else None
    if load is not None:
        try:
            out["static_load_kn"] = float(load)
        except (TypeError, ValueError):
            raise ValueError(f"metadata notes static_load_kn = {load!r}: give the static load "
                             "per fastener in kN as a number") from None
    return out


def _with_means(records: list[Record]) -> list[Record]:
    means = {}
    for name in COVARIATES:
        vals = [r.covariates[name][0] for r in records if name in r.covariates]
        if len(vals) == len(records):
            means[name] = float(np.mean(vals))
    return [replace(r, covariates={k: (v[0], means.get(k, v[0])) for k, v in
                                   r.covariates.items()}) for r in records]


def _mask(target: fdata.Target) -> fdata.Target:
    """Transfers whose band RMS is more than DYNAMIC_RANGE_DB below the point mobility's are
    not compared (NaN, the whole band at that position): no hammer test resolves them, and
    the model's eigen form of the coupling is accurate to 1e-8 of the largest response
    (railfem.identify.spectral), i.e. to 1e-5 at -60 dB. The rule reads band levels, not
    single lines: dropping single lines that dip deep (a noise floor's log-Rayleigh scatter
    does) would censor the data on their own noise and bias what is fitted to them (a noise
    floor came out 0.4 dB high in every blind run). Single lines more than LINE_RANGE_DB
    below the point are dropped all the same: within a band a far transfer can fall by
    100 dB and more where the track attenuates fast, far below what any test resolves and
    where the eigen form loses its digits (a floor 60 dB under the point has such dips once
    in 10^6 lines)."""
    k = iec61260.band_index(target.frequency, target.bands)
    tr = np.abs(target.transfer)
    pt = np.abs(target.point)[:, :, None]
    level, ref = tr.copy(), np.broadcast_to(pt, tr.shape).copy()
    for i in np.unique(k[k >= 0]):
        sel = k == i
        with np.errstate(invalid="ignore"):
            level[sel] = np.sqrt(np.nanmean(tr[sel] ** 2, axis=0))
        ref[sel] = np.sqrt(np.mean(pt[sel] ** 2, axis=0))
    keep = ((level >= ref * 10 ** (-DYNAMIC_RANGE_DB / 20))
            & (tr >= pt * 10 ** (-LINE_RANGE_DB / 20)))
    return replace(target, transfer=np.where(keep, target.transfer, np.nan))


def in_band(meas: HammerMeasurement, f_range) -> HammerMeasurement:
    """The hammer test on the frequencies inside ``f_range`` (low, high) Hz only (None:
    all): the diagnosis then fits, holds out and judges only there (the FRF points and the
    decay-rate bands they make)."""
    if f_range is None:
        return meas
    lo, hi = (float(v) for v in f_range)
    f = meas.frequency
    keep = (f >= lo) & (f <= hi)
    if keep.sum() < 2:
        raise ValueError(f"f_range = ({lo:g}, {hi:g}) Hz keeps {int(keep.sum())} of the "
                         f"measured frequencies ({f.min():g} to {f.max():g} Hz): give a band "
                         "inside the measured one")
    frf = replace(meas.frf, frequency=f[keep], values=meas.frf.values[keep])
    return replace(meas, frf=frf)


def hammer_record(meas: HammerMeasurement, name: str = "hammer", *, sensors=None,
                  f_range=None, hold_every: int = HOLD_EVERY, **options) -> Record:
    """A Record of a hammer test: point, decay rate and the transfers not held out fitted
    (the decay rate over the point and the fitted positions: nothing of the held-out
    transfers enters the fit). f_range: (low, high) Hz, the band diagnosed (in_band)."""
    meas = in_band(meas, f_range)
    if hold_every < 2:
        raise ValueError(f"hold_every = {hold_every!r}: hold out every n-th transfer position "
                         "with n >= 2")
    pos = np.asarray(meas.positions, dtype=float)
    idx = np.arange(1, len(pos))
    held = idx[(idx + 1) % hold_every == 0]
    fitted = np.setdiff1d(idx, held)
    if len(fitted) < 2 or len(held) < 1:
        raise ValueError(f"the hammer test has {len(pos)} positions: too few to hold some out "
                         "(need at least 4)")
    common = dict(sensors=sensors, **options)
    # the fitted decay rate is the EN 15461 sum over the fitted positions only: over all of
    # them it would carry the held-out transfers into the fit (in aggregate, per band)
    fit = _mask(fdata.hammer_target(meas, use=("point", "transfer", "tdr"),
                                    transfer_positions=pos[fitted], tdr_positions=fitted,
                                    **common))
    held_t = _mask(fdata.hammer_target(meas, use=("transfer",), transfer_positions=pos[held],
                                       **common))
    covs = {k: (v, v) for k, v in _covariate_values(meas.metadata).items()}
    return Record(name=name, kind="hammer", fit=fit, held=held_t, metadata=meas.metadata,
                  covariates=covs, held_positions=tuple(pos[held].tolist()))


def tdr_record(meas: DecayRateMeasurement, spacing: float, name: str = "tdr", *,
               hold_every: int = HOLD_EVERY, **options) -> Record:
    """A Record of a decay rate per band: every hold_every-th band held out. The model's
    decay rate is taken at the measurement's sensor (head or foot) when it names one."""
    if meas.sensor in ("head", "foot"):
        options.setdefault("sensor", meas.sensor)
    t = fdata.decay_rate_target(meas, spacing, **options)
    k = np.arange(len(t.bands))
    held = (k + 2) % hold_every == 0
    valid = np.isfinite(t.tdr[:, 0])
    if np.sum(valid & ~held) < 4 or np.sum(valid & held) < 1:
        raise ValueError(f"record {name!r}: {int(valid.sum())} valid bands are too few to "
                         "hold some out (need at least 5)")
    fit = replace(t, band_weight=np.where(held, 0.0, t.band_weight))
    held_t = replace(t, band_weight=np.where(held, t.band_weight, 0.0))
    covs = {k_: (v, v) for k_, v in _covariate_values(meas.metadata).items()}
    return Record(name=name, kind="tdr", fit=fit, held=held_t, metadata=meas.metadata,
                  covariates=covs, held_bands=tuple(t.bands.nominal[held].tolist()))


PASSBY_METHODS = ("energy", "slope")
MIN_PASSBY_BANDS = 6  # valid bands a pass-by needs to be a record of its own


def check_passby_method(method: str) -> None:
    if method not in PASSBY_METHODS:
        raise ValueError(f"pass-by method {method!r}: use one of {PASSBY_METHODS}")


def passby_decay_rates(result, *, method: str = "energy", sensor: str = "foot",
                       section: str = "pass-by", date: str | None = None) -> list:
    """Decay-rate records of a railfem.estimators.passby.PassbyDecayRate by ``method``
    ('energy': energy iteration, 'slope': slope fitting; NaN where the estimator rejected
    a band), taken at the recordings' sensor (the model's EN 15461 decay rate is evaluated
    there): one record per pass-by when every pass-by has at least MIN_PASSBY_BANDS valid
    bands (they share ``section`` and ``date``, so the diagnosis treats them as repeats and
    tests the residual against their scatter), else one record of the estimate pooled over
    the pass-bys."""
    check_passby_method(method)
    est = getattr(result, method)
    f = np.asarray(result.bands.nominal, dtype=float)

    def row(d, tag):
        d = np.asarray(d, dtype=float)
        return DecayRateMeasurement(
            frequency=f, decay_rate=np.where(np.isfinite(d) & (d > 0), d, np.nan),
            direction="z", sensor=sensor,
            metadata=Metadata(section=section, date=date, rail_side=tag,
                              notes={"estimator": method, "passby": tag}))

    per = np.asarray(est.per_passby, dtype=float)
    if len(per) > 1 and np.all(np.sum(np.isfinite(per) & (per > 0), axis=1)
                               >= MIN_PASSBY_BANDS):
        return [row(d, name or f"pass-by {k}") for k, (d, name)
                in enumerate(zip(per, result.names))]
    return [row(est.decay_rate, f"{len(per)} pass-by(s) pooled")]


def record_name(meta: Metadata, i: int) -> str:
    parts = [p for p in (meta.section, meta.date, meta.rail_side) if p]
    return " ".join(parts) if parts else f"row {i}"


DECAY_RATES = (DecayRateMeasurement, DecayRateTable, PassbyDecayRate)


def _rows(item) -> list:
    """The DecayRateMeasurement rows of a decay-rate item (DECAY_RATES)."""
    if isinstance(item, DecayRateTable):
        return item.rows()
    return passby_decay_rates(item) if isinstance(item, PassbyDecayRate) else [item]


def prepare(data, *, spacing: float | None = None, directions: str | None = None,
            **options) -> DiagnosisData:
    """DiagnosisData from a HammerMeasurement, a DecayRateMeasurement, a DecayRateTable, a
    PassbyDecayRate (one record per pass-by), a list of those, or DiagnosisData (returned
    as is). spacing: sleeper spacing (m) for decay rates (hammer tests carry their own).
    directions: the decay-rate rows diagnosed ('z', 'y' or 'zy'; default: the vertical
    rows, or the lateral ones when there are no vertical rows; select_directions). A
    lateral row's record is named with a trailing ' lateral'."""
    if isinstance(data, DiagnosisData):
        return data
    items = list(data) if isinstance(data, (list, tuple)) else [data]
    rows_of = {i: _rows(item) for i, item in enumerate(items) if isinstance(item, DECAY_RATES)}
    every = [r for rs in rows_of.values() for r in rs]
    # over every item: the rows of ``directions`` (by default vertical if there are any)
    kept = set(map(id, select_directions(every, directions))) if every else set()
    records, spacings, desc = [], [], []
    for i, item in enumerate(items):
        if isinstance(item, HammerMeasurement):
            name = record_name(item.metadata, i) if len(items) > 1 else "hammer"
            records.append(hammer_record(item, name, **options))
            spacings.append(item.sleeper_spacing)
            desc.append(f"hammer test, {len(item.positions)} positions, sensors "
                        f"{', '.join(item.sensor_names)}")
        elif isinstance(item, DECAY_RATES):
            rows = [r for r in rows_of[i] if id(r) in kept]
            if not rows:
                continue
            if spacing is None:
                raise ValueError("diagnosing a decay rate needs the sleeper spacing (m), "
                                 "e.g. spacing=0.6")
            for j, r in enumerate(rows):
                name = record_name(r.metadata, j) + (" lateral" if r.direction == "y" else "")
                records.append(tdr_record(r, spacing, name, **options))
            spacings.append(spacing)
            n_lat = sum(r.direction == "y" for r in rows)
            desc.append(f"{len(rows)} decay rate(s) per band"
                        + (f" ({n_lat} lateral)" if n_lat else ""))
        else:
            raise TypeError(f"cannot diagnose {type(item).__name__}: give a "
                            "HammerMeasurement, DecayRateMeasurement, DecayRateTable or "
                            "PassbyDecayRate")
    if spacing is None:
        spacing = spacings[0]
    if any(abs(s - spacing) > 1e-9 for s in spacings):
        raise ValueError(f"the records have different sleeper spacings {sorted(set(spacings))} "
                         "m: diagnose them separately")
    records.sort(key=is_lateral)  # vertical first: a base's start fit takes the first
    return DiagnosisData(records=tuple(_with_means(records)), spacing=float(spacing),
                         description="; ".join(desc))
