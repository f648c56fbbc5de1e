"""Benchmark: one evaluation of a track with deviating supports on wfe-discrete, the
direct full coupling solve against the low-rank (Woodbury) update of the diagnosis.

    python benchmarks/bench_woodbury.py                     # site preset, 1/9 oct 50-5000 Hz
    python benchmarks/bench_woodbury.py --f-high 2000 --h 0.02

The geometry is an EN 15461 hammer test (29 positions, head sensor at mid-span). Two
effects: voided_sleeper (support 2, ballast factor 0.05) and random_support (pad and
ballast factors on its 33 window supports, seeded). Direct: railfem.models.receptance
(the door: the supports at absolute positions, n_supports raised so 20 m of supports lie
beyond every position, as the diagnosis's door path does), timed with its kernel warm, so
the time is the coupling solve. Woodbury: railfem.diagnosis.evaluate.Evaluator on the
record's own (re-centred) kernel, its one-off set-up (kernel + per-frequency eigen form)
reported apart, then per evaluation and per evaluation with the closed-form tangents.
The Jacobian of a refit over the support factors: the door has no derivatives, so
forward differences cost (1 + parameters) solves ("jac direct s", computed from the
measured direct time: 2 solves for voided_sleeper's one fitted factor, 67 for the 66
factors of random_support), the Woodbury path one call with its closed-form tangents
("+tang s"). Both in the same run; "ratio" is direct / Woodbury per evaluation, "jac
ratio" per Jacobian; "diff" is the largest difference of the two (relative to each
frequency's point receptance: the two solve supports re-centred on each pair vs at
absolute positions, which differ by the truncation of the supported stretch). Written to
benchmarks/results/results_woodbury.txt.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from _common import limit_threads, machine_lines


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--f-high", type=float, default=5000.0)
    p.add_argument("--h", type=float, default=0.01, help="rail section element size (m)")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--out", type=Path,
                   default=Path(__file__).resolve().parent / "results" / "results_woodbury.txt")
    return p.parse_args(argv)


def best(fn, n):
    out, t = None, math.inf
    for _ in range(n):
        t0 = time.perf_counter()
        out = fn()
        t = min(t, time.perf_counter() - t0)
    return out, t


def main(argv=None):
    args = parse_args(argv)
    limit_threads(args.threads)
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    import numpy as np

    import railfem as rf
    from benchmarks.blind import generators as g
    from railfem import models
    from railfem.diagnosis import prepare
    from railfem.diagnosis.effects import random_support, voided_sleeper
    from railfem.diagnosis.evaluate import MARGIN, Evaluator
    from railfem.spec import RailSpec
    from railfem.standards import en15461

    f = g.frequencies(low=50.0, high=args.f_high)
    spec = rf.preset("site", model="wfe-discrete", pad_length=0.0,
                     rail=RailSpec(h=args.h)).replace(**g.TRUTH)
    pos = en15461.hammer_positions(spec.spacing).astype(float)
    pos[0] = models.POINT_OFFSET
    rec = prepare(g.measurement(np.ones((len(f), 1, len(pos)), complex), pos, f)).records[0]
    t = rec.fit
    rng = np.random.default_rng(0)
    cases = {
        "voided_sleeper": voided_sleeper.apply(spec, {"index": 2, "kb_factor": 0.05}),
        "random_support": random_support.apply(spec, {
            p.name: float(np.exp(rng.normal(0, 0.3))) for p in random_support.EFFECT.parameters}),
    }
    n_far = 2 * math.ceil((max(np.abs(t.force_x).max(), abs(t.sensor_x)) + MARGIN)
                          / spec.spacing) + 1
    n_p = spec.numerics.n_foot_springs
    lines = ["One evaluation of deviating supports on wfe-discrete: direct coupling solve "
             "vs Woodbury update", *machine_lines(args.threads),
             f"  {len(f)} frequencies {f[0]:.0f}-{f[-1]:.0f} Hz, {len(pos)} hammer positions, "
             f"rail h {args.h * 1e3:g} mm, {n_p} springs per support; direct: {n_far} "
             f"supports ({n_far * n_p} springs, absolute positions); Woodbury: "
             f"{spec.n_supports} supports re-centred per pair; best of {args.repeat}", "",
             f"{'effect':16s} {'supports':>8s} {'springs':>8s} {'direct s':>9s} "
             f"{'setup s':>8s} {'wood s':>8s} {'+tang s':>8s} {'ratio':>7s} "
             f"{'jac direct s':>12s} {'jac ratio':>9s} {'diff':>8s}"]
    ev = Evaluator(cache=False)
    for name, dev in cases.items():
        far = dev.replace(n_supports=n_far)
        models.receptance(far, f, t.force_x, [t.sensor_x], outputs=t.outputs)  # kernel
        ref, t_dir = best(lambda: models.receptance(far, f, t.force_x, [t.sensor_x],
                                                    outputs=t.outputs)[:, :, 0, :], args.repeat)
        t0 = time.perf_counter()
        ev.receptance(dev, rec)
        setup = time.perf_counter() - t0
        got, t_wood = best(lambda: ev.receptance(dev, rec), args.repeat)
        _, t_tan = best(lambda: ev.tangents(dev, rec), args.repeat)
        diff = float((np.abs(got - ref) / np.abs(ref[:, :, :1])).max())
        m = len(dev.deviations)
        n_par = len([p for p in (voided_sleeper.EFFECT if name == "voided_sleeper" else
                                 random_support.EFFECT).continuous])
        jac = (1 + n_par) * t_dir
        lines.append(f"{name:16s} {m:8d} {m * n_p:8d} {t_dir:9.3f} {setup:8.2f} "
                     f"{t_wood:8.3f} {t_tan:8.3f} {t_dir / t_wood:7.1f} {jac:12.1f} "
                     f"{jac / t_tan:9.1f} {diff:8.1e}")
    lines += ["", "  setup: once per record and rail loss factor (the kernel is the base fit's "
              "own when it ran before; here it includes the kernel)"]
    text = "\n".join(lines) + "\n"
    print(text)
    from railfem.atomic import write_text

    write_text(args.out, text)


if __name__ == "__main__":
    main()
