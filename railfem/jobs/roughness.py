"""``railfem roughness``: combined wheel-rail roughness from pass-by recordings.

    railfem roughness run1.wav run2.wav --track site --method full --out DIR
    railfem roughness run*.wav --track fit.json --method simplified --tdr energy --out DIR

``--track`` (:func:`resolve_track`): a Table 1 preset name, a TOML track spec, a
``railfem track`` run.json, or a ``railfem fit`` fit.json (its ``spec`` section, the dict
form of railfem.spec). ``--tdr`` (simplified method; :func:`decay_rate_source`): ``energy``
or ``slope`` (the pass-by estimators on the same recordings), ``hammer:DATA`` (EN 15461 on
a hammer dataset, sensor chosen by the recordings' channel location if the dataset has it),
``model`` (EN 15461 of the track model) or a decay-rate table file (CSV, the vertical
rows averaged). Writes roughness.csv, roughness.png (with the EN ISO 3095 limit),
decay_rate_used.csv (simplified) and run.json.
"""
from __future__ import annotations

import json
import logging
import time
from pathlib import Path

import numpy as np

from ..atomic import json_safe, prepare_output_dir, write_text

log = logging.getLogger(__name__)

__all__ = ["COMMAND", "METHODS", "resolve_track", "decay_rate_source", "run_roughness"]

COMMAND = "roughness"
METHODS = ("full", "simplified")
A_TERMS = ("model", "default")


def resolve_track(text: str, model: str | None = None):
    """A TrackSpec from a preset name, a TOML spec, a 'railfem track' run.json or a
    'railfem fit' fit.json; ``model`` overrides its model kind."""
    from ..spec import PRESETS, TrackSpec, preset, spec_from_dict

    if text in PRESETS:
        spec = preset(text)
    else:
        path = Path(text)
        if not path.is_file():
            raise ValueError(f"--track {text!r}: not a preset ({', '.join(PRESETS)}) and no "
                             "such file (TOML spec, railfem track run.json, railfem fit "
                             "fit.json)")
        if path.suffix == ".toml":
            from ..io.config import read_track_config

            spec = spec_from_dict(read_track_config(path)[0])
        else:
            try:
                data = json.loads(path.read_text())
            except json.JSONDecodeError as exc:
                raise ValueError(f"--track {path}: not valid JSON: {exc}") from None
            if isinstance(data, dict) and isinstance(data.get("config"), dict) \
                    and "spec" in data["config"]:
                spec = spec_from_dict(data["config"]["spec"])      # railfem track run.json
            elif isinstance(data, dict) and isinstance(data.get("spec"), dict):
                spec = spec_from_dict(data["spec"])                # railfem fit fit.json
            else:
                raise ValueError(f"--track {path}: neither a 'railfem track' run.json "
                                 "(config.spec) nor a 'railfem fit' fit.json (spec)")
    if not isinstance(spec, TrackSpec):
        raise ValueError(f"--track {text!r} did not give a track spec")
    return spec.replace(model=model) if model else spec


def _on_bands(bands, frequency, values, what: str) -> np.ndarray:
    """values (per nominal band ``frequency``) on ``bands`` (NaN where missing)."""
    out = np.full(len(bands), np.nan)
    f = np.asarray(frequency, dtype=float)
    for i, n in enumerate(bands.nominal):
        hit = np.flatnonzero(np.isclose(f, n, rtol=0.03))
        if hit.size:
            out[i] = float(values[hit[0]])
    if not np.isfinite(out).any():
        raise ValueError(f"{what} has no value in the bands {bands.nominal[0]:g}-"
                         f"{bands.nominal[-1]:g} Hz")
    return out


def decay_rate_source(source: str, bands, *, spec, recordings, passby, location: str,
                      cache=None) -> tuple[np.ndarray, str]:
    """(decay rate per band in dB/m, description) for ``--tdr`` (module docstring)."""
    from ..standards.iec61260 import ninth_octave_grid

    if source in ("energy", "slope"):
        est = passby.energy if source == "energy" else passby.slope
        return est.decay_rate, f"pass-by {est.method} on the recordings"
    if source == "model":
        from ..models import decay_rate

        f = ninth_octave_grid(bands.nominal[0], bands.nominal[-1])
        r = decay_rate(spec, f, output=location, cache=cache)
        return r.decay_rate, f"EN 15461 of the track model ({spec.name}, {spec.model})"
    if source.startswith("hammer:"):
        from ..estimators import tdr
        from ..io import read_measurement

        m = read_measurement(source[len("hammer:"):])
        names = list(m.sensor_names)
        name = location if location in names else names[0] if len(names) == 1 else None
        if name is None:
            raise ValueError(f"--tdr {source}: the dataset has sensors {names}; none is the "
                             f"recordings' location {location!r}")
        r = tdr.hammer(m, name)
        d = np.where(r.suitable, r.decay_rate, np.nan)
        return _on_bands(bands, r.frequency, d, source), f"EN 15461 of {source[7:]} ({name})"
    path = Path(source)
    if not path.is_file():
        raise ValueError(f"--tdr {source!r}: give energy, slope, model, hammer:DATA or a "
                         "decay-rate table file")
    from ..io.tdr_table import read_decay_rate_table

    table = read_decay_rate_table(path)
    rows = [j for j, d in enumerate(table.direction) if d == "z"]
    if not rows:
        raise ValueError(f"--tdr {path}: no vertical rows")
    with np.errstate(invalid="ignore"):
        mean = np.nanmean(table.decay_rate[:, rows], axis=1)
    return _on_bands(bands, table.frequency, mean, str(path)), \
        f"mean of {len(rows)} vertical rows of {path.name}"


def run_roughness(recordings, out_dir, *, track: str, method: str = "full",
                  tdr: str | None = None, a_terms: str = "model", model: str | None = None,
                  channel: str | None = None, f_low: float = 100.0, f_high: float = 5000.0,
                  wheel: str = "rigid", contact_filter: str = "analytical",
                  speed: float | None = None, detect: dict | None = None, cache=None) -> dict:
    """Roughness of the recordings by ``method``; files into ``out_dir`` (module docstring).
    Every input is checked before any computing."""
    from ..wheelrail import contact as C
    from ..estimators.passby import PassbyOptions, passby_decay_rate
    from ..estimators.passby_level import passby_level
    from ..identify import roughness as RM
    from ..io.recording import read_rail_recordings
    from ..io.wheel_frf import read_wheel_frf
    from ..simulate import passby as P
    from ..simulate.chain import WHEEL_MODELS, make_wheel
    from ..standards.iec61260 import ninth_octave_grid, third_octave_bands

    t0 = time.perf_counter()
    if method not in METHODS:
        raise ValueError(f"--method {method!r}: choose one of {', '.join(METHODS)}")
    if method == "simplified" and not tdr:
        raise ValueError("the simplified method needs a decay rate: --tdr energy, slope, "
                         "model, hammer:DATA or a decay-rate table file")
    if tdr is not None and tdr not in ("energy", "slope", "model"):
        where = Path(tdr[len("hammer:"):] if tdr.startswith("hammer:") else tdr)
        if not where.exists():
            raise ValueError(f"--tdr {tdr!r}: give energy, slope, model, hammer:DATA (an "
                             "existing dataset) or an existing decay-rate table file")
    if a_terms not in A_TERMS:
        raise ValueError(f"--a-terms {a_terms!r}: choose one of {', '.join(A_TERMS)}")
    if wheel not in WHEEL_MODELS and not Path(str(wheel)).is_file():
        raise ValueError(f"--wheel {wheel!r}: choose 'rigid', 'flexible' or an existing FRF "
                         "CSV file of the wheel mobility")
    if contact_filter not in C.FILTERS:
        raise ValueError(f"--contact-filter {contact_filter!r}: choose one of "
                         f"{', '.join(C.FILTERS)}")
    paths = [Path(p) for p in recordings]
    if not paths:
        raise ValueError("give at least one pass-by recording")
    spec = resolve_track(track, model)
    recs, location = read_rail_recordings(paths, channel)
    bands = third_octave_bands(f_low, f_high)
    f = ninth_octave_grid(f_low, f_high)
    out = prepare_output_dir(out_dir, COMMAND)
    needs_passby = method == "simplified" and tdr in ("energy", "slope")
    passby = passby_decay_rate(recs, PassbyOptions(f_low=f_low, f_high=f_high), speed=speed,
                               detect=detect) if needs_passby else None
    wheels = passby.wheels if passby else [None] * len(recs)
    levels = [passby_level(r, f_low, f_high, wheels=w, speed=speed, detect=detect)
              for r, w in zip(recs, wheels)]
    hz = C.hertz()
    wheel_model = make_wheel(wheel, f) if wheel in WHEEL_MODELS else read_wheel_frf(wheel)
    aw = wheel_model.receptance(f)
    ac = C.contact_receptance(hz, f)
    sensor_x = [r.channel.x_from_support for r in recs]
    if any(x is None for x in sensor_x):
        log.warning("sensor position in the span unknown: mid-span assumed")
    sensor_x = [spec.spacing / 2 if x is None else x for x in sensor_x]
    used, d = None, None
    if method == "full" or a_terms == "model":
        tables = P.rail_tables(spec, f, cache=cache)
    if method == "full":
        ests = [RM.full_method(lv, tables, wheel_receptance=aw, contact=hz, sensor_x=x,
                               output=location, contact_filter=contact_filter)
                for lv, x in zip(levels, sensor_x)]
    else:
        d, used = decay_rate_source(tdr, bands, spec=spec, recordings=recs, passby=passby,
                                    location=location, cache=cache)
        terms = (RM.a_terms_model(tables, bands, wheel_receptance=aw, contact_receptance=ac,
                                  sensor_x=sensor_x[0], output=location)
                 if a_terms == "model" else
                 RM.a_terms_default(spec, bands, f, contact=hz, cache=cache))
        ests = [RM.simplified_method(lv, d, terms, contact=hz, contact_filter=contact_filter)
                for lv in levels]
    comb = RM.combine(ests, name="combined")
    files = _write(out, ests, comb, method, d, bands, used)
    summary = {
        "command": COMMAND, "recordings": [str(p) for p in paths], "channel": channel,
        "track": track, "spec_name": spec.name, "model": spec.model, "method": method,
        "tdr": tdr, "tdr_used": used, "a_terms": a_terms if method == "simplified" else None,
        "wheel": wheel, "contact_filter": contact_filter, "sensor": location,
        "passbys": [{"name": lv.name, "speed_m_s": lv.speed, "n_wheels": lv.wheels.count,
                     "window_m": lv.length} for lv in levels],
        "wavelength_m": comb.wavelength, "roughness_db_re_1um": comb.level,
        "runtime_s": time.perf_counter() - t0,
        "files": {k: str(v) for k, v in files.items()},
    }
    files["json"] = write_text(out / "run.json", json.dumps(json_safe(summary), indent=2) + "\n")
    summary["files"]["json"] = str(files["json"])
    return summary


def _write(out: Path, ests, comb, method, decay, bands, used) -> dict:
    from ..plotting import plot_roughness, save_figure

    rows = [f"# combined wheel-rail roughness ({method} method), dB re 1 um per "
            "one-third-octave wavelength band; per pass-by: band centre frequency, speed, "
            "wavelength V/f", "recording,band_hz,speed_m_s,wavelength_m,level_db,status"]
    for e in ests:
        for i in range(len(e.wavelength)):
            lev = "" if not np.isfinite(e.level[i]) else f"{e.level[i]:.2f}"
            rows.append(f"{e.name},{bands.nominal[i]:g},{e.speed:.3f},{e.wavelength[i]:.5g},"
                        f"{lev},{e.status[i]}")
    for lam, lev in zip(comb.wavelength, comb.level):
        rows.append(f"combined,,,{lam:.5g},{'' if not np.isfinite(lev) else f'{lev:.2f}'},"
                    f"{'ok' if np.isfinite(lev) else 'no_value'}")
    files = {"csv": write_text(out / "roughness.csv", "\n".join(rows) + "\n")}
    curves = {"combined": comb.level}
    lams = {"combined": comb.wavelength}
    for e in ests:
        curves[e.name] = e.level
        lams[e.name] = e.wavelength
    ax = plot_roughness(lams, curves, styles={"combined": {"color": "k", "lw": 2.5}})
    ax.set_title(f"Combined roughness, {method} method", fontsize="small")
    files["png"] = save_figure(ax, out / "roughness.png")
    if decay is not None:
        text = ["# decay rate used by the simplified method, dB/m: " + used, "band_hz,D_db_per_m"]
        text += [f"{b:g},{'' if not np.isfinite(d) else f'{d:.4g}'}"
                 for b, d in zip(bands.nominal, decay)]
        files["decay_csv"] = write_text(out / "decay_rate_used.csv", "\n".join(text) + "\n")
    return files
