"""The pass-by job behind ``railfem passby``: roughness -> contact forces -> rail vibration
at the sensor for every train position, the pass-by spectrum, plots and (optionally) the
time signal a recorder would take.

Inputs may come from keyword arguments or a TOML config (:func:`read_config`; its keys
are the keyword names). Outputs (all atomic):

    band_levels.csv       band velocity level at the sensor vs leading-wheel position
    passby_spectrum.csv   pass-by average per band: exact form, paper's form, difference
    contact_force.csv     band contact-force level per wheel, averaged over the pass-by
    *.png                 level vs position, pass-by spectrum, contact forces, wheel FRF
    run.json              settings, the track (railfem.spec dict form), runtime, files,
                          exact-vs-paper difference
    passby.wav/.json      (signal=True) the recording; passby.truth.json the truth
"""
from __future__ import annotations

import json
import logging
import math
import time
from pathlib import Path

import numpy as np

from ..atomic import prepare_output_dir, write_text_atomic
from ..simulate import chain
from ..simulate import passby as P
from ..io.train import read_train_layout
from ..simulate.train import TrainLayout, default_train
from ..spec import spec_to_dict
from ..standards import iec61260
from .common import progress_logger

log = logging.getLogger(__name__)

__all__ = ["run_passby", "read_config", "track_of", "WHEEL_MODELS", "CONTACT_FILTERS",
           "DEFAULTS"]

WHEEL_MODELS = chain.WHEEL_MODELS
CONTACT_FILTERS = chain.CONTACT_FILTERS
DEFAULTS = dict(preset="site", model="wfe-discrete", speed_kmh=216.0, train=None,
                roughness=None, roughness_select=None, roughness_hold=False, wheel="rigid",
                wheel_mass=None,
                f_low=100.0, f_high=5000.0, form="exact", interaction=True, continuous=False,
                output="foot", contact_filter="analytical", wheel_load=None,
                before=30.0, after=30.0, max_distance=30.0, signal=False,
                sample_rate=25600.0, quantity="acceleration", noise_fraction=0.0,
                position_error=0.0, seed=0, data_format="wav", speed_known=True,
                plot_bands=(250.0, 500.0, 1000.0, 2000.0))


def read_config(path) -> dict:
    """Keyword arguments of run_passby from a TOML file (unknown keys are an error)."""
    from ..io.config import read_toml

    path = Path(path)
    data = read_toml(path)
    unknown = set(data) - set(DEFAULTS)
    if unknown:
        raise ValueError(f"{path}: unknown keys {sorted(unknown)}; valid keys: "
                         f"{', '.join(sorted(DEFAULTS))}")
    for key in ("train", "roughness"):  # file names relative to the config's folder
        if isinstance(data.get(key), str) and not Path(data[key]).is_absolute():
            data[key] = str(path.parent / data[key])
    return data


def track_of(track, options: dict):
    """The TrackSpec of a run: ``track`` (a TrackSpec; the 'model' option, if given,
    replaces its model) or the Table 1 ``preset`` of the options with their model."""
    from ..spec import TrackSpec, preset

    if track is None:
        return preset(options.get("preset", DEFAULTS["preset"]),
                      model=options.get("model", DEFAULTS["model"]))
    if not isinstance(track, TrackSpec):
        raise ValueError(f"track = {track!r}: give a railfem.spec.TrackSpec (or the preset "
                         "option with a preset name)")
    if "preset" in options:
        raise ValueError("give either a track (TrackSpec) or a preset, not both")
    return track.replace(model=options["model"]) if "model" in options else track


def _check(opts):
    if opts["wheel"] not in WHEEL_MODELS and not Path(str(opts["wheel"])).is_file():
        raise ValueError(f"wheel = {opts['wheel']!r}: choose 'rigid', 'flexible' or an FRF "
                         "CSV file")
    if opts["contact_filter"] not in CONTACT_FILTERS:
        raise ValueError(f"contact_filter = {opts['contact_filter']!r}: choose one of "
                         f"{CONTACT_FILTERS}")
    if opts["form"] not in P.FORMS or opts["output"] not in P.OUTPUTS:
        raise ValueError(f"form must be one of {P.FORMS} and output one of {P.OUTPUTS}")
    if not (opts["speed_kmh"] > 0 and math.isfinite(opts["speed_kmh"])):
        raise ValueError(f"speed = {opts['speed_kmh']!r} km/h: give a speed > 0 km/h")
    if not (0 < opts["f_low"] < opts["f_high"]):
        raise ValueError(f"f_low = {opts['f_low']}, f_high = {opts['f_high']} Hz: need "
                         "0 < f_low < f_high")
    if opts["signal"] and opts["sample_rate"] < 2.3 * opts["f_high"]:
        raise ValueError(f"sample_rate = {opts['sample_rate']} Hz is too low for f_high = "
                         f"{opts['f_high']} Hz: use at least {2.3 * opts['f_high']:.0f} Hz")


def _inputs(opts, f):
    """(train, roughness spectrum, wheel model) of the options: files read here."""
    from ..io.roughness_table import read_roughness
    from ..io.wheel_frf import read_wheel_frf

    train = opts["train"] if isinstance(opts["train"], TrainLayout) else (
        default_train() if opts["train"] is None else read_train_layout(opts["train"]))
    spectrum = chain.default_roughness() if opts["roughness"] is None else \
        read_roughness(opts["roughness"], opts["roughness_select"])
    wheel = opts["wheel"]
    if wheel not in WHEEL_MODELS:
        wheel = read_wheel_frf(wheel)
    elif wheel == "flexible":
        wheel = chain.make_wheel(wheel, f, mass=opts["wheel_mass"],
                                 progress=progress_logger("wheel modes"))
    return train, spectrum, wheel


def run_passby(out_dir, *, track=None, tables: P.RailTables | None = None, cache=None,
               **options) -> dict:
    """Simulate a pass-by and write its files (see the module docstring).

    track: the track, a railfem.spec.TrackSpec (default: the ``preset`` option, a Table 1
    name, with the ``model`` option). options: see DEFAULTS (speed in km/h, frequencies in
    Hz, lengths in m). tables: rail tables from P.rail_tables to reuse (their frequencies
    and model win)."""
    unknown = set(options) - set(DEFAULTS)
    if unknown:
        raise ValueError(f"unknown pass-by options {sorted(unknown)}")
    spec = track_of(track, options)
    opts = {**DEFAULTS, **options, "preset": spec.name, "model": spec.model}
    _check(opts)
    t0 = time.perf_counter()
    out = prepare_output_dir(out_dir, "passby")
    speed = opts["speed_kmh"] / 3.6
    f = iec61260.ninth_octave_grid(opts["f_low"], opts["f_high"]) if tables is None \
        else tables.frequency
    train, spectrum, wheel = _inputs(opts, f)
    run = chain.passby_chain(
        spec, train, speed, frequency=f, roughness=spectrum,
        roughness_hold=opts["roughness_hold"], wheel=wheel, wheel_mass=opts["wheel_mass"],
        wheel_load=opts["wheel_load"], contact_filter=opts["contact_filter"],
        form=opts["form"], output=opts["output"], interaction=opts["interaction"],
        continuous=opts["continuous"], before=opts["before"], after=opts["after"],
        max_distance=opts["max_distance"], tables=tables, cache=cache,
        progress=progress_logger("rail tables"))
    res, exact, paper, hz = run.result, run.exact, run.paper, run.hertz
    paths = _write_tables(out, res, exact, paper, train)
    paths.update(_plots(out, res, exact, paper, run.wheel, f, spec, opts))
    summary = {
        "command": "passby", "preset": spec.name, "model": run.tables.description,
        "speed_m_per_s": speed,
        "train": {"name": train.name, "n_wheels": train.n_wheels, "length_m": train.length,
                  "axle_offsets_m": list(train.offsets)},
        "roughness": spectrum.name, "wheel": getattr(run.wheel, "name", str(opts["wheel"])),
        "contact": {"load_n": hz.load, "a_m": hz.a, "b_m": hz.b, "stiffness_n_per_m":
                    hz.stiffness},
        "options": {k: (v if isinstance(v, (int, float, str, bool, type(None), list, tuple))
                        else str(v)) for k, v in opts.items()},
        "track": spec_to_dict(spec),
        "band_hz": res.bands.nominal.tolist(),
        "passby_level_db": np.round(res.average_level(), 3).tolist(),
        "exact_minus_paper_db": np.round(exact.average_level() - paper.average_level(),
                                         3).tolist(),
        "runtime_s": dict(run.seconds),
    }
    if opts["signal"]:
        paths.update(_signal(out, run, spec, train, opts))
    summary["runtime_s"]["total"] = time.perf_counter() - t0
    summary["files"] = {k: str(v) for k, v in paths.items()}
    paths["json"] = write_text_atomic(out / "run.json", json.dumps(summary, indent=2) + "\n")
    summary["files"]["json"] = str(paths["json"])
    log.info("pass-by %s at %.0f km/h: %.1f s (tables %.1f s)", spec.name, opts["speed_kmh"],
             summary["runtime_s"]["total"], summary["runtime_s"]["tables"])
    return summary


def _signal(out, run, spec, train, opts) -> dict:
    """The time signal of the pass-by as a recording (truth apart)."""
    from ..io.recording import write_recording
    from ..simulate import signals

    quasi = signals.quasi_static(spec, run.hertz.load)
    sig, truth = signals.synthesise(run.result, train, run.speed,
                                    sample_rate=opts["sample_rate"], quantity=opts["quantity"],
                                    quasi=quasi, noise_fraction=opts["noise_fraction"],
                                    position_error=opts["position_error"], seed=opts["seed"])
    truth["roughness"] = {"name": run.roughness.name,
                          "wavelength_m": run.roughness.wavelength.tolist(),
                          "level_db_re_1um": run.roughness.level.tolist()}
    truth["track"] = {"preset": spec.name, "model": run.tables.description}
    rec = signals.passby_recording(sig, truth, spacing=spec.spacing, location=opts["output"],
                                   speed_known=opts["speed_known"])
    rec_paths = write_recording(out / "passby", rec, data_format=opts["data_format"],
                                truth=truth)
    return {f"recording_{k}": v for k, v in rec_paths.items()}


def _write_tables(out, res, exact, paper, train) -> dict:
    paths = {}
    L = res.band_level()
    head = "position_m," + ",".join(f"L_{b:g}hz" for b in res.bands.nominal)
    rows = ["# band velocity level at the sensor, dB re 1e-9 m/s, vs leading-wheel position "
            "X (m) relative to the sensor; wheel n stands at X - offset_n; empty = no wheel "
            "within the rail tables' reach", head]
    for j, x in enumerate(res.position):
        rows.append(f"{x:.2f}," + ",".join("" if not np.isfinite(v) else f"{v:.3f}"
                                          for v in L[:, j]))
    paths["levels_csv"] = write_text_atomic(out / "band_levels.csv", "\n".join(rows) + "\n")
    le, lp = exact.average_level(), paper.average_level()
    rows = ["# pass-by average over all simulated positions, dB re 1e-9 m/s; exact = incoherent "
            "sum over sources of the coherent sum over wheels; paper = the same without the "
            "cross terms between the wheels of one source (docs/passby.md)",
            "band_hz,exact_db,paper_db,exact_minus_paper_db"]
    rows += [f"{b:g},{a:.3f},{p:.3f},{a - p:.3f}" for b, a, p in zip(res.bands.nominal, le, lp)]
    paths["spectrum_csv"] = write_text_atomic(out / "passby_spectrum.csv", "\n".join(rows) + "\n")
    fb = iec61260.band_average(res.frequency, np.sqrt(res.force_sq.mean(axis=1)), res.bands)
    rows = ["# band contact-force level per wheel, averaged over the pass-by, dB re 1 N",
            "band_hz," + ",".join(f"wheel_{i}" for i in range(train.n_wheels))]
    rows += [f"{b:g}," + ",".join(f"{20 * np.log10(v):.3f}" for v in fb[k])
             for k, b in enumerate(res.bands.nominal)]
    paths["force_csv"] = write_text_atomic(out / "contact_force.csv", "\n".join(rows) + "\n")
    return paths


def _plots(out, res, exact, paper, wheel, f, spec, opts) -> dict:
    from .. import plotting

    paths = {}
    L = res.band_level()
    cols, labels = [], []
    for fb in opts["plot_bands"]:
        k = int(np.argmin(np.abs(np.log(res.bands.nominal / fb))))
        cols.append(L[k])
        labels.append(f"{res.bands.nominal[k]:g} Hz band")
    ax = plotting.plot_passby_levels(res.position - res.settings["sensor_x_m"],
                                     np.column_stack(cols), labels)
    top = float(np.nanmax(np.where(np.isfinite(cols), cols, np.nan)))
    ax.set_ylim(top - 80.0, top + 5.0)  # no wheel within reach gives -inf / round-off levels
    ax.set_title(f"{spec.name} track, {opts['speed_kmh']:g} km/h, {opts['output']} sensor")
    paths["levels_png"] = plotting.save_figure(ax.figure, out / "level_vs_position.png")
    ax = plotting.plot_band_values(res.bands.nominal,
                                   np.column_stack([exact.average_level(), paper.average_level()]),
                                   ["exact", "paper's form"],
                                   ylabel="Pass-by level (dB re 1e-9 m/s)")
    ax.set_title(f"{spec.name} track, {opts['wheel']} wheel")
    paths["spectrum_png"] = plotting.save_figure(ax.figure, out / "passby_spectrum.png")
    fb = iec61260.band_average(res.frequency, np.sqrt(res.force_sq.mean(axis=1)), res.bands)
    ax = plotting.plot_band_values(res.bands.nominal, 20 * np.log10(fb[:, [0, -1]]),
                                   ["leading wheel", "last wheel"],
                                   ylabel="Contact force level (dB re 1 N)")
    paths["force_png"] = plotting.save_figure(ax.figure, out / "contact_force.png")
    ax_mag, _ = plotting.plot_magnitude_phase(f, 1j * 2 * np.pi * f * wheel.receptance(f),
                                              ["wheel, radial at the contact"])
    paths["wheel_png"] = plotting.save_figure(ax_mag.figure, out / "wheel_mobility.png")
    return paths
