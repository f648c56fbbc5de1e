"""Measurements as objects: FRFs and decay rates with the geometry that makes them meaningful.

* :class:`HammerMeasurement` — an EN 15461 hammer test: transfer FRFs (one response per
  sensor, one force per hammer position) + hammer distances from the sensor, the sensors
  (location on the section and direction), sleeper spacing, rail and free metadata.
* :class:`DecayRateMeasurement` — one decay rate per one-third-octave band (dB/m) with its
  direction and metadata; :class:`DecayRateTable` — many of them on the same bands (e.g. a
  campaign: rows = measurements), with selection by direction, section, date, rail side.
* :class:`Metadata` — date, temperature, section, rail side and any further notes.

Readers and writers live in :mod:`railfem.io`; the decay rate of a hammer measurement comes
from :func:`railfem.estimators.tdr.hammer`. Simulated data use the same classes, so one
estimator serves both. Directions are the axis names of :mod:`railfem.conventions`
(x along the rail, y lateral, z vertical); :func:`direction_name` maps the usual aliases.
"""
from __future__ import annotations

import datetime as _dt
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from types import MappingProxyType

import numpy as np

from railfem import validators as v
from railfem.conventions import DIRECTIONS
from railfem.response import FRF

__all__ = [
    "DIRECTION_ALIASES",
    "direction_name",
    "Metadata",
    "Sensor",
    "HammerMeasurement",
    "DecayRateMeasurement",
    "DecayRateTable",
]

#: Names accepted for a direction, mapped to the axis name (conventions.DIRECTIONS).
#: 'v'/'h' are the vertical/horizontal columns of field reports (horizontal = lateral).
DIRECTION_ALIASES = {
    "x": "x", "longitudinal": "x",
    "y": "y", "lateral": "y", "h": "y", "horizontal": "y",
    "z": "z", "vertical": "z", "v": "z",
}


def direction_name(direction: str, name: str = "direction") -> str:
    """The axis name ('x', 'y' or 'z') of ``direction`` (an axis name or an alias)."""
    key = str(direction).strip().lower()
    if key not in DIRECTION_ALIASES:
        raise ValueError(
            f"{name} = {direction!r} is unknown; use one of {', '.join(DIRECTIONS)} "
            f"(aliases: {', '.join(k for k in DIRECTION_ALIASES if k not in DIRECTIONS)}).")
    return DIRECTION_ALIASES[key]


def _json_scalar_tree(name: str, value):
    """A deep copy of ``value`` made of JSON types (dict keys str); raises otherwise."""
    if isinstance(value, Mapping):
        return {str(k): _json_scalar_tree(f"{name}[{k!r}]", x) for k, x in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_scalar_tree(f"{name}[{i}]", x) for i, x in enumerate(value)]
    if value is None or isinstance(value, (str, bool, int)):
        return value
    if isinstance(value, (float, np.floating, np.integer)):
        return value.item() if hasattr(value, "item") else value
    raise ValueError(
        f"{name} = {value!r} ({type(value).__name__}) cannot be kept as metadata; use "
        "text, numbers, booleans, lists or mappings of them.")


def _freeze(tree):
    if isinstance(tree, dict):
        return MappingProxyType({k: _freeze(x) for k, x in tree.items()})
    if isinstance(tree, list):
        return tuple(_freeze(x) for x in tree)
    return tree


def _thaw(tree):
    if isinstance(tree, Mapping):
        return {k: _thaw(x) for k, x in tree.items()}
    if isinstance(tree, tuple):
        return [_thaw(x) for x in tree]
    return tree


@dataclass(frozen=True, kw_only=True)
class Metadata:
    """What is known about a measurement besides its data (all optional)."""

    date: str | None = None
    """Measurement date, ISO 8601 'YYYY-MM-DD'."""
    temperature_c: float | None = None
    """Temperature during the measurement (rail or air, as the source states), deg C."""
    section: str | None = None
    """Track section name, e.g. 'B5'."""
    rail_side: str | None = None
    """Which rail, as the source names it (e.g. 'left'/'right', 'li'/'re')."""
    notes: Mapping = field(default_factory=dict)
    """Everything else the source gives (text, numbers, lists, mappings); kept unchanged."""

    def __post_init__(self) -> None:
        if self.date is not None:
            try:
                _dt.date.fromisoformat(str(self.date))
            except ValueError:
                raise ValueError(
                    f"Metadata.date = {self.date!r} is not an ISO date; write YYYY-MM-DD."
                ) from None
            object.__setattr__(self, "date", str(self.date))
        if self.temperature_c is not None:
            t = v.finite("Metadata.temperature_c", self.temperature_c, "deg C")
            if t < -273.15:
                raise ValueError(f"Metadata.temperature_c = {t!r} deg C is below absolute zero.")
            object.__setattr__(self, "temperature_c", t)
        for name in ("section", "rail_side"):
            value = getattr(self, name)
            if value is not None and not isinstance(value, str):
                raise ValueError(f"Metadata.{name} = {value!r}: give text or None.")
        tree = _json_scalar_tree("Metadata.notes", self.notes)
        if not isinstance(tree, dict):
            raise ValueError(f"Metadata.notes must be a mapping, got {type(self.notes).__name__}.")
        object.__setattr__(self, "notes", _freeze(tree))

    def as_dict(self) -> dict:
        """Plain JSON-ready dict (None fields left out, notes under 'notes')."""
        out = {k: getattr(self, k) for k in ("date", "temperature_c", "section", "rail_side")
               if getattr(self, k) is not None}
        if self.notes:
            out["notes"] = _thaw(self.notes)
        return out

    @classmethod
    def from_dict(cls, d: Mapping) -> Metadata:
        """Inverse of :meth:`as_dict`; unknown keys raise (put them under 'notes')."""
        known = {"date", "temperature_c", "section", "rail_side", "notes"}
        extra = set(d) - known
        if extra:
            raise ValueError(f"unknown metadata key(s) {sorted(extra)}; known: {sorted(known)} "
                             "(put anything else under 'notes').")
        return cls(**dict(d))


@dataclass(frozen=True, kw_only=True)
class Sensor:
    """One accelerometer (or velocity transducer) on the rail section."""

    name: str
    """Label, also the FRF response label, e.g. 'head' or 'foot'."""
    direction: str = "z"
    """Measured direction: 'x', 'y' or 'z' (aliases as in :func:`direction_name`)."""
    y: float | None = None
    """Lateral position on the section, m, from the rail centreline (None: unknown)."""
    z: float | None = None
    """Height on the section, m, above the foot underside (None: unknown)."""
    note: str = ""
    """Free text, e.g. 'rail head, top centre'."""

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip():
            raise ValueError(f"Sensor.name = {self.name!r}: give a non-empty label, e.g. 'head'.")
        object.__setattr__(self, "direction", direction_name(self.direction, "Sensor.direction"))
        for c in ("y", "z"):
            if getattr(self, c) is not None:
                object.__setattr__(self, c, v.finite(f"Sensor.{c}", getattr(self, c), "m"))


@dataclass(frozen=True, kw_only=True, eq=False)
class HammerMeasurement:
    """An EN 15461 hammer test: the sensor stays, the hammer moves along the rail.

    ``frf.values[f, s, i]`` is the response of sensor ``s`` to the hammer at distance
    ``positions[i]`` from the sensor. The first position is the point FRF: EN 15461 puts
    it at 0; where the hammer cannot strike at the sensor it is realised a small distance
    away (the *point offset*, ``positions[0]``, e.g. 0.02 m).
    """

    frf: FRF
    """(n_freq, n_sensors, n_positions) transfer FRFs; response labels = sensor names."""
    positions: np.ndarray
    """(n_positions,) hammer distances from the sensor along the rail, m, strictly
    increasing; positions[0] the point FRF (0 or a realised offset < positions[1] / 2)."""
    sensors: tuple[Sensor, ...]
    """One per FRF response, in the same order and with the same names."""
    sleeper_spacing: float
    """Sleeper (support) spacing, m."""
    sensor_x: float | None = None
    """Sensor position along the rail, m, in coordinates with sleepers at multiples of
    ``sleeper_spacing`` (mid-span: sleeper_spacing / 2); None if unknown."""
    excitation: str = "z"
    """Hammer direction, 'x', 'y' or 'z' (aliases as in :func:`direction_name`)."""
    rail: str = ""
    """Rail profile and material as the source states it, e.g. '60E1'."""
    metadata: Metadata = field(default_factory=Metadata)
    """Date, temperature, section, rail side, notes."""

    def __post_init__(self) -> None:
        if not isinstance(self.frf, FRF):
            raise ValueError("HammerMeasurement.frf must be an FRF, "
                             f"got {type(self.frf).__name__}.")
        x = v.strictly_increasing("HammerMeasurement.positions", self.positions, "m")
        n_freq, n_out, n_in = self.frf.shape
        if x.size != n_in:
            raise ValueError(
                f"HammerMeasurement has {x.size} hammer positions but the FRF has {n_in} "
                "forces (axis 2); give one position (m) per force column.")
        if x.size < 2:
            raise ValueError("HammerMeasurement needs the point FRF and at least one transfer "
                             f"position; got positions {x.tolist()} m.")
        if x[0] < 0.0 or x[0] >= x[1] / 2:
            raise ValueError(
                f"HammerMeasurement.positions[0] = {x[0]!r} m must be the point FRF: 0 or a "
                f"small realised offset below half the next position ({x[1] / 2!r} m); measure "
                "distances from the sensor and put the point FRF first.")
        sensors = tuple(self.sensors) if not isinstance(self.sensors, Sensor) else (self.sensors,)
        if any(not isinstance(s, Sensor) for s in sensors):
            raise ValueError("HammerMeasurement.sensors must be Sensor objects.")
        names = tuple(s.name for s in sensors)
        if names != self.frf.response:
            raise ValueError(
                f"HammerMeasurement.sensors {names} must match the FRF response labels "
                f"{self.frf.response} (same names, same order).")
        spacing = v.positive("HammerMeasurement.sleeper_spacing", self.sleeper_spacing, "m",
                             "typical 0.6 - 0.65 m")
        sensor_x = (None if self.sensor_x is None
                    else v.finite("HammerMeasurement.sensor_x", self.sensor_x, "m"))
        if sensor_x is not None and self.frf.force_x is not None:
            mismatch = np.abs(self.frf.force_x - sensor_x - x)
            if mismatch.max() > 1e-6:
                i = int(np.argmax(mismatch))
                raise ValueError(
                    f"HammerMeasurement: FRF force_x[{i}] = {self.frf.force_x[i]!r} m is not "
                    f"sensor_x + positions[{i}] = {sensor_x + x[i]!r} m; give consistent "
                    "positions (or build the FRF without force_x).")
        if not isinstance(self.metadata, Metadata):
            raise ValueError("HammerMeasurement.metadata must be a Metadata object.")
        set_ = object.__setattr__
        set_(self, "positions", x)
        set_(self, "sensors", sensors)
        set_(self, "sleeper_spacing", spacing)
        set_(self, "sensor_x", sensor_x)
        set_(self, "excitation", direction_name(self.excitation, "HammerMeasurement.excitation"))
        set_(self, "rail", str(self.rail))

    @property
    def frequency(self) -> np.ndarray:
        """Frequencies, Hz."""
        return self.frf.frequency

    @property
    def point_offset(self) -> float:
        """Realised distance of the point-FRF hammer position from the sensor, m."""
        return float(self.positions[0])

    @property
    def sensor_names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.sensors)

    def sensor(self, name: str) -> Sensor:
        """The sensor called ``name``."""
        for s in self.sensors:
            if s.name == name:
                return s
        raise KeyError(f"no sensor {name!r} in this measurement; sensors: {self.sensor_names}.")

    def transfer(self, sensor: str) -> np.ndarray:
        """(n_freq, n_positions) complex FRFs of ``sensor`` (in ``frf.quantity``)."""
        self.sensor(sensor)
        return self.frf.values[:, self.frf.response.index(sensor), :]

    def with_positions(self, indices) -> HammerMeasurement:
        """The same measurement restricted to the hammer positions ``indices`` (into
        ``positions``; the point FRF, index 0, is always kept and comes first)."""
        idx = np.asarray(indices, dtype=int).ravel()
        if idx.size and (idx.min() < 0 or idx.max() >= len(self.positions)):
            raise ValueError(f"position indices {idx.tolist()} are outside 0..."
                             f"{len(self.positions) - 1}: give indices into positions")
        keep = np.unique(np.concatenate([[0], idx]))
        f = self.frf
        frf = replace(f, values=f.values[:, :, keep], force=tuple(f.force[k] for k in keep),
                      force_x=None if f.force_x is None else f.force_x[keep])
        return replace(self, frf=frf, positions=self.positions[keep])

    def with_sensors(self, names: str | Sequence[str]) -> HammerMeasurement:
        """The same measurement restricted to the sensors ``names``."""
        names = [names] if isinstance(names, str) else list(names)
        sensors = tuple(self.sensor(n) for n in names)
        return replace(self, frf=self.frf.select(response=names), sensors=sensors)


def _band_axis(name: str, frequency) -> np.ndarray:
    f = v.strictly_increasing(name, frequency, "Hz")
    if f.size == 0 or f[0] <= 0.0:
        raise ValueError(f"{name} must hold positive band centre frequencies (Hz), "
                         f"got {f.tolist()}.")
    return f


@dataclass(frozen=True, kw_only=True, eq=False)
class DecayRateMeasurement:
    """Track decay rate per one-third-octave band, with what it was measured on."""

    frequency: np.ndarray
    """(n_bands,) band centre frequencies, Hz (nominal), strictly increasing."""
    decay_rate: np.ndarray
    """(n_bands,) decay rate, dB/m; NaN where not measured."""
    direction: str = "z"
    """Vibration direction: 'z' vertical, 'y' lateral (aliases 'v', 'h', ...)."""
    valid: np.ndarray | None = None
    """(n_bands,) True where the value may be used (e.g. EN 15461 checks passed); default:
    where decay_rate is finite. Always False where decay_rate is NaN."""
    sensor: str | None = None
    """Sensor location if known, e.g. 'head' or 'foot'."""
    metadata: Metadata = field(default_factory=Metadata)

    def __post_init__(self) -> None:
        f = _band_axis("DecayRateMeasurement.frequency", self.frequency)
        d = v.finite_array("DecayRateMeasurement.decay_rate", self.decay_rate, "dB/m",
                           ndim=1, allow_nan=True)
        if d.size != f.size:
            raise ValueError(f"DecayRateMeasurement has {d.size} decay rates for {f.size} bands; "
                             "give one value (dB/m, NaN if missing) per band.")
        if np.any(d[np.isfinite(d)] <= 0.0):
            k = int(np.flatnonzero(np.isfinite(d) & (d <= 0.0))[0])
            raise ValueError(f"DecayRateMeasurement.decay_rate at {f[k]:g} Hz is {d[k]!r} dB/m; "
                             "a decay rate is > 0 (use NaN for a missing value).")
        ok = np.isfinite(d)
        if self.valid is not None:
            valid = np.asarray(self.valid, dtype=bool).reshape(-1)
            if valid.size != f.size:
                raise ValueError(f"DecayRateMeasurement.valid has {valid.size} entries for "
                                 f"{f.size} bands; give one bool per band.")
            ok = ok & valid
        if not isinstance(self.metadata, Metadata):
            raise ValueError("DecayRateMeasurement.metadata must be a Metadata object.")
        set_ = object.__setattr__
        set_(self, "frequency", f)
        set_(self, "decay_rate", d)
        set_(self, "valid", v.readonly(ok))
        set_(self, "direction", direction_name(self.direction, "DecayRateMeasurement.direction"))


@dataclass(frozen=True, kw_only=True, eq=False)
class DecayRateTable:
    """Many decay-rate measurements on the same bands (frequency is axis 0)."""

    frequency: np.ndarray
    """(n_bands,) band centre frequencies, Hz (nominal)."""
    decay_rate: np.ndarray
    """(n_bands, n_rows) decay rates, dB/m; NaN where not measured."""
    direction: tuple[str, ...]
    """(n_rows,) vibration direction per measurement ('z', 'y', ...)."""
    metadata: tuple[Metadata, ...]
    """(n_rows,) metadata per measurement."""
    sensor: tuple[str | None, ...] | None = None
    """(n_rows,) sensor location per measurement, or None (unknown for all)."""

    def __post_init__(self) -> None:
        f = _band_axis("DecayRateTable.frequency", self.frequency)
        d = v.finite_array("DecayRateTable.decay_rate", self.decay_rate, "dB/m", ndim=2,
                           allow_nan=True)
        if d.shape[0] != f.size:
            raise ValueError(f"DecayRateTable.decay_rate has shape {d.shape}; expected "
                             f"({f.size}, n_rows): bands on axis 0.")
        n = d.shape[1]
        direction = tuple(direction_name(x, f"DecayRateTable.direction[{i}]")
                          for i, x in enumerate(self.direction))
        meta = tuple(self.metadata)
        sensor = (None,) * n if self.sensor is None else tuple(self.sensor)
        for name, seq in (("direction", direction), ("metadata", meta), ("sensor", sensor)):
            if len(seq) != n:
                raise ValueError(f"DecayRateTable.{name} has {len(seq)} entries for {n} rows.")
        if any(not isinstance(m, Metadata) for m in meta):
            raise ValueError("DecayRateTable.metadata must hold Metadata objects.")
        bad = np.isfinite(d) & (d <= 0.0)
        if bad.any():
            b, r = np.argwhere(bad)[0]
            raise ValueError(f"DecayRateTable.decay_rate row {r}, {f[b]:g} Hz is {d[b, r]!r} "
                             "dB/m; a decay rate is > 0 (use NaN for a missing value).")
        set_ = object.__setattr__
        set_(self, "frequency", f)
        set_(self, "decay_rate", d)
        set_(self, "direction", direction)
        set_(self, "metadata", meta)
        set_(self, "sensor", sensor)

    def __len__(self) -> int:
        return self.decay_rate.shape[1]

    def row(self, i: int) -> DecayRateMeasurement:
        """Measurement ``i`` as a :class:`DecayRateMeasurement`."""
        return DecayRateMeasurement(frequency=self.frequency, decay_rate=self.decay_rate[:, i],
                                    direction=self.direction[i], sensor=self.sensor[i],
                                    metadata=self.metadata[i])

    def rows(self) -> list[DecayRateMeasurement]:
        return [self.row(i) for i in range(len(self))]

    @classmethod
    def from_rows(cls, rows: Sequence[DecayRateMeasurement]) -> DecayRateTable:
        """Stack measurements on identical bands (their ``valid`` masks are not kept)."""
        rows = list(rows)
        if not rows:
            raise ValueError("DecayRateTable.from_rows needs at least one measurement.")
        f = rows[0].frequency
        for i, r in enumerate(rows):
            if r.frequency.shape != f.shape or np.any(np.abs(r.frequency / f - 1) > 1e-9):
                raise ValueError(f"row {i} has bands {r.frequency.tolist()} Hz, row 0 has "
                                 f"{f.tolist()} Hz; put only measurements on the same bands "
                                 "in one table.")
        return cls(frequency=f, decay_rate=np.column_stack([r.decay_rate for r in rows]),
                   direction=tuple(r.direction for r in rows),
                   metadata=tuple(r.metadata for r in rows),
                   sensor=tuple(r.sensor for r in rows))

    def select(self, *, direction: str | None = None, section: str | Sequence[str] | None = None,
               date: str | Sequence[str] | None = None,
               rail_side: str | Sequence[str] | None = None) -> DecayRateTable:
        """The rows that match every given criterion (a value or a list of values).

        ``direction`` takes aliases ('v' = 'z', 'h' = 'y'); ``date`` is 'YYYY-MM-DD' or a
        year 'YYYY' or month 'YYYY-MM' prefix. An empty selection raises, listing what there is.
        """
        keep = np.ones(len(self), dtype=bool)
        if direction is not None:
            want = direction_name(direction)
            keep &= np.array([d == want for d in self.direction])
        for key, want in (("section", section), ("rail_side", rail_side)):
            if want is not None:
                want = {want} if isinstance(want, str) else set(want)
                keep &= np.array([getattr(m, key) in want for m in self.metadata])
        if date is not None:
            prefixes = (date,) if isinstance(date, str) else tuple(date)
            keep &= np.array([m.date is not None and m.date.startswith(prefixes)
                              for m in self.metadata])
        if not keep.any():
            have = {"direction": sorted(set(self.direction)),
                    "section": sorted({str(m.section) for m in self.metadata}),
                    "date": sorted({str(m.date) for m in self.metadata}),
                    "rail_side": sorted({str(m.rail_side) for m in self.metadata})}
            raise KeyError(f"no row matches direction={direction!r}, section={section!r}, "
                           f"date={date!r}, rail_side={rail_side!r}; the table has {have}.")
        idx = np.flatnonzero(keep)
        return replace(self, decay_rate=self.decay_rate[:, idx],
                       direction=tuple(self.direction[i] for i in idx),
                       metadata=tuple(self.metadata[i] for i in idx),
                       sensor=tuple(self.sensor[i] for i in idx))

    def summary(self) -> dict:
        """Counts per direction, section, date and the temperature range (JSON-ready)."""
        temps = [m.temperature_c for m in self.metadata if m.temperature_c is not None]

        def counts(values):
            out: dict = {}
            for x in values:
                out[str(x)] = out.get(str(x), 0) + 1
            return dict(sorted(out.items()))

        return {"rows": len(self), "bands_hz": [float(x) for x in self.frequency],
                "direction": counts(self.direction),
                "section": counts(m.section for m in self.metadata),
                "date": counts(m.date for m in self.metadata),
                "temperature_c": [min(temps), max(temps)] if temps else None}
