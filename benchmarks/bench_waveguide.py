"""Benchmark of the free-rail waveguide: DOFs, assembly time and time per frequency of k(omega).

    python benchmarks/bench_waveguide.py                       # default: 10 and 7.5 mm
    python benchmarks/bench_waveguide.py --sizes 10 5 --full 20 10 --threads 2

Per mesh (60E1, shipped meshes when present):

* DOFs, total and per symmetry family; time to load/mesh and to assemble K0, K1, K2, M;
* time per frequency of k(omega) with
  (a) the full 2N linearisation of the unreduced quadratic problem (companion form, k
      scaled to balance the coefficients, K2^-1 applied, one dense complex eig of size 2N;
      only for the sizes in --full, it is slow),
  (b) the two symmetry families with the substitution u_x = i k w: one dense eig of size
      N_family per family, all waves (waves.waves_at(method="dense")),
  (c) the families with shift-invert ARPACK for the 40 waves of smallest |k| per family
      (waves.waves_at(method="shift-invert")),
  and the speed-up of (b) and (c) over (a) measured in the same run;
* for (a) vs (b): the largest relative difference of the 40 smallest |k| per family, to show
  the three solve the same problem.

The BLAS thread count is set before numpy is imported (--threads, default 1: on a loaded
2-core machine OpenBLAS threads oversubscribe and a dense eig can run 10-50x slower).
The table is printed and written to benchmarks/results_waveguide.txt (--out).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from _common import limit_threads, machine_lines


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sizes", type=float, nargs="+", default=[10.0, 7.5],
                   help="element sizes in mm (default 10 7.5)")
    p.add_argument("--full", type=float, nargs="*", default=[20.0, 10.0],
                   help="sizes (mm) on which to time the full 2N linearisation (default 20 10)")
    p.add_argument("--frequencies", type=float, nargs="+", default=[100.0, 1000.0, 3000.0],
                   help="frequencies (Hz) timed for (b) and (c)")
    p.add_argument("--full-frequency", type=float, default=1000.0,
                   help="frequency (Hz) timed for (a) (one solve: it is slow)")
    p.add_argument("--threads", type=int, default=1, help="BLAS threads (default 1)")
    p.add_argument("--out", type=Path,
                   default=Path(__file__).resolve().parent / "results_waveguide.txt")
    return p.parse_args(argv)


def main(argv=None):
    args = parse_args(argv)
    limit_threads(args.threads)
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    import numpy as np
    import scipy.linalg as sl

    from railfem import meshing, waveguide, waves

    def full_linearisation(guide, omega):
        """All 2N roots k of k^2 K2 + i k K1 + K0 - w^2 M (unreduced), companion form."""
        A0 = (guide.K0 - omega**2 * guide.M).toarray().astype(complex)
        A1 = 1j * guide.K1.toarray()
        K2 = guide.K2.toarray()
        n0 = np.linalg.norm(A0)
        s = np.sqrt(n0 / np.linalg.norm(K2))  # k = s kappa
        lu = sl.lu_factor(K2 * (s * s / n0))
        N = K2.shape[0]
        C = np.zeros((2 * N, 2 * N), dtype=complex)
        C[:N, N:] = np.eye(N)
        C[N:, :N] = -sl.lu_solve(lu, A0 / n0)
        C[N:, N:] = -sl.lu_solve(lu, A1 * (s / n0))
        return sl.eigvals(C, overwrite_a=True, check_finite=False) * s

    def timed(fn, *a, **kw):
        t = time.perf_counter()
        out = fn(*a, **kw)
        return out, time.perf_counter() - t

    lines = []

    def emit(text=""):
        print(text, flush=True)
        lines.append(text)

    emit("railfem waveguide benchmark (60E1)")
    for line in machine_lines(args.threads):
        emit(line)
    emit(f"  (b), (c) timed at {', '.join(f'{f:g}' for f in args.frequencies)} Hz (mean per "
         f"frequency, both families); (a) at {args.full_frequency:g} Hz")
    emit("")
    header = (f"{'h mm':>5} {'DOFs':>6} {'sym':>5} {'anti':>5} {'mesh s':>7} {'asm s':>6} "
              f"{'(a) 2N s':>9} {'(b) dense s':>11} {'(c) s-i s':>10} {'a/b':>6} {'a/c':>7} "
              f"{'b/c':>6} {'max|dk|/|k| a-c':>16}")
    emit(header)
    emit("-" * len(header))
    sizes = sorted(set(args.sizes) | set(args.full), reverse=True)
    for hmm in sizes:
        h = hmm * 1e-3
        mesh, t_mesh = timed(meshing.get_mesh, "60E1", h)
        guide, t_asm = timed(waveguide.assemble, mesh)
        nfam = {k: f.T.shape[1] for k, f in guide.families.items()}
        ops = {fam: waves.FamilyOperators(guide, fam) for fam in waveguide.FAMILIES}
        tb = tc = float("nan")
        if hmm in args.sizes:
            tb = tc = 0.0
            for f in args.frequencies:
                for fam in waveguide.FAMILIES:
                    _, t = timed(waves.waves_at, ops[fam], 2 * np.pi * f, method="dense")
                    tb += t
                    _, t = timed(waves.waves_at, ops[fam], 2 * np.pi * f,
                                 method="shift-invert", n_waves=40)
                    tc += t
            tb /= len(args.frequencies)
            tc /= len(args.frequencies)
        ta, mismatch = float("nan"), float("nan")
        if hmm in args.full:
            omega = 2 * np.pi * args.full_frequency
            roots, ta = timed(full_linearisation, guide, omega)
            diffs = []
            for fam in waveguide.FAMILIES:
                kb = waves.waves_at(ops[fam], omega, method="shift-invert", n_waves=40).k
                for k in kb:
                    diffs.append(np.min(np.abs(roots - k)) / abs(k))
            mismatch = max(diffs)
            if not np.isfinite(tb):  # (b) and (c) at the same frequency for the ratios
                tb = sum(timed(waves.waves_at, ops[fam], omega, method="dense")[1]
                         for fam in waveguide.FAMILIES)
                tc = sum(timed(waves.waves_at, ops[fam], omega, method="shift-invert",
                               n_waves=40)[1] for fam in waveguide.FAMILIES)

        def fmt(x, w, p=3):
            return f"{x:{w}.{p}f}" if np.isfinite(x) else f"{'-':>{w}}"

        def ratio(a, b, w):
            return f"{a / b:{w}.0f}" if np.isfinite(a) and np.isfinite(b) else f"{'-':>{w}}"

        mism = f"{mismatch:16.1e}" if np.isfinite(mismatch) else f"{'-':>16}"
        emit(f"{hmm:5g} {guide.n_dofs:6d} {nfam['symmetric']:5d} {nfam['antisymmetric']:5d} "
             f"{t_mesh:7.3f} {t_asm:6.3f} {fmt(ta, 9, 2)} {fmt(tb, 11)} {fmt(tc, 10)} "
             f"{ratio(ta, tb, 6)} {ratio(ta, tc, 7)} {ratio(tb, tc, 6)} {mism}")
    emit("")
    emit("mesh s: load the shipped mesh (or Gmsh when none); asm s: assemble K0, K1, K2, M.")
    emit("(a) all 2N roots of the unreduced problem; (b) all N roots (both families, k^2);")
    emit("(c) 40 waves of smallest |k| per family. Ratios from times measured in this run;")
    emit("rows without (b)/(c) timings over the frequency list use the (a) frequency.")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
