"""Recordings: time signals as a measurement system writes them, with a metadata sidecar.

A recording is a data file and a JSON sidecar with the same stem::

    passby_01.wav   (or .npz)   float32 samples, one column per channel, physical units
    passby_01.json              format tag, sample rate, channels, speed if known, site

The sidecar holds only what a field team would know: sample rate, per channel the
quantity, unit, sensor position on the rail (head/foot), direction and position along the
track relative to the sleepers, the train speed if measured, the sleeper spacing and free
text. A simulator's truth (roughness, layout, band levels) goes in a separate file that
readers of recordings never open (railfem.simulate.signals writes ``*.truth.json``).

WAV files are written with scipy.io.wavfile as IEEE float32 in the physical unit (no
scaling); NPZ files hold ``signal`` (n_samples, n_channels) float32. Both are written
atomically; :func:`read_recording` accepts the sidecar or the data file.
"""
from __future__ import annotations

import io
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["Recording", "Channel", "write_recording", "read_recording", "FORMAT_TAG"]

FORMAT_TAG = "railfem-recording v1"
DATA_FORMATS = ("wav", "npz")
QUANTITY_UNITS = {"acceleration": "m/s^2", "velocity": "m/s", "displacement": "m"}


@dataclass(frozen=True, kw_only=True)
class Channel:
    """One sensor. name: label. quantity: acceleration / velocity / displacement.
    location: 'foot' or 'head' (of the rail). direction: 'z' (vertical) or 'y'.
    x_from_support: sensor position along the track from the nearest support towards
    the train's direction of travel (m), e.g. spacing/2 at mid-span."""

    name: str
    quantity: str = "acceleration"
    location: str = "foot"
    direction: str = "z"
    x_from_support: float | None = None

    def __post_init__(self):
        if self.quantity not in QUANTITY_UNITS:
            raise ValueError(f"Channel.quantity = {self.quantity!r}: choose one of "
                             f"{', '.join(QUANTITY_UNITS)}")
        if self.direction not in ("x", "y", "z"):
            raise ValueError(f"Channel.direction = {self.direction!r}: x, y or z")

    @property
    def unit(self) -> str:
        return QUANTITY_UNITS[self.quantity]


@dataclass(frozen=True, kw_only=True, eq=False)
class Recording:
    """signal: (n_samples, n_channels) in the channels' units. sample_rate: Hz.
    channels: one Channel per column. speed: train speed (m/s) if known, else None.
    site: free metadata (sleeper_spacing_m, rail, description, ...)."""

    signal: np.ndarray
    sample_rate: float
    channels: tuple[Channel, ...]
    speed: float | None = None
    site: dict = field(default_factory=dict)

    def __post_init__(self):
        sig = np.asarray(self.signal, dtype=float)
        if sig.ndim == 1:
            sig = sig[:, None]
        object.__setattr__(self, "signal", sig)
        object.__setattr__(self, "channels", tuple(self.channels))
        if sig.ndim != 2 or sig.shape[1] != len(self.channels):
            raise ValueError(f"Recording.signal has shape {sig.shape} but there are "
                             f"{len(self.channels)} channels: one column per channel")
        if not (np.isfinite(self.sample_rate) and self.sample_rate > 0):
            raise ValueError(f"Recording.sample_rate = {self.sample_rate!r} Hz: give a rate > 0")
        if not np.all(np.isfinite(sig)):
            raise ValueError("Recording.signal contains NaN or inf samples")
        if self.speed is not None and not (np.isfinite(self.speed) and self.speed > 0):
            raise ValueError(f"Recording.speed = {self.speed!r} m/s: give a speed > 0 or None")

    @property
    def time(self) -> np.ndarray:
        return np.arange(self.signal.shape[0]) / self.sample_rate

    @property
    def duration(self) -> float:
        return self.signal.shape[0] / self.sample_rate


def _sidecar(rec: Recording, data_name: str) -> dict:
    return {"format": FORMAT_TAG, "data_file": data_name, "sample_rate_hz": rec.sample_rate,
            "n_samples": int(rec.signal.shape[0]),
            "channels": [{"name": c.name, "quantity": c.quantity, "unit": c.unit,
                          "location": c.location, "direction": c.direction,
                          "x_from_support_m": c.x_from_support} for c in rec.channels],
            "speed_m_per_s": rec.speed, "site": rec.site}


def write_recording(path, rec: Recording, *, data_format: str = "wav") -> dict:
    """Write ``<stem>.<wav|npz>`` and ``<stem>.json`` (path may carry any suffix);
    returns {"data": path, "meta": path}."""
    from .atomic import write_bytes_atomic, write_text_atomic

    if data_format not in DATA_FORMATS:
        raise ValueError(f"data_format = {data_format!r}: choose one of {DATA_FORMATS}")
    path = Path(path)
    stem = path.with_suffix("") if path.suffix in (".wav", ".npz", ".json") else path
    data_path = stem.with_name(stem.name + "." + data_format)
    buf = io.BytesIO()
    samples = rec.signal.astype(np.float32)
    if data_format == "wav":
        from scipy.io import wavfile

        if rec.sample_rate != int(rec.sample_rate):
            raise ValueError(f"WAV needs an integer sample rate, got {rec.sample_rate} Hz: "
                             "use data_format='npz'")
        wavfile.write(buf, int(rec.sample_rate), samples if samples.shape[1] > 1
                      else samples[:, 0])
    else:
        np.savez(buf, signal=samples)
    paths = {"data": write_bytes_atomic(data_path, buf.getvalue())}
    meta = json.dumps(_sidecar(rec, data_path.name), indent=2) + "\n"
    paths["meta"] = write_text_atomic(stem.with_name(stem.name + ".json"), meta)
    return paths


def read_recording(path) -> Recording:
    """Read a recording from its sidecar (.json) or data file (.wav / .npz)."""
    path = Path(path)
    meta_path = path if path.suffix == ".json" else path.with_suffix(".json")
    try:
        meta = json.loads(meta_path.read_text())
    except FileNotFoundError:
        raise ValueError(f"{meta_path}: the recording's metadata sidecar is missing") from None
    if meta.get("format") != FORMAT_TAG:
        raise ValueError(f"{meta_path}: not a {FORMAT_TAG!r} sidecar (format = "
                         f"{meta.get('format')!r})")
    data_path = meta_path.with_name(meta["data_file"])
    if data_path.suffix == ".wav":
        from scipy.io import wavfile

        rate, samples = wavfile.read(data_path)
        if rate != meta["sample_rate_hz"]:
            raise ValueError(f"{data_path}: sample rate {rate} Hz differs from the sidecar's "
                             f"{meta['sample_rate_hz']} Hz")
    else:
        with np.load(data_path) as z:
            samples = z["signal"]
    samples = np.asarray(samples, dtype=float)
    if samples.ndim == 1:
        samples = samples[:, None]
    if samples.shape[0] != meta["n_samples"]:
        raise ValueError(f"{data_path}: {samples.shape[0]} samples, the sidecar says "
                         f"{meta['n_samples']} (truncated file?)")
    chans = tuple(Channel(name=c["name"], quantity=c["quantity"], location=c["location"],
                          direction=c["direction"], x_from_support=c.get("x_from_support_m"))
                  for c in meta["channels"])
    for c, m in zip(chans, meta["channels"]):
        if m.get("unit") != c.unit:
            raise ValueError(f"{meta_path}: channel {c.name!r} unit {m.get('unit')!r} does not "
                             f"match its quantity {c.quantity!r} ({c.unit})")
    return Recording(signal=samples, sample_rate=float(meta["sample_rate_hz"]), channels=chans,
                     speed=meta.get("speed_m_per_s"), site=meta.get("site", {}))
