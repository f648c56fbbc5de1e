"""Read and write recordings (:class:`railfem.recording.Recording`): a signal file (NPZ or
WAV) plus a metadata sidecar (TOML or JSON) with the same stem.

``run1.npz`` or ``run1.wav`` has its metadata in ``run1.toml`` or ``run1.json`` (the one
that exists; both is an error). :func:`read_recording` takes either the signal file or the
sidecar. Sidecar keys (SI; a field team writes the short single-sensor form by hand)::

    fs_hz = 25600.0               # sample rate (a WAV header or the NPZ array 'fs' may
                                  # hold it instead; two sources must agree)
    scale = 1.0                   # optional: SI value = scale * stored value (needed for
                                  # integer-PCM WAV)
    speed_m_s = 50.0              # optional: train speed
    axle_spacing_m = 2.5          # optional: bogie axle spacing (wheelbase)
    axle_positions_m = [0, 2.5]   # optional: all axle positions along the train
    # one sensor (short form):
    quantity = "acceleration"     # required: acceleration, velocity or displacement
    unit = "m/s^2"                # optional; must be the quantity's SI unit
    location = "foot"             # optional, free text ('sensor' is accepted too)
    direction = "z"               # optional: x, y or z
    x_from_support_m = 0.3        # optional: from the nearest support, m
    # or several sensors, one column each, in the order of the columns:
    [[channels]]
    name = "rail_foot_z"
    quantity = "acceleration"     # and unit, location, direction, x_from_support_m
    # written by railfem: format = "railfem-recording v2", data_file, n_samples

Every other key is kept in ``Recording.metadata``. The NPZ holds ``samples``
((n,) or (n, n_channels)) and optionally ``fs``; a WAV file holds one channel per column
(float WAV in SI units, integer PCM with ``scale``). Sidecars of the earlier
``railfem-recording v1`` format (``railfem passby`` before the formats were unified) are
read too.

The truth of a simulation goes to ``<stem>.truth.json`` (:func:`write_recording` with
``truth=``); :func:`read_recording` never opens it.
"""
from __future__ import annotations

import io
import json
import math
from pathlib import Path

import numpy as np

from railfem.io.config import read_toml
from railfem.recording import QUANTITY_UNITS, Channel, Recording

__all__ = ["FORMAT_TAG", "read_recording", "write_recording", "sidecar_path",
           "truth_path"]

FORMAT_TAG = "railfem-recording v2"
LEGACY_TAG = "railfem-recording v1"
DATA_FORMATS = ("npz", "wav")
SIDECARS = ("toml", "json")

_TOP = {"format", "data_file", "fs_hz", "n_samples", "scale", "speed_m_s", "axle_spacing_m",
        "axle_positions_m", "channels"}
_SHORT = {"quantity", "unit", "location", "sensor", "direction", "x_from_support_m", "name"}
_CHANNEL = {"name", "quantity", "unit", "location", "direction", "x_from_support_m"}
RESERVED = _TOP | _SHORT


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


def truth_path(path) -> Path:
    """Where a simulator's truth of recording ``path`` lives (``<stem>.truth.json``)."""
    path = Path(path)
    stem = path.with_suffix("") if path.suffix.lower() in (".npz", ".wav", ".json",
                                                            ".toml") else path
    return stem.with_name(stem.name + ".truth.json")


def _read_sidecar(path: Path) -> dict:
    if path.suffix == ".toml":
        return read_toml(path)
    try:
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)
    except json.JSONDecodeError as exc:
        raise ValueError(f"metadata file {path} is not valid {path.suffix[1:].upper()}: "
                         f"{exc}") from None
    except OSError as exc:
        raise ValueError(f"cannot read metadata file {path}: {exc.strerror or exc}") from None
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


def _from_v1(meta: dict) -> dict:
    """The keys of a 'railfem-recording v1' sidecar in today's names."""
    out = {k: v for k, v in meta.items() if k not in ("format", "sample_rate_hz",
                                                      "speed_m_per_s", "site")}
    out.update(format=FORMAT_TAG, fs_hz=meta.get("sample_rate_hz"),
               speed_m_s=meta.get("speed_m_per_s"))
    out.update(meta.get("site") or {})
    return out


def _channel(entry: dict, where: str, default_name: str) -> Channel:
    quantity = entry.get("quantity")
    if quantity not in QUANTITY_UNITS:
        raise ValueError(f"{where}: 'quantity' must be one of {sorted(QUANTITY_UNITS)}, got "
                         f"{quantity!r}")
    unit = entry.get("unit")
    si = QUANTITY_UNITS[quantity]
    if unit is not None and str(unit).replace("²", "^2") not in (si, si.replace("^", "")):
        raise ValueError(f"{where}: unit {unit!r} is not the SI unit of {quantity} ({si}); "
                         "convert the data or set 'scale'")
    location = entry.get("location", entry.get("sensor", "unknown"))
    x = entry.get("x_from_support_m")
    try:
        return Channel(name=str(entry.get("name", default_name)), quantity=quantity,
                       location=str(location), direction=str(entry.get("direction", "z")),
                       x_from_support=None if x is None else float(x))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{where}: {exc}") from None


def _channels(meta: dict, where: Path) -> tuple[Channel, ...]:
    given = meta.get("channels")
    short = sorted(k for k in _SHORT if k in meta)
    if given is None:
        return (_channel({("location" if k == "sensor" else k): meta[k] for k in short},
                         str(where), "ch0"),)
    if short:
        raise ValueError(f"{where}: both a 'channels' list and the single-sensor keys "
                         f"{short}; keep one form")
    if not isinstance(given, list) or not given or not all(isinstance(c, dict) for c in given):
        raise ValueError(f"{where}: 'channels' must be a list of tables ([[channels]] in "
                         "TOML), one per column of the samples")
    for j, c in enumerate(given):
        unknown = set(c) - _CHANNEL
        if unknown:
            raise ValueError(f"{where}: channels[{j}] has unknown keys {sorted(unknown)}; "
                             f"valid: {', '.join(sorted(_CHANNEL))}")
    return tuple(_channel(c, f"{where}, channels[{j}]", f"ch{j}") for j, c in enumerate(given))


def _data_path(path: Path, meta_path: Path, meta: dict) -> Path:
    named = meta.get("data_file")
    if path.suffix.lower() in (".npz", ".wav"):
        if named is not None and named != path.name:
            raise ValueError(f"{meta_path} describes {named}, not {path.name}")
        return path
    if named is not None:
        return meta_path.with_name(str(named))
    found = [meta_path.with_suffix("." + s) for s in DATA_FORMATS
             if meta_path.with_suffix("." + s).is_file()]
    if len(found) != 1:
        raise ValueError(f"{meta_path}: {'no' if not found else 'more than one'} signal file "
                         f"({meta_path.stem}.npz or .wav) next to it; give the signal file")
    return found[0]


def _load_samples(data_path: Path, meta_path: Path, scale):
    suffix = data_path.suffix.lower()
    if not data_path.is_file():
        raise ValueError(f"recording {data_path} does not exist")
    if suffix == ".npz":
        with np.load(data_path, allow_pickle=False) as z:
            key = "samples" if "samples" in z else "signal" if "signal" in z else None
            if key is None:
                raise ValueError(f"{data_path}: no array 'samples' (has {sorted(z.files)})")
            samples = np.asarray(z[key])
            fs_file = float(z["fs"]) if "fs" in z else None
    elif suffix == ".wav":
        from scipy.io import wavfile

        fs_file, samples = wavfile.read(data_path)
        fs_file = float(fs_file)
    else:
        raise ValueError(f"recording {data_path}: unknown format {data_path.suffix!r}; use "
                         ".npz or .wav")
    if np.issubdtype(samples.dtype, np.integer) and scale is None:
        raise ValueError(f"{meta_path}: {data_path.name} holds integers (PCM); give 'scale' "
                         "(SI units per count) so the samples can be converted")
    return samples.astype(float) * (1.0 if scale is None else scale), fs_file


def read_recording(path) -> Recording:
    """Read a recording from its signal file (.npz / .wav) or its sidecar (.toml / .json).

    Every channel is read; ``Recording.select(name)`` picks one for the estimators."""
    path = Path(path)
    if path.suffix.lower() in (".toml", ".json"):
        meta_path = path
        if not meta_path.is_file():
            raise ValueError(f"recording metadata {path} does not exist")
    elif path.suffix.lower() in (".npz", ".wav"):
        if not path.is_file():
            raise ValueError(f"recording {path} does not exist")
        meta_path = sidecar_path(path)
    else:
        raise ValueError(f"recording {path}: unknown format {path.suffix!r}; give the .npz "
                         "or .wav signal file or its .toml/.json metadata")
    meta = _read_sidecar(meta_path)
    tag = meta.get("format")
    if tag == LEGACY_TAG:
        meta = _from_v1(meta)
    elif tag not in (None, FORMAT_TAG):
        raise ValueError(f"{meta_path}: unknown recording format {tag!r} (this railfem reads "
                         f"{FORMAT_TAG!r})")
    channels = _channels(meta, meta_path)
    scale = _number(meta, "scale", meta_path)
    data_path = _data_path(path, meta_path, meta)
    samples, fs_file = _load_samples(data_path, meta_path, scale)
    fs_meta = _number(meta, "fs_hz", meta_path)
    if fs_file is not None and fs_meta is not None and not math.isclose(fs_file, fs_meta,
                                                                         rel_tol=1e-9):
        raise ValueError(f"{data_path}: the file says fs = {fs_file:g} Hz, {meta_path.name} "
                         f"says {fs_meta:g} Hz; make them agree")
    fs = fs_file if fs_file is not None else fs_meta
    if fs is None:
        raise ValueError(f"{meta_path}: no sample rate; add 'fs_hz' (Hz)")
    n = meta.get("n_samples")
    if n is not None and samples.shape[0] != n:
        raise ValueError(f"{data_path}: {samples.shape[0]} samples, {meta_path.name} says "
                         f"{n} (truncated file?)")
    cols = 1 if samples.ndim == 1 else samples.shape[1]
    if cols != len(channels):
        raise ValueError(f"{data_path}: {cols} column(s) of samples but {meta_path.name} "
                         f"describes {len(channels)} channel(s)")
    positions = meta.get("axle_positions_m")
    return Recording(
        samples=samples, fs=fs, channels=channels,
        speed=_number(meta, "speed_m_s", meta_path),
        axle_spacing=_number(meta, "axle_spacing_m", meta_path),
        axle_positions=None if positions is None else tuple(positions),
        name=data_path.name,
        metadata={k: v for k, v in meta.items() if k not in RESERVED})


def read_rail_recordings(paths, channel: str | None = None) -> tuple[list, str]:
    """(recordings, sensor location) of pass-by recordings of one sensor place on the rail:
    each file read (``channel`` picks one of a multi-channel recording) and their channels'
    location checked to be one of 'head' and 'foot' for all of them."""
    recs = [read_recording(p).select(channel) for p in paths]
    where = {r.channel.location for r in recs}
    if len(where) != 1 or not where <= {"foot", "head"}:
        raise ValueError(f"the recordings' sensor locations are {sorted(map(str, where))}: "
                         "give recordings of one sensor on the rail 'foot' or 'head' (the "
                         "channel location in the metadata; --channel picks one channel of a "
                         "multi-channel recording)")
    return recs, where.pop()


def _sidecar(rec: Recording, data_name: str) -> dict:
    clash = sorted(set(rec.metadata) & RESERVED)
    if clash:
        raise ValueError(f"Recording.metadata keys {clash} are reserved for the recording's "
                         "own fields; rename them")
    meta = {"format": FORMAT_TAG, "data_file": data_name, "fs_hz": rec.fs,
            "n_samples": rec.n_samples}
    for key, value in (("speed_m_s", rec.speed), ("axle_spacing_m", rec.axle_spacing),
                       ("axle_positions_m", rec.axle_positions)):
        if value is not None:
            meta[key] = list(value) if isinstance(value, tuple) else value
    meta["channels"] = [{k: v for k, v in (
        ("name", c.name), ("quantity", c.quantity), ("unit", c.unit), ("location", c.location),
        ("direction", c.direction), ("x_from_support_m", c.x_from_support)) if v is not None}
        for c in rec.channels]
    meta.update(rec.metadata)
    return meta


def write_recording(path, recording: Recording, *, data_format: str | None = None,
                    sidecar: str = "json", truth: dict | None = None) -> dict:
    """Write ``<stem>.<npz|wav>`` and its sidecar ``<stem>.<json|toml>`` atomically; with
    ``truth`` (a simulator's, JSON-ready) also ``<stem>.truth.json``. ``path`` may be the
    stem or carry any of these suffixes (a .npz/.wav suffix sets the data format; default
    npz). WAV files are IEEE float32 in SI units (no scaling); NPZ holds float64 ``samples``
    and ``fs``. Returns {"data", "meta"[, "truth"]} paths."""
    from railfem.atomic import atomic_path, write_bytes_atomic, write_text_atomic

    path = Path(path)
    suffix = path.suffix.lower().lstrip(".")
    if suffix in DATA_FORMATS:
        if data_format is not None and data_format != suffix:
            raise ValueError(f"{path.name}: the suffix says {suffix}, data_format = "
                             f"{data_format!r}")
        data_format = suffix
    data_format = data_format or "npz"
    if data_format not in DATA_FORMATS:
        raise ValueError(f"data_format = {data_format!r}: choose one of {DATA_FORMATS}")
    if sidecar not in SIDECARS:
        raise ValueError(f"sidecar = {sidecar!r}: choose one of {SIDECARS}")
    stem = path.with_suffix("") if suffix in DATA_FORMATS + SIDECARS else path
    data_path = stem.with_name(stem.name + "." + data_format)
    side = stem.with_name(stem.name + "." + sidecar)
    other = stem.with_name(stem.name + "." + SIDECARS[1 - SIDECARS.index(sidecar)])
    if other.exists():
        raise ValueError(f"{other} exists and would make the metadata ambiguous; remove it")
    meta = _sidecar(recording, data_path.name)
    text = json.dumps(meta, indent=2) + "\n" if sidecar == "json" else _toml(meta)
    x = recording.samples
    if data_format == "wav":
        from scipy.io import wavfile

        if recording.fs != int(recording.fs):
            raise ValueError(f"WAV needs an integer sample rate, got {recording.fs} Hz: "
                             "use data_format='npz'")
        buf = io.BytesIO()
        samples = x.astype(np.float32)
        wavfile.write(buf, int(recording.fs), samples if samples.shape[1] > 1 else samples[:, 0])
        paths = {"data": write_bytes_atomic(data_path, buf.getvalue())}
    else:
        with atomic_path(data_path) as tmp:
            with open(tmp, "wb") as fh:
                np.savez(fh, samples=x if x.shape[1] > 1 else x[:, 0], fs=recording.fs)
        paths = {"data": data_path}
    paths["meta"] = write_text_atomic(side, text)
    if truth is not None:
        paths["truth"] = write_text_atomic(truth_path(stem), json.dumps(truth) + "\n")
    return paths


def _toml_value(key: str, value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        if not math.isfinite(value):
            raise ValueError(f"metadata '{key}' = {value!r} cannot be written as TOML")
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, (list, tuple)) and all(
            isinstance(v, (int, float, str)) and not isinstance(v, bool) for v in value):
        return "[" + ", ".join(_toml_value(key, v) for v in value) + "]"
    raise ValueError(f"metadata '{key}' = {value!r} cannot be written as TOML here; use "
                     "sidecar='json'")


def _toml(meta: dict) -> str:
    """TOML of the sidecar: flat values, one level of tables, [[channels]]."""
    lines, tables = [], []
    for key, value in meta.items():
        if key == "channels" or isinstance(value, dict):
            tables.append((key, value))
        else:
            lines.append(f"{key} = {_toml_value(key, value)}")
    for key, value in tables:
        for entry in (value if key == "channels" else [value]):
            lines.append(f"\n[[{key}]]" if key == "channels" else f"\n[{key}]")
            for k, v in entry.items():
                lines.append(f"{k} = {_toml_value(k, v)}")
    return "\n".join(lines) + "\n"
