"""Coverage of roll_restraint's interval on the blind lateral data
(benchmarks/blind/generators.py, decay_rates('roll_restraint', seed, bands=...): vertical
and lateral EN 15461 decay rates of both rails, the truth's grip k_roll 1e6 N m/rad, its
loss factor 0.3), diagnosed as tests/test_diagnosis_lateral.py's ``blind`` does (effect
roll_restraint alone, n_starts=2, no pairs, final profile on): per seed the grip share and
k_roll with their 95 % intervals, whether they hold the truth, BIC against the base,
whether the candidate was kept, and the grip's variance part by part (noise: the
model-based one; robust: the cluster-robust one; unfitted: the assumed loss factor's
term, roll_restraint.ETA_ROLL_SD; discrepancy: the model-form ensemble's terms, with each
variant's shift of the grip; for a kept model the final analysis's, which leaves the
assumed loss factor's term out) and its envelope over the assumed loss factor's range
(railfem.diagnosis.envelope: the grip at 0.025 and 0.4, the union of the intervals); for
a candidate not kept, whose screening row is what the diagnosis reports, the envelope
is computed on its screening refit as well (``envelope``, not reported by the
diagnosis). JSON lines, then a table.

    export OPENBLAS_NUM_THREADS=1 RAILFEM_CACHE=/tmp/cache
    nice -n 5 python -m benchmarks.bench_roll_coverage OUT.jsonl 0-9
    ... OUT.jsonl 0 --level 0 [--form own] [--bands small]     (clean data)
    ... OUT.jsonl 0-2 --case none          (data without a grip: nothing may be kept)
    ... OUT.jsonl 2 --eta-roll 0.2         (another assumed loss factor of the grip)
    python -m benchmarks.bench_roll_coverage --summed OUT.jsonl   (variants summed)
    python -m benchmarks.bench_roll_coverage --table OUT.jsonl
    python -m benchmarks.bench_roll_coverage --envelope OUT.jsonl (the assumed range)

``--bands``: 'lateral' (generators.LATERAL_BANDS, 100-630 Hz, default) or 'small'
(100-400 Hz, the test's SMALL_BANDS). CPU seconds per run are recorded (the loaded
machine's, cached kernels included)."""
from __future__ import annotations

import json
import sys
import time

import numpy as np

BANDS = {"lateral": (100.0, 630.0), "small": (100.0, 400.0)}
GRIP = "roll_restraint.grip"


class Parts:
    """Wraps railfem.identify.uncertainty.analyse: the grip's variance parts of its last
    call with the grip in the box (the reported analysis)."""

    def __init__(self, uncertainty):
        self.u, self.orig, self.last = uncertainty, uncertainty.analyse, None

    def __call__(self, space, x, J, r, profiles=None, clusters=None, nuisance=None,
                 discrepancy=None):
        out = self.orig(space, x, J, r, profiles=profiles, clusters=clusters,
                        nuisance=nuisance, discrepancy=discrepancy)
        names = list(space.names)
        if GRIP in names:
            i = names.index(GRIP)
            _, C_diag, s2, dof, *_ = self.u.covariance(J, r)
            parts = {"noise": float(C_diag[i]), "s2": float(s2), "dof": int(dof)}
            if clusters is not None:
                parts["robust"] = float(self.u.robust_covariance(J, r, clusters)[0][i, i])
            if nuisance is not None and np.size(nuisance):  # the assumed eta_roll's share
                parts["unfitted"] = float(self.u.nuisance_covariance(
                    J, np.asarray(nuisance, dtype=float))[i, i])
            parts["t"] = float(out["t_quantile"])
            if discrepancy is not None and np.size(discrepancy):
                N = np.asarray(discrepancy, dtype=float)
                parts["discrepancy"] = float(self.u.nuisance_covariance(J, N)[i, i])
                # one column per variant, scaled by sqrt(1/n) and t(n)/t(dof)
                # (railfem.diagnosis.intervals.discrepancy_terms): its own share
                parts["n_columns"] = int(N.shape[1])
                parts["per_variant"] = [float(np.sqrt(self.u.nuisance_covariance(
                    J, N[:, [k]])[i, i])) for k in range(N.shape[1])]
            parts["sd"] = out["parameters"][i]["std_vector"]
            self.last = parts
        return out


def ends(outcome) -> dict:
    """The grip's envelope (railfem.diagnosis.envelope) of a refitted roll_restraint
    model: its interval at the assumed loss factor alone, the grip refitted at each end,
    and the union (the reported interval)."""
    par = {p["name"]: p for p in outcome.parameters()}
    grip = par[GRIP]
    return {"grip_ci95_centre": grip.get("ci95_centre"), "grip_ci95": grip["ci95"],
            "k_roll_ci95": par["roll_restraint.k_roll"]["ci95"],
            "ends": [{"eta_roll": e["value"], "cost": e["cost"],
                      "grip": next(p["value"] for p in e["parameters"]
                                   if p["name"] == GRIP)} for e in outcome.envelope]}


def run(seed: int, bands: str, level: float, form: str, case: str = "roll_restraint",
        eta_roll: float | None = None) -> dict:
    from dataclasses import replace

    from benchmarks.blind import generators as g
    from railfem.diagnosis import diagnose, effects, loop
    from railfem.diagnosis.envelope import assumed_envelope
    from railfem.identify import uncertainty

    parts = Parts(uncertainty)
    uncertainty.analyse = parts
    screened, screen_one = {}, loop.screen_one

    def keep(s, e):  # the screening's outcomes (the diagnosis keeps their rows only)
        o, row = screen_one(s, e)
        screened[o.name] = o
        return o, row

    loop.screen_one = keep
    eff = effects.REGISTRY["roll_restraint"]
    if eta_roll is not None:  # another assumed loss factor of the grip
        effects.REGISTRY["roll_restraint"] = replace(
            eff, assumed=tuple(replace(a, value=eta_roll) for a in eff.assumed))
    try:
        t0 = time.process_time()
        rows = g.decay_rates(case, seed, bands=BANDS[bands], cache=True,
                             level=level, form=form)
        d = diagnose(rows, model=g.LATERAL_MODEL, spacing=0.6, effects=("roll_restraint",),
                     data_options={"directions": "zy"}, n_starts=2, pairs=False,
                     profile_final=True, cache=True)
        cpu = time.process_time() - t0
    finally:
        uncertainty.analyse = parts.orig
        effects.REGISTRY["roll_restraint"] = eff
        loop.screen_one = screen_one
    best = min(d.candidates, key=lambda row: row["bic"])
    fitted = d.chosen.parameters() if d.chosen is not None else best["parameters"]
    par = {p["name"].split(".")[-1]: p for p in fitted}
    truth = g.LATERAL_CASES[case].get("k_roll")
    lo, hi = par["k_roll"]["ci95"]
    return {"seed": seed, "bands": bands, "level": level, "form": form, "case": case,
            "eta_roll": eta_roll,
            "chosen": None if d.chosen is None else d.chosen.name,
            "cpu_s": round(cpu, 1), "best": best["name"], "delta_bic": best["delta_bic"],
            "kept": d.chosen is not None, "grip": par["grip"]["value"],
            "grip_ci95": par["grip"]["ci95"], "k_roll": par["k_roll"]["value"],
            "k_roll_ci95": [lo, hi],
            "inside": None if truth is None else bool(lo <= truth <= hi),
            "parts": parts.last,
            # the envelope of the chosen model's final intervals, or (not kept: the
            # screening row is reported) what it would be on the screening's refit
            "envelope": (ends(d.chosen) if d.chosen is not None else
                         ends(assumed_envelope(screened["roll_restraint"]))
                         if "roll_restraint" in screened else None)}


def seeds(text: str) -> list[int]:
    if "-" in text:
        a, b = map(int, text.split("-"))
        return list(range(a, b + 1))
    return [int(s) for s in text.split(",")]


def table(path: str) -> str:
    rows = [json.loads(line) for line in open(path) if line.strip()]
    out = ["| seed | bands | noise | form | grip | grip 95 % | k_roll 95 % (N m/rad) | "
           "inside | dBIC | kept | SD: noise / disc. / assumed | CPU s |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        p = r.get("parts") or {}
        sd = (f"{np.sqrt(max(p.get('noise', 0), p.get('robust', 0))):.3f} / "
              f"{np.sqrt(p.get('discrepancy', 0)):.3f} / "
              f"{np.sqrt(p.get('unfitted', 0)):.3f}")
        g0, g1 = r["grip_ci95"]
        k0, k1 = r["k_roll_ci95"]
        out.append(f"| {r['seed']} | {r['bands']} | {r['level']:g} | {r['form']} | "
                   f"{r['grip']:.3f} | {g0:.3f}-{g1:.3f} | {k0:.3g}-{k1:.3g} | "
                   f"{inside(r)} | {r['delta_bic']:.1f} | "
                   f"{'yes' if r['kept'] else 'no'} | {sd} | {r['cpu_s']:.0f} |")
    n = [r for r in rows if r["level"] > 0 and r.get("case", "roll_restraint") != "none"]
    if n:
        out.append(f"\nnoisy runs: truth inside {sum(r['inside'] for r in n)}/{len(n)}, "
                   f"mean grip {np.mean([r['grip'] for r in n]):.3f} (truth 0.5)")
    return "\n".join(out)


def inside(row) -> str:
    """'yes' / '**out**' (the truth in k_roll's interval), or, on data without a grip
    (case 'none'), what the diagnosis kept ('none': no claim)."""
    if row.get("case", "roll_restraint") == "none":
        return f"none: kept {row.get('chosen') or 'nothing'}"
    return "yes" if row["inside"] else "**out**"


def summed(path: str, n_aspects: int = 3) -> str:
    """The grip's interval if the variants' shift variances were summed with the normal
    quantile (railfem.diagnosis.intervals.discrepancy_terms: not taken) beside today's,
    from each run's variance parts: today's discrepancy share is scaled by
    t(0.975, n_aspects) / t(0.975, dof); summed, by sqrt(n_aspects)."""
    from scipy import stats

    out = ["| seed | grip | half-width today | lower end today | half-width summed | "
           "lower end summed | ratio |", "|---|---|---|---|---|---|---|"]
    for r in (json.loads(line) for line in open(path) if line.strip()):
        p = r.get("parts") or {}
        if r.get("case", "roll_restraint") == "none" or "discrepancy" not in p:
            continue
        k = stats.t.ppf(0.975, n_aspects) / stats.t.ppf(0.975, p["dof"])
        noise = max(p["noise"], p.get("robust", 0.0)) + p.get("unfitted", 0.0)
        now = p["t"] * np.sqrt(noise + p["discrepancy"])
        alt = p["t"] * np.sqrt(noise + p["discrepancy"] * n_aspects / k ** 2)
        out.append(f"| {r['seed']} | {r['grip']:.3f} | {now:.3f} | {r['grip'] - now:.3f} | "
                   f"{alt:.3f} | {r['grip'] - alt:.3f} | {alt / now:.3f} |")
    return "\n".join(out)


def envelope_table(path: str) -> str:
    """Per run: the grip reported, its interval at the assumed loss factor alone
    (``ci95_centre``), the grip refitted at its range's ends and the envelope; for a
    candidate not kept (the screening row is what is reported) the envelope computed on
    the screening's refit, and whether k_roll's envelope holds the truth."""
    out = ["| seed | noise | case | kept | grip | grip 95 % at 0.1 | grip at 0.025 / 0.4 | "
           "grip envelope | k_roll envelope (N m/rad) | reported inside | envelope inside |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in (json.loads(line) for line in open(path) if line.strip()):
        e = r.get("envelope")
        if not e:
            continue
        c0, c1 = e["grip_ci95_centre"] or [np.nan, np.nan]
        g0, g1 = e["grip_ci95"]
        k0, k1 = e["k_roll_ci95"]
        ends_ = " / ".join(f"{x['grip']:.3f}" for x in e["ends"])
        if r.get("case", "roll_restraint") == "none":
            env_in = "-"
        else:
            env_in = "yes" if k0 <= 1e6 <= k1 else "**out**"
        out.append(f"| {r['seed']} | {r['level']:g} | {r.get('case', 'roll_restraint')} | "
                   f"{'yes' if r['kept'] else 'no'} | {r['grip']:.3f} | {c0:.3f}-{c1:.3f} | "
                   f"{ends_} | {g0:.3f}-{g1:.3f} | {k0:.3g}-{k1:.3g} | {inside(r)} | "
                   f"{env_in} |")
    return "\n".join(out)


def main(argv: list[str]) -> None:
    if argv[0] in ("--table", "--summed", "--envelope"):
        print({"--table": table, "--summed": summed,
               "--envelope": envelope_table}[argv[0]](argv[1]))
        return
    opts = dict(zip(argv[2::2], argv[3::2]))
    for s in seeds(argv[1]):
        row = run(s, opts.get("--bands", "lateral"), float(opts.get("--level", 0.05)),
                  opts.get("--form", "cross"), opts.get("--case", "roll_restraint"),
                  float(opts["--eta-roll"]) if "--eta-roll" in opts else None)
        with open(argv[0], "a") as fh:
            fh.write(json.dumps(row) + "\n")
        print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
