"""The sleeper's loss factor and the base's rail loss factor on reduced cross-model data:
the competing support effects (rail_damper, sleeper_flexibility, two_rail) diagnosed on
rail_damper, sleeper_flexibility and clean data (benchmarks/blind/generators.py,
form='cross'), reduced as the fast forms of tests/test_diagnosis_cross_support.py (every
second ninth-octave line to 2.5 kHz, every second or third position, one start, no
pairs). One JSON line per run: every candidate's dBIC and gates, the chosen effect, its
sleeper parameters and held-out gain, the base's eta_r and its interval, CPU seconds.

    OPENBLAS_NUM_THREADS=1 nice -n 5 python -m benchmarks.bench_sleeper_damping OUT.jsonl \
        rail_damper,sleeper_flexibility,none 0-1 [LABEL]
"""
from __future__ import annotations

import json
import sys
import time

from benchmarks.blind import generators as g

COMPETING = ("rail_damper", "sleeper_flexibility", "two_rail")
F = g.frequencies(high=2500.0)[::2]  # 27 lines
EVERY = {"sleeper_flexibility": 2}  # the others: every third position


def run(case: str, seed: int) -> dict:
    from railfem.diagnosis import diagnose

    c0, t0 = time.process_time(), time.perf_counter()
    data = g.thinned(g.dataset(case, seed, f=F, model="wfe-discrete", form="cross"),
                     EVERY.get(case, 3))
    d = diagnose(data, model="wfe-discrete", effects=COMPETING, pairs=False, n_starts=1)
    rows = [{"name": r["name"], "delta_bic": round(r["delta_bic"], 1), "kept": r["kept"],
             "plausible": r["plausible"], "why": r["implausible_why"],
             "held_out": round(r["held_out"].get("reduction") or 0.0, 3),
             "held_pass": bool(r["held_out"].get("pass")), "theta": r["theta"]}
            for r in d.candidates]
    base = {p["name"]: {"value": p["value"], "ci95": p.get("ci95")}
            for p in d.base.parameters() if p["group"] == "base"}
    out = {"case": case, "seed": seed, "verdict": d.verdict,
           "chosen": d.chosen.name if d.chosen else None, "rows": rows, "base": base,
           "failures": d.failures, "cpu_s": time.process_time() - c0,
           "wall_s": time.perf_counter() - t0, "seconds": d.seconds}
    if d.chosen is not None:
        out["chosen_theta"] = d.chosen.theta()
        out["final_held_out"] = d.chosen_row["final_held_out"]["reduction"]
        out["chosen_eta_r"] = d.chosen.eta_r
    return out


def main(argv) -> None:
    path, cases, seeds = argv[0], argv[1].split(","), argv[2]
    label = argv[3] if len(argv) > 3 else ""
    lo, _, hi = seeds.partition("-")
    for case in cases:
        for seed in range(int(lo), int(hi or lo) + 1):
            row = dict(run(case, seed), label=label)
            with open(path, "a") as fh:
                fh.write(json.dumps(row, default=float) + "\n")
            print(case, seed, row["verdict"], row["chosen"],
                  [(r["name"], r["delta_bic"], r["kept"]) for r in row["rows"]],
                  f"{row['cpu_s']:.0f} s CPU", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
