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
* ``run.json`` — the command record.

A campaign (``campaign=True``: every selected row of a table) fits the rows on a Dask
cluster (``scheduler`` address, or a LocalCluster) and writes one sub-folder per row plus
``campaign.csv`` / ``campaign.json``.
"""
from __future__ import annotations

import json
import logging
import time
from pathlib import Path

import numpy as np

from ..atomic import prepare_output_dir, write_text_atomic
from ..identify.fit import (
    CHI2_95, DEFAULT_PARAMETERS, FIT_BOUNDS, PROFILED, Problem, base_spec, default_workers, fit,
    prebuild_nodes,
)
from ..identify.data import QUANTITIES, decay_rate_target, model_quantities
from ..identify.forward import ForwardModel, Geometry
from ..params import ParameterSpace

log = logging.getLogger(__name__)

SELECT_KEYS = {"dir": "direction", "direction": "direction", "sec": "section",
               "section": "section", "date": "date", "rail": "rail_side",
               "rail_side": "rail_side", "side": "rail_side"}


def parse_select(text: str | None) -> dict:
    """'dir=v,sec=B5' -> {'direction': 'v', 'section': 'B5'} (values may be a|b lists)."""
    out: dict = {}
    for item in (text or "").split(","):
        if not item.strip():
            continue
        key, sep, value = item.partition("=")
        key = key.strip().lower()
        if not sep or key not in SELECT_KEYS or not value.strip():
            raise ValueError(f"--select item {item!r}: write KEY=VALUE with KEY one of "
                             f"{', '.join(sorted(SELECT_KEYS))}, e.g. dir=v,sec=B5")
        vals = [v.strip() for v in value.split("|")]
        out[SELECT_KEYS[key]] = vals[0] if len(vals) == 1 else vals
    return out


def parse_use(text: str) -> tuple[str, ...]:
    use = tuple(x.strip() for x in text.split(",") if x.strip())
    bad = [u for u in use if u not in QUANTITIES]
    if bad or not use:
        raise ValueError(f"--use {text!r}: give a comma list of {', '.join(QUANTITIES)}")
    return use


def read_data(path, *, select=None, row=None, campaign=False):
    """(kind, items): ('hammer', [measurement]) or ('table', [(row index, measurement)])."""
    from ..io import SBB_NIEDERWANGEN_COLUMNS, read_decay_rate_table, read_measurement

    path = Path(path)
    if not path.exists():
        raise ValueError(f"DATA {path} does not exist; give a dataset folder, a .toml "
                         "descriptor or a decay-rate table (.csv)")
    if path.is_dir() or path.suffix.lower() == ".toml":
        if select or row is not None or campaign:
            raise ValueError("--select, --row and --campaign apply to decay-rate tables; "
                             f"{path} is a hammer measurement")
        return "hammer", [read_measurement(path)]
    head = path.read_text(encoding="utf-8", errors="replace")[:4096]
    columns = SBB_NIEDERWANGEN_COLUMNS if "messdatum" in head else None
    table = read_decay_rate_table(path, columns=columns)
    index = np.arange(len(table))
    crit = parse_select(select) if isinstance(select, str) else dict(select or {})
    if crit:
        keep = table.select(**crit)
        index = np.array([i for i in range(len(table))
                          if any(table.metadata[i] is m for m in keep.metadata)])
    if row is not None:
        if not 0 <= row < len(index):
            raise ValueError(f"--row {row}: the selection has {len(index)} rows (0.."
                             f"{len(index) - 1})")
        index = index[[row]]
    if not campaign and len(index) != 1:
        raise ValueError(f"the selection holds {len(index)} rows; pick one with --row N or "
                         "--select, or fit them all with --campaign")
    return "table", [(int(i), table.row(int(i))) for i in index]


def run_fit(data, out_dir, *, model: str = "wfe-discrete", use=None,
            parameters=DEFAULT_PARAMETERS, select=None, row=None,
            campaign: bool = False, scheduler: str | None = None, base=None,
            n_starts: int = 8, workers: int | None = None, seed: int = 0,
            transfer_positions=None, f_range=None, profiles=PROFILED,
            cache=None, slow_nodes=None, slow_refine=None, command: str = "") -> dict:
    """Fit ``model`` to DATA and write the outputs to ``out_dir``; returns the run record."""
    t0 = time.perf_counter()
    out = prepare_output_dir(out_dir, "fit")
    kind, items = read_data(data, select=select, row=row, campaign=campaign)
    opts = dict(model=model, parameters=tuple(parameters), n_starts=n_starts, seed=seed,
                cache=cache, profiles=profiles, slow_nodes=slow_nodes, slow_refine=slow_refine)
    record = {"command": "fit", "argv": command, "data": str(data), "model": model,
              "parameters": list(parameters), "kind": kind}
    if kind == "hammer":
        target_options = {"transfer_positions": transfer_positions, "f_range": f_range}
        res = fit(items[0], use=use or ("point", "transfer", "tdr"), base=base,
                         workers=workers, target_options=target_options, **opts)
        record["files"] = write_fit(out, res)
        record["result"] = _short(res)
    elif not campaign:
        i, meas = items[0]
        if use is not None and tuple(use) != ("tdr",):
            raise ValueError(f"a decay-rate table holds only 'tdr'; --use {','.join(use)}")
        res = fit(meas, base=base, workers=workers, **opts)
        record["row"] = i
        record["metadata"] = meas.metadata.as_dict()
        record["files"] = write_fit(out, res)
        record["result"] = _short(res)
    else:
        rows = fit_campaign(items, scheduler=scheduler, base=base, workers=workers, **opts)
        record["rows"] = write_campaign(out, rows)
    record["runtime_s"] = time.perf_counter() - t0
    write_text_atomic(out / "run.json", json.dumps(record, indent=2, default=_json) + "\n")
    return record


def _json(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    return str(o)


def _short(res) -> dict:
    return {"parameters": {p["name"]: {"value": p["value"], "ci95": p["ci95"],
                                       "identifiable": p["identifiable"]}
                           for p in res.parameters},
            "residual_rms_db": res.residual_rms, "seconds": res.seconds}


# ------------------------------------------------------------------ campaigns


def _campaign_fit(forward, meas, opts):
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1):
        res = fit(meas, forward=forward, workers=1, **opts)
    return res


def fit_campaign(items, *, scheduler=None, base=None, workers=None, model="wfe-discrete",
                 parameters=DEFAULT_PARAMETERS, slow_nodes=None, slow_refine=None,
                 cache=None, **opts):
    """Fit every (index, DecayRateMeasurement) of ``items`` on a Dask cluster (the address
    ``scheduler`` or a LocalCluster of ``workers`` processes, one thread each). Rows on the
    same bands share one forward model: its kernels (and, for a kernel parameter, the
    profile nodes) are computed once here and scattered to the workers. Returns
    [(index, measurement, FitResult)] in the order given."""
    from dask.distributed import Client, LocalCluster, as_completed

    first = items[0][1]
    spec0 = base_spec(first, model, base)
    b = {n: FIT_BOUNDS[n] for n in parameters if n in FIT_BOUNDS}
    space = ParameterSpace(spec0, parameters, bounds=b)
    target = decay_rate_target(first, spec0.spacing)
    geometry = Geometry(frequency=target.frequency, outputs=target.outputs,
                        sensor_x=target.sensor_x, force_x=target.force_x)
    forward = ForwardModel(space, geometry, cache=cache)
    beam = model.startswith("timoshenko")
    slow_nodes = slow_nodes or (5 if beam else 6)
    slow_refine = (3 if beam else 0) if slow_refine is None else slow_refine
    nw = workers or default_workers()
    slow = [n for n in space.names if n in forward.slow]
    if slow:  # the profile nodes every row uses, built once (in processes)
        i = space.names.index(slow[0])
        nodes = np.linspace(space.lower[i], space.upper[i], slow_nodes + 2)[1:-1]
        x = np.clip(space.from_spec(space.base), space.lower, space.upper)
        problem = Problem(target=target, forward=forward)
        prebuild_nodes(problem, nodes, i, x, nw)
    opts.update(slow_nodes=slow_nodes, slow_refine=slow_refine)
    for _, m in items:
        if not np.array_equal(m.frequency, first.frequency):
            raise ValueError("campaign rows must share the bands of the first row")
    if scheduler:
        client = Client(scheduler)
        cluster = None
    else:
        cluster = LocalCluster(n_workers=nw, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
    try:
        fwd = client.scatter(forward, broadcast=True)
        futs = {client.submit(_campaign_fit, fwd, m, opts, pure=False): k
                for k, (_, m) in enumerate(items)}
        results = [None] * len(items)
        t0 = time.perf_counter()
        for n, fut in enumerate(as_completed(futs), 1):
            k = futs[fut]
            results[k] = fut.result()
            md = items[k][1].metadata
            log.info("campaign: row %d (%s %s %s) done, %d/%d, %.0f s", items[k][0],
                     md.section, md.date, md.rail_side, n, len(items),
                     time.perf_counter() - t0)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return [(i, m, r) for (i, m), r in zip(items, results)]


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
        files = write_fit(sub, res)
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


def write_fit(out: Path, res) -> dict:
    """fit.json and the plots of one fit into ``out``; returns the file paths."""
    from .. import plotting

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
        axes[0].set_title(f"Point mobility, {res.model} fit")
        files["point_png"] = plotting.save_figure(axes[0].figure, out / "point.png")
    if t.transfer is not None and "transfer" in t.use:
        ax = None
        for j, k in enumerate(t.transfer_index):
            for o, s in enumerate(t.outputs[:1]):
                ax = _transfer_lines(ax, f, t.transfer[:, o, j], q["transfer"][:, o, j],
                                     f"{s} x = {t.positions[k]:.2f} m")
        ax.set_title(f"Transfer mobilities ({t.outputs[0]} sensor), {res.model} fit")
        files["transfer_png"] = plotting.save_figure(ax.figure, out / "transfer.png")
    if t.tdr is not None and "tdr" in t.use:
        ax = None
        for o, s in enumerate(t.outputs):
            ax = plotting.plot_band_overlay(t.bands.nominal, t.tdr[:, o], q["tdr"][:, o],
                                            valid=np.isfinite(t.tdr[:, o]),
                                            labels=(f"{s} measured", f"{s} fitted"), ax=ax,
                                            logy=True)
        ax.set_title(f"Decay rate, {res.model} fit")
        files["tdr_png"] = plotting.save_figure(ax.figure, out / "tdr.png")
    cols, labels = [], []
    for quantity, table in res.residual_bands.items():
        for s in t.outputs:
            cols.append([np.nan if v is None else v for v in table[s]])
            labels.append(f"{quantity} ({s})")
    ax = plotting.plot_band_residual(t.bands.nominal, np.array(cols).T, labels,
                                     ylabel="Residual RMS per band (dB)")
    ax.set_title(f"Residual per band, {res.model} fit")
    files["residual_png"] = plotting.save_figure(ax.figure, out / "residual.png")
    if res.profiles:
        files["profiles_png"] = _plot_profiles(out / "profiles.png", res)
    return {k: str(v) for k, v in files.items()}


def _transfer_lines(ax, f, measured, fitted, label):
    if ax is None:
        ax = _new_axes()
    line, = ax.loglog(f, np.abs(measured), "o", markersize=3, label=f"{label} measured")
    ax.loglog(f, np.abs(fitted), "-", color=line.get_color(), label=f"{label} fitted")
    ax.set_xlabel("Frequency (Hz)")
    ax.set_ylabel("Mobility (m/s/N)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    return ax


def _new_axes():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    _, ax = plt.subplots(figsize=(7.0, 5.0), layout="constrained")
    return ax


def _plot_profiles(path, res):
    from .. import plotting

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(res.profiles)
    fig, axes = plt.subplots(1, n, figsize=(4.0 * n, 3.5), layout="constrained",
                             squeeze=False)
    for ax, (name, p) in zip(axes[0], res.profiles.items()):
        ax.semilogx(p["value"], p["delta_chi2"], "o-")
        ax.axhline(CHI2_95, color="k", linestyle="--", linewidth=0.8,
                   label="95 % threshold")
        ax.set_xlabel(f"{name} ({res.parameter(name)['unit']})")
        ax.set_ylabel("Delta chi-square")
        ax.set_ylim(0, max(4 * CHI2_95, 1.0))
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    return plotting.save_figure(fig, path)


def compare_models(data, models=("wfe-discrete", "wfe-periodic", "timoshenko-discrete",
                                 "timoshenko-continuous"), **fit_options) -> dict:
    """The same data fitted with each model: {model: FitResult}. Identified stiffnesses
    differ between models because each model lacks different physics; that difference is
    the model dependence of the identification (docs/identification.md)."""
    out = {}
    for m in models:
        log.info("model comparison: fitting %s", m)
        out[m] = fit(data, m, **fit_options)
    return out


def comparison_table(results: dict) -> str:
    """A text table: per model, each parameter with its 95 % interval and identifiability,
    and the residual RMS per quantity."""
    names = next(iter(results.values())).names
    lines = ["model".ljust(24) + "".join(n.ljust(30) for n in names) + "residual RMS (dB)"]
    for m, r in results.items():
        cells = []
        for n in names:
            p = r.parameter(n)
            cells.append(f"{p['value']:.3g} [{p['ci95'][0]:.2g},{p['ci95'][1]:.2g}] "
                         f"{p['identifiable'][0]}".ljust(30))
        rms = ", ".join(f"{q} {v:.2f}" for q, v in r.residual_rms.items())
        lines.append(m.ljust(24) + "".join(cells) + rms)
    return "\n".join(lines)
