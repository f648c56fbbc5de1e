"""Benchmark of the supported track through the model door (railfem.models).

    python benchmarks/bench_track.py [--threads 1] [--no-job]
        [--out benchmarks/results/results_track.txt]

Problem: the site track of METHOD.md Table 1, 60E1 h = 10 mm, the 69 frequencies of the
1/9-octave grid 50 Hz - 8 kHz, the 29 EN 15461 hammer positions, head and foot sensor.
Per model: the direct solve of railfem before the kernel + coupling split (the frozen copy
in tests/reference/track_4bb7c79.py, the baseline), the first evaluation through the door
(cold kernel cache: waves, Green's functions and coupling), and a re-evaluation with new
pad and ballast parameters (the kernel from memory, the coupling solve only). Then the
main job ``railfem track --preset site`` for wfe-discrete and wfe-periodic (cold cache, in
a subprocess, wall time). All measured in this run; ratios to the baseline.
"""
from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import limit_threads, machine_lines

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--threads", type=int, default=1, help="BLAS threads (default 1)")
    p.add_argument("--no-job", action="store_true", help="skip the two main-job runs")
    p.add_argument("--out", type=Path,
                   default=Path(__file__).resolve().parent / "results" / "results_track.txt")
    args = p.parse_args(argv)
    limit_threads(args.threads)
    sys.path.insert(0, str(ROOT))
    import numpy as np

    import railfem as rf
    from railfem import models
    from railfem.track import beams
    from railfem.track import supports
    from railfem.track.kernelcache import KernelStore
    from railfem.standards import iec61260
    from tests.reference import track_4bb7c79 as ref

    f = iec61260.ninth_octave_grid(50, 8000)
    lines = ["# railfem supported-track benchmark (model door)", *machine_lines(args.threads),
             f"# site track, 60E1 h = 10 mm, {len(f)} frequencies, 29 EN 15461 positions, "
             "head and foot; times in s",
             f"{'model':<22}{'baseline':>10}{'first':>9}{'re-eval':>9}{'first/base':>12}"
             f"{'re-eval/base':>14}{'max |diff|/max':>16}"]
    sys.stdout.write("\n".join(lines) + "\n")
    new_params = dict(kp=300e6, eta_p=0.15, kb=60e6, eta_b=0.8)
    for model in ("wfe-discrete", "wfe-periodic", "timoshenko-discrete"):
        spec = rf.preset("site", model=model)
        xs, pos, hx = models.hammer_x(spec)
        t0 = time.perf_counter()
        old = _baseline(ref, spec, f, hx, xs, np, beams, supports, models)
        t_base = time.perf_counter() - t0
        with tempfile.TemporaryDirectory() as cache:
            store = KernelStore(directory=cache)
            t0 = time.perf_counter()
            new = models.receptance(spec, f, hx, [xs], cache=store)
            t_first = time.perf_counter() - t0
            t0 = time.perf_counter()
            models.receptance(spec.replace(**new_params), f, hx, [xs], cache=store)
            t_re = time.perf_counter() - t0
        diff = np.abs(new - old).max() / np.abs(old).max()
        lines.append(f"{model:<22}{t_base:>10.2f}{t_first:>9.2f}{t_re:>9.3f}"
                     f"{t_first / t_base:>12.2f}{t_re / t_base:>14.4f}{diff:>16.1e}")
        sys.stdout.write(lines[-1] + "\n")
    if not args.no_job:
        lines.append("# main job, `railfem track --preset site --model M` (cold kernel cache, "
                     "subprocess wall time incl. imports and plots)")
        base = None
        for model in ("wfe-discrete", "wfe-periodic"):
            with tempfile.TemporaryDirectory() as tmp:
                env = dict(os.environ, PYTHONPATH=str(ROOT), RAILFEM_CACHE=f"{tmp}/cache")
                t0 = time.perf_counter()
                subprocess.run([sys.executable, "-m", "railfem.cli", "-q", "track", "--preset",
                                "site", "--model", model, "--out", f"{tmp}/out"], env=env,
                               check=True, capture_output=True)
                dt = time.perf_counter() - t0
            base = base or dt
            lines.append(f"job {model:<18}{dt:>10.1f} s   ratio to wfe-discrete {dt / base:.2f}")
            sys.stdout.write(lines[-1] + "\n")
    text = "\n".join(lines) + "\n"
    args.out.write_text(text)
    sys.stdout.write(text)


def _baseline(ref, spec, f, hx, xs, np, beams, supports, models):
    """Receptance (nf, 2, 1, 29) by the pre-split direct solves (re-centred like the job)."""
    d = spec.spacing
    if spec.model == "wfe-periodic":
        rail = models.wfe_rail(spec.rail, spec.numerics.patch_width, 8)
        outs = [rail.outputs["head"], rail.outputs["foot"]]
        return ref.periodic_receptance(rail.guide, spec.support, d, f, load=rail.load,
                                       outputs=outs, force_x=hx, response_x=[xs])
    rx = np.array([xs])
    c = np.round((rx[:, None] + hx[None, :]) / (2 * d)) * d
    uf, jf = np.unique(np.round(hx[None, :] - c, 10), return_inverse=True)
    ur, jr = np.unique(np.round(rx[:, None] - c, 10), return_inverse=True)
    jf, jr = jf.reshape(c.shape), jr.reshape(c.shape)
    lay = supports.uniform_layout(spec.support, d, 131)
    if spec.model == "timoshenko-discrete":
        bs = models.beam_section(spec.rail)
        a = ref.discrete_track_receptance(bs, lay, 2 * np.pi * f, uf, ur)
        a = np.repeat(np.asarray(a)[:, None], 2, axis=1)
    else:
        rail = models.wfe_rail(spec.rail, spec.numerics.patch_width, 8)
        outs = [rail.outputs["head"], rail.outputs["foot"]]
        a = ref.discrete_receptance(rail.guide, lay, f, load=rail.load, outputs=outs,
                                    force_x=uf, response_x=ur)
    return a[:, :, jr, jf]


if __name__ == "__main__":
    main()
