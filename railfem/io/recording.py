"""Read and write pass-by recordings: a signal file (NPZ or WAV) plus a metadata sidecar.

A recording ``run1.npz`` or ``run1.wav`` has its metadata in ``run1.toml`` or
``run1.json`` next to it (the first that exists; both is an error). Sidecar keys (SI;
only ``quantity`` is required, ``fs_hz`` when the signal file has no rate)::

    quantity = "acceleration"     # or "velocity"; samples are then m/s^2 or m/s
    unit = "m/s^2"                # optional; must match the quantity's SI unit if given
    fs_hz = 25600.0               # sample rate (NPZ may hold it as 'fs'; WAV has its own)
    scale = 1.0                   # optional: SI value = scale * stored value (WAV PCM)
    sensor = "foot"               # optional, free text
    direction = "z"               # optional: x, y or z
    speed_m_s = 50.0              # optional: train speed
    axle_spacing_m = 2.5          # optional: bogie axle spacing (wheelbase)
    axle_positions_m = [0, 2.5]   # optional: all axle positions along the train

Every other key is kept in ``Recording.metadata``.

A recording written by ``railfem passby`` (:mod:`railfem.recording`, JSON sidecar with
``format = "railfem-recording v1"``, one column per channel) is read too: one channel
becomes one :class:`Recording` (``channel`` names it when there are several). The NPZ holds ``samples`` (1-D) and
optionally ``fs``. A WAV file must be mono; integer PCM is read as integers and needs
``scale`` (SI units per count), float WAV is read as is. Truths of a simulation belong in a
separate file that this reader never opens.
"""
from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import numpy as np

from railfem.estimators.recording import QUANTITIES, Recording

__all__ = ["read_recording", "write_recording", "sidecar_path"]

_KNOWN = {"quantity", "unit", "fs_hz", "scale", "sensor", "direction", "speed_m_s",
          "axle_spacing_m", "axle_positions_m"}


def sidecar_path(path) -> Path:
    """The metadata file of signal file ``path`` (.toml or .json with the same stem)."""
    path = Path(path)
    found = [p for p in (path.with_suffix(".toml"), path.with_suffix(".json")) if p.is_file()]
    if not found:
        raise ValueError(f"recording {path}: no metadata file {path.with_suffix('.toml').name}"
                         f" or {path.with_suffix('.json').name} next to it; write one with "
                         "at least 'quantity' (acceleration or velocity) and 'fs_hz'")
    if len(found) > 1:
        raise ValueError(f"recording {path}: both {found[0].name} and {found[1].name} exist; "
                         "keep one metadata file")
    return found[0]


def _read_sidecar(path: Path) -> dict:
    try:
        if path.suffix == ".toml":
            with open(path, "rb") as fh:
                return tomllib.load(fh)
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)
    except (tomllib.TOMLDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"metadata file {path} is not valid {path.suffix[1:].upper()}: "
                         f"{exc}") from None
    if not isinstance(data, dict):
        raise ValueError(f"metadata file {path} must hold a table/object of keys")
    return data


def _number(meta: dict, key: str, where: Path):
    v = meta.get(key)
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ValueError(f"{where}: '{key}' must be a number, got {v!r}")
    return float(v)


def _from_railfem_recording(path: Path, channel: str | None) -> Recording:
    from railfem import recording as rr

    rec = rr.read_recording(path)
    names = [c.name for c in rec.channels]
    if channel is None:
        if len(names) > 1:
            raise ValueError(f"recording {path.name} has channels {names}; choose one "
                             "(channel=... / --channel NAME)")
        channel = names[0]
    if channel not in names:
        raise ValueError(f"recording {path.name} has no channel {channel!r}; it has {names}")
    j = names.index(channel)
    c = rec.channels[j]
    if c.quantity not in QUANTITIES:
        raise ValueError(f"recording {path.name}, channel {channel!r}: quantity "
                         f"{c.quantity!r} is not supported; give an acceleration or velocity")
    meta = dict(rec.site)
    meta.update(channel=c.name, x_from_support_m=c.x_from_support)
    return Recording(samples=rec.signal[:, j], fs=rec.sample_rate, quantity=c.quantity,
                     sensor=c.location, direction=c.direction, speed=rec.speed,
                     name=f"{path.name}:{c.name}" if len(names) > 1 else path.name,
                     metadata=meta)


def read_recording(path, *, channel: str | None = None) -> Recording:
    """Read ``path`` (.npz or .wav) and its sidecar into a :class:`Recording`.

    ``channel`` selects a channel of a multi-channel ``railfem passby`` recording."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"recording {path} does not exist")
    meta_path = sidecar_path(path)
    meta = _read_sidecar(meta_path)
    if "format" in meta:
        from railfem.recording import FORMAT_TAG

        if meta["format"] != FORMAT_TAG:
            raise ValueError(f"{meta_path}: unknown recording format {meta['format']!r}")
        return _from_railfem_recording(path, channel)
    if channel is not None:
        raise ValueError(f"recording {path.name} has a single channel; do not give channel")
    quantity = meta.get("quantity")
    if quantity not in QUANTITIES:
        raise ValueError(f"{meta_path}: 'quantity' must be one of {sorted(QUANTITIES)}, got "
                         f"{quantity!r}")
    unit = meta.get("unit")
    if unit is not None and unit.replace("²", "^2") not in (QUANTITIES[quantity],
                                                           QUANTITIES[quantity].replace("^", "")):
        raise ValueError(f"{meta_path}: unit {unit!r} is not the SI unit of {quantity} "
                         f"({QUANTITIES[quantity]}); convert the data or set 'scale'")
    fs_meta = _number(meta, "fs_hz", meta_path)
    scale = _number(meta, "scale", meta_path)
    suffix = path.suffix.lower()
    if suffix == ".npz":
        with np.load(path, allow_pickle=False) as z:
            if "samples" not in z:
                raise ValueError(f"{path}: no array 'samples' (has {sorted(z.files)})")
            samples = np.asarray(z["samples"])
            fs_file = float(z["fs"]) if "fs" in z else None
    elif suffix == ".wav":
        from scipy.io import wavfile

        fs_file, samples = wavfile.read(path)
        fs_file = float(fs_file)
        if samples.ndim != 1:
            raise ValueError(f"{path}: {samples.shape[1]} channels; railfem reads mono WAV "
                             "files (one sensor per file)")
        if np.issubdtype(samples.dtype, np.integer) and scale is None:
            raise ValueError(f"{meta_path}: {path.name} is integer PCM; give 'scale' (SI "
                             "units per count) so the samples can be converted")
    else:
        raise ValueError(f"recording {path}: unknown format {path.suffix!r}; use .npz or .wav")
    if fs_file is not None and fs_meta is not None and not math.isclose(fs_file, fs_meta,
                                                                         rel_tol=1e-9):
        raise ValueError(f"{path}: the file says fs = {fs_file:g} Hz, {meta_path.name} says "
                         f"{fs_meta:g} Hz; make them agree")
    fs = fs_file if fs_file is not None else fs_meta
    if fs is None:
        raise ValueError(f"{meta_path}: no sample rate; add 'fs_hz' (Hz)")
    samples = samples.astype(float) * (1.0 if scale is None else scale)
    positions = meta.get("axle_positions_m")
    return Recording(
        samples=samples, fs=fs, quantity=quantity, sensor=str(meta.get("sensor", "unknown")),
        direction=str(meta.get("direction", "z")), speed=_number(meta, "speed_m_s", meta_path),
        axle_spacing=_number(meta, "axle_spacing_m", meta_path),
        axle_positions=None if positions is None else tuple(positions),
        name=path.name, metadata={k: v for k, v in meta.items() if k not in _KNOWN})


def write_recording(path, recording: Recording, *, sidecar: str = "toml") -> tuple[Path, Path]:
    """Write ``recording`` as ``path`` (.npz, float samples) plus a sidecar, atomically."""
    from railfem.atomic import atomic_path, write_text

    path = Path(path)
    if path.suffix.lower() != ".npz":
        raise ValueError(f"write_recording writes .npz files, got {path.name}")
    if sidecar not in ("toml", "json"):
        raise ValueError(f"sidecar must be 'toml' or 'json', got {sidecar!r}")
    meta = dict(recording.metadata)
    meta.update(quantity=recording.quantity, unit=recording.unit, fs_hz=recording.fs,
                sensor=recording.sensor, direction=recording.direction)
    for key, value in (("speed_m_s", recording.speed),
                       ("axle_spacing_m", recording.axle_spacing),
                       ("axle_positions_m", recording.axle_positions)):
        if value is not None:
            meta[key] = list(value) if isinstance(value, tuple) else value
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, samples=recording.samples, fs=recording.fs)
    side = path.with_suffix("." + sidecar)
    other = path.with_suffix(".json" if sidecar == "toml" else ".toml")
    if other.exists():
        raise ValueError(f"{other} exists and would make the metadata ambiguous; remove it")
    text = json.dumps(meta, indent=2) + "\n" if sidecar == "json" else _toml(meta)
    write_text(side, text)
    return path, side


def _toml(meta: dict) -> str:
    """Flat TOML of str, number, bool and list-of-number values (what recordings need)."""
    lines = []
    for key, value in meta.items():
        if isinstance(value, (list, tuple)):
            lines.append(f"{key} = [{', '.join(repr(float(v)) for v in value)}]")
        elif isinstance(value, bool):
            lines.append(f"{key} = {'true' if value else 'false'}")
        elif isinstance(value, (int, float)):
            lines.append(f"{key} = {value!r}")
        elif isinstance(value, str):
            lines.append(f"{key} = {json.dumps(value)}")
        else:
            raise ValueError(f"metadata '{key}' = {value!r} cannot be written as TOML here; "
                             "use sidecar='json'")
    return "\n".join(lines) + "\n"
