"""Benchmark of the free-rail forced response: time per frequency for the EN 15461 set.

    python benchmarks/bench_mobility.py                          # default: 10 mm mesh
    python benchmarks/bench_mobility.py --sizes 10 7.5 --frequencies 100 1000 4000

Per mesh (60E1, shipped meshes when present), for a unit vertical force on the rail head
(20 mm patch, 20 mm along the rail, rail loss factor 0.01) and the responses on the rail
head (patch average) and at the rail-foot sensor, at the 29 EN 15461 hammer positions for
0.6 m sleeper spacing (railfem.standards.en15461.hammer_positions(0.6), 0 ... 39.6 m):

* DOFs, total and of the symmetric family (a vertical load on the symmetric section excites
  only that family; the antisymmetric one is skipped by railfem.rail.mobility);
* (a) dense: all waves of the family at every frequency (waves.waves_at(method="dense")),
  then the residue sum at the 58 outputs;
* (b) shift-invert: the 40 waves of smallest |k| (ARPACK on the sparse factorisation) plus
  the frozen near-field tail, then the same sum; the tail is a one-off dense solve at the
  lowest frequency, timed separately;
* the ratio (a)/(b) per frequency from times measured in the same run, and the largest
  relative difference of (b) from (a) over the 58 outputs.

The steps are those of railfem.rail.mobility.free_receptance, timed one by one. The BLAS thread
count is set before numpy is imported (--threads, default 1; see bench_waveguide.py). The
table is printed and written to benchmarks/results/results_mobility.txt (--out).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from _common import limit_threads, machine_lines, no_wave_cache


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sizes", type=float, nargs="+", default=[10.0],
                   help="element sizes in mm (default 10: the shipped default mesh)")
    p.add_argument("--frequencies", type=float, nargs="+",
                   default=[100.0, 500.0, 1000.0, 2000.0, 4000.0],
                   help="frequencies (Hz) timed (default 100 500 1000 2000 4000)")
    p.add_argument("--repeat", type=int, default=2,
                   help="timings per frequency and method; the fastest is kept (default 2)")
    p.add_argument("--n-waves", type=int, default=40, help="shift-invert waves (default 40)")
    p.add_argument("--threads", type=int, default=1, help="BLAS threads (default 1)")
    p.add_argument("--out", type=Path,
                   default=Path(__file__).resolve().parent / "results" / "results_mobility.txt")
    return p.parse_args(argv)


def main(argv=None):
    args = parse_args(argv)
    limit_threads(args.threads)
    no_wave_cache()
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    import numpy as np

    from railfem.rail import meshing
    from railfem.rail import mobility
    from railfem.rail import waveguide
    from railfem.rail import waves
    from railfem.materials import Material
    from railfem.standards.en15461 import hammer_positions

    x = hammer_positions(0.6)
    lines = []

    def emit(text=""):
        print(text, flush=True)
        lines.append(text)

    def best(fn, *a, **kw):
        t_min, out = np.inf, None
        for _ in range(max(1, args.repeat)):
            t = time.perf_counter()
            out = fn(*a, **kw)
            t_min = min(t_min, time.perf_counter() - t)
        return out, t_min

    emit("railfem free-rail mobility benchmark (60E1, EN 15461 positions)")
    for line in machine_lines(args.threads):
        emit(line)
    emit(f"  force: vertical, 20 mm head patch x 20 mm along the rail, loss factor 0.01; "
         f"outputs: head patch and foot sensor (z) at {len(x)} positions 0 ... {x[-1]:g} m "
         f"= {2 * len(x)} responses; best of {args.repeat} per entry")
    emit("")
    header = (f"{'h mm':>5} {'DOFs':>5} {'sym':>5} {'f Hz':>6} {'(a) dense s':>11} "
              f"{'(b) s-i s':>10} {'a/b':>6} {'max|b-a|/|a|':>13}")
    emit(header)
    emit("-" * len(header))
    summary = []
    for hmm in args.sizes:
        mesh = meshing.get_mesh("60E1", hmm * 1e-3)
        guide = waveguide.assemble(mesh, Material.steel(0.01))
        head = mobility.head_patch(guide, 0.02)
        outputs = [head, mobility.point(guide, "foot_sensor", "z")]
        Fw = head.weights[:, None]
        Rw = np.column_stack([o.weights for o in outputs])
        fams = [fr for fr in (mobility.FamilyResponse(guide, fam, Fw, Rw)
                              for fam in waveguide.FAMILIES) if fr.active]
        n_sym = guide.families["symmetric"].T.shape[1]
        f_min = min(args.frequencies)
        tails, t_tail = best(lambda: {fr.ops.family: waves.frozen_tail(
            fr.ops, 2 * np.pi * f_min, args.n_waves) for fr in fams})

        def response(omega, method):
            out = 0.0
            for fr in fams:
                w = waves.waves_at(fr.ops, omega, method=method, n_waves=args.n_waves)
                if method == "shift-invert":
                    w = waves.join(w, tails[fr.ops.family])
                out = out + mobility.wave_sum(fr, w, x, 0.02, 0.0)
            return out

        ta_all, tb_all = [], []
        for f in sorted(args.frequencies):
            omega = 2 * np.pi * f
            ua, ta = best(response, omega, "dense")
            ub, tb = best(response, omega, "shift-invert")
            err = np.max(np.abs(ub - ua) / np.abs(ua))
            ta_all.append(ta)
            tb_all.append(tb)
            emit(f"{hmm:5g} {guide.n_dofs:5d} {n_sym:5d} {f:6g} {ta:11.3f} {tb:10.3f} "
                 f"{ta / tb:6.1f} {err:13.1e}")
        summary.append((hmm, guide.n_dofs, len(fams), t_tail, np.mean(ta_all),
                        np.mean(tb_all)))
    emit("")
    emit(f"{'h mm':>5} {'DOFs':>5} {'families':>8} {'tail (one-off) s':>16} "
         f"{'mean (a) s/f':>12} {'mean (b) s/f':>12} {'a/b':>6} {'break-even nf':>13}")
    for hmm, n, nfam, t_tail, ta, tb in summary:
        emit(f"{hmm:5g} {n:5d} {nfam:8d} {t_tail:16.3f} {ta:12.3f} {tb:12.3f} "
             f"{ta / tb:6.1f} {t_tail / (ta - tb):13.1f}")
    emit("")
    emit("(a) all waves at each frequency; (b) 40 waves + the frozen tail (computed once at the")
    emit("lowest frequency: its cost is the tail column; a sweep of nf frequencies costs")
    emit("tail + nf * (b)). break-even nf: number of frequencies above which (b) is cheaper.")
    emit("Times per frequency include the residue sum at all outputs (58 responses).")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
