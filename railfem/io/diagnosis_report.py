"""The diagnosis report, report.md: the markdown of a diagnosis summary (the dict
railfem.jobs.diagnose.summary makes of a railfem.diagnosis.Diagnosis), and the dominant
bands the summary names."""
from __future__ import annotations

import json

import numpy as np

TOP_BANDS = 3  # dominant bands named in the summary


def dominant_bands(s: dict, n: int = TOP_BANDS) -> list[dict]:
    """The ``n`` bands with the largest error (RMS dB) of the remaining residual (after
    the chosen effect, else the base's), each band's largest over quantities and the
    fitted and held-out parts."""
    rows = s["error_after"] or s["error_before"]
    worst: dict = {}
    for r in rows:
        if np.isfinite(r["rms_db"]) and r["rms_db"] > worst.get(r["band_hz"], {}).get(
                "rms_db", -np.inf):
            worst[r["band_hz"]] = r
    return sorted(worst.values(), key=lambda r: -r["rms_db"])[:n]


def band_words(r: dict) -> str:
    return (f"the {r['band_hz']:g} Hz band of {r['quantity']} at {r['rms_db']:.1f} dB RMS "
            f"({'held-out' if r['part'] == 'held' else 'fitted'} part)")


def _fmt(v, unit=""):
    if v is None:
        return "-"
    if isinstance(v, str):
        return v
    return f"{v:.4g}{(' ' + unit) if unit and unit != '-' else ''}"


def interval(p: dict, key: str = "ci95") -> str:
    """'[lo, hi]' of a parameter; an end of a grid parameter's interval that is the
    grid's edge (its profile still below the threshold there) is open: '≥ 0.24 (grid
    edge)'; an interval open at the top (inf) is one-sided: 'at least 2e+06'."""
    ci = p.get(key) or [None, None]
    reason = p.get("reason") or ""
    lo = _fmt(ci[0])
    hi = _fmt(ci[1])
    if "open on the low" in reason:
        lo = f"≤ {lo} (grid edge)"
    if "open on the" in reason and "high side" in reason:
        hi = f"≥ {hi} (grid edge)"
    if ci[1] == float("inf") and ci[0] is not None and ci[0] > 0:  # one-sided (k_roll)
        return f"at least {lo}"
    return f"[{lo}, {hi}]"


def markdown(s: dict, figs: list[str], title: str) -> str:
    L = [f"# Diagnosis {title}".rstrip(), "", f"**{s['statement']}**", ""]
    if s["verdict"] != "noise":
        L += ["Dominant bands of the remaining residual: "
              + "; ".join(band_words(r) for r in dominant_bands(s)) + ".", ""]
    L += ["What to try next:", ""] + [f"* {n}" for n in s["next_steps"]] + [""]
    L += [
         f"Model: `{s['model']}`. Data: {s['data']['description']}.", "",
         f"Base model: {s['base_model']}.", ""]
    b = s["base"]
    L += ["## Calibrated base model", "", "| parameter | value | 95 % interval | identifiable |",
          "|---|---|---|---|"]
    for p in b["parameters"]:
        ci = p.get("ci95") or [None, None]
        L.append(f"| {p['name']} | {_fmt(p['value'], p.get('unit', ''))} | "
                 f"[{_fmt(ci[0])}, {_fmt(ci[1])}] | {p.get('identifiable', '-')} |")
    st = b["structure_test"]
    L += ["", f"Residual RMS (dB), fitted: {json.dumps(_round(b['residual_rms_db']['fit']))}; "
          f"held out: {json.dumps(_round(b['residual_rms_db']['held']))}.", "",
          f"Noise or structure: **{st['verdict']}** (Ljung-Box over frequency p = "
          f"{st['ljung_box_frequency']['p']:.3g}, over position p = "
          f"{st['ljung_box_position']['p']:.3g}"
          + (f", against the repeat scatter p = {st['scatter']['p']:.3g}" if "scatter" in st
             else "")
          + f"; white part {st['sigma_white_db']:.2f} dB, structured part "
          f"{st['structured_rms_db']:.2f} dB).", ""]
    L += ["## Candidates (screening values)", "",
          "Values of the screening refit of each candidate (the chosen one is refitted "
          "once more: its final values are under 'Chosen'). Held-out error reduction: how "
          "much lower the candidate's held-out error is than its reference's (negative: "
          "higher). Ranked: kept candidates first, then by BIC. Gates "
          + " ".join(s["rules"]["text"].split()), "",
          "| rank | candidate | kept | dAICc | dBIC | held-out error reduction | p | "
          "plausible | parameters |", "|---|---|---|---|---|---|---|---|---|"]
    for c in s["candidates"]:
        h = c["held_out"]
        th = "; ".join(f"{k}={_fmt(v)}" for e in c["theta"].values() for k, v in e.items())
        L.append(f"| {c['rank']} | {c['name']} | {'yes' if c['kept'] else 'no'} | "
                 f"{c['delta_aicc']:.1f} | {c['delta_bic']:.1f} | "
                 f"{_percent(h.get('reduction'))} | {_fmt(h.get('p'))} | "
                 f"{'yes' if c['plausible'] else c['implausible_why']} | {th} |")
    if s["skipped"]:
        L += ["", "Not tried: " + "; ".join(f"{k} ({v})" for k, v in s["skipped"].items())
              + "."]
    late = [c for c in s["candidates"] if c.get("final_rejected")]
    if late:
        L += ["", "Passed the screening gates but not after the final refit: "
              + "; ".join(f"{c['name']} ({c['final_rejected']})" for c in late) + "."]
    if s["failures"]:
        L += ["", "Failed (not judged; the run went on without them): "
              + "; ".join(f"{f['candidate']} at {f['stage']} ({f['error']})"
                          for f in s["failures"]) + "."]
    if s["chosen"]:
        c = s["chosen"]
        L += ["", f"## Chosen: {c['name']} (final refit values)", "",
              "| parameter | value | 95 % interval | joint 95 % interval | identifiable |",
              "|---|---|---|---|---|"]
        for p in c["parameters"]:
            L.append(f"| {p['name']} | {_fmt(p['value'], p.get('unit', ''))} | "
                     f"{interval(p)} | "
                     + (interval(p, "ci95_joint") if p.get("ci95_joint") else "–")
                     + f" | {p.get('identifiable', '-')} |")
        L += ["", "The joint interval holds all the effect's parameters at once with 95 % "
              "confidence (Bonferroni over them); the 95 % interval is each one's own."]
        sup = [p for p in c["parameters"] if "support_value" in p]
        if sup:
            L += ["", "The supports' stiffness (factor x fitted mean; its intervals from the "
                  "variance of the product, tighter than the factor's: a shift of the mean "
                  "moves the factors the other way):", "",
                  "| parameter | stiffness | 95 % interval | joint 95 % interval |",
                  "|---|---|---|---|"]
            for p in sup:
                ci, cj = p["support_ci95"], p["support_ci95_joint"]
                L.append(f"| {p['name']} | {_fmt(p['support_value'], 'N/m')} | "
                         f"[{_fmt(ci[0])}, {_fmt(ci[1])}] | [{_fmt(cj[0])}, {_fmt(cj[1])}] |")
        if c.get("unfitted_terms"):
            L += ["", f"The intervals include what the scatter of {c['unfitted_terms']} "
                  "unfitted terms (the effect's supports outside its window at the prior's "
                  "SD; held fixed in the fit) can do to the estimates."]
        spans = sorted({p["assumed_range"] for p in c["parameters"] if p.get("assumed_range")})
        if spans:
            L += ["", "An assumed value the data cannot fix is carried by the "
                  "envelope, not a tangent: " + "; ".join(spans) + " (the intervals at the "
                  "assumed value itself: 'ci95_centre' in diagnosis.json)."]
        h = c["held_out"]
        L += ["", f"Held-out error (mean squared scaled residual) {h['mse_ref']:.3g} -> "
              f"{h['mse']:.3g} ({100 * h['reduction']:.0f} % lower, paired t = {h['t']:.2f}, "
              f"p = {h['p']:.2g} (t-test or Wilcoxon, x2), {h['blocks']} blocks); "
              "held-out RMS residual (dB), base -> with the effect: "
              + held_db(s["base"]["residual_rms_db"]["held"], c["residual_rms_db"]["held"])
              + ".", "",
              "Residual RMS (dB) after, fitted: "
              f"{json.dumps(_round(c['residual_rms_db']['fit']))}; "
              f"held out: {json.dumps(_round(c['residual_rms_db']['held']))}. Structure test "
              f"after: **{c['structure_test']['verdict']}** (structured part "
              f"{c['structure_test']['structured_rms_db']:.2f} dB)."]
    L += ["", "## Error per quantity and band (RMS dB)", "",
          "| part | quantity | band (Hz) | before | after |", "|---|---|---|---|---|"]
    after = {(r["part"], r["quantity"], r["band_hz"]): r["rms_db"]
             for r in (s["error_after"] or [])}
    for r in s["error_before"]:
        a = after.get((r["part"], r["quantity"], r["band_hz"]))
        L.append(f"| {r['part']} | {r['quantity']} | {r['band_hz']:g} | {r['rms_db']:.2f} | "
                 f"{'-' if a is None else f'{a:.2f}'} |")
    L += ["", "## Figures", ""] + [f"![{f}]({f})" for f in figs] + [""]
    return "\n".join(L)


def _round(d):
    return {k: (None if v is None else round(v, 3)) for k, v in d.items()}


def _percent(share) -> str:
    """0.53 -> '53 %' (no '-0 %')."""
    return f"{100 * (share or 0.0) + 0.0:.0f} %".replace("-0 %", "0 %")


def held_db(before: dict, after: dict) -> str:
    """'point 3.12 -> 2.50, tdr 1.80 -> 1.20' (RMS dB per quantity)."""
    return ", ".join(f"{q} {v:.2f} -> {after[q]:.2f}" for q, v in before.items()
                     if v is not None and after.get(q) is not None) or "none held out"
