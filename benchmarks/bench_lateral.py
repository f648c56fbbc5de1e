"""Benchmark of the lateral track job and its coupling solves.

    python benchmarks/bench_lateral.py --base /tmp/base_tree [--threads 1] [--no-base-cold]
        [--out benchmarks/results/results_lateral.txt]

Problem: ``railfem track --preset site --support-directions zyx`` (wfe-discrete, 60E1
h = 10 mm, 131 supports x 3 spring rows, 4 springs across the foot in 3 directions, the 69
frequencies of the 1/9-octave grid 50 Hz - 8 kHz, the 29 EN 15461 hammer positions, the
vertical load and the lateral one).

1. The job, cold (empty kernel cache) and warm, with this tree and with ``--base`` (a git
   worktree of the code to compare with, run through PYTHONPATH), each in a subprocess:
   wall time and CPU time (user + system of the subprocess; on a shared machine the CPU
   time is the comparable figure). The output CSVs of the two trees compared.
2. The coupling alone on the job's two kernels (from the warm cache): the dense solve
   (mirror halves, family split) against the chain of waves (railfem.track.semiseparable),
   CPU per frequency and the largest difference relative to each frequency's largest
   receptance.
"""
from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import limit_threads, machine_lines

ROOT = Path(__file__).resolve().parents[1]
ARGS = ["track", "--preset", "site", "--support-directions", "zyx"]


def run_job(tree: Path, cache: Path, out: Path) -> tuple[float, float]:
    """(wall s, CPU s) of the job run from ``tree`` in a subprocess."""
    env = dict(os.environ, RAILFEM_CACHE=str(cache), PYTHONPATH=str(tree))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "railfem.cli", *ARGS, "--out", str(out)], env=env,
                   check=True, cwd=tree, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def compare_outputs(a: Path, b: Path) -> list[str]:
    """Differences of b's CSVs against a's."""
    import numpy as np
    from railfem.io.frf_csv import read_frf_csv

    lines = []
    for name in ("transfer_mobility.csv", "transfer_mobility_lateral.csv"):
        x, y = read_frf_csv(a / name).values, read_frf_csv(b / name).values
        d = np.abs(x - y)
        lines.append(f"  {name}: largest difference {(d / np.abs(x).max(axis=0)).max():.1e} "
                     f"of its transfer function's largest value; "
                     f"{int(np.sum(d > 1e-6 * np.abs(x)))} of {x.size} entries differ by "
                     f"more than 1e-6 of their own value")

    def rows(p):
        return [r for r in p.read_text().splitlines() if not r.startswith("#")][1:]

    for name in ("decay_rate.csv", "along_rail.csv"):
        ra, rb = rows(a / name), rows(b / name)
        same = sum(p == q for p, q in zip(ra, rb))
        extra = ""
        if name == "along_rail.csv":
            za = np.array([complex(*map(float, r.split(",")[4:6])) for r in ra])
            zb = np.array([complex(*map(float, r.split(",")[4:6])) for r in rb])
            extra = f", largest difference {np.abs(za - zb).max() / np.abs(za).max():.1e} " \
                    "of the table's largest value"
        lines.append(f"  {name}: {same} of {len(ra)} rows identical as text{extra}")
    return lines


def coupling_rows(cache: Path) -> list[str]:
    import numpy as np
    from railfem import models, spec as S
    from railfem.jobs.track import JobSettings
    from railfem.track import wfe as track
    from railfem.track.coupling import couple_discrete

    spec = S.preset("site", support_directions="zyx")
    f = JobSettings().frequency()
    xs, pos, hammer = models.hammer_x(spec)
    span = np.round(np.arange(0.0, spec.spacing + 1e-9, 0.1), 10)
    along = np.round(np.arange(-6.0, 6.0 + 1e-9, 0.1), 10)
    cases = [("vertical load", models.discrete_kernel(
                  spec, f, np.concatenate([hammer, span]), np.concatenate([[xs], along]),
                  cache=str(cache))[0]),
             ("lateral load", models.discrete_kernel(
                  spec, f, hammer, [xs], outputs=models.LATERAL, force="head_lateral",
                  cache=str(cache))[0])]
    lines = []
    for name, kernel in cases:
        K = track.spring_stiffness(spec.layout(), 2 * np.pi * f, kernel)
        t = {}
        out = {}
        for method in ("dense", "chain"):
            c0 = time.process_time()
            out[method] = couple_discrete(kernel, K, method=method)
            t[method] = (time.process_time() - c0) / len(f)
        d, c = out["dense"], out["chain"]
        err = (np.abs(c - d).max(axis=(1, 2, 3)) / np.abs(d).max(axis=(1, 2, 3))).max()
        n_s, n_p, n_rx, n_fx = kernel.shape
        lines.append(f"  {name}: {n_s} sets x {n_p} springs, {n_rx} x {n_fx} response x "
                     f"force positions; CPU per frequency dense {t['dense']:.3f} s, chain "
                     f"{t['chain']:.3f} s, ratio {t['dense'] / t['chain']:.1f}; largest "
                     f"difference {err:.1e} of the frequency's largest receptance")
    return lines


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--base", type=Path, required=True,
                   help="a worktree of the code to compare with (git worktree add DIR REV)")
    p.add_argument("--threads", type=int, default=1, help="BLAS threads (default 1)")
    p.add_argument("--no-base-cold", action="store_true", help="skip the base's cold run")
    p.add_argument("--out", type=Path,
                   default=Path(__file__).resolve().parent / "results" / "results_lateral.txt")
    args = p.parse_args(argv)
    limit_threads(args.threads)
    sys.path.insert(0, str(ROOT))
    tmp = Path(tempfile.mkdtemp(prefix="bench_lateral_"))
    lines = [f"Lateral track job: railfem {' '.join(ARGS)} --out DIR",
             "Reproduce: python benchmarks/bench_lateral.py --base DIR (DIR: git worktree "
             "add DIR <rev>)", *machine_lines(args.threads), ""]
    runs = {}
    for label, tree in (("new", ROOT), ("base", args.base.resolve())):
        cache = tmp / f"cache_{label}"
        for state in ("cold", "warm"):
            if label == "base" and state == "cold" and args.no_base_cold:
                continue
            runs[label, state] = run_job(tree, cache, tmp / f"out_{label}_{state}")
            print(label, state, runs[label, state], flush=True)
    lines.append("job                      wall (s)   CPU (s)   CPU ratio base/new")
    for state in ("cold", "warm"):
        for label in ("base", "new"):
            if (label, state) in runs:
                w, c = runs[label, state]
                ratio = ""
                if label == "new" and ("base", state) in runs:
                    ratio = f"{runs['base', state][1] / c:9.1f}"
                lines.append(f"  {state:5s} {label:5s}          {w:9.1f} {c:9.1f}   {ratio}")
    lines += ["", "outputs, new against base (warm runs):",
              *compare_outputs(tmp / "out_base_warm", tmp / "out_new_warm"),
              "", "coupling alone on the job's kernels (this tree, in process):",
              *coupling_rows(tmp / "cache_new")]
    args.out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
