"""Speed of the free rail and the kernel, new code against an old checkout in the same run.

    git worktree add /tmp/speed_old <commit before the speed work>
    python benchmarks/bench_speed.py --old /tmp/speed_old [--new .] [--quick]
        [--out benchmarks/results/results_speed.txt]

Each measurement runs in a subprocess with PYTHONPATH pointing at the old or the new tree
(1 BLAS thread), so both import their own railfem. Measured:

* the main job ``railfem track --preset site``, cold (empty kernel cache) and warm
  (wall and CPU time of the subprocess, imports and plots included);
* k(omega) per frequency on the 5 mm 60E1 mesh: one family (symmetric), 50 waves,
  shift-invert; and shift-invert against dense on the 10 mm mesh of the site preset;
* the free-rail receptance (mobility.free_receptance) with 100 and 50 waves: head patch,
  12 frequencies, 401 positions 0-40 m;
* the share of wave labelling in waves.solve (10 mm mesh, 4 frequencies, both families);
* a discrete kernel at another rail loss factor (site track, 12 frequencies): old: a new
  kernel on a guide of that loss factor; new: discrete_kernel(eta_r=) on the guide of a
  kernel just built (matrices and undamped tail re-used);
* (new code only) the error of the first-order eigenvalue sensitivity (shapes kept) that
  would move a kernel to another eta_r without any eigen-solve, against fresh waves.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import machine_lines

ROOT = Path(__file__).resolve().parents[1]


# ------------------------------------------------------------------ children (one tree)
def _site():
    import railfem.spec as S
    from railfem import models

    spec = S.preset("site")
    n = spec.numerics
    return spec, models.wfe_rail(spec.rail, n.patch_width, n.n_foot_springs, n.foot_rule)


def child_kofw(h: float, method: str, n_waves: int, freqs) -> dict:
    import numpy as np

    from railfem.materials import Material
    from railfem.rail import meshing, waveguide, waves

    g = waveguide.assemble(meshing.get_mesh("60E1", h), Material.steel(0.01))
    ops = waves.FamilyOperators(g, "symmetric")
    waves.waves_at(ops, 2 * np.pi * 40.0, method=method, n_waves=n_waves)  # warm up
    t0 = time.perf_counter()
    for f in freqs:
        waves.waves_at(ops, 2 * np.pi * f, method=method, n_waves=n_waves)
    return {"t": (time.perf_counter() - t0) / len(freqs), "n": ops.B0.shape[0]}


def child_mobility(n_waves: int) -> dict:
    import numpy as np

    from railfem.rail import mobility

    _, rail = _site()
    g = rail.guide
    loc = mobility.head_patch(g, 0.02)
    f = np.geomspace(60, 6000, 12)
    x = np.linspace(0, 40, 401)
    t0 = time.perf_counter()
    mobility.free_receptance(g, f, [loc], [loc], x, n_waves=n_waves)
    return {"t": time.perf_counter() - t0}


def child_labels() -> dict:
    from railfem.rail import labels, waves

    _, rail = _site()
    spent = [0.0]
    label = labels.label_waves

    def timed(*a, **k):
        t = time.perf_counter()
        out = label(*a, **k)
        spent[0] += time.perf_counter() - t
        return out

    labels.label_waves = timed
    t0 = time.perf_counter()
    waves.solve(rail.guide, [200.0, 800.0, 2000.0, 5000.0], n_waves=40)
    total = time.perf_counter() - t0
    return {"t": total, "labels": spent[0]}


def child_eta(new: bool) -> dict:
    import inspect

    import numpy as np

    from railfem.track import wfe

    spec, rail = _site()
    lay = spec.layout()
    f = np.geomspace(50, 5000, 12)
    kw = dict(load=rail.loads["head"], outputs=[rail.outputs["head"]], force_x=[0.0, 0.3],
              response_x=[0.0, 1.2], spring_length=lay.row_length, n_waves=40)
    xs = lay.springs().x
    wfe.discrete_kernel(rail.guide, rail.springs, xs, f, **kw)  # the kernel of eta = 0.01
    t0 = time.perf_counter()
    if new and "eta_r" in inspect.signature(wfe.discrete_kernel).parameters:
        wfe.discrete_kernel(rail.guide, rail.springs, xs, f, eta_r=0.03, **kw)
    else:
        from dataclasses import replace

        from railfem.rail import waveguide

        g = waveguide.assemble(rail.guide.mesh, replace(rail.guide.material, loss_factor=0.03))
        wfe.discrete_kernel(g, rail.springs, xs, f, **kw)
    return {"t": time.perf_counter() - t0, "nf": len(f), "n_sets": len(xs)}


def child_sensitivity() -> dict:
    """Max relative error of the free-rail receptance (head patch, x = 0, 0.6, 6, 40 m)
    when the waves of eta0 = 0.01 are moved to eta by one Newton step on k per wave with
    the shapes kept (first-order sensitivity), against waves solved at eta."""
    import numpy as np

    from railfem.rail import mobility, waves

    _, rail = _site()
    g0 = rail.guide
    loc = mobility.head_patch(g0, 0.02)
    x = np.array([0.0, 0.6, 6.0, 40.0])
    fr0 = mobility.FamilyResponse(g0, "symmetric", loc.weights[:, None], loc.weights[:, None])
    ops = fr0.ops
    rows = {}
    for eta in (0.001, 0.003, 0.03, 0.1, 0.3):
        fr = mobility.FamilyResponse(g0.with_loss_factor(eta), "symmetric",
                                     loc.weights[:, None], loc.weights[:, None])
        worst = 0.0
        for f in (100.0, 700.0, 2500.0, 5500.0):
            om = 2 * np.pi * f
            w0 = waves.waves_at(ops, om, method="shift-invert", n_waves=40)
            ref = mobility.wave_sum(fr, waves.waves_at(fr.ops, om, method="shift-invert",
                                                       n_waves=40), x, 0.02)
            phi = w0.phi[ops.order]
            psi = ops.flip[:, None] * phi
            c1 = 1 + 1j * eta
            dot = lambda A: np.einsum("ij,ij->j", psi, A @ phi)  # noqa: E731
            m, k2, k1, k0 = dot(ops.M), dot(ops.K2), dot(ops.K1), dot(ops.K0)
            k = w0.k - (k2 * w0.k**2 + 1j * k1 * w0.k + k0 - om**2 / c1 * m) \
                / (2 * k2 * w0.k + 1j * k1)
            moved = waves.Waves(family=w0.family, omega=om, k=k, phi=w0.phi,
                                denom=c1 * (2 * k * k2 + 1j * k1))
            got = mobility.wave_sum(fr, moved, x, 0.02)
            worst = max(worst, float((np.abs(got - ref) / np.abs(ref)).max()))
        rows[str(eta)] = worst
    return rows


CHILDREN = {"kofw": child_kofw, "mobility": child_mobility, "labels": child_labels,
            "eta": child_eta, "sensitivity": child_sensitivity}


# ------------------------------------------------------------------ parent
def run_child(tree: Path, name: str, **kw) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree), OPENBLAS_NUM_THREADS="1",
               OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    out = subprocess.run([sys.executable, __file__, "--child", name, "--kw", json.dumps(kw)],
                         env=env, check=True, capture_output=True, text=True,
                         cwd=tempfile.gettempdir())
    return json.loads(out.stdout.strip().splitlines()[-1])


def run_job(tree: Path, cache: str, out: str) -> tuple[float, float]:
    """(wall, CPU) seconds of `railfem track --preset site` from ``tree``."""
    env = dict(os.environ, PYTHONPATH=str(tree), RAILFEM_CACHE=cache,
               OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    # cwd away from any tree: ``python -m`` puts the working directory before PYTHONPATH
    subprocess.run([sys.executable, "-m", "railfem.cli", "-q", "track", "--preset", "site",
                    "--out", out], env=env, check=True, capture_output=True,
                   cwd=Path(out).parent)
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return time.perf_counter() - t0, cpu


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--old", type=Path, help="checkout of the code before the speed work")
    p.add_argument("--new", type=Path, default=ROOT, help="tree of the new code (default: this)")
    p.add_argument("--quick", action="store_true", help="skip the 5 mm mesh and the eta_r rows")
    p.add_argument("--out", type=Path,
                   default=Path(__file__).resolve().parent / "results" / "results_speed.txt")
    p.add_argument("--child", help=argparse.SUPPRESS)
    p.add_argument("--kw", default="{}", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child:
        print(json.dumps(CHILDREN[args.child](**json.loads(args.kw))))
        return
    if args.old is None:
        p.error("--old PATH is required (a git worktree of the commit before the speed work)")
    lines = ["# railfem speed of the free rail and the kernel: new code against the old "
             "checkout, same run, subprocesses, 1 BLAS thread", *machine_lines(1),
             f"# old: {args.old}, new: {args.new}",
             f"{'case':<48}{'size':<30}{'old s':>9}{'new s':>9}{'old/new':>9}"]
    emit(lines)

    def row(case, size, t_old, t_new):
        emit(lines, f"{case:<48}{size:<30}{t_old:>9.3f}{t_new:>9.3f}{t_old / t_new:>9.2f}")

    with tempfile.TemporaryDirectory() as tmp:
        res = {}
        for tag, tree in (("old", args.old), ("new", args.new)):
            cache = f"{tmp}/cache_{tag}"
            res[tag] = [run_job(tree, cache, f"{tmp}/out_{tag}_{i}") for i in range(2)]
        size = "60E1 h=10 mm, 1319 DOFs, 92 f"
        for i, what in enumerate(("cold", "warm")):
            row(f"main job {what}, wall", size, res["old"][i][0], res["new"][i][0])
            row(f"main job {what}, CPU", size, res["old"][i][1], res["new"][i][1])
    rng = [150.0, 600.0, 1500.0, 3000.0, 6000.0]
    if not args.quick:
        o, n = (run_child(t, "kofw", h=0.005, method="shift-invert", n_waves=50, freqs=rng)
                for t in (args.old, args.new))
        row("k(omega) per frequency, shift-invert", f"60E1 h=5 mm, {n['n']} DOFs, 50 w",
            o["t"], n["t"])
    for method in ("shift-invert", "dense"):
        o, n = (run_child(t, "kofw", h=0.01, method=method, n_waves=50, freqs=rng[:2])
                for t in (args.old, args.new))
        row(f"k(omega) per frequency, {method}", f"60E1 h=10 mm, {n['n']} DOFs, 50 w",
            o["t"], n["t"])
    for nw in (100, 50):
        o, n = (run_child(t, "mobility", n_waves=nw) for t in (args.old, args.new))
        row(f"free-rail receptance, {nw} waves", "h=10 mm, 12 f x 401 x", o["t"], n["t"])
    o, n = (run_child(t, "labels") for t in (args.old, args.new))
    row("waves.solve (labels included)", "h=10 mm, 4 f, 2 families", o["t"], n["t"])
    row("  of which labelling", "", o["labels"], n["labels"])
    emit(lines, f"# labelling share of waves.solve: old {o['labels'] / o['t']:.1%}, new "
                f"{n['labels'] / n['t']:.1%} (waves.solve(labels=False) skips it)")
    if not args.quick:
        o = run_child(args.old, "eta", new=False)
        n = run_child(args.new, "eta", new=True)
        row("kernel at another eta_r (0.01 -> 0.03)",
            f"site, {n['nf']} f, {n['n_sets']} spring sets", o["t"], n["t"])
        s = run_child(args.new, "sensitivity")
        emit(lines, "# first-order sensitivity (shapes kept, one Newton step on k per wave) "
                    "from eta_r = 0.01, max relative error of the free-rail receptance at "
                    "x = 0, 0.6, 6, 40 m, 100-5500 Hz, against fresh waves:")
        emit(lines, "#   " + ", ".join(f"eta_r {e}: {v:.1e}" for e, v in s.items()))
    args.out.write_text("\n".join(lines) + "\n")


def emit(lines, line=None):
    if line is not None:
        lines.append(line)
        sys.stdout.write(line + "\n")
    else:
        sys.stdout.write("\n".join(lines) + "\n")
    sys.stdout.flush()


if __name__ == "__main__":
    main()
