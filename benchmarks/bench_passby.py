"""Benchmark of the pass-by: 24 wheels, 0.1 m steps over +-60 m, 1/9-octave 100 Hz - 5 kHz,
rigid wheels, on the WFE discrete site track; and the flexible-wheel mobility 0 - 10 kHz.

    python benchmarks/bench_passby.py [--threads 1] [--out benchmarks/results/results_passby.txt]

Rows: the track kernel (rail tables: 6 force positions in a span x responses at 0.1 m over
+-max_distance, head and foot, by railfem.simulate.passby.rail_tables), then the pass-by
after it (exact form = the baseline; paper's form; no interaction; the time signal at
25.6 kHz) and the flexible wheel (mesh, every harmonic with a mode below 15 kHz (n <= 20),
receptance on
a 1 Hz grid 1 Hz - 10 kHz). Time and the ratio to the baseline, measured in this run.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from _common import limit_threads, machine_lines


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--threads", type=int, default=1, help="BLAS threads (default 1)")
    p.add_argument("--max-distance", type=float, default=30.0, help="rail tables reach (m)")
    p.add_argument("--out", type=Path,
                   default=Path(__file__).resolve().parent / "results" / "results_passby.txt")
    args = p.parse_args(argv)
    limit_threads(args.threads)
    import numpy as np

    from railfem.wheelrail import contact
    from railfem.wheelrail import roughness
    from railfem.wheelrail import wheels
    from railfem.simulate import passby as P, signals
    from railfem.simulate.train import default_train
    from railfem.standards import iec61260
    from railfem.spec import preset

    f = iec61260.ninth_octave_grid(100, 5000)
    train = default_train()
    t0 = time.perf_counter()
    tables = P.rail_tables(preset("site", model="wfe-discrete"), f, max_distance=args.max_distance)
    t_tab = time.perf_counter() - t0
    V = 216 / 3.6
    hz = contact.hertz()
    r = roughness.amplitude_at(roughness.sloped_spectrum(), f, V) * np.sqrt(
        contact.analytical_filter(2 * np.pi * f / V * hz.a))
    aw, ac = wheels.RigidWheel().receptance(f), contact.contact_receptance(hz, f)
    # +-60 m: leading wheel from 60 m before the sensor to 60 m past it minus the train
    pos = np.round(np.arange(-600, 601) * 0.1 + 0.3, 10)
    rows = []

    def run(name, fn):
        t = time.perf_counter()
        out = fn()
        rows.append((name, time.perf_counter() - t))
        return out

    res = run("pass-by, exact form", lambda: P.simulate_passby(tables, train, aw, ac, r,
                                                               positions=pos))
    run("pass-by, paper's form", lambda: P.simulate_passby(tables, train, aw, ac, r,
                                                           positions=pos, form="paper"))
    run("pass-by, no interaction", lambda: P.simulate_passby(tables, train, aw, ac, r,
                                                             positions=pos, interaction=False))
    run("time signal 25.6 kHz", lambda: signals.synthesise(
        res, train, V, quasi=signals.quasi_static(preset("site"), 78.5e3), noise_fraction=0.1,
        position_error=0.1, seed=0))
    wheel = run("flexible wheel modes n<=20, 15 kHz", lambda: wheels.flexible_wheel(
        f_max=10000.0))
    run("flexible wheel receptance 10^4 freqs", lambda: wheel.receptance(
        np.arange(1.0, 10001.0)))
    base = rows[0][1]
    lines = ["# railfem pass-by benchmark", *machine_lines(args.threads),
             f"# site track, WFE discrete (131 supports), {len(f)} frequencies 100 Hz - 5 kHz, "
             f"{train.n_wheels} wheels, {len(pos)} positions (0.1 m over +-60 m), "
             f"tables {len(tables.response_x)} x {len(tables.force_x)} positions",
             f"# track kernel (rail tables, not part of the 30 s budget): {t_tab:.1f} s",
             f"{'step':<40}{'time (s)':>10}{'ratio':>8}"]
    lines += [f"{name:<40}{t:>10.2f}{t / base:>8.2f}" for name, t in rows]
    text = "\n".join(lines) + "\n"
    args.out.write_text(text)
    print(text, end="")


if __name__ == "__main__":
    main()
