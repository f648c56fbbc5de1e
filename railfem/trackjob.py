"""The supported-track job behind ``railfem track``: one model of a Table 1 track, its point
and EN 15461 transfer mobilities, decay rates, along-rail table and plots."""
from __future__ import annotations

import json
import logging
import time

import numpy as np

from . import beams, mobility, section, track, waveguide
from .atomic import prepare_output_dir
from .jobs import load_or_mesh, progress_logger, write_text_atomic
from .materials import Material
from .standards import en15461, iec61260
from .supports import TrackPreset, preset as get_preset, uniform_layout

log = logging.getLogger(__name__)

MODELS = ("wfe-discrete", "wfe-periodic", "wfe-continuous", "timoshenko-discrete",
          "timoshenko-continuous")
OUTPUTS = ("head", "foot")
POINT_OFFSET = 0.02  # m: hammer position 0 is realised 20 mm from the accelerometer


def beam_section(mesh, material: Material) -> beams.BeamSection:
    """Timoshenko vertical-bending section with the constants of the mesh (METHOD.md §3)."""
    sc = section.section_constants(mesh)
    return beams.BeamSection(E=material.E, G=material.E / (2 * (1 + material.nu)),
                             area=sc.area, I=sc.I_y, kappa=sc.kappa_z, rho=material.rho,
                             eta=material.loss_factor)


def _wfe_rail(mesh, material):
    """The WFE rail, the hammer/wheel load (20 mm head patch) and the two outputs."""
    guide = waveguide.assemble(mesh, material)
    outputs = [mobility.point(guide, "head_top", label="head"),
               mobility.point(guide, "foot_sensor", label="foot")]
    return guide, mobility.head_patch(guide, 0.02), outputs


def track_receptance(model: str, tp: TrackPreset, mesh, frequency, force_x, response_x, *,
                     n_supports: int = 131, pad_length: float = 0.0, n_rows: int = 1,
                     n_f: int = track.DEFAULT_N_FOOT_SPRINGS, progress=None) -> np.ndarray:
    """Receptance (nf, 2 [head, foot sensor], n_resp_x, n_force_x) of one track model.

    Beam models have no cross-section: their head and foot responses are the same."""
    if model not in MODELS:
        raise ValueError(f"unknown track model {model!r}; choose one of {', '.join(MODELS)}")
    f = np.asarray(frequency, dtype=float)
    fx, rx = np.asarray(force_x, dtype=float), np.asarray(response_x, dtype=float)
    material = Material.steel(tp.eta_r)
    layout = uniform_layout(tp.support, tp.spacing, n_supports, pad_length=pad_length,
                            n_rows=n_rows)
    omega = 2 * np.pi * f
    if model.endswith("discrete"):
        return _centred_on_pairs(model, tp, mesh, material, layout, f, fx, rx, n_f, progress)
    if model.startswith("timoshenko"):
        bs = beam_section(mesh, material)
        if model == "timoshenko-discrete":
            a = beams.discrete_track_receptance(bs, layout, omega, fx, rx)
        else:
            sep = rx[:, None] - fx[None, :]
            a = beams.continuous_track_receptance(bs, tp.support, tp.spacing, omega,
                                                  sep.ravel()).reshape(len(f), *sep.shape)
        return np.repeat(np.asarray(a)[:, None], 2, axis=1)
    guide, load, outputs = _wfe_rail(mesh, material)
    common = dict(load=load, outputs=outputs, progress=progress)
    if model == "wfe-periodic":
        r = track.periodic_receptance(guide, tp.support, tp.spacing, f, force_x=fx,
                                      response_x=rx, pad_length=pad_length, n_rows=n_rows,
                                      n_f=n_f, **common)
    else:
        sep = rx[:, None] - fx[None, :]
        r = track.continuous_receptance(guide, tp.support, tp.spacing, f, x=sep.ravel(),
                                        **common)
        return r.receptance[..., 0].reshape(len(f), 2, *sep.shape)
    return r.receptance


def _centred_on_pairs(model, tp, mesh, material, layout, f, fx, rx, n_f, progress):
    """Truncated discrete tracks centred on each load-response pair: the infinite track is
    periodic, so a pair (x_P, x_r) is computed as (x_P - c, x_r - c) with c the support
    nearest to their midpoint, which keeps both as far as possible from the ends of the
    supported stretch. One solve serves every pair."""
    c = np.round((rx[:, None] + fx[None, :]) / (2 * tp.spacing)) * tp.spacing
    uf, jf = np.unique(np.round(fx[None, :] - c, 10), return_inverse=True)
    ur, jr = np.unique(np.round(rx[:, None] - c, 10), return_inverse=True)
    jf, jr = jf.reshape(c.shape), jr.reshape(c.shape)
    if model == "timoshenko-discrete":
        a = beams.discrete_track_receptance(beam_section(mesh, material), layout,
                                            2 * np.pi * f, uf, ur)
        a = np.repeat(np.asarray(a)[:, None], 2, axis=1)
    else:
        guide, load, outputs = _wfe_rail(mesh, material)
        a = track.discrete_receptance(guide, layout, f, load=load, outputs=outputs,
                                      force_x=uf, response_x=ur, n_f=n_f,
                                      progress=progress).receptance
    return a[:, :, jr, jf]


def rail_pad_peak(frequency, point_mobility, tp: TrackPreset, rail_mass: float,
                  f_pinned_pinned: float = np.inf) -> float:
    """Frequency (Hz) of the rail-on-pad resonance: the largest |Y| between half and twice
    sqrt(k_p / (m' d)) / 2 pi (rail mass per span on the pad stiffness), kept below
    0.9 times the pinned-pinned frequency, whose peak can be the higher one on stiff pads."""
    f0 = np.sqrt(tp.support.kp / (rail_mass * tp.spacing)) / (2 * np.pi)
    band = (frequency > f0 / 2) & (frequency < min(2 * f0, 0.9 * f_pinned_pinned))
    if not band.any():
        return float("nan")
    i = np.argmax(np.abs(point_mobility) * band)
    return float(frequency[i])


def run_track(preset_name: str, model: str, out_dir, *, profile="60E1", h: float = 0.01,
              mesh_file=None, f_low: float = 50.0, f_high: float = 8000.0,
              n_supports: int = 131, pad_length: float = 0.0, n_rows: int = 1,
              n_f: int = track.DEFAULT_N_FOOT_SPRINGS, along_span: float = 6.0,
              along_frequencies=(250.0, 500.0, 1000.0, 2000.0), progress=None) -> dict:
    """Model the track of a Table 1 preset and write mobilities, decay rates and plots."""
    tp = get_preset(preset_name)
    out = prepare_output_dir(out_dir, "track")
    t0 = time.perf_counter()
    mesh = load_or_mesh(profile, h, mesh_file)
    f = iec61260.ninth_octave_grid(f_low, f_high)
    d = tp.spacing
    xs = d / 2  # sensor at mid-span; supports at x = n d
    pos = en15461.hammer_positions(d)
    hammer_x = xs + np.where(pos == 0, POINT_OFFSET, pos)
    span_fx = np.round(np.arange(0.0, d + 1e-9, 0.1), 10)
    along_x = np.round(np.arange(-along_span, along_span + 1e-9, 0.1), 10)
    fx = np.concatenate([hammer_x, span_fx])
    rx = np.concatenate([[xs], along_x])
    log.info("track %s, model %s: %d frequencies %.0f-%.0f Hz, %d force x %d response "
             "positions", tp.name, model, len(f), f[0], f[-1], len(fx), len(rx))
    alpha = track_receptance(model, tp, mesh, f, fx, rx, n_supports=n_supports,
                             pad_length=pad_length, n_rows=n_rows, n_f=n_f,
                             progress=progress or progress_logger(f"track {model}"))
    Y = 1j * 2 * np.pi * f[:, None, None, None] * alpha
    transfer = Y[:, :, 0, : len(pos)]  # (nf, 2, n_pos): sensor response, hammer moves
    paths = _write_outputs(out, tp, model, f, pos, hammer_x, xs, transfer,
                           Y[:, :, 1:, len(pos):], span_fx, along_x, along_frequencies)
    bs = beam_section(mesh, Material.steel())
    rail_mass, f_pp = bs.mass_per_length, beams.pinned_pinned_frequency(bs, d)
    summary = {
        "command": "track", "preset": tp.name, "model": model, "mesh": mesh.name, "n_supports": n_supports,
        "pad_length_m": pad_length, "n_rows": n_rows, "n_foot_springs": n_f,
        "sensor_x_m": xs, "point_offset_m": POINT_OFFSET,
        "rail_pad_peak_hz": {o: rail_pad_peak(f, transfer[:, j, 0], tp, rail_mass, f_pp)
                             for j, o in enumerate(OUTPUTS)},
        "runtime_s": time.perf_counter() - t0,
        "files": {k: str(v) for k, v in paths.items()},
    }
    paths["json"] = write_text_atomic(out / "run.json", json.dumps(summary, indent=2))
    log.info("track %s %s done in %.1f s; rail-on-pad peak %.0f Hz (head)", tp.name, model,
             summary["runtime_s"], summary["rail_pad_peak_hz"]["head"])
    return summary


def _write_outputs(out, tp, model, f, pos, hammer_x, xs, transfer, along, span_fx, along_x,
                   along_frequencies) -> dict:
    from . import plotting
    from .frf import FRF
    from .frfio import write_frf_csv

    paths = {}
    frf = FRF(frequency=f, values=transfer, quantity="mobility", response=OUTPUTS,
              force=tuple(f"hammer_{p:.3f}" for p in pos),
              response_x=np.full(2, xs), force_x=hammer_x)
    paths["transfer_csv"] = write_frf_csv(out / "transfer_mobility.csv", frf)
    results = [en15461.decay_rate(f, transfer[:, j, :], pos) for j in range(2)]
    rows = ["# EN 15461 track decay rate per one-third-octave band (dB/m); suitable = the "
            "band passes the 10 dB far-field check and D >= D_min",
            "band_hz,head_db_per_m,head_suitable,foot_db_per_m,foot_suitable"]
    for b in range(len(results[0].frequency)):
        rows.append(f"{results[0].frequency[b]:g}," + ",".join(
            f"{r.decay_rate[b]:.4f},{int(r.suitable[b])}" for r in results))
    paths["decay_csv"] = write_text_atomic(out / "decay_rate.csv", "\n".join(rows) + "\n")
    lines = ["# mobility (m/s/N, exp(+i omega t)) along the rail: unit vertical force on the "
             "head at force_x, response at response_x (supports at x = n * spacing)",
             "frequency_hz,force_x_m,response_x_m,output,re,im"]
    for i, fi in enumerate(f):
        for k, xf in enumerate(span_fx):
            for j, o in enumerate(OUTPUTS):
                v = along[i, j, :, k]
                lines += [f"{fi:.6g},{xf:g},{xr:g},{o},{z.real:.6e},{z.imag:.6e}"
                          for xr, z in zip(along_x, v)]
    paths["along_csv"] = write_text_atomic(out / "along_rail.csv", "\n".join(lines) + "\n")

    title = f"{tp.name} track, {model}"
    ax_mag, _ = plotting.plot_magnitude_phase(f, transfer[:, :, 0],
                                              [f"point, {o}" for o in OUTPUTS])
    ax_mag.set_title(title)
    paths["mobility_png"] = plotting.save_figure(ax_mag.figure, out / "point_mobility.png")
    ax = plotting.plot_band_values(results[0].frequency,
                                   np.column_stack([r.decay_rate for r in results]),
                                   [f"{o} sensor" for o in OUTPUTS])
    ax.set_title(title)
    paths["decay_png"] = plotting.save_figure(ax.figure, out / "decay_rate.png")
    k_mid = int(np.argmin(np.abs(span_fx - xs)))
    cols, labels = [], []
    for fa in along_frequencies:
        i = int(np.argmin(np.abs(np.log(f / fa))))
        cols.append(20 * np.log10(np.abs(along[i, 0, :, k_mid])))
        labels.append(f"{f[i]:.0f} Hz")
    ax = plotting.plot_along_rail(along_x, np.column_stack(cols), labels,
                                  ylabel="Head mobility level (dB re 1 m/s/N)")
    ax.set_title(f"{title}: force at x = {span_fx[k_mid]:g} m")
    paths["along_png"] = plotting.save_figure(ax.figure, out / "along_rail.png")
    return paths
