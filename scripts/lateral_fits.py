"""Decay-rate-only fits of the SBB Niederwangen table, lateral rows (dir = h) and vertical
rows (dir = v) with the same model, for the comparison of issue 15.

    python scripts/lateral_fits.py TABLE OUT [--rows N]

Model: wfe-periodic on the 60E1 10 mm mesh, pad 0.15 m in one row, 4 midpoint springs
across the foot, rail loss factor fixed (ETA_R). Lateral rows: supports acting vertically
and laterally ('zy'), the vertical support at the site preset, fitted kp_lat, eta_p_lat,
kb_lat, eta_b_lat (lateral hammer and sensor on the side of the head, railfem.models).
Vertical rows: supports acting vertically ('z'), fitted kp, eta_p, kb, eta_b. Writes
lateral_fits.csv and prints a table; ends with KEY lines of the medians.
"""
import argparse
import json
import logging
import sys
import time
from pathlib import Path

import numpy as np

import railfem as rf
from railfem.io.data import read_data
from railfem.identify import fit
from railfem.identify.data import decay_rate_target
from railfem.identify.forward import ForwardModel, Geometry
from railfem.params import ParameterSpace

ETA_R = 0.01
LATERAL = ("kp_lat", "eta_p_lat", "kb_lat", "eta_b_lat")
VERTICAL = ("kp", "eta_p", "kb", "eta_b")
BOUNDS = {"kp_lat": (5e6, 5e9), "kb_lat": (1e6, 2e9), "eta_p_lat": (0.01, 2.0),
          "eta_b_lat": (0.02, 5.0), "kp": (1e7, 1e10), "kb": (5e6, 2e9),
          "eta_p": (0.01, 2.0), "eta_b": (0.02, 5.0)}


def base(directions: str):
    return rf.preset("site", model="wfe-periodic", pad_length=0.15, n_rows=1,
                     support_directions=directions).replace(eta_r=ETA_R)


def run(table, out: Path, direction: str, rows=None, n_starts=3, names=None):
    kind, items = read_data(table, select=f"dir={direction}", campaign=True)
    if rows:
        items = items[:rows]
    lateral = direction == "h"
    names = names or (LATERAL if lateral else VERTICAL)
    spec = base("zy" if lateral else "z")
    first = items[0][1]
    target = decay_rate_target(first, spec.spacing)
    geometry = Geometry(frequency=target.frequency, outputs=target.outputs,
                        sensor_x=target.sensor_x, force_x=target.force_x)
    space = ParameterSpace(spec, names, bounds={n: BOUNDS[n] for n in names})
    forward = ForwardModel(space, geometry, cache=False)
    results = []
    for i, m in items:
        t0 = time.perf_counter()
        res = fit(m, "wfe-periodic", parameters=names, base=spec, n_starts=n_starts,
                  workers=1, profiles=(), forward=forward)
        md = m.metadata
        row = {"row": i, "dir": direction, "section": md.section, "date": md.date,
               "rail": md.rail_side, "tdr_rms_db": res.residual_rms.get("tdr"),
               "seconds": time.perf_counter() - t0}
        for p in res.parameters:
            row[p["name"]] = p["value"]
            row[p["name"] + "_ci95"] = list(p["ci95"])
            row[p["name"] + "_ident"] = p["identifiable"]
        results.append(row)
        print(json.dumps(row), flush=True)
    return results


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("table")
    ap.add_argument("out", type=Path)
    ap.add_argument("--rows", type=int, default=None)
    ap.add_argument("--dir", default="h,v")
    ap.add_argument("--starts", type=int, default=3)
    ap.add_argument("--lateral-params", default=",".join(LATERAL),
                    help="fitted parameters of the lateral rows (default all four)")
    ap.add_argument("--vertical-params", default=",".join(VERTICAL),
                    help="fitted parameters of the vertical rows (default all four)")
    a = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    a.out.mkdir(parents=True, exist_ok=True)
    allrows = []
    for d in a.dir.split(","):
        names = (a.lateral_params if d == "h" else a.vertical_params).split(",")
        allrows += run(a.table, a.out, d, a.rows, a.starts, tuple(names))
        (a.out / "fits.json").write_text(json.dumps(allrows, indent=1))
    for d in ("h", "v"):
        sel = [r for r in allrows if r["dir"] == d]
        for n in (LATERAL if d == "h" else VERTICAL):
            if sel and n in sel[0]:
                print(f"KEY median_{n} {np.median([r[n] for r in sel]):.6g}")


if __name__ == "__main__":
    sys.exit(main())
