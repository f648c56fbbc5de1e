"""The supported-track job behind ``railfem track``: one model of a track spec, its point
and EN 15461 transfer mobilities, decay rates, along-rail table, plots and ``run.json``.

The job only calls the model door (railfem.models). ``run.json`` records everything that
determines the results: the resolved spec (railfem.spec.spec_to_dict), the job settings,
the frequency grid, the mesh, the model and the railfem version; its ``config`` section is
a valid config (``railfem track --config run.json`` or ``--from-run DIR`` repeats the run).
"""
from __future__ import annotations

import json
import logging
import time
from dataclasses import dataclass, replace

import numpy as np

from .. import models
from ..track import beams
from ..atomic import prepare_output_dir, write_text_atomic
from ..spec import TrackSpec, spec_to_dict
from ..standards import en15461, iec61260

log = logging.getLogger(__name__)

OUTPUTS = models.WHERE
POINT_OFFSET = models.POINT_OFFSET


@dataclass(frozen=True, kw_only=True)
class JobSettings:
    """What the job computes besides the spec. f_low, f_high: band range (Hz) of the 1/9
    octave grid. along_span: half length (m) of the along-rail table around the span.
    along_frequencies: frequencies (Hz) of the along-rail plot."""

    f_low: float = 50.0
    f_high: float = 8000.0
    along_span: float = 6.0
    along_frequencies: tuple = (250.0, 500.0, 1000.0, 2000.0)

    def __post_init__(self):
        from .. import validators as v

        v.positive("job.f_low", self.f_low, "Hz")
        v.positive("job.f_high", self.f_high, "Hz")
        if self.f_high < self.f_low:
            raise ValueError(f"job.f_high = {self.f_high!r} Hz is below job.f_low = "
                             f"{self.f_low!r} Hz")
        v.positive("job.along_span", self.along_span, "m")
        object.__setattr__(self, "along_frequencies",
                           tuple(v.positive("job.along_frequencies", x, "Hz")
                                 for x in self.along_frequencies))

    def frequency(self) -> np.ndarray:
        return iec61260.ninth_octave_grid(self.f_low, self.f_high)


JOB_KEYS = {"f_low": float, "f_high": float, "along_span": float, "along_frequencies": list}


def job_from_dict(d: dict, base: JobSettings | None = None) -> JobSettings:
    """JobSettings from the [job] table of a config; unknown keys are errors naming them."""
    base = base or JobSettings()
    if not isinstance(d, dict):
        raise ValueError(f"[job] must be a table, got {d!r}")
    out = {}
    for k, x in d.items():
        if k not in JOB_KEYS:
            raise ValueError(f"unknown key 'job.{k}'; valid keys: {', '.join(JOB_KEYS)}")
        if JOB_KEYS[k] is float and (isinstance(x, bool) or not isinstance(x, (int, float))):
            raise ValueError(f"job.{k} = {x!r}: give a number")
        out[k] = tuple(x) if k == "along_frequencies" else float(x)
    return replace(base, **out)


def rail_pad_peak(frequency, point_mobility, spec: TrackSpec, rail_mass: float,
                  f_pinned_pinned: float = np.inf) -> float:
    """Frequency (Hz) of the rail-on-pad resonance: the largest |Y| between half and twice
    sqrt(k_p / (m' d)) / 2 pi (rail mass per span on the pad stiffness), kept below
    0.9 times the pinned-pinned frequency, whose peak can be the higher one on stiff pads."""
    f0 = np.sqrt(spec.support.kp / (rail_mass * spec.spacing)) / (2 * np.pi)
    band = (frequency > f0 / 2) & (frequency < min(2 * f0, 0.9 * f_pinned_pinned))
    if not band.any():
        return float("nan")
    i = np.argmax(np.abs(point_mobility) * band)
    return float(frequency[i])


def resonance_marks(frequency, point_mobility, spec: TrackSpec, rail_mass: float,
                    f_pinned_pinned: float) -> dict:
    """The named resonances of the point mobility (Hz): sleeper on ballast (largest |Y|
    within a factor 2 of sqrt(k_b / (m_s + m' d)) / 2 pi: the rail span and sleeper mass on
    the ballast), rail on pad (:func:`rail_pad_peak`) and the pinned-pinned frequency of
    the beam between supports (computed, not searched)."""
    f = np.asarray(frequency, dtype=float)
    s = spec.support
    marks = {}
    if s.kb > 0 and np.isfinite(s.kb):
        f0 = np.sqrt(s.kb / (s.ms + rail_mass * spec.spacing)) / (2 * np.pi)
        band = (f > f0 / 2) & (f < 2 * f0)
        if band.any():
            marks["sleeper on ballast"] = float(f[np.argmax(np.abs(point_mobility) * band)])
    marks["rail on pad"] = rail_pad_peak(f, point_mobility, spec, rail_mass, f_pinned_pinned)
    marks["pinned-pinned"] = float(f_pinned_pinned)
    return {k: v for k, v in marks.items() if np.isfinite(v)}


#: points per 1/9-octave step added around each resonance peak of the point mobility
REFINE_POINTS = 6


def refined_point_mobility(spec: TrackSpec, f, point, marks: dict, hammer_x0: float,
                           sensor_x: float, cache=None):
    """The point mobility on the 1/9-octave grid ``f`` with a 1/54-octave grid added around
    the rail-on-pad and pinned-pinned peaks (one 1/9-octave step either side), so the plot
    resolves them: (frequency, values (nf', 2 outputs)). One extra model call for a single
    force-response pair; it includes the grid's first frequency, so its near-field tail
    (waves.frozen_tail, taken at the lowest frequency of a call) is the one the grid's call
    solved and cached: no second dense tail solve, and refined and grid values share it."""
    step = 10 ** (1 / 30)
    extra = []
    for name in ("rail on pad", "pinned-pinned"):
        fc = marks.get(name)
        if fc is None or not f[0] < fc < f[-1]:
            continue
        g = fc * step ** np.linspace(-1, 1, 2 * REFINE_POINTS + 1)
        extra.append(g[(g > f[0]) & (g < f[-1])])
    if not extra:
        return f, point
    fe = np.unique(np.concatenate(extra))
    fe = fe[np.min(np.abs(np.log(fe[:, None] / f[None, :])), axis=1) > 1e-6]
    a = models.receptance(spec, np.concatenate([f[:1], fe]), [hammer_x0], [sensor_x],
                          cache=cache)[1:, :, 0, 0]
    fa = np.concatenate([f, fe])
    ya = np.concatenate([point, 1j * 2 * np.pi * fe[:, None] * a])
    o = np.argsort(fa)
    return fa[o], ya[o]


def _cut_ons(spec: TrackSpec, f) -> dict:
    """Free-rail cut-ons of the waves a vertical load excites, inside the computed range
    (the decay-rate plot names them: the decay rate spikes just above each)."""
    if not spec.is_wfe:
        return {}
    from ..rail.branches import cut_ons
    from ..rail.waveguide import assemble

    guide = assemble(models.rail_mesh(spec.rail), spec.rail.material())
    return {c.name: c.frequency for c in cut_ons(guide, f[0], f[-1],
                                                  families=("symmetric",))}


def run_track(spec: TrackSpec, out_dir, *, job: JobSettings | None = None, cache=None,
              progress=None) -> dict:
    """Model the track ``spec`` and write mobilities, decay rates, plots and run.json."""
    from .. import __version__
    from .common import progress_logger

    job = job or JobSettings()
    out = prepare_output_dir(out_dir, "track")
    t0 = time.perf_counter()
    f = job.frequency()
    xs, pos, hammer = models.hammer_x(spec)
    d = spec.spacing
    span_fx = np.round(np.arange(0.0, d + 1e-9, 0.1), 10)
    along_x = np.round(np.arange(-job.along_span, job.along_span + 1e-9, 0.1), 10)
    fx = np.concatenate([hammer, span_fx])
    rx = np.concatenate([[xs], along_x])
    log.info("track %s, model %s: %d frequencies %.0f-%.0f Hz, %d force x %d response "
             "positions", spec.name, spec.model, len(f), f[0], f[-1], len(fx), len(rx))
    alpha = models.receptance(spec, f, fx, rx, cache=cache,
                              progress=progress or progress_logger(f"track {spec.model}"))
    Y = 1j * 2 * np.pi * f[:, None, None, None] * alpha
    transfer = Y[:, :, 0, : len(pos)]  # (nf, 2, n_pos): sensor response, hammer moves
    lateral = None
    if "y" in spec.support_directions:  # lateral hammer and sensor on the side of the head
        a_lat = models.receptance(spec, f, hammer, [xs], outputs=models.LATERAL,
                                  force="head_lateral", cache=cache,
                                  progress=progress or progress_logger(
                                      f"track {spec.model}, lateral"))
        lateral = 1j * 2 * np.pi * f[:, None, None] * a_lat[:, :, 0, :]  # (nf, 1, n_pos)
    else:
        log.info("track %s: no lateral outputs (support_directions = %r has no 'y'; set "
                 "support_directions = 'zyx' for the lateral decay rate)", spec.name,
                 spec.support_directions)
    bs = models.beam_section(spec.rail)
    rail_mass, f_pp = bs.mass_per_length, beams.pinned_pinned_frequency(bs, d)
    marks = resonance_marks(f, transfer[:, 0, 0], spec, rail_mass, f_pp)
    point = refined_point_mobility(spec, f, transfer[:, :, 0], marks, hammer[0], xs, cache)
    marks = resonance_marks(point[0], point[1][:, 0], spec, rail_mass, f_pp)
    paths = _write_outputs(out, spec, f, pos, hammer, xs, transfer,
                           Y[:, :, 1:, len(pos):], span_fx, along_x, job.along_frequencies,
                           marks, _cut_ons(spec, f), point, lateral)
    mesh = models.rail_mesh(spec.rail)
    summary = {
        "command": "track", "railfem_version": __version__,
        "name": spec.name, "model": spec.model,
        "mesh": {"name": mesh.name, "h_m": mesh.h, "file": spec.rail.mesh_file,
                 "n_vertices": int(len(mesh.vertices)), "n_triangles": int(len(mesh.triangles))},
        "sensor_x_m": xs, "point_offset_m": POINT_OFFSET,
        "hammer_positions_m": pos.tolist(),
        "lateral": None if lateral is None else {
            "channel": "head_lateral",
            "hammer": f"lateral (+y) force on a {spec.numerics.patch_width * 1e3:g} mm high "
                      f"patch on the +y side face of the head, centred "
                      f"{models.HEAD_SIDE_DEPTH * 1e3:g} mm below the head top",
            "sensor": "lateral (y) response of the side-face node at the patch centre",
            "rail_pad_peak_hz": float(f[np.argmax(np.abs(lateral[:, 0, 0]))])},
        "frequency_hz": f.tolist(),
        "rail_pad_peak_hz": {o: rail_pad_peak(point[0], point[1][:, j], spec, rail_mass, f_pp)
                             for j, o in enumerate(OUTPUTS)},
        "resonances_hz": marks,
        "point_mobility_refined_hz": [float(x) for x in np.setdiff1d(point[0], f)],
        "runtime_s": time.perf_counter() - t0,
        "files": {k: str(v) for k, v in paths.items()},
        "config": {"spec": spec_to_dict(spec),
                   "job": {"f_low": job.f_low, "f_high": job.f_high,
                           "along_span": job.along_span,
                           "along_frequencies": list(job.along_frequencies)}},
    }
    paths["json"] = write_text_atomic(out / "run.json", json.dumps(summary, indent=2))
    log.info("track %s %s done in %.1f s; rail-on-pad peak %.0f Hz (head)", spec.name,
             spec.model, summary["runtime_s"], summary["rail_pad_peak_hz"]["head"])
    return summary


def _write_outputs(out, spec, f, pos, hammer_x, xs, transfer, along, span_fx, along_x,
                   along_frequencies, marks, cut_on, point, lateral=None) -> dict:
    from .. import plotting
    from ..response import FRF
    from ..io.frf_csv import write_frf_csv

    paths = {}
    frf = FRF(frequency=f, values=transfer, quantity="mobility", response=OUTPUTS,
              force=tuple(f"hammer_{p:.3f}" for p in pos),
              response_x=np.full(2, xs), force_x=hammer_x)
    paths["transfer_csv"] = write_frf_csv(out / "transfer_mobility.csv", frf)
    results = [en15461.decay_rate(f, transfer[:, j, :], pos) for j in range(2)]
    names = ["head", "foot"]
    if lateral is not None:
        paths["transfer_lateral_csv"] = write_frf_csv(out / "transfer_mobility_lateral.csv", FRF(
            frequency=f, values=lateral, quantity="mobility", response=models.LATERAL,
            force=tuple(f"hammer_lateral_{p:.3f}" for p in pos),
            response_x=np.full(1, xs), force_x=hammer_x))
        results.append(en15461.decay_rate(f, lateral[:, 0, :], pos))
        names.append("head_lateral")
    rows = ["# EN 15461 track decay rate per one-third-octave band (dB/m); suitable = the "
            "band passes the 10 dB far-field check and D >= D_min; head/foot: vertical "
            "hammer on the head top; head_lateral: lateral hammer and sensor on the side of "
            "the head (run.json 'lateral')",
            "band_hz," + ",".join(f"{n}_db_per_m,{n}_suitable" for n in names)]
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

    title = f"{spec.name} track, {spec.model}: vertical hammer, vertical response"
    kinds = {"head": "point", "foot": "transfer"}  # the force is on the head
    ax_mag, _ = plotting.plot_point_mobility(
        point[0], point[1], [f"head force -> {o} response ({kinds[o]})" for o in OUTPUTS],
        marks=marks, ylabel="Mobility (m/s/N)")
    ax_mag.set_title(title, fontsize="medium")
    paths["mobility_png"] = plotting.save_figure(ax_mag.figure, out / "point_mobility.png")
    ax = plotting.plot_decay_rate_results(results[:2], [f"{o} sensor" for o in OUTPUTS],
                                          direction="vertical", cut_on=cut_on)
    ax.set_title(title, fontsize="medium")
    paths["decay_png"] = plotting.save_figure(ax.figure, out / "decay_rate.png")
    if lateral is not None:
        ax = plotting.plot_decay_rate_results(results[2:], ["head side, lateral"],
                                              direction="lateral")
        ax.set_title(f"{spec.name} track, {spec.model}: lateral hammer, lateral response",
                     fontsize="medium")
        paths["decay_lateral_png"] = plotting.save_figure(ax.figure,
                                                          out / "decay_rate_lateral.png")
    k_mid = int(np.argmin(np.abs(span_fx - xs)))
    idx = plotting.along_rail_frequencies(f, along_frequencies)
    cols = [20 * np.log10(np.abs(along[i, 0, :, k_mid])) for i in idx]
    n = int(np.ceil(np.abs(along_x).max() / spec.spacing))
    ax = plotting.plot_along_rail(along_x, np.column_stack(cols),
                                  [f"{f[i]:.0f} Hz" for i in idx],
                                  ylabel="Head mobility level (dB re 1 m/s/N)",
                                  x_force=span_fx[k_mid],
                                  supports=np.arange(-n, n + 1) * spec.spacing)
    ax.set_title(f"{spec.name} track, {spec.model}: force at x = {span_fx[k_mid]:g} m "
                 "(mid-span)", fontsize="medium")
    paths["along_png"] = plotting.save_figure(ax.figure, out / "along_rail.png")
    return paths
