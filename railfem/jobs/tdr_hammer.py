"""The job behind ``railfem tdr hammer``: a hammer measurement in, EN 15461 decay rates out.

Reads a dataset folder or a TOML descriptor (:func:`railfem.io.read_measurement`), runs
:func:`railfem.estimators.tdr.hammer` for every sensor (the code used for simulated data
too) and writes, each file atomically:

* ``decay_rate.csv`` — per band and sensor: decay rate, suitable flag, positions used,
  D_min and why a band failed;
* ``decay_rate.png`` — the decay rates per band, failed bands as open markers;
* ``run.json`` — input, options, measurement summary, results and file list.
"""
from __future__ import annotations

import json
import logging
import time
from pathlib import Path

import numpy as np

from ..estimators import tdr
from ..atomic import prepare_output_dir, write_text_atomic

log = logging.getLogger(__name__)


def _finite_or_none(a):
    return [float(x) if np.isfinite(x) else None for x in np.asarray(a, dtype=float)]


def run_tdr_hammer(data, out_dir, *, exclusion: tdr.NoiseFloorExclusion = tdr.NoiseFloorExclusion(),
                   point: str = "nominal", sensors=None) -> dict:
    """Decay rate of the hammer measurement ``data``; files go to ``out_dir``. Returns run.json."""
    from .. import plotting
    from ..io import read_measurement

    t0 = time.perf_counter()
    m = read_measurement(data)
    names = list(sensors) if sensors else list(m.sensor_names)
    for n in names:
        m.sensor(n)  # unknown names fail before any computing
    out = prepare_output_dir(out_dir, "tdr hammer")  # after the input checks: no empty folder
    results = {n: tdr.hammer(m, n, exclusion=exclusion, point=point) for n in names}
    first = results[names[0]]
    head = ["band_hz"] + [f"{n}_{c}" for n in names
                         for c in ("db_per_m", "suitable", "n_used", "d_min_db_per_m", "status")]
    rows = [f"# EN 15461 track decay rate per one-third-octave band (dB/m) of {data}; "
            "suitable = far-field 10 dB check passed and D >= D_min; n_used = hammer positions "
            "in the sum after the noise-floor exclusion; status = why a band failed",
            ",".join(head)]
    for b, fc in enumerate(first.frequency):
        cells = [f"{fc:g}"]
        for n in names:
            r = results[n]
            cells += [f"{r.decay_rate[b]:.4f}", str(int(r.suitable[b])), str(int(r.n_used[b])),
                      f"{r.d_min[b]:.4f}", r.status[b]]
        rows.append(",".join(cells))
    paths = {"decay_csv": write_text_atomic(out / "decay_rate.csv", "\n".join(rows) + "\n")}
    ax = None
    for n in names:
        ax = plotting.plot_band_overlay(first.frequency, results[n].decay_rate,
                                        valid=results[n].suitable, labels=(f"{n} sensor", None),
                                        ax=ax, logy=True)
    ax.set_title(f"EN 15461 decay rate: {Path(data).name}")
    paths["decay_png"] = plotting.save_figure(ax.figure, out / "decay_rate.png")
    summary = {
        "command": "tdr hammer",
        "data": str(data),
        "measurement": {"quantity": m.frf.quantity, "n_frequencies": int(m.frequency.size),
                        "frequency_hz": [float(m.frequency[0]), float(m.frequency[-1])],
                        "positions_m": [float(x) for x in m.positions],
                        "point_offset_m": m.point_offset, "sleeper_spacing_m": m.sleeper_spacing,
                        "sensor_x_m": m.sensor_x, "sensors": list(m.sensor_names),
                        "rail": m.rail, "metadata": m.metadata.as_dict()},
        "options": {"point": point, "exclusion": exclusion.options()},
        "decay_rate": {n: {"band_hz": [float(x) for x in r.frequency],
                           "db_per_m": _finite_or_none(r.decay_rate),
                           "suitable": [bool(x) for x in r.suitable],
                           "n_used": [int(x) for x in r.n_used],
                           "status": list(r.status)} for n, r in results.items()},
        "runtime_s": time.perf_counter() - t0,
    }
    summary["files"] = {k: str(v) for k, v in paths.items()}
    summary["files"]["json"] = str(out / "run.json")
    write_text_atomic(out / "run.json", json.dumps(summary, indent=2))
    log.info("tdr hammer %s: %d sensors, %d bands, %.1f s", data, len(names),
             first.frequency.size, summary["runtime_s"])
    return summary
