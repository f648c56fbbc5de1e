"""The gates a candidate effect must pass to be kept (railfem.diagnosis.loop, step 4):
*plausible* (its parameters inside their bounds and identifiable), *better on held-out data*
by more than noise plus the model-form discrepancy explain, and *supported* by BIC."""
from __future__ import annotations

import math

import numpy as np
from scipy import stats

from railfem.diagnosis import effects as library
from railfem.diagnosis import residual as resid
from railfem.diagnosis.problem import table
from railfem.diagnosis.refit import Outcome
from railfem.identify.problem import table_scale
from railfem.standards import iec61260

ALPHA = 0.01
MIN_GAIN = 0.10
DELTA_BIC = 10.0
BOUND_MARGIN = 0.01

def held_gate(ref: Outcome, cand: Outcome, pred_ref=None, pred_c=None) -> dict:
    """Held-out comparison of cand against ref (same scales): MSE, reduction, paired t."""
    pr = ref.problem.predict(ref.x) if pred_ref is None else pred_ref
    pc = cand.problem.predict(cand.x) if pred_c is None else pred_c
    scale = ref.problem.scale
    d, a_all, b_all = [], [], []
    for r in ref.problem.records:
        t = r.held
        if t is None:
            continue
        ta, tb = table(t, pr[r.name]), table(t, pc[r.name])
        for q in ta:
            a = np.asarray(ta[q]) / table_scale(scale, t, q, np.shape(ta[q]))
            b = np.asarray(tb[q]) / table_scale(scale, t, q, np.shape(tb[q]))
            if q == "tdr":
                cells = [(a[k, o], b[k, o]) for k in range(a.shape[0])
                         for o in range(a.shape[1])]
            else:
                a3 = a.reshape(a.shape[0], a.shape[1], -1)
                b3 = b.reshape(b.shape[0], b.shape[1], -1)
                cells = []
                band = iec61260.band_index(t.frequency, t.bands)
                for kb in range(len(t.bands.nominal)):
                    m = band == kb
                    for o in range(a3.shape[1]):
                        for j in range(a3.shape[2]):
                            cells.append((a3[m, o, j], b3[m, o, j]))
            for x, y in cells:
                x, y = np.atleast_1d(x), np.atleast_1d(y)
                ok = np.isfinite(x) & np.isfinite(y)
                if ok.any():
                    d.append(np.mean(x[ok] ** 2) - np.mean(y[ok] ** 2))
                    a_all.append(x[ok])
                    b_all.append(y[ok])
    if not d:
        return {"blocks": 0, "pass": False, "reduction": None}
    d = np.array(d)
    mse_ref = float(np.mean(np.concatenate(a_all) ** 2))
    mse_c = float(np.mean(np.concatenate(b_all) ** 2))
    sd = float(np.std(d, ddof=1)) if len(d) > 1 else float("inf")
    tval = float(np.mean(d) / (sd / math.sqrt(len(d)))) if sd > 0 else (
        float("inf") if np.mean(d) > 0 else 0.0)
    p_t = float(stats.t.sf(tval, len(d) - 1)) if len(d) > 1 else 1.0
    p_w = (float(stats.wilcoxon(d, alternative="greater").pvalue)
           if len(d) > 1 and np.any(d != 0) else 1.0)
    p = min(1.0, 2 * min(p_t, p_w))  # either test, Bonferroni: still at most ALPHA
    red = 1 - mse_c / mse_ref if mse_ref > 0 else 0.0
    # judged against noise plus discrepancy: the change must exceed the model-form one
    disc = resid.beyond_discrepancy(ref.problem.model.data, pr, pc, scale, alpha=ALPHA, ref=ref)
    return {"blocks": int(len(d)), "mse_ref": mse_ref, "mse": mse_c, "reduction": red,
            "t": tval, "p_t": p_t, "p_wilcoxon": p_w, "p": p, "discrepancy": disc,
            "pass": bool(p < ALPHA and red >= MIN_GAIN and (disc is None or disc["pass"]))}


def plausibility(o: Outcome) -> tuple[bool, str]:
    box = o.problem.box
    lo, hi = box.lower, box.upper
    for i, p in enumerate(box.parameters):
        if "." not in p.name:
            continue
        margin = BOUND_MARGIN * (hi[i] - lo[i])
        if o.x[i] - lo[i] < margin or hi[i] - o.x[i] < margin:
            return False, f"{p.name} = {p.decode(o.x[i]):.4g} {p.unit} is at a bound"
        ident = o.analysis["parameters"][i]["identifiable"]
        if ident == "no":
            return False, f"{p.name} is not identifiable: {o.analysis['parameters'][i]['reason']}"
    for (e, n), prof in o.grid_profiles.items():
        eff = library.get(e)
        par = {p.name: p for p in eff.parameters}.get(n)
        if par is not None and not par.lower < prof["value"] < par.upper:
            return False, f"{e}.{n} = {prof['value']:.4g} is at a bound"
    return True, ""


def final_gate(o: Outcome) -> tuple[bool, str]:
    """The screening's plausibility gate on a final refit (its rail loss factor profiled,
    the intervals redone with it free): every effect parameter inside its bounds and not
    unidentifiable. (True, '') or (False, why)."""
    return plausibility(o)


def passes(row: dict, ref_bic: float) -> bool:
    """A screening row passes every gate: plausible, better on held-out data, supported by
    BIC against the reference's ref_bic."""
    return bool(row["plausible"] and row["held_out"].get("pass")
                and row["bic"] < ref_bic - DELTA_BIC)
