"""Benchmark of a lateral decay-rate fit through the public fit function: the eigen form in
the lateral stiffness that railfem.identify.forward picks by itself (engine 'auto' ->
'eigen', railfem.track.directional) against the coupling solve per evaluation that the
fit used before (engine 'direct').

    python benchmarks/bench_lateral_fit.py [--threads 1] [--section B1] [--starts 8]
        [--evaluations 20] [--out benchmarks/results/results_lateral_fit.txt]

Problem: the first lateral ('h') row of the SBB Niederwangen decay-rate table for
``--section``, fitted as ``railfem fit TABLE --directions y`` fits it: wfe-discrete on the
fit's base (site preset, point supports, 131 supports) with supports acting vertically
and laterally (railfem.jobs.fit.lateral_base: support directions 'zy'), parameters
kp_lat, eta_p_lat, kb_lat, eta_b_lat (LATERAL_PARAMETERS); noise-only residuals, no
profiles, one process (railfem.identify.fit.fit with discrepancy=None, profiles=(),
workers=1).

Rows:
* the fit, cold (empty kernel cache: wave solves, kernel and eigen form included) and warm
  (the same cache again), each in its own subprocess: CPU time of the subprocess, wall
  time, the number of model evaluations (ForwardModel.receptance calls, counted);
* per evaluation, both engines on the fit's geometry (kernel cached): ``--evaluations``
  parameter vectors (a scrambled Sobol sample of the box), CPU time per evaluation of
  each, their ratio, and the largest relative difference of the receptances and of the
  EN 15461 decay rates between the engines. A full fit with the direct engine is not run
  (thousands of evaluations): its cost is estimated as the cold fit's evaluation count
  times the direct engine's time per evaluation.
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


def measurement(section: str):
    from railfem.io.data import read_data

    _, items = read_data(str(TABLE), select={"direction": "h", "section": section}, row=0)
    return items[0][1]


def base():
    from railfem.identify.base import default_base
    from railfem.jobs.fit import lateral_base

    return lateral_base(default_base("wfe-discrete", spacing=0.6), "wfe-discrete")


def one_fit(section: str, starts: int, cache: str) -> dict:
    """The fit in this process through railfem.identify.fit.fit; estimates, evaluations."""
    from railfem.identify import forward as fwd_mod
    from railfem.identify.fit import fit
    from railfem.jobs.fit import LATERAL_PARAMETERS

    calls = {"n": 0, "kind": None}
    plain = fwd_mod.ForwardModel.receptance

    def counted(self, x):  # instrumentation only: counts the evaluations
        calls["n"] += 1
        calls["kind"] = self.kind
        return plain(self, x)

    fwd_mod.ForwardModel.receptance = counted
    meas = measurement(section)
    t0, c0 = time.perf_counter(), time.process_time()
    res = fit(meas, base=base(), parameters=LATERAL_PARAMETERS, workers=1, cache=cache,
              discrepancy=None, profiles=(), n_starts=starts)
    return {"wall_s": time.perf_counter() - t0, "cpu_s": time.process_time() - c0,
            "evaluations": calls["n"], "engine": calls["kind"],
            "estimates": {p["name"]: p["value"] for p in res.parameters},
            "residual_rms": {k: float(v) for k, v in res.residual_rms.items()}}


def evaluations(section: str, n: int, cache: str) -> dict:
    """CPU time per evaluation of both engines and their largest differences."""
    import numpy as np
    from scipy.stats import qmc

    from railfem.identify.data import model_quantities
    from railfem.identify.fit import prepare
    from railfem.identify.forward import ForwardModel
    from railfem.jobs.fit import LATERAL_PARAMETERS

    auto, target = prepare(measurement(section), "wfe-discrete", parameters=LATERAL_PARAMETERS,
                           base=base(), bounds=None, use=None, cache=cache, forward=None,
                           target_options=None)
    direct = ForwardModel(auto.space, auto.geometry, engine="direct", cache=cache)
    sp = auto.space
    xs = sp.lower + qmc.Sobol(d=len(sp.names), scramble=True, seed=1).random(n) * (
        sp.upper - sp.lower)
    out = {"engines": (auto.kind, direct.kind)}
    for name, f in (("eigen", auto), ("direct", direct)):
        f.receptance(xs[0])  # engine built / kernel loaded outside the timing
        c0 = time.process_time()
        out[name] = [f.receptance(x) for x in xs]
        out[f"{name}_s"] = (time.process_time() - c0) / n
    rec, dec = 0.0, 0.0
    for a, b in zip(out.pop("eigen"), out.pop("direct")):
        scale = np.abs(b).max(axis=(1, 2), keepdims=True)
        rec = max(rec, float((np.abs(a - b) / scale).max()))
        da, db = model_quantities(target, a)["tdr"], model_quantities(target, b)["tdr"]
        ok = np.isfinite(db)
        dec = max(dec, float(np.max(np.abs(da[ok] - db[ok]) / np.abs(db[ok]))))
    out.update(receptance_rel=rec, decay_rate_rel=dec, n=n, n_freq=len(target.frequency),
               n_pos=len(target.force_x))
    return out


def child(args, mode: str, cache: str) -> dict:
    """``mode`` in a subprocess (its own CPU time from rusage)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run([sys.executable, __file__, "--child", mode, "--section",
                          args.section, "--starts", str(args.starts), "--evaluations",
                          str(args.evaluations), "--threads", str(args.threads), "--cache",
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
    p.add_argument("--evaluations", type=int, default=20)
    p.add_argument("--child", help=argparse.SUPPRESS)
    p.add_argument("--cache", help=argparse.SUPPRESS)
    p.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "results"
                   / "results_lateral_fit.txt")
    args = p.parse_args(argv)
    limit_threads(args.threads)
    if args.child:
        r = (one_fit(args.section, args.starts, args.cache) if args.child == "fit"
             else evaluations(args.section, args.evaluations, args.cache))
        print(json.dumps(r))
        return
    cache = tempfile.mkdtemp(prefix="bench_lateral_fit_")
    cold = child(args, "fit", cache)
    warm = child(args, "fit", cache)
    ev = child(args, "evaluations", cache)
    lines = [f"Lateral decay-rate fit: SBB Niederwangen, first 'h' row of section "
             f"{args.section}, wfe-discrete, supports acting in zy (railfem fit --directions "
             f"y), parameters {', '.join(cold['estimates'])}, {args.starts} starts, one "
             "process, through railfem.identify.fit.fit (discrepancy=None, profiles=())",
             f"Reproduce: python benchmarks/bench_lateral_fit.py --starts {args.starts} "
             f"--evaluations {args.evaluations}",
             *machine_lines(args.threads), "",
             "fit          engine   CPU (s)  wall (s)  evaluations"]
    for name, r in (("cold", cold), ("warm", warm)):
        lines.append(f"  {name:10s} {r['engine']:7s} {r['cpu_process_s']:8.1f} "
                     f"{r['wall_s']:9.1f}  {r['evaluations']:11d}")
    est = ", ".join(f"{k} = {v:.4g}" for k, v in cold["estimates"].items())
    lines += [f"  estimates (cold): {est}; residual RMS {cold['residual_rms']}",
              f"  warm run gives the same estimates: {cold['estimates'] == warm['estimates']}",
              "", f"per evaluation ({ev['n']} parameter vectors, {ev['n_freq']} frequencies x "
              f"{ev['n_pos']} hammer positions, kernel cached; CPU):",
              f"  eigen  (auto: {ev['engines'][0]})  {ev['eigen_s'] * 1e3:8.2f} ms",
              f"  direct (coupling solve)   {ev['direct_s'] * 1e3:8.2f} ms",
              f"  ratio direct / eigen      {ev['direct_s'] / ev['eigen_s']:8.0f}",
              f"  largest relative difference eigen vs direct: receptance "
              f"{ev['receptance_rel']:.1e}, EN 15461 decay rate {ev['decay_rate_rel']:.1e}",
              f"  the same fit with the direct engine (estimate: {cold['evaluations']} "
              f"evaluations x {ev['direct_s']:.2f} s): ~{cold['evaluations'] * ev['direct_s']:.0f}"
              " s CPU beyond the kernel"]
    args.out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
