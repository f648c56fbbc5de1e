"""Benchmark of a full diagnosis of a 29-position hammer dataset (railfem diagnose), each
run in a process of its own, optionally against another checkout of railfem side by side.

    python benchmarks/bench_diagnosis.py                 # practice_site_b, both models
    python benchmarks/bench_diagnosis.py --models timoshenko-discrete
    python benchmarks/bench_diagnosis.py --models wfe-discrete --effects all --f-high 4000 \
        --old /tmp/railfem-before --parallel --out benchmarks/results/results_diagnosis.txt

For each model: railfem.jobs.diagnose.run_diagnose on the dataset (29 EN 15461 positions,
head and foot sensors, 69 frequencies at 1/9 octave, 50 Hz - 8 kHz, or up to --f-high),
the effect library (--effects: the default screen, or 'all' with random_support), the base
fit's multi-start in ``--workers`` processes, a memory-only kernel cache (cold: every
kernel is computed in the run). Reported per run: the time of each stage (base fit with
the rail-loss profile and the model-form discrepancy, single candidates, pairs, final
refit), the wall time and the CPU time of the run's process and its children (the honest
number on a shared machine), the number of candidates and the verdict. With --old DIR (a
git worktree of the code before, e.g. ``git worktree add /tmp/railfem-before <commit>``)
each model is run with that code too, in the same session, and the row gets the CPU ratio
old / new and the largest differences of the two diagnosis.json (verdict, chosen effect,
ranks, kept flags; relative differences of the candidates' dBIC and parameters).
With --ref DIR (the same code as --new without the changes under test) that run is added
and compared with the new one: what the changes alone do to the results.
The table is printed and written to --out.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import limit_threads, machine_lines

HERE = Path(__file__).resolve().parent


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, default=Path("/work/shared/datasets/practice_site_b"))
    p.add_argument("--models", nargs="+", default=["timoshenko-discrete", "wfe-discrete"])
    p.add_argument("--effects", default="default",
                   help="'default' (the default screen), 'all', or names E,E")
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--f-high", type=float, default=None,
                   help="diagnose up to this frequency (Hz; default the whole dataset)")
    p.add_argument("--old", type=Path, default=None,
                   help="a checkout of railfem (the code before) to run side by side")
    p.add_argument("--new", type=Path, default=None,
                   help="a checkout of railfem to run as the new code (default: the one "
                        "installed)")
    p.add_argument("--ref", type=Path, default=None,
                   help="a checkout equal to --new but for the changes under test (e.g. a "
                        "worktree of the same commit with them reverted): run as well, its "
                        "diagnosis.json compared with new's (the changes' own effect on the "
                        "results, apart from other changes since --old)")
    p.add_argument("--parallel", action="store_true",
                   help="run the old and the new code at the same time (CPU times are each "
                        "run's own; the wall times then share the machine)")
    p.add_argument("--profile", type=Path, default=None,
                   help="write a cProfile of the new run (CPU timer) to this file")
    p.add_argument("--out", type=Path, default=HERE / "results" / "results_diagnosis.txt")
    p.add_argument("--one", nargs=2, metavar=("MODEL", "OUT_DIR"), help=argparse.SUPPRESS)
    return p.parse_args(argv)


def run_one(args) -> None:
    """One diagnosis in this process (--one MODEL OUT_DIR): the run record on stdout."""
    from railfem.jobs.diagnose import run_diagnose

    model, out = args.one
    eff = {"default": None, "all": "all"}.get(args.effects, None)
    if args.effects not in ("default", "all"):
        eff = args.effects.split(",")
    def go():
        return run_diagnose(args.data, out, model=model, effects=eff, workers=args.workers,
                            cache=False, f_range=(0.0, args.f_high) if args.f_high else None)

    if args.profile:  # the CPU timer: the machine may be shared
        import cProfile

        prof = cProfile.Profile(time.process_time)
        rec = prof.runcall(go)
        prof.dump_stats(str(args.profile))
    else:
        rec = go()
    g = rec["groups"][0]
    path = Path(out) / "diagnosis.json"
    n = len(json.loads(path.read_text())["candidates"])
    import railfem

    print(json.dumps({"seconds": g["seconds"], "verdict": g["verdict"], "chosen": g["chosen"],
                      "candidates": n, "diagnosis": str(path), "code": railfem.__file__}))


def start(args, model: str, code: Path | None, out: Path, profile=None):
    """run_one in a child process (code: a railfem checkout first on the path), its output
    to files in ``out``, a cProfile to ``profile``: (the process, its start time)."""
    env = dict(os.environ)
    if code is not None:
        env["PYTHONPATH"] = str(code) + os.pathsep + env.get("PYTHONPATH", "")
    cmd = [sys.executable, __file__, "--data", str(args.data), "--effects", args.effects,
           "--workers", str(args.workers), "--threads", str(args.threads),
           "--one", model, str(out)] + (["--f-high", str(args.f_high)] if args.f_high else []) \
        + (["--profile", str(profile)] if profile else [])
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "stdout.txt", "w") as so, open(out / "stderr.txt", "w") as se:
        return subprocess.Popen(cmd, env=env, stdout=so, stderr=se), time.perf_counter()


def finish(proc, t0: float, out: Path) -> dict:
    """Wait for a start()ed run: its record with the wall time and the CPU time (user +
    system of the child and its children, os.wait4)."""
    _, status, ru = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    if status != 0:
        raise RuntimeError(f"the run in {out} failed: {(out / 'stderr.txt').read_text()[-2000:]}")
    rec = json.loads((out / "stdout.txt").read_text().strip().splitlines()[-1])
    return dict(rec, wall=wall, cpu=ru.ru_utime + ru.ru_stime)


def compare(old_json: str, new_json: str) -> str:
    """The largest differences of two diagnosis.json: verdict, chosen, ranks and kept flags
    (equal or not), and the largest relative difference of the candidates' dBIC and of
    every fitted parameter value (base, candidates, chosen)."""
    a, b = (json.loads(Path(p).read_text()) for p in (old_json, new_json))
    same = [a.get("verdict") == b.get("verdict"),
            (a.get("chosen") or {}).get("name") == (b.get("chosen") or {}).get("name")]
    ra = {c["name"]: c for c in a["candidates"]}
    rb = {c["name"]: c for c in b["candidates"]}
    same.append([c["name"] for c in a["candidates"]] == [c["name"] for c in b["candidates"]])
    same.append(all(ra[n]["kept"] == rb[n]["kept"] for n in ra if n in rb))

    def rel(x, y):
        return abs(x - y) / max(abs(x), abs(y), 1e-300)

    d_bic = max((rel(ra[n]["delta_bic"], rb[n]["delta_bic"]) for n in ra if n in rb),
                default=0.0)
    def values(ps):
        return {p["name"]: p["value"] for p in ps or []
                if isinstance(p.get("value"), (int, float))}

    groups = [("base", a["base"]["parameters"], b["base"]["parameters"]),
              ("chosen", (a.get("chosen") or {}).get("parameters"),
               (b.get("chosen") or {}).get("parameters"))]
    groups += [(n, ra[n].get("parameters"), rb[n].get("parameters")) for n in ra if n in rb]
    d_par, where = 0.0, ""
    for g, ga, gb in groups:
        pa, pb = values(ga), values(gb)
        for k in pa:
            if k in pb and rel(pa[k], pb[k]) > d_par:
                d_par, where = rel(pa[k], pb[k]), f" ({g}: {k} {pa[k]:.6g} -> {pb[k]:.6g})"
    flags = "same" if all(same) else "DIFFERENT (verdict, chosen, ranks, kept: " + \
        ", ".join(str(s) for s in same) + ")"
    return f"{flags}; dBIC rel. {d_bic:.1e}, parameters rel. {d_par:.1e}{where}"


def main(argv=None):
    args = parse_args(argv)
    limit_threads(args.threads)
    if args.one:  # the code on PYTHONPATH (--old, --new) or the installed one
        run_one(args)
        return
    from railfem.io import read_measurement

    meas = read_measurement(args.data)
    lines = ["Full diagnosis of a 29-position hammer dataset (railfem diagnose)",
             *machine_lines(args.threads),
             f"  data {args.data} ({meas.frf.shape[0]} frequencies, {meas.frf.shape[1]} "
             f"sensors, {meas.frf.shape[2]} positions); effects {args.effects}; base fit in "
             f"{args.workers} process(es); memory-only kernel cache (cold)"
             + (f"; diagnosed up to {args.f_high:g} Hz" if args.f_high else ""),
             "  cpu s: user + system of the run's process and its children; ratio: old / new"
             " CPU in the same session", "",
             f"{'model':20s} {'code':4s} {'base s':>7s} {'singles':>8s} {'pairs':>6s} "
             f"{'final':>6s} {'wall s':>7s} {'cpu s':>7s} {'cands':>5s} {'ratio':>6s}  "
             "verdict"]
    tmp = Path(tempfile.mkdtemp(prefix="bench_diagnosis_"))
    notes = []
    for model in args.models:
        runs = [("new", args.new)] + ([("old", args.old)] if args.old else []) \
            + ([("ref", args.ref)] if args.ref else [])
        got = {}
        if args.parallel:  # side by side: each one's CPU time is its own
            procs = {tag: start(args, model, code, tmp / f"{model}_{tag}",
                                args.profile if tag == "new" else None) for tag, code in runs}
            got = {tag: finish(*procs[tag], tmp / f"{model}_{tag}") for tag, _ in runs}
        for tag, code in runs:
            if tag not in got:
                got[tag] = finish(*start(args, model, code, tmp / f"{model}_{tag}",
                                         args.profile if tag == "new" else None),
                                  tmp / f"{model}_{tag}")
        for tag, _ in runs:
            r, s = got[tag], got[tag]["seconds"]
            ratio = got["old"]["cpu"] / r["cpu"] if "old" in got else float("nan")
            lines.append(f"{model:20s} {tag:4s} {s['base']:7.1f} {s['singles']:8.1f} "
                         f"{s['pairs']:6.1f} {s['final']:6.1f} {r['wall']:7.1f} "
                         f"{r['cpu']:7.1f} {r['candidates']:5d} {ratio:6.2f}  "
                         f"{r['verdict']}: {r['chosen'] or '-'}")
        for tag in ("old", "ref"):
            if tag in got:
                notes.append(f"  {model}: diagnosis.json {tag} vs new: "
                             + compare(got[tag]["diagnosis"], got["new"]["diagnosis"]))
        notes += [f"  {model} {tag}: railfem from {got[tag]['code']}" for tag, _ in runs]
    text = "\n".join(lines + [""] + notes) + "\n"
    print(text)
    from railfem.atomic import write_text

    write_text(args.out, text)


if __name__ == "__main__":
    main()
