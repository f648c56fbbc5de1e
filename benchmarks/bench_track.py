"""Benchmark of the supported WFE track: a full 1/9-octave sweep (30 points per decade,
50 Hz - 8 kHz) of the site track, head and foot responses at the 29 EN 15461 positions for
every force position at 0.1 m steps in a span.

    python benchmarks/bench_track.py [--h 10] [--threads 1] [--out benchmarks/results_track.txt]

Rows: the discrete model (131 supports x 8 foot springs, the baseline), the same with 261
supports, and the infinite periodic model (Floquet, 512 angles); time, time per frequency,
peak resident memory growth and the ratio to the baseline, all measured in this run.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from _common import limit_threads, machine_lines


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--h", type=float, default=10.0, help="element size in mm (default 10)")
    p.add_argument("--threads", type=int, default=1, help="BLAS threads (default 1)")
    p.add_argument("--out", type=Path, default=Path(__file__).with_name("results_track.txt"))
    args = p.parse_args(argv)
    limit_threads(args.threads)
    import resource

    import numpy as np

    from railfem import meshing, mobility, supports, track, waveguide
    from railfem.materials import Material
    from railfem.standards import en15461, iec61260

    tp = supports.preset("site")
    mesh = meshing.get_mesh("60E1", args.h * 1e-3)
    guide = waveguide.assemble(mesh, Material.steel(tp.eta_r))
    load = mobility.head_patch(guide, 0.02)
    outs = [mobility.point(guide, "head_top"), mobility.point(guide, "foot_sensor")]
    f = iec61260.ninth_octave_grid(50, 8000)
    fx = np.round(np.arange(0, tp.spacing + 1e-9, 0.1), 10)
    rx = tp.spacing / 2 + en15461.hammer_positions(tp.spacing)
    runs = {
        "discrete, 131 supports": lambda: track.discrete_receptance(
            guide, supports.uniform_layout(tp.support, tp.spacing, 131), f, load=load,
            outputs=outs, force_x=fx, response_x=rx),
        "discrete, 261 supports": lambda: track.discrete_receptance(
            guide, supports.uniform_layout(tp.support, tp.spacing, 261), f, load=load,
            outputs=outs, force_x=fx, response_x=rx),
        "periodic (Floquet)": lambda: track.periodic_receptance(
            guide, tp.support, tp.spacing, f, load=load, outputs=outs, force_x=fx,
            response_x=rx),
    }
    lines = ["# railfem supported-track benchmark", *machine_lines(args.threads),
             f"# 60E1 h = {args.h:g} mm, {guide.n_dofs} DOFs "
             f"({guide.families['symmetric'].T.shape[1]} in the symmetric family solved), "
             f"{len(f)} frequencies, {len(fx)} force x {len(rx)} response positions x 2 outputs",
             f"{'model':<26}{'time (s)':>10}{'s/freq':>9}{'peak RSS +MB':>14}{'ratio':>8}"]
    base = None
    for name, run in runs.items():
        rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        t0 = time.perf_counter()
        run()
        dt = time.perf_counter() - t0
        rss = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0) / 1024
        base = base or dt
        lines.append(f"{name:<26}{dt:>10.1f}{dt / len(f):>9.2f}{rss:>14.0f}{dt / base:>8.2f}")
        sys.stdout.write(lines[-1] + "\n")
    text = "\n".join(lines) + "\n"
    args.out.write_text(text)
    sys.stdout.write(text)


if __name__ == "__main__":
    main()
