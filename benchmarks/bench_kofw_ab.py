"""k(omega) and the free-rail receptance against an older checkout in one process.

The railfem package of the older checkout (--old, e.g. a ``git worktree``) is copied under
another name (railfem_old, into --work) and imported next to this tree's railfem; each case
then runs old and new alternately, call by call, --rounds times, and the fastest CPU time
(time.process_time) of each tree is kept. On a shared machine this is far steadier than
timing the trees in separate processes (bench_waveguide.py table 4), where a change of load
between two processes moves one tree's time and not the other's. Only railfem.rail (relative
imports) is taken from the old copy; anything it imports by absolute name comes from this
tree.

Cases (60E1, --h mm, the whole section as one family, BLAS threads 1, wave cache off): k0 and
k1, waves.waves_at(method="shift-invert", n_waves=--n-whole) without and with loss factor
0.01; m, mobility.free_receptance with --n-mobility waves, head patch load, head patch and
foot sensor responses at the 29 EN 15461 positions, tail=False, one frequency per call.
Printed: mean over --frequencies of each tree's best time, the receptance's ratio to k1, and
the largest relative difference old/new per case and frequency (wavenumbers sorted by |k|,
receptance entries against the largest).

  python benchmarks/bench_kofw_ab.py --old /tmp/wk_old --rounds 8
"""
from __future__ import annotations

import argparse
import importlib
import shutil
import sys
import time
from pathlib import Path

from _common import limit_threads, machine_lines, no_wave_cache


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--old", type=Path, required=True, help="older checkout (its railfem/)")
    p.add_argument("--work", type=Path, default=Path("/tmp/railfem_ab"),
                   help="where the old package is copied (default /tmp/railfem_ab)")
    p.add_argument("--rounds", type=int, default=6, help="alternations, fastest kept")
    p.add_argument("--cases", default="k0,k1,m", help="any of k0, k1, m (comma separated)")
    p.add_argument("--h", type=float, default=5.0, help="element size (mm), default 5")
    p.add_argument("--n-whole", type=int, default=50, help="waves of k(omega)")
    p.add_argument("--n-mobility", type=int, default=100, help="waves of the receptance")
    p.add_argument("--frequencies", type=float, nargs="+", default=[100.0, 1000.0, 3000.0])
    return p.parse_args(argv)


def old_package(old: Path, work: Path):
    """The old checkout's railfem, imported as railfem_old."""
    dest = work / "railfem_old"
    if dest.exists():
        shutil.rmtree(dest)
    shutil.copytree(old / "railfem", dest, ignore=shutil.ignore_patterns("__pycache__"))
    sys.path.insert(0, str(work))
    return importlib.import_module("railfem_old")


def setup(pkg, args):
    """{case: {frequency: callable}} of one tree."""
    import dataclasses

    import numpy as np
    import scipy.sparse as sp

    for mod in ("rail.meshing", "rail.waveguide", "rail.waves", "rail.mobility", "materials"):
        importlib.import_module(f"{pkg.__name__}.{mod}")
    from railfem.standards.en15461 import hammer_positions

    R = pkg.rail

    def whole(eta):
        g = R.waveguide.assemble(R.meshing.get_mesh("60E1", args.h * 1e-3),
                                 pkg.materials.Material.steel(eta))
        comp = np.empty(g.n_dofs, dtype=int)
        for c in range(3):
            comp[g.node_dofs[:, c]] = c
        full = R.waveguide.Family(name="full", T=sp.identity(g.n_dofs, format="csr"),
                                  component=comp)
        return dataclasses.replace(g, families={"full": full})

    cases = {}
    for case, eta in (("k0", 0.0), ("k1", 0.01)):
        ops = R.waves.FamilyOperators(whole(eta), "full")
        cases[case] = {f: (lambda ops=ops, f=f: R.waves.waves_at(
            ops, 2 * np.pi * f, method="shift-invert", n_waves=args.n_whole).k)
            for f in args.frequencies}
    g = whole(0.01)
    head = R.mobility.head_patch(g, 0.02)
    resp = [head, R.mobility.point(g, "foot_sensor", "z")]
    x = hammer_positions(0.6)
    cases["m"] = {f: (lambda f=f: R.mobility.free_receptance(
        g, [f], [head], resp, x, n_waves=args.n_mobility, tail=False)) for f in args.frequencies}
    return cases


def main(argv=None):
    args = parse_args(argv)
    limit_threads(1)
    no_wave_cache()
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    import numpy as np

    import railfem

    header = ["railfem k(omega) A/B in one process"] + machine_lines(1)
    trees = {"old": setup(old_package(args.old, args.work), args), "new": setup(railfem, args)}
    wanted = args.cases.split(",")
    best, last = {}, {}
    for r in range(args.rounds):
        for case in wanted:
            for f in args.frequencies:
                for name in (("old", "new") if r % 2 == 0 else ("new", "old")):
                    c0 = time.process_time()
                    last[name, case, f] = trees[name][case][f]()
                    dt = time.process_time() - c0
                    best[name, case, f] = min(best.get((name, case, f), np.inf), dt)
    print("\n".join(header))
    print(f"  old: {args.old}; 60E1 h = {args.h:g} mm; CPU s, best of {args.rounds} "
          f"alternations, mean over {', '.join(f'{f:g}' for f in args.frequencies)} Hz")
    mean = {(n, c): float(np.mean([best[n, c, f] for f in args.frequencies]))
            for n in trees for c in wanted}
    for c in wanted:
        diffs = []
        for f in args.frequencies:
            a, b = last["old", c, f], last["new", c, f]
            diffs.append(np.max(np.abs(a - b) / np.abs(a)) if c != "m"
                         else np.abs(a - b).max() / np.abs(a).max())
        print(f"  {c:3s} old {mean['old', c]:.4f}  new {mean['new', c]:.4f}  "
              f"old/new {mean['old', c] / mean['new', c]:.3f}  max rel diff "
              + " ".join(f"{d:.1e}" for d in diffs))
    if "m" in wanted and "k1" in wanted:
        print("  ratio m / k1: old {:.2f}  new {:.2f}".format(
            mean["old", "m"] / mean["old", "k1"], mean["new", "m"] / mean["new", "k1"]))


if __name__ == "__main__":
    main()
