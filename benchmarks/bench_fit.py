"""Benchmark of the fit (railfem.identify): the 29-position refsim hammer dataset (head and
foot, 69 frequencies; point + transfers + decay rate) and the SBB decay-rate table.

    python benchmarks/bench_fit.py [--workers 2] [--skip-sbb]
        [--out benchmarks/results/results_fit.txt]

Rows (cold: kernels in memory only, nothing from the disk cache):
* baseline: one evaluation of the door (railfem.models.receptance) at the dataset geometry,
  kernel included — what a fit without the kernel + coupling split would pay per call;
* one coupling re-evaluation through the door vs through the eigen form;
* the wfe-discrete fit of five support parameters (kp, eta_p, kb, eta_b, ms), eight starts;
* the wfe-discrete fit of six (+ eta_r, profiled over kernel nodes), eight starts;
* the timoshenko-discrete fit of six; the SBB table (16 vertical rows, decay rate only,
  kp, eta_p, kb, eta_b, eta_r) with timoshenko-discrete and wfe-discrete on a LocalCluster.
Ratios are to the baseline of the same run.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from _common import limit_threads, machine_lines

SHARED = Path("/work/shared")


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--skip-sbb", action="store_true")
    p.add_argument("--out", type=Path,
                   default=Path(__file__).resolve().parent / "results" / "results_fit.txt")
    args = p.parse_args(argv)
    limit_threads(1)
    import logging

    import numpy as np

    import railfem as rf
    from railfem import models
    from railfem.jobs.fit import run_fit
    from railfem.identify import fit
    from railfem.identify.forward import SpectralEngine, Geometry
    from railfem.io import read_measurement
    from railfem.track.supports import dynamic_stiffness

    logging.basicConfig(level=logging.WARNING)
    meas = read_measurement(SHARED / "datasets/refsim_site")
    f = meas.frequency
    fx = meas.sensor_x + meas.positions
    spec = rf.preset("site")
    rows = []

    t = time.perf_counter()
    models.receptance(spec, f, fx, [meas.sensor_x], cache=False)
    base = time.perf_counter() - t
    rows.append(("door evaluation, kernel included (baseline)", "1 eval", base))
    t = time.perf_counter()
    models.receptance(spec.replace(kp=300e6), f, fx, [meas.sensor_x], cache=False)
    rows.append(("door re-evaluation (coupling solve)", "1 eval", time.perf_counter() - t))
    t = time.perf_counter()
    eng = SpectralEngine(spec, Geometry(frequency=f, outputs=("head", "foot"),
                                        sensor_x=meas.sensor_x, force_x=fx), cache=False)
    rows.append(("eigen form of the coupling, built once", "1 kernel", time.perf_counter() - t))
    Ks = dynamic_stiffness(spec.support, 2 * np.pi * f)
    t = time.perf_counter()
    for _ in range(50):
        eng.coupling.receptance(Ks)
    rows.append(("eigen-form re-evaluation", "1 eval", (time.perf_counter() - t) / 50))

    use = ("point", "transfer", "tdr")
    five = ("kp", "eta_p", "kb", "eta_b", "ms")
    for model, names, label in (
            ("wfe-discrete", five, "wfe-discrete fit, 5 support parameters"),
            ("wfe-discrete", five + ("eta_r",), "wfe-discrete fit, 6 (+ eta_r profiled)"),
            ("timoshenko-discrete", five + ("eta_r",), "timoshenko-discrete fit, 6")):
        t = time.perf_counter()
        r = fit(meas, model, parameters=names, use=use, n_starts=8, workers=args.workers,
                cache=False)
        dt = time.perf_counter() - t
        rows.append((label, f"8 starts, {args.workers} proc, "
                     f"{sum(s['nfev'] for s in r.starts)} evals", dt))
    if not args.skip_sbb:
        table = SHARED / "measured_data/sbb_niederwangen/tdr_niederwangen_wide.csv"
        for model in ("timoshenko-discrete", "wfe-discrete"):
            with tempfile.TemporaryDirectory() as tmp:
                t = time.perf_counter()
                run_fit(table, Path(tmp) / "o", model=model, select="dir=v", campaign=True,
                        parameters=("kp", "eta_p", "kb", "eta_b", "eta_r"),
                        workers=args.workers, profiles=(), cache=False)
                rows.append((f"SBB table, {model}", "16 rows, tdr only",
                             time.perf_counter() - t))
    lines = ["# railfem fit benchmark (refsim_site: 69 frequencies x 29 positions x head/foot)"]
    lines += machine_lines(1)
    lines.append(f"{'case':48s} {'size':34s} {'time (s)':>10s} {'ratio':>8s}")
    for name, size, sec in rows:
        lines.append(f"{name:48s} {size:34s} {sec:10.3f} {sec / base:8.3f}")
    text = "\n".join(lines) + "\n"
    sys.stdout.write(text)
    args.out.write_text(text)


if __name__ == "__main__":
    main()
