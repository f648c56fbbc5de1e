"""The ``railfem tdr passby`` job: pass-by recordings in, per-band decay rates out.

Writes into the output folder, each file atomically: ``decay_rate_passby.csv`` (both
estimators per band with their scatter and status), ``wheels.csv`` (detected wheels and
speed per recording), ``band_levels_passby.csv`` (band levels at 0.1 m steps of train
travel), ``decay_rate_passby.png`` and ``run.json``.
"""
from __future__ import annotations

import json
import logging
import time
from pathlib import Path

import numpy as np

from ..atomic import json_safe, prepare_output_dir, write_text
from ..estimators.passby import PassbyDecayRate, PassbyOptions, passby_decay_rate
from ..io.recording import read_recording

__all__ = ["COMMAND", "run_tdr_passby"]

log = logging.getLogger(__name__)

COMMAND = "tdr passby"


def _fmt(v) -> str:
    return "" if not np.isfinite(v) else f"{v:.4g}"


def _decay_csv(res: PassbyDecayRate) -> str:
    head = ["band_hz", "centre_hz"]
    for key in ("energy", "slope"):
        head += [f"{key}_D_dB_per_m", f"{key}_raw_dB_per_m", f"{key}_std_wheels_dB_per_m",
                 f"{key}_n_wheels", f"{key}_std_passbys_dB_per_m", f"{key}_n_passbys",
                 f"{key}_status"]
    rows = ["# track decay rate from pass-by recordings, per one-third-octave band; "
            "D = accepted value (empty where the band failed, see status), raw = value "
            "before the acceptance checks; see docs/passby_tdr.md",
            ",".join(head)]
    b = res.bands
    for i in range(len(b)):
        cells = [f"{b.nominal[i]:g}", f"{b.centre[i]:.6g}"]
        for est in (res.energy, res.slope):
            cells += [_fmt(est.decay_rate[i]), _fmt(est.raw[i]), _fmt(est.std_wheels[i]),
                      str(int(est.n_wheels[i])), _fmt(est.std_passbys[i]),
                      str(int(est.n_passbys[i])), est.status[i]]
        rows.append(",".join(cells))
    return "\n".join(rows) + "\n"


def _wheels_csv(res: PassbyDecayRate) -> str:
    rows = ["# wheels detected in each recording: instant over the sensor (s from the record "
            "start) and position along the train (m, 0 at the first wheel)",
            "recording,wheel,time_s,position_m,speed_m_s,speed_source,speed_scatter_m_s"]
    for name, w in zip(res.names, res.wheels):
        for n, (t, x) in enumerate(zip(w.times, w.positions)):
            rows.append(f"{name},{n},{t:.6f},{x:.4f},{w.speed:.5g},{w.speed_source},"
                        f"{w.speed_scatter:.3g}")
    return "\n".join(rows) + "\n"


def _levels_csv(res: PassbyDecayRate, unit: str) -> str:
    b = res.bands
    rows = [f"# band levels in blocks of {res.options.step} m of train travel, dB re 1 "
            f"({unit})^2 mean square; x = train position relative to the sensor (m, 0 when "
            "the first wheel is over it)",
            "recording,x_m," + ",".join(f"L_{n:g}Hz_dB" for n in b.nominal)]
    for name, x, lev in zip(res.names, res.levels_x, res.levels):
        for j, xj in enumerate(x):
            rows.append(f"{name},{xj:.2f}," + ",".join(_fmt(v) for v in lev[:, j]))
    return "\n".join(rows) + "\n"


def _plot(res: PassbyDecayRate, path: Path) -> Path:
    from ..plotting import plot_decay_rate_estimates, save_figure

    estimates = {}
    for label, est in (("energy iteration", res.energy), ("slope fitting", res.slope)):
        spread = np.where(est.n_passbys > 1, est.std_passbys,
                          est.std_wheels / np.sqrt(np.maximum(est.n_wheels, 1)))
        estimates[label] = (est.decay_rate, spread)
    ax = plot_decay_rate_estimates(res.bands.centre, estimates)
    ax.set_title(f"Pass-by decay rate, {len(res.names)} recording(s); bars: std over "
                 "pass-bys (one pass-by: std error over wheels)", fontsize="small")
    return save_figure(ax, path)


def run_tdr_passby(paths, out_dir, options: PassbyOptions | None = None, *,
                   speed: float | None = None, axle_spacing: float | None = None,
                   axle_positions=None, channel: str | None = None) -> dict:
    """Read the recordings, estimate the decay rates and write the outputs; returns the
    run summary (also written as run.json)."""
    t0 = time.perf_counter()
    opts = options or PassbyOptions()
    paths = [Path(p) for p in paths]
    if not paths:
        raise ValueError("give at least one recording (.npz or .wav with a .toml/.json "
                         "sidecar)")
    # all input checks before computing
    recordings = [read_recording(p).select(channel) for p in paths]
    units = {r.channel.unit for r in recordings}
    if len(units) > 1:
        raise ValueError(f"the recordings mix quantities ({sorted(units)}); estimate "
                         "accelerations and velocities separately")
    out = prepare_output_dir(out_dir, COMMAND)
    res = passby_decay_rate(recordings, opts, speed=speed, axle_spacing=axle_spacing,
                            axle_positions=axle_positions)
    files = {
        "decay_csv": write_text(out / "decay_rate_passby.csv", _decay_csv(res)),
        "wheels_csv": write_text(out / "wheels.csv", _wheels_csv(res)),
        "levels_csv": write_text(out / "band_levels_passby.csv",
                                 _levels_csv(res, units.pop())),
        "png": _plot(res, out / "decay_rate_passby.png"),
    }
    b = res.bands
    summary = {
        "command": COMMAND,
        "recordings": [str(p) for p in paths],
        "channel": channel,
        "overrides": {"speed_m_s": speed, "axle_spacing_m": axle_spacing,
                      "axle_positions_m": axle_positions},
        "options": {k: getattr(opts, k) for k in opts.__dataclass_fields__},
        "sensors": [{"name": r.name, "channel": r.channel.name, "location": r.channel.location,
                     "direction": r.channel.direction, "quantity": r.channel.quantity,
                     "fs_hz": r.fs, "duration_s": r.duration}
                    for r in recordings],
        "wheels": [{"name": n, "count": w.count, "speed_m_s": w.speed,
                    "speed_source": w.speed_source, "speed_scatter_m_s": w.speed_scatter}
                   for n, w in zip(res.names, res.wheels)],
        "bands_hz": b.nominal,
        "energy_iteration": {"D_dB_per_m": res.energy.decay_rate,
                             "status": res.energy.status,
                             "std_passbys_dB_per_m": res.energy.std_passbys,
                             "std_wheels_dB_per_m": res.energy.std_wheels},
        "slope_fitting": {"D_dB_per_m": res.slope.decay_rate, "status": res.slope.status,
                          "std_passbys_dB_per_m": res.slope.std_passbys,
                          "std_wheels_dB_per_m": res.slope.std_wheels},
        "runtime_s": time.perf_counter() - t0,
        "files": {k: str(v) for k, v in files.items()},
    }
    files["json"] = write_text(out / "run.json", json.dumps(json_safe(summary), indent=2) + "\n")
    summary["files"]["json"] = str(files["json"])
    log.info("tdr-passby: %d recording(s), %d bands in %.1f s", len(paths), len(b),
             summary["runtime_s"])
    return summary
