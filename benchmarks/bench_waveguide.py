"""Benchmark of the free-rail waveguide: DOFs, assembly time and time per frequency of k(omega).

    python benchmarks/bench_waveguide.py                       # all three tables
    python benchmarks/bench_waveguide.py --sizes 10 5 --full 20 10 --threads 2
    python benchmarks/bench_waveguide.py --sizes --full --speed-sizes 5 --tail-sizes  # one table
    git worktree add /tmp/wg_old <commit of the code to compare with>
    nice -n 5 python benchmarks/bench_waveguide.py --speed-sizes --tail-sizes --sizes --full \
        --old /tmp/wg_old --out benchmarks/results/results_kofw_speed.txt   # table 4 only

Table 1, solver speed, old path vs this railfem (--speed-sizes, default 10 and 5 mm): time
per frequency of k(omega) for the n smallest-|k| waves by shift-invert, (i) with the mirror
split (--n-split waves per family, both families, default 25) and (ii) for the whole section
solved as one family (--n-whole waves, default 50; T = identity, built here), undamped and
with the rail loss factor 0.01. "old" is the path of railfem before the solver rework,
kept as functions in this script (lil build of A(omega) per frequency, COLAMD ordering,
complex arithmetic throughout, ARPACK's own start vector); "new" is waves.waves_at with its
cache off. Wall and CPU (process) time: CPU time is the honest figure on a shared machine.

Table 2, the frozen near-field tail (--tail-sizes, default 10 and 5 mm; symmetric family,
40 retained waves, 50 Hz, loss factor 0.01): old (dense complex solve of the inverted form
with the loss factor) vs new (waves.frozen_tail: undamped, real arithmetic, direct form,
first-order loss shift): time and peak memory of numpy allocations (tracemalloc).

Table 3, the formulations (--sizes, --full), per mesh (60E1, shipped meshes when present):

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

Table 4, k(omega), free-rail mobility and labelling against an older checkout (--old: a
tree whose railfem is imported in subprocesses with PYTHONPATH, the new one is this tree;
--done-size, default 5 mm; CPU time, best of --repeat per frequency, mean over
--frequencies): (i) k(omega) of the whole 60E1 section as one family (T = identity),
--n-whole waves, undamped and with loss factor 0.01; (ii) the free-rail receptance
(mobility.free_receptance, tail=False: the frozen tail is a one-off) of that section with
--n-mobility waves, head patch load (20 mm x 20 mm), head patch and foot sensor responses at
the 29 EN 15461 positions, loss factor 0.01, and its ratio to (i) with loss in the same tree;
(iii) the share of wave labelling in waves.solve (time inside labels.label_waves over the
time of the rest of the solve; whole section with --n-whole waves, and both mirror families
of the 10 mm mesh with 40 waves). The wavenumbers and receptances of the two trees are
compared entry by entry, the wavenumbers also at 1.001 times the section's first cut-on
frequency (not timed). Each measurement runs old and new alternately --rounds times (default
2) and keeps each tree's fastest run, so that a change of machine load hits both.

The BLAS thread count is set before numpy is imported (--threads, default 1: on a loaded
2-core machine OpenBLAS threads oversubscribe and a dense eig can run 10-50x slower).
The table is printed and written to benchmarks/results/results_waveguide.txt (--out).
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from _common import limit_threads, machine_lines, no_wave_cache


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--speed-sizes", type=float, nargs="*", default=[10.0, 5.0],
                   help="sizes (mm) of the old-vs-new solver table (default 10 5)")
    p.add_argument("--n-split", type=int, default=25, help="waves per family, mirror split")
    p.add_argument("--n-whole", type=int, default=50, help="waves of the whole section")
    p.add_argument("--repeat", type=int, default=2,
                   help="timings per frequency in table 1; the fastest is kept (default 2)")
    p.add_argument("--tail-sizes", type=float, nargs="*", default=[10.0, 5.0],
                   help="sizes (mm) of the frozen-tail table (default 10 5)")
    p.add_argument("--sizes", type=float, nargs="*", default=[10.0, 7.5],
                   help="element sizes in mm (default 10 7.5)")
    p.add_argument("--full", type=float, nargs="*", default=[20.0, 10.0],
                   help="sizes (mm) on which to time the full 2N linearisation (default 20 10)")
    p.add_argument("--frequencies", type=float, nargs="+", default=[100.0, 1000.0, 3000.0],
                   help="frequencies (Hz) timed in table 1 and for (b) and (c)")
    p.add_argument("--full-frequency", type=float, default=1000.0,
                   help="frequency (Hz) timed for (a) (one solve: it is slow)")
    p.add_argument("--threads", type=int, default=1, help="BLAS threads (default 1)")
    p.add_argument("--old", type=Path, help="older checkout for table 4 (omitted: no table 4)")
    p.add_argument("--done-size", type=float, default=5.0, help="mesh (mm) of table 4")
    p.add_argument("--n-mobility", type=int, default=100, help="waves of table 4's mobility")
    p.add_argument("--rounds", type=int, default=2,
                   help="table 4: old and new measured alternately this many times, the "
                        "fastest kept (default 2: a load change hits both trees)")
    p.add_argument("--child", help=argparse.SUPPRESS)
    p.add_argument("--out", type=Path,
                   default=Path(__file__).resolve().parent / "results" / "results_waveguide.txt")
    return p.parse_args(argv)


def main(argv=None):
    args = parse_args(argv)
    limit_threads(args.threads)
    no_wave_cache()
    if args.child:  # a table-4 measurement in the tree on PYTHONPATH
        run_child(args.child)
        return
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    import numpy as np
    import scipy.linalg as sl

    from railfem.rail import meshing
    from railfem.rail import waveguide
    from railfem.rail import waves

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
    emit("")
    if args.speed_sizes:
        speed_table(args, emit)
    if args.tail_sizes:
        tail_table(args, emit)
    if args.old:
        against_old_table(args, emit)
    if not (args.sizes or args.full):
        finish(args, lines)
        return
    emit("Table 3: formulations")
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
    finish(args, lines)


def finish(args, lines):
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


# ------------------------------------------------------------- the old path, for reference
def old_constant_matrix(ops, omega):
    """A(omega) as railfem built it before the rework: a lil matrix per frequency."""
    na = ops.na
    Z = (ops.c * ops.K0 - omega**2 * ops.M).tolil()
    Z[:na, na:] = ops.c * ops.K1[:na, na:]
    return Z.tocsc()


def old_waves(ops, omega, lam, x):
    """The old post-processing of (lambda, vector) pairs into positive-going waves."""
    import numpy as np

    from railfem.rail.waves import Waves

    k = np.sqrt(lam.astype(complex))
    k = np.where(k.imag > 0, -k, k)
    x = x.astype(complex)
    x[: ops.na] *= 1j * k
    undamped = np.abs(k.imag) <= 1e-6 * np.abs(k)
    if undamped.any():
        kr = k[undamped].real
        cg = ops.group_velocity(omega, kr, x[:, undamped])
        k[undamped] = np.where(cg >= 0, kr, -kr)
        x[: ops.na, undamped] *= np.where(cg >= 0, 1.0, -1.0)
    idx = np.argsort(np.abs(k))
    k, x = k[idx], x[:, idx]
    x /= np.linalg.norm(x, axis=0)
    return Waves(family=ops.family, omega=omega, k=k, phi=ops.to_reduced(x),
                 denom=ops.dA(k, x))


def old_shift_invert(ops, omega, n):
    import scipy.sparse.linalg as spl

    lu = spl.splu(old_constant_matrix(ops, omega))
    B = ops.B.astype(complex)
    op = spl.LinearOperator(B.shape, dtype=complex, matvec=lambda x: lu.solve(-(B @ x)))
    nu, vec = spl.eigs(op, k=min(n, B.shape[0] - 2), which="LM", tol=1e-10)
    return old_waves(ops, omega, 1.0 / nu, vec)


def old_frozen_tail(ops, omega0, n):
    """All waves by the dense complex solve of the inverted form, then those beyond n."""
    import scipy.linalg as sl

    A = old_constant_matrix(ops, omega0).toarray()
    B = ops.B.toarray().astype(complex)
    lu, piv = sl.lu_factor(A, check_finite=False)
    nu, x = sl.eig(sl.lu_solve((lu, piv), -B, check_finite=False), check_finite=False,
                   overwrite_a=True)
    w = old_waves(ops, omega0, 1.0 / nu, x)
    return w.k[n:], w.phi[:, n:], w.denom[n:]


def whole_section(guide):
    """The waveguide with one more family, 'full': every DOF, T = identity (no mirror)."""
    import dataclasses

    import numpy as np
    import scipy.sparse as sp

    from railfem.rail.waveguide import Family

    comp = np.empty(guide.n_dofs, dtype=int)
    for c in range(3):
        comp[guide.node_dofs[:, c]] = c
    full = Family(name="full", T=sp.identity(guide.n_dofs, format="csr"), component=comp)
    return dataclasses.replace(guide, families={**guide.families, "full": full})


def clocks(fn, *a, repeat=1, **kw):
    """(result, best wall time, best CPU time) of fn(*a, **kw) over `repeat` runs."""
    best_w = best_c = float("inf")
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        out = fn(*a, **kw)
        best_w = min(best_w, time.perf_counter() - w0)
        best_c = min(best_c, time.process_time() - c0)
    return out, best_w, best_c


def speed_table(args, emit):
    import numpy as np

    from railfem.rail import meshing
    from railfem.rail import waveguide
    from railfem.rail import waves
    from railfem.materials import Material

    emit(f"Table 1: k(omega) by shift-invert, old path vs new, seconds per frequency (mean "
         f"over {', '.join(f'{f:g}' for f in args.frequencies)} Hz, best of {args.repeat})")
    head = (f"{'h mm':>5} {'eta':>5} {'case':<22} {'DOFs':>6} {'old wall':>9} {'new wall':>9} "
            f"{'old CPU':>8} {'new CPU':>8} {'CPU ratio':>9} {'max|dk|/|k|':>12}")
    emit(head)
    emit("-" * len(head))
    for hmm in args.speed_sizes:
        mesh = meshing.get_mesh("60E1", hmm * 1e-3)
        for eta in (0.0, 0.01):
            guide = whole_section(waveguide.assemble(mesh, Material.steel(eta)))
            cases = [(f"split, {args.n_split}/family", waveguide.FAMILIES, args.n_split),
                     (f"whole, {args.n_whole} waves", ("full",), args.n_whole)]
            for name, fams, n in cases:
                ops = [waves.FamilyOperators(guide, fam) for fam in fams]
                t = np.zeros(4)
                dk = 0.0
                for f in args.frequencies:
                    om = 2 * np.pi * f
                    for op in ops:
                        old, wo, co = clocks(old_shift_invert, op, om, n, repeat=args.repeat)
                        new, wn, cn = clocks(waves.waves_at, op, om, method="shift-invert",
                                             n_waves=n, repeat=args.repeat)
                        t += [wo, wn, co, cn]
                        d = np.abs(old.k[:, None] - new.k[None, :]).min(axis=1)
                        dk = max(dk, float((d / np.abs(old.k)).max()))
                t /= len(args.frequencies)
                dofs = sum(op.B0.shape[0] for op in ops)
                emit(f"{hmm:5g} {eta:5g} {name:<22} {dofs:6d} {t[0]:9.3f} {t[1]:9.3f} "
                     f"{t[2]:8.3f} {t[3]:8.3f} {t[2] / t[3]:9.2f} {dk:12.1e}")
    emit("split: both mirror families, DOFs summed; whole: the section as one family.")
    emit("max|dk|/|k|: largest distance of an old wavenumber from the nearest new one.")
    emit("")


def tail_table(args, emit):
    import tracemalloc

    import numpy as np

    from railfem.rail import meshing
    from railfem.rail import mobility
    from railfem.rail import waveguide
    from railfem.rail import waves
    from railfem.materials import Material

    emit("Table 2: frozen near-field tail (symmetric family, 40 retained waves, 50 Hz, "
         "eta 0.01)")
    head = (f"{'h mm':>5} {'DOFs':>6} {'old s':>8} {'new s':>8} {'ratio':>6} "
            f"{'old MB':>7} {'new MB':>7} {'head point: old err':>20} {'new err':>8}")
    emit(head)
    emit("-" * len(head))
    for hmm in args.tail_sizes:
        guide = waveguide.assemble(meshing.get_mesh("60E1", hmm * 1e-3), Material.steel(0.01))
        ops = waves.FamilyOperators(guide, "symmetric")
        om0 = 2 * np.pi * 50.0
        res = {}
        for name, fn in (("old", old_frozen_tail), ("new", waves.frozen_tail)):
            tracemalloc.start()
            out, wall, _ = clocks(fn, ops, om0, 40)
            peak = tracemalloc.get_traced_memory()[1] / 1e6
            tracemalloc.stop()
            if name == "old":
                out = waves.Waves(family="symmetric", omega=om0, k=out[0], phi=out[1],
                                  denom=out[2])
            res[name] = (out, wall, peak)
        # accuracy: head point receptance (20 mm patch, 20 mm load length) at 2 kHz against
        # all waves at 2 kHz (dense solve), with 40 retained waves + each tail
        hp = mobility.head_patch(guide, 0.02)
        fr = mobility.FamilyResponse(guide, "symmetric", hp.weights[:, None],
                                     hp.weights[:, None])
        om = 2 * np.pi * 2000.0
        ref = mobility.wave_sum(fr, waves.waves_at(ops, om, method="dense"), [0.0], 0.02)
        kept = waves.waves_at(ops, om, method="shift-invert", n_waves=40)
        err = {name: float(np.abs(mobility.wave_sum(fr, waves.join(kept, r[0]), [0.0], 0.02)
                                   - ref).max() / np.abs(ref).max())
               for name, r in res.items()}
        emit(f"{hmm:5g} {ops.B0.shape[0]:6d} {res['old'][1]:8.2f} {res['new'][1]:8.2f} "
             f"{res['old'][1] / res['new'][1]:6.2f} {res['old'][2]:7.0f} {res['new'][2]:7.0f} "
             f"{err['old']:20.1e} {err['new']:8.1e}")
    emit("MB: peak of numpy allocations (tracemalloc) during the tail solve. err: relative")
    emit("error of the 2 kHz head point receptance (retained waves + tail) against all waves.")
    emit("")


# ---------------------------------------------------------- table 4: against an old tree
def one_family(guide):
    """The waveguide with the whole section as its only family (T = identity)."""
    import dataclasses

    whole = whole_section(guide)
    return dataclasses.replace(whole, families={"full": whole.families["full"]})


def best_cpu(fn, repeat):
    out, best = None, float("inf")
    for _ in range(max(1, repeat)):
        c0 = time.process_time()
        out = fn()
        best = min(best, time.process_time() - c0)
    return out, best


def run_child(spec_json: str) -> None:
    """One measurement of table 4 in the railfem found on PYTHONPATH; arrays to spec["npz"],
    times as one JSON line on stdout."""
    import json

    import numpy as np

    from railfem.materials import Material
    from railfem.rail import meshing, mobility, waveguide, waves

    spec = json.loads(spec_json)
    f = np.asarray(spec["frequencies"], dtype=float)
    guide = waveguide.assemble(meshing.get_mesh("60E1", spec["h"] * 1e-3),
                               Material.steel(spec["eta"]))
    whole = one_family(guide)
    out, arrays = {"railfem": waves.__file__}, {}
    if spec["kind"] == "kofw":
        ops = waves.FamilyOperators(whole, "full")
        ts, ks = [], []
        for fi in f:
            w, t = best_cpu(lambda: waves.waves_at(ops, 2 * np.pi * fi, method="shift-invert",
                                                   n_waves=spec["n"]), spec["repeat"])
            ts.append(t)
            ks.append(w.k)
        out.update(t=float(np.mean(ts)), dofs=int(ops.B0.shape[0]))
        arrays["k"] = np.array(ks)
        # not timed: just above the first cut-on, where two waves meet at k = 0
        f_cut = 1.001 * float(waves.cut_on_frequencies(whole, n=1)[0])
        arrays["k_cut"] = waves.waves_at(ops, 2 * np.pi * f_cut, method="shift-invert",
                                         n_waves=spec["n"]).k
        arrays["f_cut"] = np.array(f_cut)
    elif spec["kind"] == "mobility":
        head = mobility.head_patch(whole, 0.02)
        resp = [head, mobility.point(whole, "foot_sensor", "z")]
        from railfem.standards.en15461 import hammer_positions

        x = hammer_positions(0.6)
        ts, rs = [], []
        for fi in f:
            r, t = best_cpu(lambda: mobility.free_receptance(
                whole, [fi], [head], resp, x, n_waves=spec["n"], tail=False), spec["repeat"])
            ts.append(t)
            rs.append(r[0])
        out.update(t=float(np.mean(ts)), n_out=len(resp) * len(x))
        arrays["r"] = np.array(rs)
    else:  # labels: time inside label_waves against the whole solve
        from railfem.rail import labels

        g = whole if spec["split"] is False else guide
        spent = [0.0]
        label = labels.label_waves

        def timed(*a, **k):
            c0 = time.process_time()
            res = label(*a, **k)
            spent[0] += time.process_time() - c0
            return res

        labels.label_waves = timed
        best = (float("inf"), 0.0)
        for _ in range(max(1, spec["repeat"])):
            spent[0] = 0.0
            c0 = time.process_time()
            waves.solve(g, f, n_waves=spec["n"])
            best = min(best, (time.process_time() - c0, spent[0]))
        out.update(t=best[0] / len(f), labels=best[1] / len(f),
                   dofs=int(sum(fam.T.shape[1] for fam in g.families.values())))
    np.savez(spec["npz"], **arrays)
    print(json.dumps(out))


def child(tree, **spec):
    """Run one table-4 measurement with PYTHONPATH=tree; (times, arrays)."""
    import json
    import os
    import subprocess
    import tempfile

    import numpy as np

    with tempfile.TemporaryDirectory() as tmp:
        spec["npz"] = str(Path(tmp) / "out.npz")
        env = dict(os.environ, PYTHONPATH=str(tree), RAILFEM_WAVE_CACHE_MB="0")
        res = subprocess.run([sys.executable, __file__, "--child", json.dumps(spec)], env=env,
                             check=True, capture_output=True, text=True, cwd=tmp)
        times = json.loads(res.stdout.strip().splitlines()[-1])
        arrays = dict(np.load(spec["npz"]))
    if not times["railfem"].startswith(str(Path(tree).resolve())):
        raise RuntimeError(f"{tree}: imported railfem from {times['railfem']}")
    return times, arrays


def alternating(trees, rounds, **spec):
    """{tree name: (times, arrays)}: each tree measured ``rounds`` times, old and new in turn,
    the fastest run of each kept (a change of machine load then hits both)."""
    out = {}
    for _ in range(max(1, rounds)):
        for name, tree in trees.items():
            times, arrays = child(tree, **spec)
            if name not in out or times["t"] < out[name][0]["t"]:
                out[name] = (times, arrays)
    return out


def against_old_table(args, emit):
    import numpy as np

    new_tree = Path(__file__).resolve().parents[1]
    trees = {"old": args.old.resolve(), "new": new_tree}
    freqs = list(args.frequencies)
    h, rep = args.done_size, max(args.repeat, 3)
    emit(f"Table 4: against {args.old} (old) in the same run; CPU s per frequency, best of "
         f"{rep}, mean over {', '.join(f'{x:g}' for x in freqs)} Hz; 60E1 h = {h:g} mm; "
         f"old and new alternately, {args.rounds} rounds, fastest kept")
    emit("  reproduce: git worktree add /tmp/wg_old <old commit>; nice -n 5 python "
         "benchmarks/bench_waveguide.py --speed-sizes --tail-sizes --sizes --full "
         "--old /tmp/wg_old --out benchmarks/results/results_kofw_speed.txt")
    head = (f"{'case':<44} {'size':<24} {'old CPU':>8} {'new CPU':>8} {'old/new':>7} "
            f"{'max rel diff':>12}")
    emit(head)
    emit("-" * len(head))
    base = dict(h=h, frequencies=freqs, repeat=rep)
    kofw = {}
    for eta in (0.0, 0.01):
        res = alternating(trees, args.rounds, kind="kofw", eta=eta, n=args.n_whole, **base)
        ko, kn = res["old"][1]["k"], res["new"][1]["k"]
        diff = float(np.max(np.abs(kn - ko) / np.abs(ko)))
        ko, kn = res["old"][1]["k_cut"], res["new"][1]["k_cut"]
        cut = (float(res["new"][1]["f_cut"]), float(np.max(np.abs(kn - ko) / np.abs(ko))))
        to, tn = res["old"][0]["t"], res["new"][0]["t"]
        kofw[eta] = (to, tn)
        case, size = f"k(omega), whole section, eta {eta:g}", \
            f"{res['new'][0]['dofs']} DOFs, {args.n_whole} waves"
        emit(f"{case:<44} {size:<24} {to:8.3f} {tn:8.3f} {to / tn:7.2f} {diff:12.1e}")
        case = f"  at 1.001 x the first cut-on, {cut[0]:.0f} Hz"
        emit(f"{case:<44} {'':<24} {'':>8} {'':>8} {'':>7} {cut[1]:12.1e}")
    res = alternating(trees, args.rounds, kind="mobility", eta=0.01, n=args.n_mobility, **base)
    ro, rn = res["old"][1]["r"], res["new"][1]["r"]
    diff = float(np.max(np.abs(rn - ro) / np.abs(ro)))
    to, tn = res["old"][0]["t"], res["new"][0]["t"]
    case = f"free-rail receptance, {args.n_mobility} waves, eta 0.01"
    size = f"{res['new'][0]['n_out']} outputs, no tail"
    emit(f"{case:<44} {size:<24} {to:8.3f} {tn:8.3f} {to / tn:7.2f} {diff:12.1e}")
    ko, kn = kofw[0.01]
    case = f"  its ratio to k(omega) {args.n_whole} waves, eta 0.01"
    emit(f"{case:<44} {'':<24} {to / ko:8.2f} {tn / kn:8.2f}")
    for split, n, hh in ((False, args.n_whole, h), (True, 40, 10.0)):
        spec = dict(base, h=hh, eta=0.01, n=n, split=split, kind="labels")
        res = alternating(trees, args.rounds, **spec)
        (o, _), (nw, _) = res["old"], res["new"]
        so, sn = o["labels"] / (o["t"] - o["labels"]), nw["labels"] / (nw["t"] - nw["labels"])
        name = "whole section" if not split else "both families"
        case, size = f"labelling in waves.solve, {name}", f"{nw['dofs']} DOFs ({hh:g} mm), {n} w"
        emit(f"{case:<44} {size:<24} {o['labels']:8.3f} {nw['labels']:8.3f} "
             f"{o['labels'] / nw['labels']:7.2f}")
        emit(f"{'  share of the rest of the solve (old, new)':<44} {'':<24} "
             f"{100 * so:7.1f}% {100 * sn:7.1f}%")
    emit("k(omega): waves.waves_at(method='shift-invert') per frequency; receptance:")
    emit("mobility.free_receptance per frequency (tail=False: the frozen tail is a one-off per")
    emit("sweep); its ratio: receptance time over the k(omega) time with loss in the same tree.")
    emit("max rel diff: largest |new - old| / |old| over wavenumbers (sorted by |k|) or over")
    emit("receptance entries. Labelling: CPU time inside labels.label_waves per frequency.")
    emit("")


if __name__ == "__main__":
    main()
