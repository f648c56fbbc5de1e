"""The job behind ``railfem diagnose``: measured data in, the residual traced to an effect.

DATA is a hammer measurement (dataset folder or TOML descriptor, railfem.io) or a
decay-rate table (CSV; the SBB Niederwangen columns are recognised) with an optional row
selection. A table is diagnosed per group of rows (default: per section and date, the
rails of one group being repeats of each other) and, when the selection spans records at
different temperatures, once more as a whole campaign (``all``). Each diagnosis writes
into its folder, every file atomically:

* ``diagnosis.json`` — base model and its residual test, ranked candidates with parameters
  and scores, the chosen effect(s) with 95 % intervals, the error before and after per
  quantity and band on fitted and held-out data, the verdict in words;
* ``report.md`` — the same for a reader, with the figures:
  ``residual_point.png``, ``residual_map_<sensor>.png``, ``residual_distance.png`` (hammer
  data), ``residual_tdr.png``, ``candidates.png``, ``before_after_<quantity>.png`` and,
  after an effect is added, ``residual_map_after_<sensor>.png``;
* ``run.json`` — the command record (top folder).
"""
from __future__ import annotations

import json
import logging
import math
import re
import time
import warnings
from pathlib import Path

import numpy as np

from ..atomic import prepare_output_dir, write_text
from ..diagnosis import effects as library
from ..diagnosis import gates, loop
from ..diagnosis.residual import NEGLIGIBLE_DB
from ..spec import model_kind
from ..diagnosis.data import prepare
from ..standards import en15461, iec61260
from ..io.diagnosis_report import band_words, dominant_bands, markdown
from .common import FIT_PROGRESS, progress_bar_enabled, watch_progress

log = logging.getLogger(__name__)


def _json(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.bool_):
        return bool(o)
    return str(o)


def strict(o):
    """``o`` with every non-finite float (an interval open at the top, a test that could
    not run) as None: diagnosis.json is strict JSON, which has no Infinity or NaN."""
    if isinstance(o, dict):
        return {k: strict(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [strict(v) for v in o]
    if isinstance(o, np.ndarray):
        return strict(o.tolist())
    if isinstance(o, (float, np.floating)):
        return float(o) if np.isfinite(o) else None
    return o


def groups_of(items, group: str | None):
    """[(name, [measurement])] for table rows grouped by metadata keys ('section,date')."""
    keys = [k.strip() for k in (group or "").split(",") if k.strip()]
    bad = [k for k in keys if k not in ("section", "date", "rail_side")]
    if bad:
        raise ValueError(f"--group {group!r}: use section, date and/or rail_side")
    out: dict = {}
    for _, m in items:
        name = "_".join(str(getattr(m.metadata, k) or "na") for k in keys) or "all"
        out.setdefault(name, []).append(m)
    return list(out.items())


def run_diagnose(data, out_dir, *, model: str = "wfe-discrete", select=None,
                 group: str | None = "section,date", spacing: float = 0.6, effects=None,
                 n_starts: int = 4, workers: int = 1, cache=None, campaign: bool = True,
                 passby: dict | None = None, f_range=None, base=None,
                 reference=None, reference_select=None, discrepancy="ensemble",
                 command: str = "") -> dict:
    """Diagnose DATA and write the report(s) to ``out_dir``; returns the run record.
    DATA: a hammer dataset folder or descriptor, a decay-rate table, or a list of pass-by
    recordings (``passby``: options of passby_rows). f_range: (low, high) Hz of the FRF
    points of hammer data diagnosed (pass-by bands: ``passby``). base: the base TrackSpec
    (default railfem.identify.base.default_base, as ``railfem fit``). reference: a
    reference section (``--reference``: read_reference) every group is diagnosed against
    (railfem.diagnosis.reference), its table rows chosen by ``reference_select``."""
    from ..io.data import data_kind, read_data

    t0 = time.perf_counter()
    en15461.reset_notes()
    if effects not in (None, "all"):
        for n in effects:
            library.get(n)
    paths = [Path(p) for p in (data if isinstance(data, (list, tuple)) else [data])]
    kind = data_kind(paths)
    recs = paths if kind == "passby" else []
    if recs:
        items = passby_rows(recs, **(passby or {}))
    else:
        data = paths[0]
        if f_range is not None and kind == "table":
            raise ValueError("--f-low/--f-high select the FRF points of hammer data (and the "
                             "bands of pass-by recordings); a decay-rate table's bands are "
                             "its rows'")
        kind, items = (read_data(data, select=select, campaign=True) if kind == "table"
                       else read_data(data))
    out = prepare_output_dir(out_dir, "diagnose")
    jobs = []
    if kind == "hammer":
        jobs.append(("", items))
    elif kind == "passby":
        jobs.append(("passby", items))
    else:
        rows = [(i, m) for i, m in items if m.direction == "z"]
        if not rows:
            raise ValueError("the selection holds no vertical decay rates (dir v/z); the "
                             "track models are vertical")
        jobs += [(n, ms) for n, ms in groups_of(rows, group)]
        temps = [m.metadata.temperature_c for _, m in rows]
        if campaign and len(jobs) > 1 and None not in temps and max(temps) - min(temps) >= 5:
            jobs.append(("all", [m for _, m in rows]))
    record = {"command": "diagnose", "argv": command, "data": [str(p) for p in paths]
              if recs else str(data), "model": model,
              "kind": kind, "groups": []}
    opts = dict(model=model, n_starts=n_starts, workers=workers, cache=cache,
                effects=effects, base=base, discrepancy=discrepancy,
                data_options={"f_range": tuple(f_range)} if f_range and kind == "hammer"
                else None)
    arg = " ".join(str(p) for p in paths)
    refs = read_reference(reference, reference_select) if reference is not None else None
    calibrated: dict = {}
    for name, ms in jobs:
        sub = out / name if name else out
        log.info("diagnose: %s (%d record(s))", name or "hammer test", len(ms))
        sp = None if kind == "hammer" else spacing
        with watch_progress(*FIT_PROGRESS, (LOOP, CANDIDATE, {
                "what": "candidates screened",
                "total": candidate_count(ms, sp, opts) if progress_bar_enabled() else None})):
            if refs is None:
                d = loop.diagnose(ms, spacing=sp, **opts)
            else:
                d = against_reference(ms, refs, calibrated, spacing=sp, opts=opts)
        files = write_report(sub, d, title=name or Path(paths[0]).name, data=arg, kind=kind)
        s = json.loads(Path(files[0]).read_text())
        record["groups"].append({"name": name or "hammer", "records": len(ms),
                                 "verdict": d.verdict, "statement": d.statement,
                                 "summary": findings(s),
                                 "chosen": d.chosen.name if d.chosen else None,
                                 "base_model": d.base_model, "failures": d.failures,
                                 "reference": d.reference.to_dict() if d.reference
                                 else None, "changed": d.changed,
                                 "files": files, "seconds": d.seconds})
    record["runtime_s"] = time.perf_counter() - t0
    write_text(out / "run.json", json.dumps(record, indent=2, default=_json) + "\n")
    return record


def read_reference(path, select=None) -> dict:
    """The reference of ``--reference``: {None: fit dict} for a ``railfem fit`` fit.json or
    a diagnosis.json (its base), {None: [measurement]} for a hammer dataset, {date: [rows]}
    for the vertical rows of a decay-rate table (``select``: its row selection)."""
    from ..io.data import data_kind, read_data

    path = Path(path)
    if path.suffix == ".json":
        try:
            d = json.loads(path.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise ValueError(f"--reference {path}: not a readable JSON file ({exc})") from None
        if isinstance(d, dict) and isinstance(d.get("base"), dict) and "spec" in d["base"]:
            return {None: d["base"]}  # a diagnosis.json: the reference's base
        if isinstance(d, dict) and "spec" in d and "parameters" in d:
            return {None: d}  # a railfem fit fit.json
        raise ValueError(f"--reference {path}: neither a railfem fit fit.json nor a "
                         "railfem diagnose diagnosis.json")
    if not path.exists():
        raise ValueError(f"--reference {path} does not exist")
    if data_kind(path) != "table":
        if select:
            raise ValueError("--reference-select applies to a decay-rate table")
        return {None: read_data(path)[1]}
    rows = [m for _, m in read_data(path, select=select, campaign=True)[1]
            if m.direction == "z"]
    if not rows:
        raise ValueError(f"--reference {path}: the selection holds no vertical decay rates")
    out: dict = {}
    for m in rows:
        out.setdefault(m.metadata.date, []).append(m)
    return out


def against_reference(ms, refs: dict, calibrated: dict, *, spacing, opts):
    """Diagnosis of the records ``ms`` against the reference (read_reference): the rows of
    the same date where the reference has them, else all its rows; each reference
    calibrated once (``calibrated``: a cache by date)."""
    from ..diagnosis import reference as ref_mod

    date = getattr(getattr(ms[0], "metadata", None), "date", None)
    key = date if date in refs else None
    if key not in calibrated:
        src = refs[key] if key in refs else [m for rows in refs.values() for m in rows]
        keep = {k: opts[k] for k in ("base", "n_starts", "workers", "cache", "data_options",
                                     "discrepancy")}
        calibrated[key] = ref_mod.calibrate(src, model=opts["model"], spacing=spacing,
                                            **keep)
    return ref_mod.diagnose(ms, reference=calibrated[key], spacing=spacing, **opts)


LOOP = "railfem.diagnosis.loop"
CANDIDATE = r"^diagnosis: [^:]+: dBIC"  # one screened candidate (loop.screen_singles)


def candidate_count(ms, spacing, opts) -> int | None:
    """How many candidates the diagnosis of ``ms`` screens (for its progress bar)."""
    try:
        data = prepare(ms, spacing=spacing, **(opts.get("data_options") or {}))
        return len(loop.select_effects(data, opts["model"], opts["effects"])[0])
    except (ValueError, KeyError):
        return None


def passby_rows(paths, *, method: str = "energy", channel: str | None = None,
                speed: float | None = None, axle_spacing: float | None = None,
                f_low: float = 100.0, f_high: float = 5000.0) -> list:
    """Pass-by recordings -> one decay-rate record per pass-by (railfem.estimators.passby,
    ``method`` 'energy' or 'slope'), the sensor location taken from the recordings."""
    from ..diagnosis.data import check_passby_method, passby_decay_rates
    from ..estimators.passby import PassbyOptions, passby_decay_rate
    from ..io.recording import read_rail_recordings

    check_passby_method(method)  # before the estimator runs
    opts = PassbyOptions(f_low=f_low, f_high=f_high)
    recordings, where = read_rail_recordings(paths, channel)
    res = passby_decay_rate(recordings, opts, speed=speed, axle_spacing=axle_spacing)
    return passby_decay_rates(res, method=method, sensor=where)


# ------------------------------------------------------------------ the report


def error_table(res, bands) -> list[dict]:
    """RMS (dB) per part, quantity and band over records and sensors."""
    acc: dict = {}
    for row in res.band_table(bands):
        k = (row["part"], row["quantity"], row["band_hz"])
        s, n = acc.get(k, (0.0, 0))
        acc[k] = (s + row["rms_db"] ** 2 * row["n"], n + row["n"])
    return [{"part": p, "quantity": q, "band_hz": b, "rms_db": float(np.sqrt(s / n))}
            for (p, q, b), (s, n) in sorted(acc.items())]


def _bands(d):
    f = np.concatenate([r.fit.frequency for r in d.data.records])
    return iec61260.third_octave_bands(float(f.min()), float(f.max()))


def summary(d) -> dict:
    """diagnosis.json content."""
    from .. import __version__
    from ..spec import spec_to_dict

    bands = _bands(d)
    base = d.base
    out = {
        "railfem_version": __version__, "model": d.model,
        "data": {"description": d.data.description,
                 "records": [{"name": r.name, "kind": r.kind, "use": list(r.fit.use),
                              "held_out_positions_m": list(r.held_positions),
                              "held_out_bands_hz": list(r.held_bands),
                              "metadata": r.metadata.as_dict()} for r in d.data.records]},
        "verdict": d.verdict, "statement": d.statement, "base_model": d.base_model,
        "reference": d.reference.to_dict() if d.reference is not None else None,
        "changed_against_reference": d.changed,
        "base": {"parameters": base.parameters(), "spec": spec_to_dict(base.spec()),
                 "cost": base.cost, "aicc": base.aicc, "bic": base.bic, "k": base.k,
                 "n": base.n, "residual_rms_db": {"fit": d.residual_before.rms(part="fit"),
                                                  "held": d.residual_before.rms(part="held")},
                 "structure_test": d.structure_before, "scale_db": base.problem.scale},
        "candidates": d.candidates,
        "skipped": d.skipped,
        "failures": d.failures,
        "chosen": None,
        "error_before": error_table(d.residual_before, bands),
        "error_after": None,
        "rules": {"alpha": gates.ALPHA, "min_held_out_gain": gates.MIN_GAIN,
                  "delta_bic": gates.DELTA_BIC, "bound_margin": gates.BOUND_MARGIN,
                  "negligible_structure_db": NEGLIGIBLE_DB,
                  "text": gate_text()},
        "library": [library.get(n).describe() for n in library.names()],
        "seconds": d.seconds,
    }
    if d.chosen is not None:
        c = d.chosen
        out["chosen"] = {"name": c.name, "parameters": c.parameters(),
                         "spec": spec_to_dict(c.spec()),
                         "held_out": d.chosen_row["final_held_out"],
                         "residual_rms_db": {"fit": d.residual_after.rms(part="fit"),
                                             "held": d.residual_after.rms(part="held")},
                         "structure_test": d.structure_after,
                         "aicc": c.aicc, "bic": c.bic, "k": c.k,
                         "unfitted_terms": c.analysis.get("unfitted_terms", 0)}
        out["error_after"] = error_table(d.residual_after, bands)
    return out


def gate_text() -> str:
    """The gates of railfem.diagnosis.gates in words, with the values of its rules."""
    text = loop.__doc__.split("4. **Gates**")[1].split("5.")[0].strip()
    for name, value in (("MIN_GAIN", f"{100 * gates.MIN_GAIN:g} %"),
                        ("ALPHA", f"{gates.ALPHA:g}"), ("DELTA_BIC", f"{gates.DELTA_BIC:g}")):
        text = re.sub(rf"\b{name}\b", value, text)
    return text


# ------------------------------------------------------------------ what to do next

HIGH_BAND_HZ = 2000.0  # above it a beam model skips the rail's cross-section deformation


def next_steps(s: dict, data: str = "DATA", kind: str = "hammer") -> list[str]:
    """What to try after this diagnosis, in words with the commands (``kind``: of DATA,
    railfem.io.data: a table's bands are its rows', no --f-high)."""
    if s["verdict"] in ("noise", "explained"):
        return ["nothing more to look for: the remaining residual is consistent with noise; "
                "the fitted values are in diagnosis.json"]
    top = dominant_bands(s)
    out = []
    # the worst band high up: the bands there, above the lowest of them, are left out
    high = ([r for r in top if r["band_hz"] >= HIGH_BAND_HZ]
            if top and top[0]["band_hz"] >= HIGH_BAND_HZ else [])
    if high and kind != "table":
        f = min(r["band_hz"] for r in high) / 2 ** (1 / 6)  # the band's lower edge
        step = 10 ** (math.floor(math.log10(f)) - 1)
        f = math.floor(f / step) * step  # rounded down to 2 digits: 4454 -> 4400
        out.append(f"leave out the bands that dominate: `railfem diagnose {data} --f-high "
                   f"{f:.0f}`")
    if high and model_kind(s["model"]).is_beam:
        out.append(f"above {HIGH_BAND_HZ:g} Hz the rail's cross-section deforms, which a "
                   f"beam skips: `railfem diagnose {data} --model wfe-discrete`")
    for name, why in s["skipped"].items():
        if "not screened by default" in why:
            out.append(f"the candidate {name} is not screened by default (tens of "
                       f"parameters): `railfem diagnose {data} --effects {name}`")
        elif "--model" in why or "diagnose with" in why:
            out.append(f"{name} was not tried with this model ({why})")
    tried = ({n for c in s["candidates"] for n in c.get("effects", [c["name"]])}
             | set(s["skipped"]) | {f["candidate"] for f in s.get("failures") or []})
    untried = [e["name"] for e in s["library"] if e["name"] not in tried]
    if untried:
        out.append(f"{len(untried)} effect(s) of the library were not asked for "
                   f"({', '.join(untried)}): `railfem diagnose {data} --effects all`")
    if not out:
        out.append("the library's effects do not explain the bands above: look at "
                   "report.md's figures for a pattern over distance or frequency")
    return out


def findings(s: dict) -> list[str]:
    """The one-screen summary: the verdict, the dominant bands, what to do next."""
    L = [s["statement"]]
    if s["verdict"] != "noise":
        L.append("dominant: " + "; ".join(band_words(r) for r in dominant_bands(s)))
    return L + [f"next: {n}" for n in s["next_steps"]]


def write_report(out_dir, d, *, title: str = "", data: str = "DATA",
                 kind: str = "hammer") -> list[str]:
    """diagnosis.json, report.md and the figures of diagnosis ``d`` in ``out_dir``;
    ``data``, ``kind``: the DATA argument the report's suggested commands name, its kind."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    s = summary(d)
    s["next_steps"] = next_steps(s, data, kind)
    files = [str(write_text(out / "diagnosis.json", json.dumps(strict(s), indent=2, default=_json,
                                       allow_nan=False) + "\n"))]
    figs = figures(out, d)
    files += figs
    files.append(str(write_text(out / "report.md", markdown(s, [Path(f).name for f in figs],
                                                           title))))
    return files


def figures(out: Path, d) -> list[str]:
    from ..plotting import (
        plot_band_residual, plot_candidate_scores, plot_error_before_after_parts,
        plot_residual_distance, plot_residual_map, plot_residual_spectrum, save_figure,
    )

    files = []
    rb, ra = d.residual_before, d.residual_after
    for label, res in (("", rb), ("after_", ra)):
        if res is None:
            continue
        for blk in res.select(part="fit", quantity="transfer")[:1]:
            held = res.select(part="held", quantity="transfer", record=blk.record)
            pos = blk.positions
            vals = blk.values
            if held:
                pos = np.concatenate([pos, held[0].positions])
                vals = np.concatenate([vals, held[0].values], axis=2)
            for o, sensor in enumerate(blk.outputs):
                ax = plot_residual_map(blk.x, pos, vals[:, o, :],
                                       title=f"Transfer residual, {sensor}, "
                                             f"{'with ' + d.chosen.name if label else 'base'}")
                files.append(str(save_figure(ax, out / f"residual_map_{label}{sensor}.png")))
    pts = rb.select(part="fit", quantity="point")
    if pts:
        b = pts[0]
        v = b.values[:, :, 0]
        labels = [f"{s} base" for s in b.outputs]
        if ra is not None:
            v = np.column_stack([v, ra.select(part="fit", quantity="point")[0].values[:, :, 0]])
            labels += [f"{s} with {d.chosen.name}" for s in b.outputs]
        ax = plot_residual_spectrum(b.x, v, labels)
        ax.set_title("Point mobility residual")
        files.append(str(save_figure(ax, out / "residual_point.png")))
        tr = rb.select(part="fit", quantity="transfer")[0]
        bands = _bands(d)
        pick = [c for c in (100, 250, 630, 1600, 4000)
                if bands.lower.min() <= c <= bands.upper.max()]
        cols, labs = [], []
        for c in pick:
            k = int(np.argmin(np.abs(bands.nominal - c)))
            m = (tr.x >= bands.lower[k]) & (tr.x < bands.upper[k])
            with np.errstate(invalid="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # a band without points
                cols.append(np.sqrt(np.nanmean(tr.values[m, 0, :] ** 2, axis=0)) *
                            np.sign(np.nanmean(tr.values[m, 0, :], axis=0)))
            labs.append(f"{c:g} Hz")
        ax = plot_residual_distance(tr.positions, np.column_stack(cols), labs,
                                    ylabel="Signed band RMS residual (dB)")
        ax.set_title(f"Transfer residual over distance ({tr.outputs[0]}, base)")
        files.append(str(save_figure(ax, out / "residual_distance.png")))
    tdr = rb.select(part="fit", quantity="tdr") + rb.select(part="held", quantity="tdr")
    if tdr:
        centres = tdr[0].x
        cols, labs = [], []
        for b in tdr:
            for o, sensor in enumerate(b.outputs):
                cols.append(b.values[:, o, 0])
                labs.append(f"{b.record} {sensor} ({b.part})")
        ax = plot_band_residual(centres, np.column_stack(cols)[:, :12], labs[:12],
                                ylabel="Measured - model (dB)")
        ax.set_title("Decay-rate residual, base model")
        files.append(str(save_figure(ax, out / "residual_tdr.png")))
    if d.candidates:
        ax = plot_candidate_scores([c["name"] for c in d.candidates],
                                   [c["delta_bic"] for c in d.candidates],
                                   [c["held_out"].get("reduction") or 0.0
                                    for c in d.candidates],
                                   [c["kept"] for c in d.candidates], gate=gates.MIN_GAIN)
        ax.set_title("Candidates: BIC change and held-out error reduction")
        files.append(str(save_figure(ax, out / "candidates.png")))
    bands = _bands(d)
    eb = error_table(rb, bands)
    ea = error_table(ra, bands) if ra is not None else []
    for q in sorted({r["quantity"] for r in eb}):
        panels = {}
        for part in sorted({r["part"] for r in eb if r["quantity"] == q}):
            bb = {r["band_hz"]: r["rms_db"] for r in eb if r["quantity"] == q
                  and r["part"] == part}
            aa = {r["band_hz"]: r["rms_db"] for r in ea if r["quantity"] == q
                  and r["part"] == part}
            cs = sorted(bb)
            panels[part] = (cs, [bb[c] for c in cs], [aa.get(c, np.nan) for c in cs])
        axes = plot_error_before_after_parts(q, panels)
        files.append(str(save_figure(axes[0].figure, out / f"before_after_{q}.png")))
    return files
