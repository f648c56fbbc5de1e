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
default model's re-evaluation in the same run; the flexible options also with the seat
receptance by the full solve of all the sleeper's modes (the code before the modal form,
``sleeper.reference_seat_receptance``), column new/old.

The second table times the sleeper's seat receptance alone (both load cases, the site
ballast): the full solve with its modes computed (what every new sleeper value cost
before: the old memo was keyed by the sleeper), the modal form cold (modes computed) and
warm (modes of the geometry cached: a new stiffness, mass or loss factor), the number of
modes of the two half sleepers (DOFs) and of those retained below
sleeper.MODAL_CUTOFF_HZ, and the largest relative difference to the full solve at
20 Hz - 5 kHz; best of 5.
"""
from __future__ import annotations

import argparse
import contextlib
import functools
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
             f"# python benchmarks/bench_sleeper.py --threads {args.threads}",
             *machine_lines(args.threads),
             f"# {len(f)} frequencies x 29 EN 15461 hammer positions, head sensor; times in s; "
             "kernel shared (cold = first call of the default model)",
             ]
    sys.stdout.write("\n".join(lines) + "\n")
    options = [("default (rigid, 1 rail)", {}, (1,)),
               ("flexible sleeper", {"sleeper": "flexible"}, (1,)),
               ("rigid, 2 rails", {"rails": 2}, (1, 2)),
               ("flexible, 2 rails", {"sleeper": "flexible", "rails": 2}, (1, 2)),
               ("ballast mass 300 kg", {"mb": 300.0, "kf": 80e6, "eta_f": 0.5}, (1,))]
    lines.append(f"{'model':<22}{'option':<26}{'responses':>10}{'time':>9}{'ratio':>8}"
                 f"{'old':>9}{'new/old':>9}")
    for model in ("wfe-discrete", "timoshenko-discrete"):
        base = rf.preset("site", model=model)
        xs, pos, hx = models.hammer_x(base)
        force = [models.head(x) for x in hx]
        with tempfile.TemporaryDirectory() as cache:
            store = KernelStore(directory=cache)
            t0 = time.perf_counter()
            models.frf(base, f, force=force, response=[models.head(xs)], cache=store)
            cold = time.perf_counter() - t0
            lines.append(f"{model:<22}{'default, cold kernel':<26}{1:>10}{cold:>9.2f}")
            sys.stdout.write(lines[-1] + "\n")
            ref = None
            for name, changes, rails in options:
                spec = base.replace(**changes)
                response = [models.head(xs, rail=r) for r in rails]

                def run():
                    models.frf(spec, f, force=force, response=response, cache=store)
                best = best_of(run, sleeper)
                ref = best if ref is None else ref
                row = f"{model:<22}{name:<26}{len(rails):>10}{best:>9.3f}{best / ref:>8.2f}"
                if "sleeper" in changes:
                    with full_solve(sleeper):
                        old = best_of(run, sleeper)
                    row += f"{old:>9.3f}{best / old:>9.2f}"
                lines.append(row)
                sys.stdout.write(lines[-1] + "\n")
    lines += seat_table(sleeper, f)
    try:
        lines.append("  load average at end %.2f %.2f %.2f" % os.getloadavg())
    except OSError:
        pass
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    sys.stdout.write(lines[-1] + "\n")


def best_of(run, sleeper, n=5):
    """Best time (s) of ``n`` runs, the sleeper's memo cleared before each."""
    best = float("inf")
    for _ in range(n):
        sleeper.clear_cache()
        t0 = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - t0)
    return best


@contextlib.contextmanager
def full_solve(sleeper):
    """Seat receptances by the full solve of all modes (the code before the modal form)."""
    modal = sleeper._receptance  # the benchmark swaps the implementation, memo and all

    @functools.lru_cache(maxsize=64)
    def old(sl, case, w_bytes, s_bytes, shape):
        import numpy as np
        w = np.frombuffer(w_bytes, dtype=float).reshape(shape)
        s = np.frombuffer(s_bytes, dtype=complex).reshape(shape)
        return sleeper.reference_seat_receptance(sl, w, s * sl.length / 2, case)
    sleeper._receptance = old
    try:
        yield
    finally:
        sleeper._receptance = modal


def seat_table(sleeper, f_grid):
    """Rows of the seat-receptance table (module docstring)."""
    import numpy as np
    from railfem.diagnosis.effects.sleeper_flexibility import sleeper_of

    bed = 42e6 * (1 + 1j)
    out = [f"# seat receptance alone, both load cases, site ballast; times in ms; modes = "
           f"all modes / retained below {sleeper.MODAL_CUTOFF_HZ:.0f} Hz, "
           "both halves (symmetric + antisymmetric)",
           f"{'sleeper':<22}{'freqs':>6}{'modes':>12}{'full':>9}{'modal cold':>11}"
           f"{'modal warm':>11}{'full/warm':>10}{'max rel err':>13}"]
    for name, sl in (("B90 (f1 113 Hz)", sleeper.B90),
                     ("f1 40 Hz", sleeper_of(150.0, 40.0, 0.02)),
                     ("f1 800 Hz", sleeper_of(150.0, 800.0, 0.02))):
        for w in (2 * np.pi * f_grid, 2 * np.pi * np.geomspace(20.0, 8000.0, 500)):
            n_free = sl.free_frequencies(1000)  # all flexible modes, both halves
            retained = 2 + int((n_free <= sleeper.MODAL_CUTOFF_HZ).sum())  # + 2 rigid
            modes = f"{2 * (2 * len(sleeper.half_nodes(sl)) - 1)}/{retained}"
            full = best_of(lambda: [sleeper.reference_seat_receptance(sl, w, bed, c)
                                    for c in sleeper.CASES], sleeper)
            cold = best_of(lambda: sl.seat_matrix(w, bed), sleeper)
            sl.seat_matrix(w[:1], bed)
            warm = float("inf")
            for i in range(5):  # another bed each time: the memo misses, the modes hit
                t0 = time.perf_counter()
                sl.seat_matrix(w, bed * (1 + 1e-9 * (i + 1)))
                warm = min(warm, time.perf_counter() - t0)
            lo = w <= 2 * np.pi * 5000
            err = max(np.abs(sl.seat_receptance(w[lo], bed, c)
                             / sleeper.reference_seat_receptance(sl, w[lo], bed, c) - 1).max()
                      for c in sleeper.CASES)
            out.append(f"{name:<22}{len(w):>6}{modes:>12}{1e3 * full:>9.2f}{1e3 * cold:>11.2f}"
                       f"{1e3 * warm:>11.2f}{full / warm:>10.1f}{err:>13.1e}")
            sys.stdout.write(out[-1] + "\n")
    return out


if __name__ == "__main__":
    main()
