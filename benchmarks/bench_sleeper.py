"""Benchmark of the real-track options through the model door: flexible sleeper, two rails.

    python benchmarks/bench_sleeper.py [--threads 1]
        [--out benchmarks/results/results_sleeper.txt]

Problem: the site track of METHOD.md Table 1 (wfe-discrete, 60E1 h = 10 mm, and
timoshenko-discrete), the 69 frequencies of the 1/9-octave grid 50 Hz - 8 kHz, the 29
EN 15461 hammer positions, head sensor at mid-span: one ``railfem.models.frf`` call per
option. The free-rail kernel does not depend on the supports, so it is computed once (the
default model's first call, "cold") and every option reuses it: the times of the options
are their coupling solves plus the sleeper's seat receptance (its memo cleared before
every run); best of 5 (the machine may be shared: see the load lines). Ratios to the
default model's re-evaluation in the same run.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

from _common import limit_threads, machine_lines

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--threads", type=int, default=1, help="BLAS threads (default 1)")
    p.add_argument("--out", type=Path,
                   default=Path(__file__).resolve().parent / "results" / "results_sleeper.txt")
    args = p.parse_args(argv)
    limit_threads(args.threads)
    sys.path.insert(0, str(ROOT))
    import railfem as rf
    from railfem import models
    from railfem.standards import iec61260
    from railfem.track import sleeper
    from railfem.track.kernelcache import KernelStore

    f = iec61260.ninth_octave_grid(50, 8000)
    lines = ["# railfem real-track options benchmark (models.frf, site preset)",
             *machine_lines(args.threads),
             f"# {len(f)} frequencies x 29 EN 15461 hammer positions, head sensor; times in s; "
             "kernel shared (cold = first call of the default model)",
             f"{'model':<22}{'option':<26}{'responses':>10}{'time':>9}{'ratio':>8}"]
    sys.stdout.write("\n".join(lines) + "\n")
    options = [("default (rigid, 1 rail)", {}, (1,)),
               ("flexible sleeper", {"sleeper": "flexible"}, (1,)),
               ("rigid, 2 rails", {"rails": 2}, (1, 2)),
               ("flexible, 2 rails", {"sleeper": "flexible", "rails": 2}, (1, 2)),
               ("ballast mass 300 kg", {"mb": 300.0, "kf": 80e6, "eta_f": 0.5}, (1,))]
    for model in ("wfe-discrete", "timoshenko-discrete"):
        base = rf.preset("site", model=model)
        xs, pos, hx = models.hammer_x(base)
        force = [models.head(x) for x in hx]
        with tempfile.TemporaryDirectory() as cache:
            store = KernelStore(directory=cache)
            t0 = time.perf_counter()
            models.frf(base, f, force=force, response=[models.head(xs)], cache=store)
            cold = time.perf_counter() - t0
            lines.append(f"{model:<22}{'default, cold kernel':<26}{1:>10}{cold:>9.2f}"
                         f"{'':>8}")
            sys.stdout.write(lines[-1] + "\n")
            ref = None
            for name, changes, rails in options:
                spec = base.replace(**changes)
                response = [models.head(xs, rail=r) for r in rails]
                best = float("inf")
                for _ in range(5):
                    sleeper.clear_cache()
                    t0 = time.perf_counter()
                    models.frf(spec, f, force=force, response=response, cache=store)
                    best = min(best, time.perf_counter() - t0)
                ref = best if ref is None else ref
                lines.append(f"{model:<22}{name:<26}{len(rails):>10}{best:>9.3f}"
                             f"{best / ref:>8.2f}")
                sys.stdout.write(lines[-1] + "\n")
    t0 = time.perf_counter()
    sleeper.clear_cache()
    sleeper.B90.seat_matrix(2 * 3.141592653589793 * f, 42e6 * (1 + 1j))
    lines.append(f"# seat receptance matrix of the B90 sleeper alone ({len(f)} frequencies, "
                 f"both load cases, {sleeper.B90.n_elements} elements per half): "
                 f"{time.perf_counter() - t0:.3f} s")
    try:
        lines.append("  load average at end %.2f %.2f %.2f" % os.getloadavg())
    except OSError:
        pass
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    sys.stdout.write(lines[-1] + "\n")


if __name__ == "__main__":
    main()
