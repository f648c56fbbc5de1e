"""The SBB Niederwangen decay rates diagnosed with the default effect library, which now
holds the real-track effects (sleeper_flexibility, two_rail, ballast_mass).

    OPENBLAS_NUM_THREADS=1 python benchmarks/sbb/diagnose_sbb.py \
        [--model timoshenko-discrete] [--groups B1,B5:2015] [--starts 4] \
        [--out benchmarks/results/results_sbb.md] [--json /tmp/sbb.json]

Per section and date (the two rails are repeats), vertical rows (``dir = v``): the verdict
and the chosen effect of ``railfem.diagnosis.diagnose``, every new effect's screening row
(BIC against the base, held-out gain and its p-value, plausibility, fitted values next to
the literature values of railfem.track.sleeper) and, for the chosen model or else the best
new effect by BIC, the RMS per band before and after on the fitted and on the held-out
bands. The structured residual per band is what exceeds the rail-to-rail scatter,
sqrt(max(0, mean r^2 - s_b^2)) with s_b the pooled scatter of the group's two rails (dB);
its median over the groups is given before and after. ``--lateral``: the lateral rows
(``dir = h``) summarised from the measured values and a forward check of the new options.

``--diagnose-lateral`` diagnoses, per section and date, the vertical and the lateral rows
together (railfem.diagnosis.prepare(directions='zy'); the lateral rows in the lateral
channel, hammer and sensor on the side of the head) on the periodic WFE track
(``--lateral-model``, default wfe-periodic) with roll_restraint and the real-track effects
(LATERAL_EFFECTS), and writes ``--lateral-out`` (default
benchmarks/results/results_sbb_lateral.md): per group the verdict, the fitted values next
to the literature, and the median structured residual per band before and after, fitted
and held-out bands, vertical and lateral rows apart:

    OPENBLAS_NUM_THREADS=1 python benchmarks/sbb/diagnose_sbb.py --diagnose-lateral \
        --no-profile [--groups B5:2013-01-29] [--json /tmp/sbb_lateral.json]
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from railfem.diagnosis import residual as resid  # noqa: E402
from railfem.diagnosis.effects import get  # noqa: E402
from railfem.diagnosis.effects.roll_restraint import K_ROLL_CLIPS  # noqa: E402
from railfem.diagnosis.loop import diagnose  # noqa: E402
from railfem.diagnosis.refit import refit  # noqa: E402
from railfem.io.tdr_table import SBB_NIEDERWANGEN_COLUMNS, read_decay_rate_table  # noqa: E402
from railfem.track.sleeper import B90, TWO_LAYER_ASSUMED  # noqa: E402

TABLE = Path("/work/shared/measured_data/sbb_niederwangen/tdr_niederwangen_wide.csv")
NEW = ("sleeper_flexibility", "two_rail", "ballast_mass")
LATERAL_EFFECTS = ("roll_restraint",) + NEW
LATERAL_MODEL = "wfe-periodic"
log = logging.getLogger("diagnose_sbb")


def fitted_text(e: dict) -> tuple[str, str]:
    """A screened candidate's fitted values with their 95 % intervals, and 'yes' or 'no
    (why)' for its plausibility: the two text cells of the candidate tables."""
    par = "; ".join(f"{k} {v['value']:.3g}" + (f" [{v['ci95'][0]:.3g}, {v['ci95'][1]:.3g}]"
                                               if v.get("ci95") else "")
                    for k, v in e["params"].items())
    return par, "yes" if e["plausible"] else f"no ({e['implausible_why']})"


def groups(rows, direction="z"):
    out: dict = {}
    for r in rows:
        if r.direction == direction:
            m = r.metadata
            out.setdefault(f"{m.section} {m.date}", []).append(r)
    return out


def repeat_scatter(rows) -> dict:
    """{band: pooled rail-to-rail scatter of 10 lg(decay rate) (dB)} of one group."""
    f = np.asarray(rows[0].frequency, dtype=float)
    v = np.stack([10 * np.log10(np.asarray(r.decay_rate, dtype=float)) for r in rows])
    dev = v - np.nanmean(v, axis=0)
    dof = np.sum(np.isfinite(v), axis=0) - 1
    s2 = np.nansum(dev ** 2, axis=0) / np.maximum(dof, 1)
    return {float(c): float(np.sqrt(s)) for c, s, d in zip(f, s2, dof) if d > 0}


def per_band(res, part, lateral=None) -> dict:
    """{band: (mean r^2, n)} of the decay-rate residual (dB) over the group's records
    (lateral: None all, True the lateral records only, False the vertical ones)."""
    acc: dict = {}
    for b in res.select(part=part, quantity="tdr"):
        if lateral is not None and ("head_lateral" in b.outputs) != lateral:
            continue
        for k, c in enumerate(b.x):
            v = b.values[k].ravel()
            v = v[np.isfinite(v)]
            if v.size:
                s, n = acc.get(float(c), (0.0, 0))
                acc[float(c)] = (s + float(np.sum(v ** 2)), n + v.size)
    return {c: (s / n, n) for c, (s, n) in acc.items()}


def band_summary(res, scatter, lateral=None) -> dict:
    """{part: {band: {rms, structured}}} (dB)."""
    out = {}
    for part in ("fit", "held"):
        out[part] = {}
        for c, (m2, _) in per_band(res, part, lateral).items():
            s = scatter.get(c, 0.0)
            out[part][c] = {"rms": float(np.sqrt(m2)),
                            "structured": float(np.sqrt(max(0.0, m2 - s ** 2)))}
    return out


def refit_effect(d, name):
    """The base + effect ``name`` refitted on the diagnosis's data (as its screening)."""
    b = d.base
    o = refit(d.data, b.problem.model.evaluator, b.problem.model.spec, (get(name),), b.x,
              b.problem.scale)
    return o, resid.make_residual(d.data, o.problem.predict(o.x))


def fitted(row) -> dict:
    return {p["name"].split(".", 1)[1]: {"value": p["value"], "ci95": p.get("ci95")}
            for p in row["parameters"] if "." in p["name"]}


def run_group(name, rows, model, starts, effects=None, profile=True):
    t0 = time.perf_counter()
    d = diagnose(rows, model=model, spacing=0.6, n_starts=starts, effects=effects,
                 profile_final=profile)
    scatter = repeat_scatter(rows)
    rows_by_name = {c["name"]: c for c in d.candidates}
    new = {}
    for n in NEW:
        c = rows_by_name.get(n)
        new[n] = None if c is None else {
            "delta_bic": c["delta_bic"], "plausible": c["plausible"],
            "implausible_why": c["implausible_why"],
            "held_reduction": c["held_out"].get("reduction"),
            "held_p": c["held_out"].get("p"), "held_pass": c["held_out"].get("pass"),
            "params": fitted(c)}
    ok = [n for n in NEW if new[n] is not None]
    best_new = min(ok, key=lambda n: new[n]["delta_bic"]) if ok else None
    after_name, res_after = None, None
    if d.chosen is not None:
        after_name, res_after = d.chosen.name, d.residual_after
    elif best_new is not None:
        _, res_after = refit_effect(d, best_new)
        after_name = best_new
    ranking = sorted(d.candidates, key=lambda c: c["bic"])[:4]
    return {
        "group": name, "rows": len(rows), "verdict": d.verdict, "statement": d.statement,
        "chosen": d.chosen.name if d.chosen else None,
        "base": {p["name"]: p["value"] for p in d.base.parameters()
                 if p["name"] in ("kp", "eta_p", "kb", "eta_b", "eta_r")},
        "structured_before_db": d.structure_before.get("structured_rms_db"),
        "structured_after_db": (d.structure_after or {}).get("structured_rms_db"),
        "ranking": [{"name": c["name"], "delta_bic": c["delta_bic"],
                     "held_reduction": c["held_out"].get("reduction"),
                     "plausible": c["plausible"]} for c in ranking],
        "new": new, "best_new": best_new, "after": after_name,
        "bands_before": band_summary(d.residual_before, scatter),
        "bands_after": band_summary(res_after, scatter) if res_after is not None else None,
        "scatter": scatter, "seconds": time.perf_counter() - t0,
        "failures": d.failures}


# ------------------------------------------------------------------ lateral rows


def lateral_summary(rows) -> dict:
    """Measured lateral decay rates: median per band over the lateral rows (dB/m)."""
    lat = [r for r in rows if r.direction == "y"]
    f = np.asarray(lat[0].frequency, dtype=float)
    v = np.stack([np.asarray(r.decay_rate, dtype=float) for r in lat])
    return {"n_rows": len(lat), "median_dB_per_m": dict(zip(f.tolist(),
                                                             np.nanmedian(v, 0).tolist()))}


def lateral_forward(bands=(100.0, 125.0, 160.0, 200.0, 250.0, 315.0)) -> dict:
    """Lateral decay rate (dB/m) per band of the lateral track of scripts/lateral_fits.py
    (wfe-periodic, site preset, 0.15 m pad in one row, supports acting vertically and
    laterally, rail loss factor 0.01; lateral hammer and sensor on the side of the head)
    with the base support, the flexible sleeper and the ballast mass (vertical chain: the
    lateral chain has no sleeper): whether the new options reach the measured 9-14 dB/m."""
    import railfem as rf
    from railfem import models
    from railfem.standards import iec61260

    spec = rf.preset("site", model="wfe-periodic", pad_length=0.15, n_rows=1,
                     support_directions="zy").replace(eta_r=0.01)
    f = iec61260.ninth_octave_grid(min(bands) / 1.25, max(bands) * 1.25)
    out = {}
    for tag, s in (("base", spec), ("flexible sleeper", spec.replace(sleeper="flexible")),
                   ("ballast mass", spec.replace(**TWO_LAYER_ASSUMED))):
        r = models.decay_rate(s, f, output="head_lateral", cache=False)
        out[tag] = {float(c): float(d) for c, d in zip(r.frequency, r.decay_rate)
                    if any(abs(c - b) < 1 for b in bands)}
        log.info("lateral %s: %s", tag, out[tag])
    return out


# ------------------------------------------------------------------ lateral diagnosis


def joint_groups(rows) -> dict:
    """{section date: vertical and lateral rows} of the groups that have lateral rows."""
    lat = groups(rows, "y")
    ver = groups(rows, "z")
    return {k: ver.get(k, []) + v for k, v in lat.items()}


def candidate(c) -> dict:
    return {"delta_bic": c["delta_bic"], "plausible": c["plausible"],
            "implausible_why": c["implausible_why"],
            "held_reduction": c["held_out"].get("reduction"),
            "held_p": c["held_out"].get("p"), "held_pass": c["held_out"].get("pass"),
            "params": fitted(c)}


#: the rail seat of the base (SupportParameters.seat), --seat: 'rigid' is the default
SEAT = {"seat": "rigid"}


def seat_base(model):
    """The diagnosis's default base with SEAT's rail seat, or None (the default as it is)."""
    if SEAT["seat"] == "rigid":
        return None
    from railfem.identify.base import default_base

    s = default_base(model)
    return s.replace(support=dataclasses.replace(s.support, seat=SEAT["seat"]))


def run_lateral_group(name, rows, model, starts, effects=LATERAL_EFFECTS, profile=True):
    """The group's vertical and lateral rows diagnosed together (see the docstring)."""
    t0 = time.perf_counter()
    d = diagnose(rows, model=model, spacing=0.6, n_starts=starts, effects=effects,
                 profile_final=profile, data_options={"directions": "zy"},
                 base=seat_base(model))
    by = {c["name"]: c for c in d.candidates}
    new = {n: candidate(by[n]) if n in by else None for n in effects}
    ok = [n for n in effects if new[n] is not None]
    best = min(ok, key=lambda n: new[n]["delta_bic"]) if ok else None
    after, res_after = (d.chosen.name, d.residual_after) if d.chosen is not None else \
        ((best, refit_effect(d, best)[1]) if best else (None, None))
    out = {"group": name, "verdict": d.verdict, "statement": d.statement,
           "chosen": d.chosen.name if d.chosen else None, "after": after,
           "base": {p["name"]: p["value"] for p in d.base.parameters()
                    if p["name"] in ("kp", "eta_p", "kb", "eta_b", "eta_r")},
           "structured_before_db": d.structure_before.get("structured_rms_db"),
           "structured_after_db": (d.structure_after or {}).get("structured_rms_db"),
           "new": new, "best_new": best, "failures": d.failures,
           "seconds": time.perf_counter() - t0}
    for tag, lat in (("lateral", True), ("vertical", False)):
        rs = [r for r in rows if (r.direction == "y") == lat]
        sc = repeat_scatter(rs) if len(rs) > 1 else {}
        out[f"scatter_{tag}"] = sc
        out[f"bands_before_{tag}"] = band_summary(d.residual_before, sc, lat)
        out[f"bands_after_{tag}"] = (band_summary(res_after, sc, lat)
                                     if res_after is not None else None)
    return out


def lateral_cost(rows, model_names=("wfe-periodic", "wfe-continuous"), repeats=3) -> dict:
    """{model: (CPU s of the first evaluation, CPU s per further evaluation)} of a lateral
    row's model (the diagnosis's evaluator: the lateral track of the site base, a new pad
    stiffness at each evaluation), on a memory-only kernel cache."""
    from railfem.diagnosis import prepare
    from railfem.diagnosis.evaluate import Evaluator
    from railfem.identify.base import default_base

    rec = prepare([r for r in rows if r.direction == "y"][:1], spacing=0.6).records[0]
    out = {}
    for m in model_names:
        ev, spec = Evaluator(), default_base(m)
        t = []
        for k in range(repeats):
            c0 = time.process_time()
            ev.receptance(spec.replace(kp=spec.support.kp * (1 + 0.2 * k)), rec)
            t.append(time.process_time() - c0)
        out[m] = (t[0], float(np.mean(t[1:])))
        log.info("cost %s: first %.2f s, then %.3f s CPU", m, *out[m])
    return out


def markdown_lateral(results, command, cost=None) -> str:
    L = ["# SBB Niederwangen: vertical and lateral rows diagnosed together", "",
         f"Reproduce: `{command}`", "",
         "Per section and date, the vertical (`v`) and lateral (`h`) rows of both rails "
         f"diagnosed together on the {LATERAL_MODEL} track (the lateral rows with the "
         "lateral hammer and sensor on the side of the head; the lateral pad and the "
         "sleeper's lateral ballast support follow the fitted vertical ones by the presets' "
         "rule, kp/7 and kb/2), every third band held out, candidates "
         f"{', '.join(LATERAL_EFFECTS)}. Literature for the roll stiffness k_roll: elastic "
         f"clips of a W14-type fastening ~{K_ROLL_CLIPS:.0e} N m/rad (derived), the vertical "
         "pad across the foot ~1.1e6 N m/rad for 600 MN/m (already in the base), above "
         "~1e5 N m/rad the foot bearing on the guide plates (docs/model.md).", "",
         "| group | verdict | chosen | structured before → after (dB) | s |",
         "|---|---|---|---|---|"]
    for g in results:
        L.append(f"| {g['group']} | {g['verdict']} | {g['chosen'] or '—'} | "
                 f"{fmt(g['structured_before_db'])} → {fmt(g['structured_after_db'])} | "
                 f"{g['seconds']:.0f} |")
    L += ["", "## The candidates per group", "",
          "ΔBIC against the base (negative: better), held-out gain (p), plausible, fitted "
          "values (95 % interval); base kp, kb in N/m.", "",
          "| group | base | effect | ΔBIC | held-out gain (p) | plausible | fitted |",
          "|---|---|---|---|---|---|---|"]
    for g in results:
        base = ", ".join(f"{k} {v:.3g}" for k, v in g["base"].items())
        for n, e in g["new"].items():
            if e is None:
                L.append(f"| {g['group']} | {base} | {n} | failed or not tried | | | |")
                continue
            par, why = fitted_text(e)
            L.append(f"| {g['group']} | {base} | {n} | {e['delta_bic']:.1f} | "
                     f"{fmt(e['held_reduction'])} ({fmt(e['held_p'])}) | {why} | {par} |")
    for tag in ("lateral", "vertical"):
        L += ["", f"## Median structured residual per band over the groups, {tag} rows (dB)",
              "", "After: the chosen model, else the best candidate by BIC. Structured: "
              "what exceeds the rail-to-rail scatter of the group.", "",
              "| band (Hz) | part | before | after | RMS before | RMS after |",
              "|---|---|---|---|---|---|"]
        for part in ("held", "fit"):
            mb = median_bands(results, f"bands_before_{tag}", part, "structured")
            ma = median_bands(results, f"bands_after_{tag}", part, "structured")
            rb = median_bands(results, f"bands_before_{tag}", part, "rms")
            ra = median_bands(results, f"bands_after_{tag}", part, "rms")
            for c in mb:
                L.append(f"| {c:g} | {part} | {fmt(mb[c])} | {fmt(ma.get(c))} | "
                         f"{fmt(rb.get(c))} | {fmt(ra.get(c))} |")
    if cost:
        L += ["", "## Cost of a lateral row's model (CPU s, one process, 54 frequencies)", "",
              "The evaluator's receptance of one lateral row (29 hammer positions), a new pad "
              "stiffness each time; memory-only kernel cache. The discrete WFE track "
              "(131 supports) needs ~70 s of CPU for its lateral kernel and ~0.6 s per "
              "frequency for each coupling solve (results_lateral.txt): ~30 s per "
              "evaluation. The periodic WFE track is the lateral rows' model.", "",
              "| model | first evaluation (kernel) | each further evaluation |",
              "|---|---|---|"]
        L += [f"| {m} | {a:.2f} | {b:.3f} |" for m, (a, b) in cost.items()]
    L += ["", "## Verdicts in words", ""]
    L += [f"* **{g['group']}** (after: {g['after'] or '—'}): {g['statement']}"
          + (f" Failures: {g['failures']}" if g["failures"] else "") for g in results]
    return "\n".join(L) + "\n"


def _floats(g):
    """A lateral group result read back from JSON (band keys as floats)."""
    for k in list(g):
        if k.startswith("bands_") and g[k]:
            g[k] = {p: {float(c): v for c, v in d.items()} for p, d in g[k].items()}
        elif k.startswith("scatter_"):
            g[k] = {float(c): v for c, v in g[k].items()}
    return g


def main_lateral(a, rows, want, cmd):
    results = [_floats(g) for m in a.merge for g in json.loads(Path(m).read_text())]
    done = {g["group"] for g in results}
    for name, rs in joint_groups(rows).items():
        if name in done or (want and not any(name.startswith(w.replace(":", " "))
                                             for w in want)):
            continue
        log.info("lateral group %s (%d rows)", name, len(rs))
        effects = tuple(a.effects.split(",")) if a.effects else LATERAL_EFFECTS
        results.append(run_lateral_group(name, rs, a.lateral_model, a.starts, effects,
                                         profile=not a.no_profile))
        if a.json:
            Path(a.json).write_text(json.dumps(results, indent=1, default=float))
        Path(a.lateral_out).write_text(markdown_lateral(results, cmd))
    cost = lateral_cost(rows) if a.cost else None
    Path(a.lateral_out).write_text(markdown_lateral(results, cmd, cost))


# ------------------------------------------------------------------ the table


def median_bands(results, key, part, what):
    acc: dict = {}
    for g in results:
        for c, v in ((g[key] or {}).get(part) or {}).items():
            acc.setdefault(float(c), []).append(v[what])
    return {c: float(np.median(v)) for c, v in sorted(acc.items())}


def fmt(x, p=2):
    return "—" if x is None else f"{x:.{p}g}" if abs(x) < 1e-2 else f"{x:.{p}f}"


def markdown(results, command, lateral=None) -> str:
    L = ["# SBB Niederwangen decay rates diagnosed with the real-track effects", "",
         f"Reproduce: `{command}`", "",
         "Vertical rows, per section and date (the two rails as repeats; every third band "
         "held out), default library plus sleeper_flexibility, two_rail, ballast_mass. "
         f"Literature values (railfem.track.sleeper): first free-free bending frequency of "
         f"the B90/B91-type sleeper {B90.free_frequencies(1)[0]:.0f} Hz (measured monobloc "
         "sleepers ~100-200 Hz), sleeper loss factor 0.02; assumed two-layer ballast "
         f"mb {TWO_LAYER_ASSUMED['mb']:.0f} kg, kf {TWO_LAYER_ASSUMED['kf'] / 1e6:.0f} MN/m, "
         f"eta_f {TWO_LAYER_ASSUMED['eta_f']}.", "",
         "| group | verdict | chosen | best by BIC (ΔBIC, held-out gain) "
         "| structured before → after (dB) | s |",
         "|---|---|---|---|---|---|"]
    for g in results:
        r0 = g["ranking"][0] if g["ranking"] else None
        best = "—" if r0 is None else (f"{r0['name']} ({r0['delta_bic']:.0f}, "
                                       f"{fmt(r0['held_reduction'])})")
        L.append(f"| {g['group']} | {g['verdict']} | {g['chosen'] or '—'} | {best} | "
                 f"{fmt(g['structured_before_db'])} → {fmt(g['structured_after_db'])} | "
                 f"{g['seconds']:.0f} |")
    L += ["", "## The new effects per group", "",
          "ΔBIC against the base (negative: better), held-out gain (fraction of the held-out "
          "mean square removed) with its p-value, plausible, fitted values (95 % interval).", "",
          "| group | effect | ΔBIC | held-out gain (p) | plausible | fitted |",
          "|---|---|---|---|---|---|"]
    for g in results:
        for n in NEW:
            e = g["new"][n]
            if e is None:
                L.append(f"| {g['group']} | {n} | not screened | | | |")
                continue
            par, why = fitted_text(e)
            L.append(f"| {g['group']} | {n} | {e['delta_bic']:.1f} | "
                     f"{fmt(e['held_reduction'])} ({fmt(e['held_p'])}) | {why} | {par} |")
    L += ["", "## RMS per band before → after (dB), per group", "",
          "After: the chosen model, else the best new effect by BIC (named). Fitted and "
          "held-out bands; rail-to-rail scatter s_b.", ""]
    for g in results:
        bb, ba = g["bands_before"], g["bands_after"] or {}
        L += [f"**{g['group']}** (after: {g['after'] or '—'})", "",
              "| band (Hz) | part | s_b | RMS before | RMS after | structured before "
              "| structured after |",
              "|---|---|---|---|---|---|---|"]
        for part in ("fit", "held"):
            for c in sorted(bb[part]):
                a = (ba.get(part) or {}).get(c)
                L.append(f"| {c:g} | {part} | {fmt(g['scatter'].get(c))} | "
                         f"{fmt(bb[part][c]['rms'])} | {fmt(a and a['rms'])} | "
                         f"{fmt(bb[part][c]['structured'])} | {fmt(a and a['structured'])} |")
        L.append("")
    L += ["## Median structured residual per band over the groups (vertical rows, dB)", "",
          "| band (Hz) | part | before | after |", "|---|---|---|---|"]
    for part in ("fit", "held"):
        mb = median_bands(results, "bands_before", part, "structured")
        ma = median_bands(results, "bands_after", part, "structured")
        for c in mb:
            L.append(f"| {c:g} | {part} | {fmt(mb[c])} | {fmt(ma.get(c))} |")
    if lateral:
        L += ["", "## Lateral rows", "", lateral.get("note", ""), ""]
        meas = {float(c): v for c, v in lateral["measured"]["median_dB_per_m"].items()}
        fw = {t: {float(c): v for c, v in d.items()} for t, d in
              (lateral.get("forward") or {}).items()}
        hdr = ["band (Hz)", "measured median (dB/m)"] + [f"model: {k}" for k in fw]
        L += ["| " + " | ".join(hdr) + " |", "|" + "---|" * len(hdr)]
        for c in sorted(float(k) for k in meas):
            if fw and not any(abs(float(k) - c) < 1e-6 for k in next(iter(fw.values()))):
                continue
            vals = [fmt(v.get(c), 3) for v in fw.values()]
            L.append(f"| {c:g} | {fmt(meas[c])} | " + " | ".join(vals) + " |")
    return "\n".join(L) + "\n"


def _vertical(obj):
    """The vertical group results of a JSON file written by --json (bands as floats)."""
    gs = obj["vertical"] if isinstance(obj, dict) else obj
    for g in gs:
        for key in ("bands_before", "bands_after"):
            if g.get(key):
                g[key] = {p: {float(c): v for c, v in d.items()} for p, d in g[key].items()}
        g["scatter"] = {float(c): v for c, v in g["scatter"].items()}
    return gs


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--model", default="timoshenko-discrete")
    p.add_argument("--groups", default="", help="comma-separated prefixes of groups")
    p.add_argument("--starts", type=int, default=4)
    p.add_argument("--effects", default="", help="comma-separated effects (default: the "
                   "default library, which holds the new effects)")
    p.add_argument("--no-profile", action="store_true", help="keep the base's rail loss "
                   "factor for the candidates (diagnose(profile_final=False)): ~6x cheaper")
    p.add_argument("--lateral", action="store_true", help="also the lateral forward check")
    p.add_argument("--diagnose-lateral", action="store_true", help="diagnose the vertical "
                   "and lateral rows of each group together (no vertical-only run)")
    p.add_argument("--lateral-model", default=LATERAL_MODEL)
    p.add_argument("--seat", default="rigid", choices=("rigid", "per_spring"),
                   help="the base's rail seat (SupportParameters.seat)")
    p.add_argument("--cost", action="store_true", help="with --diagnose-lateral: the CPU "
                   "cost of a lateral row's model (periodic and continuous WFE)")
    p.add_argument("--lateral-out",
                   default=str(ROOT / "benchmarks/results/results_sbb_lateral.md"))
    p.add_argument("--out", default=str(ROOT / "benchmarks/results/results_sbb.md"))
    p.add_argument("--json", default="")
    p.add_argument("--merge", nargs="*", default=[],
                   help="build the table from these JSON files of earlier runs (no vertical "
                        "diagnosis)")
    a = p.parse_args(argv)
    SEAT["seat"] = a.seat
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    table = read_decay_rate_table(TABLE, columns=SBB_NIEDERWANGEN_COLUMNS)
    rows = table.rows()
    want = [s for s in a.groups.split(",") if s]
    cmd = "OPENBLAS_NUM_THREADS=1 python benchmarks/sbb/diagnose_sbb.py " + " ".join(
        sys.argv[1:] if argv is None else argv)
    if a.diagnose_lateral:
        return main_lateral(a, rows, want, cmd.strip())
    results = [g for m in a.merge for g in _vertical(json.loads(Path(m).read_text()))]
    for name, rs in ([] if a.merge else groups(rows).items()):
        if want and not any(name.startswith(w.replace(":", " ")) for w in want):
            continue
        log.info("group %s (%d rows)", name, len(rs))
        results.append(run_group(name, rs, a.model, a.starts,
                                 tuple(a.effects.split(",")) if a.effects else None,
                                 profile=not a.no_profile))
        if a.json:
            Path(a.json).write_text(json.dumps(results, indent=1, default=float))
    lateral = next((o["lateral"] for o in map(lambda m: json.loads(Path(m).read_text()),
                                               a.merge)
                    if isinstance(o, dict) and o.get("lateral")), None)
    if a.lateral:
        lateral = {"measured": lateral_summary(rows), "forward": lateral_forward(),
                   "note": "The diagnosis takes vertical rows only; lateral rows: measured "
                           "median and the lateral decay rate of the site preset's lateral "
                           "track (wfe-periodic) with each new option."}
    Path(a.out).write_text(markdown(results, cmd.strip(), lateral))
    if a.json:
        Path(a.json).write_text(json.dumps({"vertical": results, "lateral": lateral},
                                           indent=1, default=float))


if __name__ == "__main__":
    main()
