"""The blind study: for a case of benchmarks/blind/generators.CASES and a seed, generate the
data, diagnose them without telling the diagnosis the case, and score the outcome.

    python -m benchmarks.blind.study OUT.jsonl CASE[,CASE] SEEDS [all] [--cross] [--model M]
                                     [--effects E1,E2,...]              (SEEDS e.g. 0-9)
    python -m benchmarks.blind.study --table OUT.jsonl                   (the markdown table)

(``all``: screen every effect of the library, random_support too, which the default
search leaves out for its cost; the case random_support is run that way unless
``--effects`` names its library. ``--effects``: the library to screen, by name (the case's
effect and its competitors); ``--model``: the track model of the generator
and the estimator (default
generators.MODEL); ``--cross``: the data made by the cross-model generator, form='cross' of
benchmarks/blind/generators.py, which differs from the estimator in model form; a clean
case then counts as right when the verdict is 'consistent' or 'noise'.)

appends one JSON line per run to OUT.jsonl; ``table(rows)`` makes the per-case summary
(rank-1 rate, interval coverage, held-out error reduction, claims)."""
from __future__ import annotations

import json
import sys
import time

import numpy as np

from benchmarks.blind import generators as g

OUTSIDE = ("rail_stiffness",)  # effects the library does not have
ALL_EFFECTS = ("random_support",)  # cases only the whole library (effects='all') can find


def run_case(case: str, seed: int, *, model: str = g.MODEL, f=None, effects=None,
             n_starts: int = 2, form: str = "own") -> dict:
    from railfem.diagnosis import diagnose

    t = time.perf_counter()
    effects = "all" if case in ALL_EFFECTS and effects is None else effects
    d = diagnose(g.dataset(case, seed, f=f, model=model, form=form), model=model,
                 n_starts=n_starts, effects=effects)
    truth = g.truth(case, seed)
    cov = {}
    if d.chosen is not None:
        ps = d.chosen.parameters()
        for p in ps:
            n = p["name"].split(".")[-1]
            if n in truth and p.get("ci95") and p["group"] == "effect":
                if "support_value" in p:
                    # a support factor multiplies the fitted mean stiffness: compare the
                    # support's stiffness (its own intervals) over the generator's mean
                    s = g.TRUTH[n.split("_")[0]]
                    v, (lo, hi) = p["support_value"] / s, (x / s for x in p["support_ci95"])
                    jl, jh = (x / s for x in p["support_ci95_joint"])
                else:
                    v, (lo, hi) = p["value"], p["ci95"]
                    jl, jh = p.get("ci95_joint", p["ci95"])
                cov[n] = {"value": v, "ci95": [lo, hi], "truth": truth[n],
                          "inside": bool(lo <= truth[n] <= hi), "ci95_joint": [jl, jh],
                          "inside_joint": bool(jl <= truth[n] <= jh)}
    red = d.chosen_row["final_held_out"]["reduction"] if d.chosen_row else None
    return {"case": case, "seed": seed, "model": model,
            "rank1": d.candidates[0]["name"] if d.candidates else None,
            "kept": [r["name"] for r in d.candidates if r["kept"]],
            "verdict": d.verdict, "chosen": d.chosen.name if d.chosen else None,
            "claim": d.chosen.name if d.verdict == "explained" else None,
            "coverage": cov, "held_out_reduction": red,
            "structured_before_db": d.structure_before["structured_rms_db"],
            "structured_after_db": (d.structure_after or {}).get("structured_rms_db"),
            "effects": effects if isinstance(effects, str) or effects is None else
            list(effects), "form": form, "base": _base_coverage(d),
            "seconds": time.perf_counter() - t}


def _base_coverage(d) -> dict:
    """The base parameters (kp, eta_p, kb, eta_b, eta_r) of the final model (the chosen
    one; the base when none is chosen: the base of an effect case has absorbed the effect)
    against the generator's truth: value, 95 % interval, inside, half-width (decades)."""
    out = {}
    for p in (d.chosen or d.base).parameters():
        if p["name"] in g.TRUTH and p.get("ci95") and p.get("group", "base") == "base":
            lo, hi = p["ci95"]
            out[p["name"]] = {"value": p["value"], "ci95": [lo, hi],
                              "inside": bool(lo <= g.TRUTH[p["name"]] <= hi),
                              "half_width": float(np.log10(hi / lo) / 2), "model":
                              d.chosen.name if d.chosen is not None else "base"}
    return out


def covered(cov: dict) -> bool:
    """The run's parameters are recovered: every one inside its joint 95 % interval (all of
    the effect's parameters at once; rows from before the joint intervals: the marginal
    rule then in use, every one inside, a random effect's at least 90 %)."""
    if all("inside_joint" in c for c in cov.values()):
        return all(c["inside_joint"] for c in cov.values())
    inside = [c["inside"] for c in cov.values()]
    return all(inside) if len(inside) <= 4 else sum(inside) >= 0.9 * len(inside)


def marginal(rows: list[dict]) -> tuple[int, int]:
    """(inside, total) of the parameters inside their own (marginal) 95 % intervals."""
    cs = [c for r in rows for c in (r["coverage"] or {}).values()]
    return sum(c["inside"] for c in cs), len(cs)


def table(rows: list[dict]) -> list[dict]:
    """Per case: runs, rank-1 rate, claims, coverage of the chosen effect's parameters
    (when the right effect was chosen), median held-out error reduction."""
    out = []
    for case in dict.fromkeys(r["case"] for r in rows):
        rs = [r for r in rows if r["case"] == case]
        right = [r for r in rs if r["chosen"] == case]
        inside = [covered(r["coverage"]) for r in right if r["coverage"]]
        reds = [r["held_out_reduction"] for r in right if r["held_out_reduction"] is not None]
        out.append({"case": case, "runs": len(rs),
                    "rank1": sum(r["rank1"] == case for r in rs),
                    "explained": sum(r["claim"] == case for r in rs),
                    "false_claims": sum(r["claim"] is not None and r["claim"] != case
                                        for r in rs),
                    "coverage": f"{sum(inside)}/{len(inside)}",
                    "marginal": "{}/{}".format(*marginal(right)),
                    "held_out_reduction_median": float(np.median(reds)) if reds else None,
                    "held_out_reduction_min": float(min(reds)) if reds else None,
                    "seconds_median": float(np.median([r["seconds"] for r in rs]))})
    return out


def base_table(rows: list[dict]) -> str:
    """Per base parameter: runs with the truth inside the 95 % interval, and the median
    half-width of the interval (decades) over the rows that record it."""
    out = ["| parameter | inside 95 % | median half-width (decades) |", "|---|---|---|"]
    names = dict.fromkeys(n for r in rows for n in (r.get("base") or {}))
    for n in names:
        cs = [r["base"][n] for r in rows if n in (r.get("base") or {})]
        hw = float(np.median([c["half_width"] for c in cs]))
        out.append(f"| {n} | {sum(c['inside'] for c in cs)}/{len(cs)} | {hw:.3f} |")
    return "\n".join(out)


def latest(rows: list[dict]) -> list[dict]:
    """One row per (case, seed, effects): the last one not marked ``superseded`` (a re-run
    replaces a row; a row kept for the record of a replaced design is marked)."""
    last = {}
    for r in rows:
        if r.get("superseded"):
            continue
        last[(r["case"], r["seed"], r.get("effects") or "", r.get("form", "own"))] = r
    return list(last.values())


def markdown(rows: list[dict]) -> str:
    """The study table (latest rows; the null and outside cases once per effect set)."""
    groups: dict = {}
    for r in latest(rows):
        tag = " (all effects)" if r.get("effects") == "all" and r["case"] not in ALL_EFFECTS \
            else ""
        tag += " (cross-model data)" if r.get("form") == "cross" else ""
        groups.setdefault(r["case"] + tag, []).append(r)
    out = ["| case | seeds | ranked first | explained (right) | partly | false claims | "
           "coverage (joint) | parameters inside 95 % | held-out reduction median (min) | "
           "s median |", "|---|---|---|---|---|---|---|---|---|---|"]
    for key, rs in groups.items():
        case = rs[0]["case"]
        t = table(rs)[0]
        partly = sum(r["verdict"] == "partly explained" and r["chosen"] == case for r in rs)
        med, mn = t["held_out_reduction_median"], t["held_out_reduction_min"]
        red = f"{100 * med:.0f} % ({100 * mn:.0f} %)" if med is not None else "–"
        rank = "–" if case in ("none",) + OUTSIDE else f"{t['rank1']}/{len(rs)}"
        out.append(f"| {key} | {len(rs)} | {rank} | {t['explained']}/{len(rs)} | {partly} | "
                   f"{t['false_claims']} | {t['coverage']} | {t['marginal']} | {red} | "
                   f"{t['seconds_median']:.0f} |")
    return "\n".join(out)


def _seeds(text: str):
    if "-" in text:
        a, b = text.split("-")
        return range(int(a), int(b) + 1)
    return [int(s) for s in text.split(",")]


if __name__ == "__main__":
    import logging

    if sys.argv[1] == "--table":  # python -m benchmarks.blind.study --table RESULTS.jsonl
        with open(sys.argv[2], encoding="utf-8") as fh:
            rows = [json.loads(line) for line in fh]
        print(markdown(rows))
        if any(r.get("base") for r in rows):
            print()
            print(base_table(latest(rows)))
        sys.exit(0)

    logging.basicConfig(level=logging.WARNING)
    path, cases, seeds = sys.argv[1], sys.argv[2].split(","), _seeds(sys.argv[3])
    form = "cross" if "--cross" in sys.argv else "own"
    model = sys.argv[sys.argv.index("--model") + 1] if "--model" in sys.argv else g.MODEL
    named = sys.argv[sys.argv.index("--effects") + 1] if "--effects" in sys.argv else None
    rest = [a for a in sys.argv[4:] if a not in ("--cross", "--model", model, "--effects",
                                                 named)]
    which = tuple(named.split(",")) if named else rest[0] if rest else None
    for case in cases:
        for seed in seeds:
            row = run_case(case, seed, model=model, effects=which, form=form)
            with open(path, "a", encoding="utf-8") as fh:
                fh.write(json.dumps(row) + "\n")
            print(json.dumps({k: row[k] for k in ("case", "seed", "rank1", "verdict",
                                                  "chosen", "held_out_reduction",
                                                  "seconds")}), flush=True)
