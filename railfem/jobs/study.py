"""``railfem study passby``: the error study of the pass-by decay-rate estimators and the
roughness methods (issue 14, docs/roughness.md), on simulated pass-bys read back as
recordings.

Per track (default: the four Table 1 tracks and the site track, WFE discrete model):

1. rail tables and the model's EN 15461 decay rate at the pass-by sensor (foot, mid-span:
   the truth the pass-by estimators are compared with) and its far-field wave attenuation
   (slope of the band level of the transfer along the rail, 1 m onwards);
2. ``n_passbys`` pass-bys (speeds 212-218 km/h, 24 wheels, a known roughness), time
   signals with seeded noise and wheel-position error, written as recordings (truth in
   separate files) and read back with railfem.io.recording: the estimators see files only;
3. energy iteration and slope fitting (railfem.estimators.passby), the pass-by levels and
   the roughness by the full and the simplified method (TDR from the simulated hammer,
   energy iteration, slope fitting; A terms from the model and the original defaults);
4. on one track (``sensitivity_track``): the full method with pad and ballast stiffness
   off by +-25 %, and the causes of the simplified method's error (noise-free band values:
   interaction between wheels, discrete supports, default A terms, the TDR source).

The per-track computations are railfem.studies.passby_study; this job checks the inputs,
runs the tracks (in worker processes) and writes tables (CSV), figures (PNG),
``report.md`` (railfem.studies.passby_report) and ``run.json`` (with a timing table).
"""
from __future__ import annotations

import json
import logging
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path


from ..atomic import json_safe, prepare_output_dir, write_text
from ..studies.passby_study import SPEEDS_KMH, STUDY_TRACKS, track_study, warm_cache
from .common import progress_logger

log = logging.getLogger(__name__)

__all__ = ["run_passby_study", "STUDY_TRACKS", "SPEEDS_KMH", "COMMAND"]

COMMAND = "study passby"


# ----------------------------------------------------------------------------- job
def run_passby_study(out_dir, *, model: str = "wfe-discrete", tracks=STUDY_TRACKS,
                     speeds_kmh=SPEEDS_KMH, noise_fraction: float = 0.1,
                     position_error: float = 0.1, seed: int = 0, f_low: float = 100.0,
                     f_high: float = 5000.0, sensitivity_track: str | None = "site",
                     sensitivity_factors=(0.75, 1.25), workers: int = 2, cache=None,
                     sbb=None) -> dict:
    """Run the study (module docstring) and write its files into ``out_dir``. sbb: the SBB
    rail roughness table to plot beside the estimates (None: the one in ../shared if it is
    there)."""
    from ..spec import MODELS, PRESETS, preset
    from ..standards.iec61260 import ninth_octave_grid

    t0 = time.perf_counter()
    tracks = tuple(tracks)
    bad = [t for t in tracks if t not in PRESETS]
    if bad or not tracks:
        raise ValueError(f"tracks {bad or tracks}: choose among {', '.join(PRESETS)}")
    if model not in MODELS:
        raise ValueError(f"model {model!r}: choose one of {', '.join(MODELS)}")
    if len(speeds_kmh) < 1 or min(speeds_kmh) <= 0:
        raise ValueError(f"speeds_kmh = {speeds_kmh!r}: give one positive speed per pass-by")
    if sensitivity_track is not None and sensitivity_track not in tracks:
        raise ValueError(f"sensitivity_track {sensitivity_track!r} is not among the tracks")
    if not (f_high * 10 ** 0.05 < 0.4 * 25600.0):
        raise ValueError(f"f_high = {f_high} Hz: the recordings are sampled at 25.6 kHz, the "
                         "highest band must lie below 10 kHz")
    from ..studies.passby_report import SBB_ROUGHNESS

    if sbb is not None and not Path(sbb).is_file():
        raise ValueError(f"SBB roughness table {sbb} does not exist")
    sbb = Path(sbb) if sbb is not None else (SBB_ROUGHNESS if SBB_ROUGHNESS.is_file() else None)
    out = prepare_output_dir(out_dir, COMMAND)
    f = ninth_octave_grid(f_low, f_high)
    t_w = time.perf_counter()
    from ..simulate.chain import make_wheel

    flexible = make_wheel("flexible", f).receptance(f)
    specs = {t: preset(t, model=model) for t in tracks}
    warm_cache(specs[tracks[0]], f, cache)  # one kernel computation, shared by the workers
    t_warm = time.perf_counter() - t_w
    cfg = dict(model=model, f_low=f_low, f_high=f_high, speeds_kmh=tuple(speeds_kmh),
               noise_fraction=noise_fraction, position_error=position_error, seed=seed,
               sensitivity_track=sensitivity_track,
               sensitivity_factors=tuple(sensitivity_factors), cache=cache,
               flexible_receptance=flexible, sbb=sbb)
    # the sensitivity track does the most work: start it first so the others overlap it
    order = sorted(tracks, key=lambda t: t != sensitivity_track)
    progress = progress_logger("study tracks")
    if workers > 1 and len(tracks) > 1:
        with ProcessPoolExecutor(max_workers=min(workers, len(tracks))) as pool:
            done = [_tick(r, progress, k + 1, len(order)) for k, r in enumerate(
                pool.map(track_study, [specs[t] for t in order], [cfg] * len(order),
                         [out] * len(order)))]
    else:
        done = [_tick(track_study(specs[t], cfg, out), progress, k + 1, len(order))
                for k, t in enumerate(order)]
    results = [done[order.index(t)] for t in tracks]
    from ..studies.passby_report import write_study_outputs

    files = write_study_outputs(out, results, cfg)
    summary = {
        "command": COMMAND, "model": model, "tracks": list(tracks),
        "speeds_kmh": list(speeds_kmh), "noise_fraction": noise_fraction,
        "position_error_m": position_error, "seed": seed, "f_low": f_low, "f_high": f_high,
        "workers": workers,
        "timing_s": {"flexible_wheel_and_kernels": t_warm,
                     **{r["track"]: r["timing"] for r in results},
                     "total": time.perf_counter() - t0},
        "files": {k: str(v) for k, v in files.items()},
    }
    files["json"] = write_text(out / "run.json",
                               json.dumps(json_safe(summary), indent=2) + "\n")
    summary["files"]["json"] = str(files["json"])
    summary["results"] = results
    log.info("study passby: %d tracks in %.0f s", len(tracks), summary["timing_s"]["total"])
    return summary


def _tick(result, progress, done: int, total: int):
    """``result`` after reporting ``done`` of ``total`` to ``progress``."""
    progress(done, total)
    return result
