"""The pass-by job behind ``railfem passby``: roughness -> contact forces -> rail vibration
at the sensor for every train position, the pass-by spectrum, plots and (optionally) the
time signal a recorder would take.

Inputs may come from keyword arguments or a TOML config (:func:`read_config`; its keys
are the keyword names). Outputs (all atomic):

    band_levels.csv       band velocity level at the sensor vs leading-wheel position
    passby_spectrum.csv   pass-by average per band: exact form, paper's form, difference
    contact_force.csv     band contact-force level per wheel, averaged over the pass-by
    *.png                 level vs position, pass-by spectrum, contact forces, wheel FRF
    run.json              settings, runtime, files, exact-vs-paper difference
    passby.wav/.json      (signal=True) the recording; passby.truth.json the truth
"""
from __future__ import annotations

import json
import logging
import math
import time
from pathlib import Path

import numpy as np

from ..wheelrail import contact
from ..wheelrail import roughness as rough
from ..wheelrail import wheels
from ..atomic import prepare_output_dir, write_text_atomic
from .common import progress_logger
from ..simulate import passby as P
from ..simulate.train import TrainLayout, default_train, read_train_layout
from ..standards import iec61260
from ..track.supports import TrackPreset, preset as get_preset

log = logging.getLogger(__name__)

__all__ = ["run_passby", "read_config", "make_wheel", "roughness_spectrum", "WHEEL_MODELS",
           "CONTACT_FILTERS", "DEFAULTS"]

WHEEL_MODELS = ("rigid", "flexible")
CONTACT_FILTERS = contact.FILTERS
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


def make_wheel(kind, frequency, *, mass=None, progress=None):
    """'rigid', 'flexible' or the path of an FRF CSV file -> a wheel model."""
    mass = mass or wheels.DEFAULT_UNSPRUNG_MASS
    if kind == "rigid":
        return wheels.RigidWheel(mass=mass)
    if kind == "flexible":
        return wheels.flexible_wheel(mass=mass, f_max=float(np.max(frequency)),
                                     progress=progress)
    path = Path(str(kind))
    if not path.is_file():
        raise ValueError(f"wheel = {kind!r}: choose 'rigid', 'flexible' or an existing FRF "
                         "CSV file of the wheel mobility")
    return wheels.read_wheel_mobility(path)


def roughness_spectrum(source, select=None) -> rough.RoughnessSpectrum:
    """None: the default straight-line spectrum; a path: a railfem spectrum CSV or the SBB
    wide table (recognised by its 'rail' and wavelength columns)."""
    if source is None:
        return rough.sloped_spectrum(0.0, 10.0, name="default: 0 dB re 1 um at 10 mm, "
                                                      "+10 dB/decade of wavelength")
    path = Path(source)
    if not path.is_file():
        raise ValueError(f"roughness file {path} does not exist")
    head = path.read_text().splitlines()[0]
    if head.startswith("loc,") or ",rail," in head:
        return rough.read_sbb_roughness(path, select=select)
    return rough.read_spectrum_csv(path)


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


def run_passby(out_dir, *, tables: P.RailTables | None = None, cache=None,
               **options) -> dict:
    """Simulate a pass-by and write its files (see the module docstring).

    options: see DEFAULTS (speed in km/h, frequencies in Hz, lengths in m). tables: rail
    tables from P.rail_tables to reuse (their frequencies and model win)."""
    unknown = set(options) - set(DEFAULTS)
    if unknown:
        raise ValueError(f"unknown pass-by options {sorted(unknown)}")
    opts = {**DEFAULTS, **options}
    _check(opts)
    t0 = time.perf_counter()
    out = prepare_output_dir(out_dir, "passby")
    tp: TrackPreset = get_preset(opts["preset"]) if isinstance(opts["preset"], str) \
        else opts["preset"]
    train = opts["train"] if isinstance(opts["train"], TrainLayout) else (
        default_train() if opts["train"] is None else read_train_layout(opts["train"]))
    spec = roughness_spectrum(opts["roughness"], opts["roughness_select"])
    speed = opts["speed_kmh"] / 3.6
    f = iec61260.ninth_octave_grid(opts["f_low"], opts["f_high"]) if tables is None \
        else tables.frequency
    # fails early if the spectrum does not cover the frequencies (unless told to hold)
    amp = rough.amplitude_at(spec, f, speed,
                             outside="hold" if opts["roughness_hold"] else "raise")
    wheel = make_wheel(opts["wheel"], f, mass=opts["wheel_mass"],
                       progress=progress_logger("wheel modes"))
    load = opts["wheel_load"] or contact.DEFAULT_WHEEL_LOAD
    hz = contact.hertz(load, wheel_radius=wheels.DEFAULT_WHEEL_RADIUS)
    if tables is None:
        tables = P.rail_tables(tp, f, model=opts["model"], continuous=opts["continuous"],
                               max_distance=opts["max_distance"], cache=cache,
                               progress=progress_logger("rail tables"))
    t_tables = time.perf_counter()
    r = amp * np.sqrt(contact.filter_power(opts["contact_filter"], f, speed, hz))
    aw, ac = wheel.receptance(f), contact.contact_receptance(hz, f)
    common = dict(output=opts["output"], interaction=opts["interaction"],
                  before=opts["before"], after=opts["after"],
                  settings={"speed_m_per_s": speed, "roughness": spec.name,
                            "wheel": getattr(wheel, "name", type(wheel).__name__),
                            "contact_filter": opts["contact_filter"]})
    res = P.simulate_passby(tables, train, aw, ac, r, form=opts["form"], **common)
    other = P.simulate_passby(tables, train, aw, ac, r,
                              form="paper" if opts["form"] == "exact" else "exact", **common)
    exact, paper = (res, other) if opts["form"] == "exact" else (other, res)
    t_sim = time.perf_counter()
    paths = _write_tables(out, res, exact, paper, train)
    paths.update(_plots(out, res, exact, paper, wheel, f, tp, opts))
    summary = {
        "command": "passby", "preset": tp.name, "model": tables.description, "speed_m_per_s": speed,
        "train": {"name": train.name, "n_wheels": train.n_wheels, "length_m": train.length,
                  "axle_offsets_m": list(train.offsets)},
        "roughness": spec.name, "wheel": getattr(wheel, "name", str(opts["wheel"])),
        "contact": {"load_n": hz.load, "a_m": hz.a, "b_m": hz.b, "stiffness_n_per_m":
                    hz.stiffness},
        "options": {k: (v if isinstance(v, (int, float, str, bool, type(None), list, tuple))
                        else str(v)) for k, v in opts.items()},
        "band_hz": res.bands.nominal.tolist(),
        "passby_level_db": np.round(res.average_level(), 3).tolist(),
        "exact_minus_paper_db": np.round(exact.average_level() - paper.average_level(),
                                         3).tolist(),
        "runtime_s": {"tables": t_tables - t0, "simulation": t_sim - t_tables},
    }
    if opts["signal"]:
        from ..simulate import signals

        quasi = signals.quasi_static(tp, load)
        sig, truth = signals.synthesise(res, train, speed, sample_rate=opts["sample_rate"],
                                        quantity=opts["quantity"], quasi=quasi,
                                        noise_fraction=opts["noise_fraction"],
                                        position_error=opts["position_error"],
                                        seed=opts["seed"])
        truth["roughness"] = {"name": spec.name, "wavelength_m": spec.wavelength.tolist(),
                              "level_db_re_1um": spec.level.tolist()}
        truth["track"] = {"preset": tp.name, "model": tables.description}
        from ..io.recording import write_recording

        rec = signals.passby_recording(sig, truth, spacing=tp.spacing, location=opts["output"],
                                       speed_known=opts["speed_known"])
        rec_paths = write_recording(out / "passby", rec, data_format=opts["data_format"],
                                    truth=truth)
        paths.update({f"recording_{k}": v for k, v in rec_paths.items()})
    summary["runtime_s"]["total"] = time.perf_counter() - t0
    summary["files"] = {k: str(v) for k, v in paths.items()}
    paths["json"] = write_text_atomic(out / "run.json", json.dumps(summary, indent=2) + "\n")
    summary["files"]["json"] = str(paths["json"])
    log.info("pass-by %s at %.0f km/h: %.1f s (tables %.1f s)", tp.name, opts["speed_kmh"],
             summary["runtime_s"]["total"], summary["runtime_s"]["tables"])
    return summary


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
            "sum over sources of the coherent sum over wheels; paper = METHOD.md section 5 form",
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


def _plots(out, res, exact, paper, wheel, f, tp, opts) -> dict:
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
    ax.set_title(f"{tp.name} track, {opts['speed_kmh']:g} km/h, {opts['output']} sensor")
    paths["levels_png"] = plotting.save_figure(ax.figure, out / "level_vs_position.png")
    ax = plotting.plot_band_values(res.bands.nominal,
                                   np.column_stack([exact.average_level(), paper.average_level()]),
                                   ["exact", "paper's form"],
                                   ylabel="Pass-by level (dB re 1e-9 m/s)")
    ax.set_title(f"{tp.name} track, {opts['wheel']} wheel")
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
