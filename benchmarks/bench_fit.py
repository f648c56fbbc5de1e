"""Benchmark of the fit (railfem.identify): the 29-position refsim hammer dataset (head and
foot, 69 frequencies; point + transfers + decay rate) and the SBB decay-rate table.

    python benchmarks/bench_fit.py [--workers 2] [--skip-sbb]
        [--out benchmarks/results/results_fit.txt]
    python benchmarks/bench_fit.py --commands [--old SRC] [--section NAME]  # cold, warm
    python benchmarks/bench_fit.py --cross SEEDS [--step 2]  # blind cross-model intervals

``--commands``: ``railfem fit /work/shared/datasets/practice_site_b --out DIR`` (the
command's defaults: wfe-discrete, five base parameters, model-form discrepancy) cold (a new
empty RAILFEM_CACHE) and warm (the same command again), wall and CPU seconds (the child's
user + system), against the code in ``--old`` (a source tree run with PYTHONPATH, e.g.
``mkdir /tmp/old && git archive REV railfem | tar -x -C /tmp/old``) in the same session;
the section "commands" of the results file is replaced. ``--cross``: seeds 0..SEEDS-1 of
clean cross-model data (benchmarks/blind/generators.py, dataset('none', seed,
model='wfe-discrete', form='cross'), every ``--step``-th line of 50-4000 Hz), fitted with
and without the discrepancy: per seed which base parameters lie inside their 95 %
intervals, and the median half-widths (section "cross").

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
    p.add_argument("--commands", action="store_true")
    p.add_argument("--old", type=Path, default=None, metavar="SRC")
    p.add_argument("--section", default="commands", metavar="NAME",
                   help="the results file's section --commands writes")
    p.add_argument("--cross", type=int, default=0, metavar="SEEDS")
    p.add_argument("--step", type=int, default=2)
    p.add_argument("--kernel", action="store_true")
    p.add_argument("--agree", default=None, metavar="MODEL")
    p.add_argument("--out", type=Path,
                   default=Path(__file__).resolve().parent / "results" / "results_fit.txt")
    p.add_argument("--kernel-child", nargs=3, default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    limit_threads(1)
    if args.kernel_child:
        kernel_child(args.kernel_child[0], args.kernel_child[1], int(args.kernel_child[2]))
        return
    if args.commands or args.cross or args.kernel or args.agree:
        name, lines = ((args.section, command_timings(args.old)) if args.commands
                       else ("kernel", kernel_paths()) if args.kernel
                       else (f"agreement {args.agree}", agreement(args.agree)) if args.agree
                       else ("cross", cross_study(args.cross, args.step)))
        sys.stdout.write("\n".join(lines) + "\n")
        replace_section(args.out, name, lines)
        return
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
    old = args.out.read_text() if args.out.exists() else ""
    keep = old[old.index("\n## "):] if "\n## " in old else ""  # the other sections
    args.out.write_text(text + keep)


DATASET = SHARED / "datasets/practice_site_b"


def run_command(src: Path | None, cache: Path, out: Path) -> tuple[float, float]:
    """(wall, CPU) seconds of ``railfem fit DATASET`` with the code of ``src`` (None: the
    installed one) and the kernel cache ``cache``."""
    import os
    import resource
    import subprocess

    env = dict(os.environ, RAILFEM_CACHE=str(cache))
    if src is not None:
        env["PYTHONPATH"] = str(src)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    subprocess.run([sys.executable, "-m", "railfem.cli", "-q", "fit", str(DATASET), "--out",
                    str(out)], env=env, check=True, capture_output=True)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def command_timings(old: Path | None) -> list[str]:
    """Cold and warm ``railfem fit`` on practice_site_b, new (and ``old``) code."""
    import json

    meta = json.loads((DATASET / "meta.json").read_text())
    lines = [f"railfem fit {DATASET.name} --out DIR   ({len(meta['hammer_positions_m'])} "
             "positions, head + foot, 69 frequencies, wfe-discrete, 5 base parameters)"]
    lines += machine_lines(1)
    lines.append(f"  {'code':46s} {'run':5s} {'wall (s)':>9s} {'CPU (s)':>9s} {'ratio':>7s}")
    got, params = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for label, src in (("old", old), ("new", None)):
            if label == "old" and old is None:
                continue
            cache = Path(tmp) / f"cache-{label}"
            for run in ("cold", "warm"):
                got[label, run] = run_command(src, cache, Path(tmp) / f"out-{label}-{run}")
                doc = json.loads((Path(tmp) / f"out-{label}-{run}" / "fit.json").read_text())
                disc = doc.get("model_form_discrepancy", {}).get("method", "none (old code)")
                params[label, run] = {q["name"]: q["value"] for q in doc["parameters"]}
        for (label, run), (wall, cpu) in got.items():
            ref = got.get(("old", run))
            ratio = f"{wall / ref[0]:7.2f}" if ref else f"{'-':>7s}"
            what = ("new: discrepancy 'ensemble' (default)" if label == "new"
                    else f"old: {old}")
            lines.append(f"  {what:46s} {run:5s} {wall:9.2f} {cpu:9.2f} {ratio}")
    lines.append(f"  (ratio: wall new / old in this session; last fit.json discrepancy: {disc})")
    if ("old", "cold") in params:
        new, ref = params["new", "cold"], params["old", "cold"]
        worst = max(abs(new[n] - v) / abs(v) for n, v in ref.items())
        lines.append(f"  fit.json parameters, new vs old (cold): largest relative difference "
                     f"{worst:.1e} over {', '.join(ref)}")
    return lines


def cross_study(n_seeds: int, step: int) -> list[str]:
    """Blind fits of cross-model clean data with and without the discrepancy."""
    import importlib

    import numpy as np

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository
    from benchmarks.blind import generators as g

    F = importlib.import_module("railfem.identify.fit")
    f = g.frequencies(low=50.0, high=4000.0)[::step]
    names = ("kp", "eta_p", "kb", "eta_b", "eta_r")
    lines = [f"blind cross-model fits: dataset('none', seed, model='wfe-discrete', "
             f"form='cross'), {len(f)} lines 50-4000 Hz, 29 positions, 5 % noise; "
             "fit(n_starts=2, workers=1, profiles=())"]
    lines += machine_lines(1)
    half = {d: {n: [] for n in names} for d in ("ensemble", None)}
    inside = {d: {n: 0 for n in names} for d in ("ensemble", None)}
    all_in = {"ensemble": 0, None: 0}
    fwd = None
    for seed in range(n_seeds):
        (meas,) = g.dataset("none", seed, f=f, model="wfe-discrete", form="cross")
        if fwd is None:
            fwd = F.prepare(meas, "wfe-discrete", parameters=names, base=None, bounds=None,
                            use=None, cache=False, forward=None, target_options=None)[0]
        for d in ("ensemble", None):
            t = time.perf_counter()
            res = F.fit(meas, forward=fwd, n_starts=2, workers=1, profiles=(),
                        discrepancy=d)
            row = []
            for n in names:
                p = res.parameter(n)
                ok = p["ci95"][0] <= g.TRUTH[n] <= p["ci95"][1]
                inside[d][n] += ok
                half[d][n].append(np.log10(p["ci95"][1] / p["ci95"][0]) / 2)
                row.append(f"{n} {p['value'] / g.TRUTH[n] - 1:+.1%}{'' if ok else ' OUT'}")
            all_in[d] += all(p["ci95"][0] <= g.TRUTH[p["name"]] <= p["ci95"][1]
                             for p in res.parameters)
            lines.append(f"  seed {seed} {str(d):8s} {time.perf_counter() - t:6.1f} s  "
                         + ", ".join(row))
    for d in ("ensemble", None):
        lines.append(f"  discrepancy {str(d):8s}: all five inside in {all_in[d]}/{n_seeds}; "
                     "inside per parameter " + ", ".join(f"{n} {inside[d][n]}/{n_seeds}"
                                                          for n in names))
        lines.append(f"  {'':21s} median 95 % half-width (decades) "
                     + ", ".join(f"{n} {np.median(half[d][n]):.3f}" for n in names))
    return lines


def kernel_paths(n_f: int = 12) -> list[str]:
    """The WFE kernel at a second rail loss factor: through the fitter's path
    (railfem.models.discrete_kernel of the spec at that eta_r, as SpectralEngine builds
    it) and through railfem.track.wfe.discrete_kernel(eta_r=) on the first kernel's
    section, each in a fresh process (kernel_child) after a first kernel at eta_r = 0.01;
    CPU seconds and the largest difference of the two kernels."""
    import subprocess

    import numpy as np

    got = {}
    with tempfile.TemporaryDirectory() as tmp:
        for path in ("fitter", "eta_r"):
            out = Path(tmp) / f"{path}.npy"
            r = subprocess.run([sys.executable, __file__, "--kernel-child", path, str(out),
                                str(n_f)], capture_output=True, text=True, check=True)
            got[path] = [float(v) for v in r.stdout.split()] + [np.load(out)]
    diff = np.abs(got["fitter"][2] - got["eta_r"][2]).max() / np.abs(got["eta_r"][2]).max()
    lines = [f"WFE kernel (wfe-discrete, point supports, 29 positions, {n_f} frequencies "
             "100-5000 Hz) at eta_r = 0.02 after one at 0.01, CPU seconds"]
    lines += machine_lines(1)
    lines.append(f"  first kernel (eta_r = 0.01)                        {got['fitter'][0]:8.2f}")
    lines.append(f"  second, the fitter's path (models.discrete_kernel) {got['fitter'][1]:8.2f}")
    lines.append(f"  second, track.wfe.discrete_kernel(eta_r=)          {got['eta_r'][1]:8.2f}")
    lines.append(f"  largest relative difference of the two kernels     {diff:8.1e}")
    return lines


def kernel_child(path: str, out: str, n_f: int) -> None:
    """One process of kernel_paths: prints (first kernel, second kernel) CPU seconds."""
    import numpy as np

    from railfem import models
    from railfem.identify.base import default_base
    from railfem.track import wfe

    spec = default_base("wfe-discrete")
    xs, _, hx = models.hammer_x(spec)
    f = np.geomspace(100, 5000, n_f)
    first = spec.replace(eta_r=0.01)
    t = time.process_time()
    models.discrete_kernel(first, f, hx, [xs], outputs=("head",), cache=False)[0]
    t1 = time.process_time() - t
    t = time.process_time()
    if path == "fitter":
        k = models.discrete_kernel(spec.replace(eta_r=0.02), f, hx, [xs], outputs=("head",),
                                   cache=False)[0]
    else:
        n, lay = first.numerics, first.layout()
        rail = models.wfe_rail(first.rail, n.patch_width, n.n_foot_springs, n.foot_rule)
        c = np.round((xs + hx) / (2 * spec.spacing)) * spec.spacing  # as models centres
        uf, ur = np.unique(np.round(hx - c, 10)), np.unique(np.round(xs - c, 10))
        k = wfe.discrete_kernel(rail.guide, rail.springs, lay.springs().x, f,
                                load=rail.loads["head"], outputs=[rail.outputs["head"]],
                                force_x=uf, response_x=ur,
                                spring_length=lay.row_length, load_length=n.load_length,
                                n_waves=n.n_waves, tail=n.tail, eta_r=0.02)
    sys.stdout.write(f"{t1} {time.process_time() - t}\n")
    np.save(out, k.ss)


def agreement(model: str) -> list[str]:
    """fit and diagnose (default base and discrepancy, one candidate) on seed 0 of clean
    cross-model data (20 lines of 50-4000 Hz): their base estimates and 95 % intervals."""
    import importlib

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository
    from benchmarks.blind import generators as g
    from railfem.diagnosis import diagnose

    F = importlib.import_module("railfem.identify.fit")
    f = g.frequencies(low=50.0, high=4000.0)[::3]
    (meas,) = g.dataset("none", 0, f=f, model=model, form="cross")
    t = time.perf_counter()
    r = F.fit(meas, model, n_starts=2, workers=1, profiles=())
    t_fit = time.perf_counter() - t
    t = time.perf_counter()
    d = diagnose([meas], model=model, effects=("noise_floor",), n_starts=2)
    t_diag = time.perf_counter() - t
    lines = [f"fit vs diagnose, {model}, dataset('none', 0, form='cross'), {len(f)} lines: "
             f"fit {t_fit:.0f} s, diagnose {t_diag:.0f} s (verdict {d.verdict})"]
    lines += machine_lines(1)
    base = {p["name"]: p for p in d.base.parameters()}
    for n in ("kp", "eta_p", "kb", "eta_b"):
        a, b = r.parameter(n), base[n]
        each = (a["ci95"][0] <= b["value"] <= a["ci95"][1]
                and b["ci95"][0] <= a["value"] <= b["ci95"][1])
        lines.append(f"  {n:6s} fit {a['value']:.4g} [{a['ci95'][0]:.4g}, {a['ci95'][1]:.4g}]"
                     f"   diagnose {b['value']:.4g} [{b['ci95'][0]:.4g}, {b['ci95'][1]:.4g}]"
                     f"   truth {g.TRUTH[n]:.4g}   each inside the other's interval: {each}")
    a = r.parameter("eta_r")
    lines.append(f"  eta_r  fit {a['value']:.4g} [{a['ci95'][0]:.4g}, {a['ci95'][1]:.4g}]"
                 f"   diagnose {d.base.eta_r:.4g}   truth {g.TRUTH['eta_r']:.4g}")
    return lines


def replace_section(path: Path, name: str, lines: list[str]) -> None:
    """Write ``lines`` as the section ``name`` of the results file (replacing it)."""
    head, tail = f"## {name}", "## end " + name
    text = path.read_text() if path.exists() else ""
    if head in text:
        a, rest = text.split(head, 1)
        text = a + rest.split(tail, 1)[1].lstrip("\n")
    cmd = "python benchmarks/bench_fit.py " + " ".join(sys.argv[1:])
    path.write_text(text.rstrip("\n") + "\n\n" + "\n".join([head, f"# {cmd}", *lines, tail])
                    + "\n")


if __name__ == "__main__":
    main()
