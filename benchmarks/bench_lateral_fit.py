"""Benchmark of a lateral decay-rate fit: the coupling solve per evaluation against the
eigen form in the lateral stiffness (railfem.track.directional).

    python benchmarks/bench_lateral_fit.py [--threads 1] [--section B1] [--starts 8]
        [--engine direct|eigen|both] [--out benchmarks/results/results_lateral_fit.txt]

Problem: the first lateral ('h') row of the SBB Niederwangen decay-rate table for
``--section``, fitted with wfe-discrete (the fit's base: site preset, point supports,
131 supports) with supports acting in z, y, x; parameters kp_lat, eta_p_lat, kb_lat,
eta_b_lat; noise-only residuals, no profiles, one process. ``railfem fit`` itself has no
option for the support directions, so the fit is run through the library
(railfem.identify.fit.fit with a base spec). Each engine in its own subprocess with an
empty kernel cache (cold: the wave solves and the kernel included); wall and CPU time,
the estimates of both.

Engines: 'direct', what the fit does today for lateral data (one coupling solve per
evaluation, railfem.track.coupling.couple_discrete); 'eigen', the lateral springs in eigen
form, the vertical and longitudinal ones eliminated once per frequency
(railfem.track.directional.directional_spectral), then a short sum per evaluation. The
eigen engine is defined here: railfem.identify.forward does not select it yet.
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

from _common import limit_threads, machine_lines

ROOT = Path(__file__).resolve().parents[1]
TABLE = ROOT.parent / "shared" / "measured_data" / "sbb_niederwangen" / "tdr_niederwangen_wide.csv"
PARAMETERS = ("kp_lat", "eta_p_lat", "kb_lat", "eta_b_lat")


def one_fit(engine: str, section: str, starts: int, cache: str) -> dict:
    """The fit in this process; returns estimates and times."""
    import dataclasses

    import numpy as np

    from railfem import models
    from railfem.identify.base import default_base
    from railfem.identify.fit import fit, prepare
    from railfem.io.data import read_data
    from railfem.track import wfe as track
    from railfem.track.directional import directional_spectral
    from railfem.track.directions import directional_stiffness

    _, items = read_data(str(TABLE), select={"direction": "h", "section": section}, row=0)
    meas = items[0][1]
    base = dataclasses.replace(default_base("wfe-discrete", spacing=0.6),
                               support_directions="zyx")
    t0, c0 = time.perf_counter(), time.process_time()
    forward, _ = prepare(meas, "wfe-discrete", parameters=PARAMETERS, base=base, bounds=None,
                         use=None, cache=cache, forward=None, target_options=None)
    if engine == "eigen":
        g = forward.geometry
        omega = 2 * np.pi * g.frequency

        class Eigen:
            """The lateral springs' stiffness in eigen form (the others held at base)."""

            def __init__(self, spec):
                kernel, jr, jf = models.discrete_kernel(
                    spec, g.frequency, g.force_x, [g.sensor_x], outputs=g.outputs,
                    force=g.force, cache=cache)
                lay = spec.layout()
                self.pattern = lay.springs().weight
                self.held = (spec.support.kp, spec.support.eta_p, spec.support.kb,
                             spec.support.eta_b, spec.support.ms)
                k = lay.spring_stiffness(omega, "y") / self.pattern[None, :]
                assert np.allclose(k, directional_stiffness(spec.support, omega, "y")[:, None])
                self.form = directional_spectral(
                    kernel, track.spring_stiffness(lay, omega, kernel), self.pattern, "y",
                    jr[0], jf[0])

            def receptance(self, spec):
                s = spec.support
                assert (s.kp, s.eta_p, s.kb, s.eta_b, s.ms) == self.held
                return self.form.receptance(directional_stiffness(s, omega, "y"))

        engine_obj = Eigen(forward.space.base)
        forward.engine = lambda spec: engine_obj
    t1 = time.perf_counter()
    res = fit(meas, base=base, parameters=PARAMETERS, workers=1, cache=cache,
              discrepancy=None, profiles=(), n_starts=starts, forward=forward)
    return {"engine": engine, "wall_s": time.perf_counter() - t0,
            "cpu_s": time.process_time() - c0, "prepare_s": t1 - t0,
            "estimates": {p["name"]: p["value"] for p in res.parameters},
            "residual_rms": {k: float(v) for k, v in res.residual_rms.items()}}


def run(engine: str, section: str, starts: int, threads: int) -> dict:
    """one_fit in a subprocess with an empty kernel cache; CPU time of the subprocess."""
    cache = tempfile.mkdtemp(prefix="bench_lateral_fit_")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run([sys.executable, __file__, "--child", engine, "--section", section,
                          "--starts", str(starts), "--threads", str(threads), "--cache",
                          cache], env=env, check=True, capture_output=True, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    r = json.loads(out.stdout.strip().splitlines()[-1])
    r["cpu_process_s"] = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return r


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--section", default="B1")
    p.add_argument("--starts", type=int, default=8)
    p.add_argument("--engine", default="both", choices=("direct", "eigen", "both"))
    p.add_argument("--child", help=argparse.SUPPRESS)
    p.add_argument("--cache", help=argparse.SUPPRESS)
    p.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "results"
                   / "results_lateral_fit.txt")
    args = p.parse_args(argv)
    limit_threads(args.threads)
    if args.child:
        print(json.dumps(one_fit(args.child, args.section, args.starts, args.cache)))
        return
    engines = ("direct", "eigen") if args.engine == "both" else (args.engine,)
    rows = {e: run(e, args.section, args.starts, args.threads) for e in engines}
    lines = [f"Lateral decay-rate fit: SBB Niederwangen, first 'h' row of section "
             f"{args.section}, wfe-discrete zyx, parameters {', '.join(PARAMETERS)}, "
             f"{args.starts} starts, one process, cold kernel cache",
             "Reproduce: python benchmarks/bench_lateral_fit.py", *machine_lines(args.threads),
             "", "engine   wall (s)  CPU (s)  of which kernel + engine build (wall s)"]
    for e, r in rows.items():
        lines.append(f"  {e:7s} {r['wall_s']:8.1f} {r['cpu_process_s']:8.1f} "
                     f"{r['prepare_s']:8.1f}")
    lines.append("")
    for e, r in rows.items():
        est = ", ".join(f"{k} = {v:.4g}" for k, v in r["estimates"].items())
        lines.append(f"  {e}: {est}; residual RMS {r['residual_rms']}")
    if len(rows) == 2:
        a, b = rows["direct"]["estimates"], rows["eigen"]["estimates"]
        lines.append("  largest relative difference of the estimates: "
                     f"{max(abs(a[k] - b[k]) / abs(a[k]) for k in a):.1e}")
    args.out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
