"""The job behind ``railfem fit``: measured data in, fitted track parameters out.

DATA is a hammer measurement (a dataset folder or a TOML descriptor, railfem.io) or a
decay-rate table (CSV, railfem.io.read_decay_rate_table; the SBB Niederwangen column names
are recognised) with a row selection. One fit writes into the output folder, each file
atomically:

* ``fit.json`` — parameters with 95 % intervals and identifiability, correlations, residual
  RMS per quantity and band, the model, the data and the options used;
* ``point.png`` (point mobility, magnitude and phase), ``transfer.png`` (selected
  transfers), ``tdr.png`` (decay rate per band): measured vs fitted;
* ``residual.png`` — residual RMS per band and quantity; ``profiles.png`` — the profile
  likelihoods;
* ``summary.txt`` — what was found (values in MN/m as the command line takes them) and
  what to do next, as ``railfem fit`` prints it;
* ``run.json`` — the command record.

A table's lateral rows (direction 'y', 'h' in the SBB table; ``directions='y'`` selects
them) are fitted on the base with supports acting vertically and laterally (support
directions 'zy', as ``railfem diagnose`` models a lateral row), by default for the lateral
support chain (LATERAL_PARAMETERS); the fitted parameters then change the lateral springs
only, so the fit evaluates the coupling in eigen form (railfem.identify.forward).

A campaign (``campaign=True``: every selected row of a table) fits the rows on a Dask
cluster (``scheduler`` address, or a LocalCluster) and writes one sub-folder per row plus
``campaign.csv`` / ``campaign.json``. What DATA is, is decided by railfem.io.data; the
campaign and model comparison are library functions (railfem.identify.campaign,
railfem.identify.compare).
"""
from __future__ import annotations

import json
import logging
import time
from pathlib import Path

import numpy as np

from ..atomic import prepare_output_dir, write_text_atomic
from ..identify.campaign import fit_campaign
from ..identify.base import describe_base
from ..identify.data import model_quantities
from ..identify.fit import DEFAULT_PARAMETERS, DISCREPANCY, PROFILED, fit
from ..identify.profiling import CHI2_95
from ..io.data import parse_select, read_data
from ..measurement import direction_name
from .common import FIT_PROGRESS, watch_progress

log = logging.getLogger(__name__)

#: the parameters a lateral row is fitted for by default: the lateral support chain
LATERAL_PARAMETERS = ("kp_lat", "eta_p_lat", "kb_lat", "eta_b_lat")
DIRECTIONS = ("z", "y")  # decay-rate rows: vertical, lateral


def run_fit(data, out_dir, *, model: str = "wfe-discrete", use=None,
            parameters=None, select=None, row=None, directions: str | None = None,
            campaign: bool = False, scheduler: str | None = None, base=None,
            n_starts: int = 8, workers: int | None = None, seed: int = 0,
            transfer_positions=None, f_range=None, profiles=PROFILED,
            cache=None, slow_nodes=None, slow_refine=None, discrepancy=DISCREPANCY,
            command: str = "") -> dict:
    """Fit ``model`` to DATA and write the outputs to ``out_dir``; returns the run record.
    directions: a table's rows fitted, 'z' (vertical) or 'y' (lateral), on top of
    ``select``; a lateral row is fitted on ``lateral_base(base)`` (default parameters
    LATERAL_PARAMETERS, else DEFAULT_PARAMETERS). discrepancy: the model-form discrepancy
    ('ensemble', the default, as ``railfem diagnose``; None: noise only),
    railfem.identify.fit."""
    t0 = time.perf_counter()
    out = prepare_output_dir(out_dir, "fit")
    kind, items = read_data(data, select=with_direction(select, directions), row=row,
                            campaign=campaign)
    lateral = is_lateral(items, kind)
    if lateral:
        base = lateral_base(base, model)
    if parameters is None:
        parameters = LATERAL_PARAMETERS if lateral else DEFAULT_PARAMETERS
    if lateral and tuple(profiles) == PROFILED:  # the lateral chain's stiffnesses
        profiles = tuple(f"{n}_lat" for n in PROFILED)
    opts = dict(model=model, parameters=tuple(parameters), n_starts=n_starts, seed=seed,
                cache=cache, profiles=profiles, slow_nodes=slow_nodes, slow_refine=slow_refine,
                discrepancy=discrepancy)
    record = {"command": "fit", "argv": command, "data": str(data), "model": model,
              "parameters": list(parameters), "kind": kind, "discrepancy": discrepancy,
              "directions": "y" if lateral else "z"}
    if base is not None:
        record["base"] = describe_base(base, parameters) + (
            f"; supports acting in {base.support_directions}" if lateral else "")
    if kind == "hammer":
        target_options = {"transfer_positions": transfer_positions, "f_range": f_range}
        with watch_progress(*FIT_PROGRESS):
            res = fit(items[0], use=use or ("point", "transfer", "tdr"), base=base,
                      workers=workers, target_options=target_options, **opts)
        label = Path(str(data)).name
    elif not campaign:
        i, meas = items[0]
        if use is not None and tuple(use) != ("tdr",):
            raise ValueError(f"a decay-rate table holds only 'tdr'; --use {','.join(use)}")
        with watch_progress(*FIT_PROGRESS):
            res = fit(meas, base=base, workers=workers, **opts)
        record["row"] = i
        record["metadata"] = meas.metadata.as_dict()
        label = row_label(i, meas.metadata)
    else:
        with watch_progress(*FIT_PROGRESS):
            rows = fit_campaign(items, scheduler=scheduler, base=base, workers=workers,
                                **opts)
        record["rows"] = write_campaign(out, rows)
        record["files"] = {"campaign_csv": str(out / "campaign.csv"),
                           "campaign_json": str(out / "campaign.json")}
    if not campaign:
        record["files"] = write_fit(out, res, data_label=label)
        record["result"] = _short(res)
        record["summary"] = fit_summary(res, data, label)
        record["files"]["summary_txt"] = str(write_text_atomic(
            out / "summary.txt", "\n".join(record["summary"]) + "\n"))
    record["runtime_s"] = time.perf_counter() - t0
    record.setdefault("files", {})["run_json"] = str(out / "run.json")
    write_text_atomic(out / "run.json", json.dumps(record, indent=2, default=_json) + "\n")
    return record


def with_direction(select, directions: str | None):
    """``select`` (a dict or its text, railfem.io.data.parse_select) with the rows of
    ``directions`` ('z' vertical, 'y' lateral; None: as selected)."""
    if directions is None:
        return select
    if directions not in DIRECTIONS:
        raise ValueError(f"directions = {directions!r}: give 'z' (vertical rows) or 'y' "
                         "(lateral rows); a fit takes one direction at a time")
    crit = parse_select(select) if isinstance(select, str) else dict(select or {})
    given = crit.get("direction")
    if given is not None and direction_name(given) != directions:
        raise ValueError(f"--select dir={given} and --directions {directions} disagree: "
                         "give one of them")
    crit["direction"] = directions
    return crit


def is_lateral(items, kind: str) -> bool:
    """Whether the selected rows are lateral (all of them: a fit takes one direction)."""
    if kind == "hammer":
        return False
    dirs = {m.direction for _, m in items}
    if len(dirs) > 1:
        raise ValueError("the selection holds vertical and lateral rows: fit one direction at "
                         "a time (--directions z or --directions y)")
    return dirs == {"y"}


def lateral_base(base, model: str):
    """The base of a lateral row: ``base`` (default railfem.identify.base.default_base of
    ``model``) with supports acting laterally as well (support directions with 'y'),
    as the diagnosis models a lateral row."""
    from ..identify.base import default_base

    spec = default_base(model) if base is None else base
    if "y" in spec.support_directions:
        return spec
    dirs = spec.support_directions + "y"
    return spec.replace(support_directions="".join(d for d in "zyx" if d in dirs))


# ------------------------------------------------------------------ the summary

STRUCTURED_DB = 3.0  # a band whose residual RMS reaches this (dB) is worth a diagnosis
DISPLAY_UNITS = {"N/m": ("MN/m", 1e-6)}  # what the command line takes


def display(value, unit: str) -> tuple[float, str]:
    """(value, unit) as the command line gives them: N/m as MN/m."""
    shown, factor = DISPLAY_UNITS.get(unit, (unit, 1.0))
    return (None if value is None else value * factor), shown


def parameter_line(p: dict) -> str:
    """'kp = 612 MN/m [580, 650] identifiable: yes' (the reason when not 'yes')."""
    v, unit = display(p["value"], p.get("unit", ""))
    lo, _ = display(p["ci95"][0], p.get("unit", ""))
    hi, _ = display(p["ci95"][1], p.get("unit", ""))
    u = "" if unit in ("", "-") else f" {unit}"
    why = "" if p["identifiable"] == "yes" else f" ({p.get('reason', '')})"
    return (f"{p['name']} = {v:.4g}{u} [{lo:.3g}, {hi:.3g}] identifiable: "
            f"{p['identifiable']}{why}")


def worst_band(res) -> tuple[float, str, str, float] | None:
    """(RMS dB, quantity, sensor, band Hz) of the largest per-band residual, or None."""
    worst = None
    for q, table in res.residual_bands.items():
        for sensor, vals in table.items():
            if sensor == "band_hz":
                continue
            for f, v in zip(table["band_hz"], vals):
                if v is not None and np.isfinite(v) and (worst is None or v > worst[0]):
                    worst = (float(v), q, sensor, float(f))
    return worst


def fit_summary(res, data, label: str = "") -> list[str]:
    """The one-screen summary of a fit: what was found (values in the command line's
    units, 95 % intervals, identifiability, residual) and what to do next."""
    t = res.target
    f = t.frequency
    L = [f"fit of {res.model} to {label or data}: {', '.join(t.use)}, "
         f"{f[0]:.0f}-{f[-1]:.0f} Hz, sensors {', '.join(t.outputs)}"]
    L += ["  " + parameter_line(p) for p in res.parameters]
    L.append("residual RMS: " + ", ".join(f"{q} {v:.2f} dB"
                                          for q, v in res.residual_rms.items()))
    L.append(discrepancy_line(res.discrepancy))
    worst = worst_band(res)
    nxt = []
    if worst is not None:
        L.append(f"largest band residual: {worst[1]} ({worst[2]}) {worst[0]:.1f} dB in "
                 f"the {worst[3]:g} Hz band")
        if worst[0] >= STRUCTURED_DB:
            rows = " --select dir=h" if "head_lateral" in t.outputs else ""  # lateral rows
            nxt.append(f"the residual reaches {worst[0]:.1f} dB in a band: run `railfem "
                       f"diagnose {data}{rows}` to trace it to an effect the model leaves out")
    bad = [p["name"] for p in res.parameters if p["identifiable"] == "no"]
    if bad:
        nxt.append(f"{', '.join(bad)} not determined by these data: fix "
                   f"{'it' if len(bad) == 1 else 'them'} (leave out of --parameters, the "
                   "preset's value is kept) or add a quantity with --use")
    if not nxt:
        nxt.append("the parameters are determined and the residual is small: the fitted "
                   "spec is in fit.json ('spec')")
    return L + ["next: " + n for n in nxt]


def discrepancy_line(d: dict | None) -> str:
    """The model-form discrepancy a fit used, in one line: its variants and per quantity
    the RMS over the bands and the largest per-band s_d (dB)."""
    if not d or d.get("method") == "none" or not d.get("sd_db"):
        return "model-form discrepancy: none (residuals scaled by noise alone)"
    parts = []
    for q, sd in d["sd_db"].items():
        k = int(np.argmax(sd))
        parts.append(f"{q} RMS {float(np.sqrt(np.mean(np.square(sd)))):.2f} dB, largest "
                     f"{sd[k]:.2f} dB at {d['bands_hz'][k]:g} Hz")
    return (f"model-form discrepancy ({d['method']} over {', '.join(d['variants'])}; "
            f"per-band s_d in fit.json): " + "; ".join(parts))


def discrepancy_bands(d: dict | None, nominal) -> dict:
    """{quantity: s_d (dB) on the bands ``nominal`` (Hz), NaN where not estimated} of a
    fit's discrepancy (FitResult.discrepancy)."""
    if not d or not d.get("sd_db"):
        return {}
    centres = np.asarray(d["bands_hz"], dtype=float)
    out = {}
    for q, sd in d["sd_db"].items():
        vals = []
        for f in np.asarray(nominal, dtype=float):
            k = int(np.argmin(np.abs(np.log(centres / f))))
            vals.append(sd[k] if abs(np.log(centres[k] / f)) < 0.05 else np.nan)
        out[q] = vals
    return out


def _json(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    return str(o)


def _short(res) -> dict:
    return {"parameters": {p["name"]: {"value": p["value"], "ci95": p["ci95"],
                                       "unit": p.get("unit", ""),
                                       "identifiable": p["identifiable"]}
                           for p in res.parameters},
            "residual_rms_db": res.residual_rms, "seconds": res.seconds}


# ------------------------------------------------------------------ campaigns


def write_campaign(out: Path, rows) -> list:
    """One sub-folder per row (fit.json + plots), campaign.csv and campaign.json."""
    summary = []
    names = rows[0][2].names
    lines = ["# railfem fit campaign: one row per measurement; values SI (N/m, -, kg); "
             "ident = identifiable yes/no/weak",
             ",".join(["row", "section", "date", "rail_side", "temperature_c"]
                      + [f"{n}{s}" for n in names for s in ("", "_lo95", "_hi95", "_ident")]
                      + ["tdr_rms_db"])]
    for i, m, res in rows:
        md = m.metadata
        sub = out / f"row{i:03d}_{md.section or 'x'}_{md.date or 'x'}_{md.rail_side or 'x'}"
        sub.mkdir(exist_ok=True)
        files = write_fit(sub, res, data_label=row_label(i, md))
        cells = [str(i), md.section or "", md.date or "", md.rail_side or "",
                 "" if md.temperature_c is None else f"{md.temperature_c:g}"]
        for p in res.parameters:
            cells += [f"{p['value']:.6g}", f"{p['ci95'][0]:.4g}", f"{p['ci95'][1]:.4g}",
                      p["identifiable"]]
        cells.append(f"{res.residual_rms.get('tdr', float('nan')):.3f}")
        lines.append(",".join(cells))
        summary.append({"row": i, "metadata": md.as_dict(), "folder": str(sub),
                        "files": files, **_short(res)})
    write_text_atomic(out / "campaign.csv", "\n".join(lines) + "\n")
    write_text_atomic(out / "campaign.json", json.dumps(summary, indent=2, default=_json) + "\n")
    return summary


# ------------------------------------------------------------------ outputs


def row_label(i, metadata) -> str:
    """The row of a decay-rate table in words, for titles: 'row 3 (section B5, 2013-01-29,
    rail re)'."""
    md = metadata
    what = [f"section {md.section}" if md.section else "", md.date or "",
            f"rail {md.rail_side}" if md.rail_side else ""]
    what = ", ".join(w for w in what if w)
    return f"row {i} ({what})" if what else f"row {i}"


def write_fit(out: Path, res, *, data_label: str = "") -> dict:
    """fit.json and the plots of one fit into ``out``; returns the file paths.
    ``data_label`` (the data set, or the table row: :func:`row_label`) ends the titles."""
    from .. import plotting

    of = f"\n{data_label}" if data_label else ""  # a second title line

    files = {"fit_json": write_text_atomic(
        out / "fit.json", json.dumps(res.to_dict(), indent=2, default=_json) + "\n")}
    t = res.target
    q = model_quantities(t, res.receptance)
    f = t.frequency
    if t.point is not None and ("point" in t.use or "phase" in t.use):
        axes = None
        for o, s in enumerate(t.outputs):
            axes = plotting.plot_magnitude_phase(
                f, np.column_stack([t.point[:, o], q["point"][:, o]]),
                [f"{s} measured", f"{s} fitted"], axes=axes)
        axes[0].set_title(f"Point mobility, {res.model} fit{of}")
        files["point_png"] = plotting.save_figure(axes[0].figure, out / "point.png")
    if t.transfer is not None and "transfer" in t.use:
        ax = None
        for j, k in enumerate(t.transfer_index):
            for o, s in enumerate(t.outputs[:1]):
                ax = plotting.plot_transfer_fit(f, t.transfer[:, o, j], q["transfer"][:, o, j],
                                                f"{s} x = {t.positions[k]:.2f} m", ax=ax)
        ax.set_title(f"Transfer mobilities ({t.outputs[0]} sensor), {res.model} fit{of}")
        files["transfer_png"] = plotting.save_figure(ax.figure, out / "transfer.png")
    if t.tdr is not None and "tdr" in t.use:
        ax = None
        for o, s in enumerate(t.outputs):
            ax = plotting.plot_band_overlay(t.bands.nominal, t.tdr[:, o], q["tdr"][:, o],
                                            valid=np.isfinite(t.tdr[:, o]),
                                            labels=(f"{s} measured", f"{s} fitted"), ax=ax,
                                            logy=True)
        ax.set_title(f"Decay rate, {res.model} fit{of}")
        files["tdr_png"] = plotting.save_figure(ax.figure, out / "tdr.png")
    cols, labels = [], []
    for quantity, table in res.residual_bands.items():
        for s in t.outputs:
            cols.append([np.nan if v is None else v for v in table[s]])
            labels.append(f"{quantity} ({s})")
    for quantity, sd in discrepancy_bands(res.discrepancy, t.bands.nominal).items():
        cols.append(sd)
        labels.append(f"{quantity}: model-form discrepancy s_d")
    ax = plotting.plot_band_residual(t.bands.nominal, np.array(cols).T, labels,
                                     ylabel="Residual RMS per band (dB)")
    ax.set_title(f"Residual per band, {res.model} fit{of}")
    files["residual_png"] = plotting.save_figure(ax.figure, out / "residual.png")
    if res.profiles:
        axes = plotting.plot_profiles(
            res.profiles, units={n: res.parameter(n)["unit"] for n in res.profiles},
            threshold=CHI2_95)
        files["profiles_png"] = plotting.save_figure(axes[0].figure, out / "profiles.png")
    return {k: str(v) for k, v in files.items()}
