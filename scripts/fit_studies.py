"""Identification studies for the closing note of issue 11 (outputs not committed).

    OPENBLAS_NUM_THREADS=1 python3 scripts/fit_studies.py OUT [refsim] [practice] [sbb]
        [coverage]

* refsim: /work/shared/datasets/refsim_site fitted with the four models (point, transfers,
  decay rate; kp, eta_p, kb, eta_b, eta_r, ms); fitted vs true (truth.json is read only
  here, after the fits) and the residual per band;
* practice: practice_site_b fitted with wfe-discrete and timoshenko-discrete; where the
  residual is largest;
* sbb: every vertical row of the SBB Niederwangen decay-rate table fitted from its decay
  rate alone (campaign on a Dask LocalCluster); fitted pad stiffness vs temperature;
* coverage: decay rate alone, 20 seeds, coverage of the intervals of the parameters called
  identifiable (the default suite asserts only the flags).
Each part writes its folders under OUT and prints KEY lines.
"""
import json
import logging
import sys
import time
from pathlib import Path

import numpy as np

SHARED = Path("/work/shared")
MODELS = ("wfe-discrete", "wfe-periodic", "timoshenko-discrete", "timoshenko-continuous")
SIX = ("kp", "eta_p", "kb", "eta_b", "eta_r", "ms")


def refsim(out: Path):
    from railfem.identify.compare import comparison_table
    from railfem.jobs.fit import write_fit
    from railfem.identify import fit
    from railfem.io import read_measurement

    meas = read_measurement(SHARED / "datasets/refsim_site")
    results = {}
    for m in MODELS:
        t = time.perf_counter()
        results[m] = fit(meas, m, parameters=SIX, use=("point", "transfer", "tdr"),
                         workers=2, cache=None)
        d = out / "refsim" / m
        d.mkdir(parents=True, exist_ok=True)
        write_fit(d, results[m])
        print(f"KEY refsim_{m}_seconds {time.perf_counter() - t:.1f}", flush=True)
    truth = json.loads((SHARED / "datasets/refsim_site/truth.json").read_text())["params"]
    text = comparison_table(results)
    lines = [text, "", "truth: " + ", ".join(f"{k} {v:g}" for k, v in truth.items())]
    for m, r in results.items():
        lines.append(f"{m}: " + ", ".join(
            f"{p['name']} {p['value'] / truth[p['name']] - 1:+.1%}" for p in r.parameters))
        lines.append("   residual per band (tdr, head, dB): " + str(
            [None if v is None else round(v, 2) for v in r.residual_bands["tdr"]["head"]]))
    (out / "refsim" / "summary.txt").write_text("\n".join(lines) + "\n")
    print("\n".join(lines), flush=True)


def practice(out: Path):
    from railfem.identify.compare import comparison_table
    from railfem.jobs.fit import write_fit
    from railfem.identify import fit
    from railfem.io import read_measurement

    meas = read_measurement(SHARED / "datasets/practice_site_b")
    results = {}
    for m in ("wfe-discrete", "timoshenko-discrete"):
        results[m] = fit(meas, m, parameters=SIX, use=("point", "transfer", "tdr"),
                         workers=2, cache=None)
        d = out / "practice" / m
        d.mkdir(parents=True, exist_ok=True)
        write_fit(d, results[m])
    lines = [comparison_table(results)]
    for m, r in results.items():
        for q, table in r.residual_bands.items():
            for s in r.target.outputs:
                v = np.array([np.nan if x is None else x for x in table[s]])
                k = np.argsort(np.nan_to_num(v, nan=-1))[::-1][:3]
                lines.append(f"{m} {q} {s}: largest band residuals " + ", ".join(
                    f"{table['band_hz'][i]:g} Hz {v[i]:.2f} dB" for i in k))
    (out / "practice" / "summary.txt").write_text("\n".join(lines) + "\n")
    print("\n".join(lines), flush=True)


def sbb(out: Path, model: str):
    from railfem.jobs.fit import run_fit
    from railfem.spec import preset

    t = time.perf_counter()
    rec = run_fit(SHARED / "measured_data/sbb_niederwangen/tdr_niederwangen_wide.csv",
                  out / f"sbb_{model}", model=model, select="dir=v", campaign=True,
                  parameters=("kp", "eta_p", "kb", "eta_b", "eta_r"), base=preset("site"),
                  workers=2, profiles=("kp",), cache=None)
    print(f"KEY sbb_{model}_seconds {time.perf_counter() - t:.1f}", flush=True)
    temps, kps = [], []
    for r in rec["rows"]:
        md = r["metadata"]
        p = r["parameters"]
        temps.append(md.get("temperature_c", np.nan))
        kps.append(p["kp"]["value"])
        print(f"{md.get('section')} {md.get('date')} {md.get('rail_side')} "
              f"T={md.get('temperature_c')} " + " ".join(
                  f"{n}={v['value']:.3g}[{v['ci95'][0]:.2g},{v['ci95'][1]:.2g}]{v['identifiable'][0]}"
                  for n, v in p.items()) + f" rms={r['residual_rms_db']['tdr']:.2f}", flush=True)
    temps, kps = np.array(temps, float), np.log10(kps)
    ok = np.isfinite(temps)
    slope = np.polyfit(temps[ok], kps[ok], 1)[0]
    print(f"KEY sbb_{model}_dlog10kp_per_degC {slope:.4f}")
    print(f"KEY sbb_{model}_kp_temp_corr {np.corrcoef(temps[ok], kps[ok])[0, 1]:.3f}")


def coverage(out: Path):
    import railfem as rf
    from railfem import models
    from railfem.identify import fit
    from railfem.measurement import DecayRateMeasurement
    from railfem.standards import iec61260

    truth = dict(kp=400e6, eta_p=0.2, kb=60e6, eta_b=1.0, eta_r=0.02, ms=150.0)
    names = ("kp", "eta_p", "kb", "eta_b", "ms")
    spec = rf.preset("site", model="timoshenko-discrete").replace(**truth)
    centres = iec61260.third_octave_bands(100, 5000).nominal
    d = models.decay_rate(spec, iec61260.ninth_octave_grid(100, 5000), cache=False).decay_rate
    for level in (0.01, 0.05, 0.10):
        inside = {n: 0 for n in names}
        counted = {n: 0 for n in names}
        for seed in range(20):
            rng = np.random.default_rng(seed)
            meas = DecayRateMeasurement(frequency=centres,
                                        decay_rate=d * (1 + level * rng.standard_normal(d.size)))
            res = fit(meas, "timoshenko-discrete", parameters=names,
                      base=rf.preset("site").replace(eta_r=0.02), n_starts=8, seed=seed,
                      workers=1, profiles=())
            for p in res.parameters:
                if p["identifiable"] == "yes":
                    counted[p["name"]] += 1
                    inside[p["name"]] += p["ci95"][0] <= truth[p["name"]] <= p["ci95"][1]
        print(f"KEY tdr_only_coverage_{level} " + " ".join(
            f"{n}:{inside[n]}/{counted[n]}" for n in names), flush=True)


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    for name in ("distributed", "railfem.standards"):
        logging.getLogger(name).setLevel(logging.WARNING)
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    parts = sys.argv[2:] or ["refsim", "practice", "sbb", "coverage"]
    for part in parts:
        if part == "sbb":
            sbb(out, "timoshenko-discrete")
            sbb(out, "wfe-discrete")
        elif part.startswith("sbb:"):
            sbb(out, part[4:])
        else:
            globals()[part](out)
