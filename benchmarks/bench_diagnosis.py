"""Benchmark of a full diagnosis of a 29-position hammer dataset (issue 12: <= 10 min on 2
cores).

    python benchmarks/bench_diagnosis.py                 # practice_site_b, both models
    python benchmarks/bench_diagnosis.py --models timoshenko-discrete
    python benchmarks/bench_diagnosis.py --f-high 4000 \
        --out benchmarks/results/results_diagnosis_4k.txt   # practice_site_b keeps an effect

For each model: railfem.diagnosis.diagnose on the dataset (29 EN 15461 positions, head and
foot sensors, 69 frequencies at 1/9 octave, 50 Hz - 8 kHz), the whole effect library that
applies, the base fit's multi-start in ``--workers`` processes, a memory-only kernel cache
(cold: every kernel is computed in the run). Reported: the time of each stage (base fit
with the rail-loss profile, single candidates, pairs, final refit), the number of
candidates, and the ratio of each model's total to the timoshenko-discrete total measured
in the same run. The table is printed and written to benchmarks/results/results_diagnosis.txt.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from _common import limit_threads, machine_lines



def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, default=Path("/work/shared/datasets/practice_site_b"))
    p.add_argument("--models", nargs="+", default=["timoshenko-discrete", "wfe-discrete"])
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--f-high", type=float, default=None,
                   help="diagnose up to this frequency (Hz; default the whole dataset)")
    p.add_argument("--out", type=Path,
                   default=Path(__file__).resolve().parent / "results" / "results_diagnosis.txt")
    return p.parse_args(argv)


def main(argv=None):
    args = parse_args(argv)
    limit_threads(args.threads)
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from railfem.diagnosis import diagnose
    from railfem.io import read_measurement

    meas = read_measurement(args.data)
    lines = ["Full diagnosis of a 29-position hammer dataset (railfem.diagnosis.diagnose)",
             *machine_lines(args.threads),
             f"  data {args.data} ({meas.frf.shape[0]} frequencies, {meas.frf.shape[1]} "
             f"sensors, {meas.frf.shape[2]} positions); base fit in {args.workers} processes; "
             "memory-only kernel cache (cold)"
             + (f"; diagnosed up to {args.f_high:g} Hz" if args.f_high else ""), "",
             f"{'model':22s} {'base s':>8s} {'singles s':>10s} {'pairs s':>8s} "
             f"{'final s':>8s} {'total s':>8s} {'cands':>6s} {'ratio':>6s}  verdict"]
    totals = {}
    rows = []
    for model in args.models:
        t = time.perf_counter()
        opts = {"f_range": (0.0, args.f_high)} if args.f_high else None
        d = diagnose(meas, model=model, workers=args.workers, cache=False, data_options=opts)
        total = time.perf_counter() - t
        totals[model] = total
        rows.append((model, d, total))
    ref = totals.get("timoshenko-discrete", next(iter(totals.values())))
    for model, d, total in rows:
        s = d.seconds
        lines.append(f"{model:22s} {s['base']:8.1f} {s['singles']:10.1f} {s['pairs']:8.1f} "
                     f"{s['final']:8.1f} {total:8.1f} {len(d.candidates):6d} "
                     f"{total / ref:6.2f}  {d.verdict}: {d.chosen.name if d.chosen else '-'}")
    text = "\n".join(lines) + "\n"
    print(text)
    from railfem.atomic import write_text

    write_text(args.out, text)


if __name__ == "__main__":
    main()
