"""Coverage of the diagnosis's base intervals on clean data (benchmarks/blind/generators.py,
dataset('none', seed, model='wfe-discrete', form=FORM): 29 positions, 50 Hz - 5 kHz in
ninth octaves, 5 % noise): per seed and base parameter (kp, eta_p, kb, eta_b, eta_r) the
estimate's error against generators.TRUTH (decades), the 95 % half-width (decades) and
whether the interval holds the truth; JSON lines, then a summary (inside n/N, median
half-width, mean error).

    OPENBLAS_NUM_THREADS=1 nice -n 5 \
        python -m benchmarks.bench_base_coverage OUT.jsonl 0-9 [--form own]
    python -m benchmarks.bench_base_coverage --table OUT.jsonl

The base is the one of ``railfem diagnose`` (railfem.diagnosis.diagnose with no candidate
effects, n_starts=2, the kernels through $RAILFEM_CACHE); CPU seconds per seed are
recorded (the loaded machine's, cached kernels included)."""
from __future__ import annotations

import json
import math
import statistics
import sys
import time

BASE = ("kp", "eta_p", "kb", "eta_b", "eta_r")
MODEL = "wfe-discrete"


def run(seed: int, form: str) -> dict:
    from benchmarks.blind import generators as g
    from railfem.diagnosis import diagnose

    t0 = time.process_time()
    data = g.dataset("none", seed, model=MODEL, form=form, cache=True)
    d = diagnose(data, model=MODEL, effects=(), pairs=False, n_starts=2, cache=True)
    row = {"seed": seed, "form": form, "cpu_s": round(time.process_time() - t0, 1),
           "params": {}}
    for p in d.base.parameters():
        n = p["name"]
        if n in BASE:
            lo, hi = p["ci95"]
            row["params"][n] = {"value": p["value"], "ci95": [lo, hi],
                                "inside": bool(lo <= g.TRUTH[n] <= hi),
                                "error": math.log10(p["value"] / g.TRUTH[n]),
                                "half_width": math.log10(hi / lo) / 2}
    return row


def table(rows: list[dict]) -> str:
    out = ["| seed | " + " | ".join(BASE) + " |", "|---" * (len(BASE) + 1) + "|"]
    for r in rows:
        cells = [f"{r['params'][n]['error']:+.4f} / {r['params'][n]['half_width']:.4f}"
                 + ("" if r["params"][n]["inside"] else " **out**") for n in BASE]
        out.append(f"| {r['seed']} | " + " | ".join(cells) + " |")
    for label, f in (("inside", lambda v: f"{sum(x['inside'] for x in v)}/{len(v)}"),
                     ("median half-width",
                      lambda v: f"{statistics.median(x['half_width'] for x in v):.4f}"),
                     ("mean error", lambda v: f"{statistics.mean(x['error'] for x in v):+.4f}")):
        out.append(f"| {label} | " + " | ".join(f([r["params"][n] for r in rows])
                                                for n in BASE) + " |")
    return "\n".join(out)


def main(argv: list[str]) -> None:
    if argv[0] == "--table":
        print(table([json.loads(line) for line in open(argv[1])]))
        return
    out, span = argv[0], argv[1]
    a, b = (int(x) for x in span.split("-"))
    form = argv[argv.index("--form") + 1] if "--form" in argv else "cross"
    for seed in range(a, b + 1):
        row = run(seed, form)
        with open(out, "a") as fo:
            fo.write(json.dumps(row) + "\n")
        print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
