"""The rail seat's roll on the SBB Niederwangen lateral rows: the EN 15461 lateral decay
rate of the site track with the default rigid rail seat (SupportParameters.seat 'rigid':
the pad alone against the foot's roll) against the published per-spring chain (seat
'per_spring': each foot spring carries its share of the sleeper mass, the seat rolls with
the foot), and against the measured 15 lateral rows.

    OPENBLAS_NUM_THREADS=1 python benchmarks/sbb/seat_roll.py \
        [--out benchmarks/results/results_seat_roll.md] [--json /tmp/seat.json]

Track as diagnose_sbb.py --lateral has it (wfe-periodic, site preset, 0.15 m pad in one
row, supports 'zy', rail loss factor 0.01), and on the continuous support of
lateral_waves.py (wfe-continuous, 'zyx'). Variants: seat 'per_spring' (before), seat
'rigid' (the default now), and each with the grip k_roll = kp W^2 / 12 (eta 0.25) that
the earlier note added by hand.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks" / "sbb"))

import railfem as rf  # noqa: E402
from railfem import models  # noqa: E402
from railfem.standards import iec61260  # noqa: E402
from lateral_waves import (ETA_R, grip_spec, measured_lateral, rocking_k,  # noqa: E402
                           section)
from railfem.rail.mobility import Location  # noqa: E402
from railfem.track import supports, wfe  # noqa: E402
from railfem.track.coupling import couple_periodic  # noqa: E402

log = logging.getLogger("seat_roll")
BANDS = (100.0, 125.0, 160.0, 200.0, 250.0, 315.0)
CONTEXT = (400.0, 500.0, 630.0, 800.0, 1000.0)


def specs(model):
    if model == "wfe-periodic":
        base = rf.preset("site", model=model, pad_length=0.15, n_rows=1,
                         support_directions="zy").replace(eta_r=ETA_R)
    else:
        base = rf.preset("site", model=model, support_directions="zyx").replace(eta_r=ETA_R)
    old = base.replace(support=dataclasses.replace(base.support, seat="per_spring"))
    return {"per_spring": old, "rigid": base, "per_spring + grip": grip_spec(old),
            "rigid + grip": grip_spec(base)}


def decay(spec, lo, hi):
    f = iec61260.ninth_octave_grid(lo, hi)
    t0 = time.process_time()
    r = models.decay_rate(spec, f, output="head_lateral")
    log.info("%s %.0f-%.0f Hz: %.1f s CPU", spec.model, lo, hi, time.process_time() - t0)
    return {float(c): float(d) for c, d in zip(r.frequency, r.decay_rate)}


def rms(values, measured, bands):
    d = [10 * np.log10(values[b] / measured[b]["median"]) for b in bands]
    return float(np.sqrt(np.mean(np.square(d))))


def rocking_seat(bands=BANDS, W=0.146, L=2.6):
    """The seat held against the seat rocking with the sleeper (two rails, rigid sleeper,
    antisymmetric load): a rail's share of the rocking, Z = (kb* - omega^2 ms) L^2 / 12, in
    series with the pad's roll S = kp* W^2 / 12; the rocking wave's least decay (closed
    form B k^4 + GJ k^2 + k_theta - omega^2 J_f = 0, k_theta per metre) for both."""
    sup = rf.preset("site").support
    S = sup.kp_complex * W ** 2 / 12
    ls = section()
    rows = []
    for b in bands:
        w = 2 * np.pi * b
        Z = (sup.kb_complex - w ** 2 * sup.ms) * L ** 2 / 12
        K = S * Z / (S + Z)
        held = -8.686 * rocking_k(ls, w, S / 0.6)[0].imag
        rock = -8.686 * rocking_k(ls, w, K / 0.6)[0].imag
        rows.append({"band": b, "Z_over_S": float(abs(Z / S)),
                     "K_over_S": float(abs(K / S)), "held_db": float(held),
                     "rocking_db": float(rock)})
    return rows


def translation(f=None, x=(0.0, 0.3, 0.6, 1.2, 3.0, 6.0)):
    """The vertical seat translation kept per spring (every spring pair its chain K_s)
    against one common seat translation (pairs on the pad kp*, plus the mean vertical
    displacement of the springs on K_s - kp*, which is exact for a rigid seat), on the
    site track (wfe-periodic, default footprint), vertical head load and response:
    max |dB| per frequency over the points within 20 dB of the point receptance."""
    spec = rf.preset("site", model="wfe-periodic")
    n = spec.numerics
    rail = models.wfe_rail(spec.rail, n.patch_width, n.n_foot_springs, n.foot_rule)
    sp0 = rail.springs
    mean = Location(label="mean", weights=sum(s * p.weights
                                              for s, p in zip(sp0.weight, sp0.pairs)))
    springs = wfe.FootSprings(pairs=sp0.pairs, weight=sp0.weight, y=sp0.y, others=(mean,),
                              other_weight=np.array([1.0]), other_direction=("r",))
    f = np.geomspace(50, 5000, 31) if f is None else np.asarray(f)
    cell = supports.uniform_layout(spec.support, spec.spacing, n=1,
                                   pad_length=spec.pad_length, n_rows=spec.n_rows)
    k = wfe.periodic_kernel(rail.guide, springs, cell.springs().x, spec.spacing, f,
                            load=rail.load, outputs=[rail.outputs["head"]], force_x=[0.0],
                            response_x=np.asarray(x), spring_length=cell.row_length,
                            load_length=n.load_length, n_theta=n.n_theta)
    w = 2 * np.pi * f
    Ks = supports.dynamic_stiffness(spec.support, w) / spec.n_rows
    kp = np.full(len(w), spec.support.kp_complex) / spec.n_rows

    def K(z, r):  # (nf, rows, 4): z the pairs, r (code 3) the mean column
        out = np.zeros((len(f), spec.n_rows, 4), complex)
        out[:, :, 2], out[:, :, 3] = z[:, None], r[:, None]
        return out

    old = couple_periodic(k, K(Ks, 0 * Ks))[:, 0, :, 0]
    new = couple_periodic(k, K(kp, Ks - kp))[:, 0, :, 0]
    db = 20 * np.log10(np.abs(new / old))
    near = 20 * np.log10(np.abs(old) / np.abs(old).max(axis=1, keepdims=True)) > -20
    return [{"f": float(fi), "point_db": float(d[0]), "max_db": float(np.abs(d[m]).max())}
            for fi, d, m in zip(f, db, near)]


def run(models_=("wfe-periodic",), hi=1000.0):
    out = {"measured": measured_lateral(), "models": {}}
    for m in models_:
        out["models"][m] = {tag: decay(s, 100.0, hi) for tag, s in specs(m).items()}
    out["rocking"] = rocking_seat()
    t0 = time.process_time()
    out["translation"] = translation()
    log.info("translation: %.1f s CPU", time.process_time() - t0)
    return out


def table(res) -> str:
    meas = res["measured"]
    bands = [b for b in BANDS + CONTEXT if b in next(iter(next(iter(
        res["models"].values())).values()))]
    lines = ["## EN 15461 lateral decay rate (dB/m)", "",
             "Head, lateral hammer and sensor; RMS of 10 lg(model / measured median) over "
             "100-315 Hz. '+ grip': k_roll = kp W^2 / 12 = 1.07e6 N m/rad (eta 0.25) on top.",
             "", "| model | seat | " + " | ".join(f"{b:g}" for b in bands)
             + " | RMS 100-315 Hz (dB) |", "|---" * (len(bands) + 3) + "|",
             "| measured | median (15 rows) | " + " | ".join(
                 f"{meas[b]['median']:.1f}" for b in bands) + " | |",
             "| | range | " + " | ".join(f"{meas[b]['min']:.1f}-{meas[b]['max']:.1f}"
                                        for b in bands) + " | |"]
    for m, variants in res["models"].items():
        for tag, v in variants.items():
            lines.append(f"| {m} | {tag} | " + " | ".join(f"{v[b]:.1f}" for b in bands)
                         + f" | {rms(v, meas, BANDS):.1f} |")
    lines += ["", "## How far the seat is from held", "",
              "Held seat against a seat rocking with a rigid two-rail sleeper (antisymmetric "
              "load; per rail Z = (kb* - omega^2 ms) L^2 / 12, L = 2.6 m, in series with the "
              "pad's S = kp* W^2 / 12, W = 0.146 m): the rocking wave's least decay (closed "
              "form, continuous support).", "",
              "| band (Hz) | abs(Z / S) | abs(S Z / (S + Z)) / abs(S) | decay, seat held (dB/m) "
              "| decay, seat rocking (dB/m) |", "|---|---|---|---|---|"]
    lines += [f"| {r['band']:g} | {r['Z_over_S']:.0f} | {r['K_over_S']:.3f} | "
              f"{r['held_db']:.1f} | {r['rocking_db']:.1f} |" for r in res["rocking"]]
    lines += ["", "## The seat's vertical translation", "",
              "Vertical seat translation kept per spring against one common seat "
              "translation (site track, wfe-periodic, vertical head receptance at 0-6 m): "
              "difference at the point and largest over the points within 20 dB of it.", "",
              "| f (Hz) | point (dB) | largest within 20 dB (dB) |", "|---|---|---|"]
    lines += [f"| {r['f']:.0f} | {r['point_db']:+.3f} | {r['max_db']:.3f} |"
              for r in res["translation"]]
    return "\n".join(lines)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default="")
    p.add_argument("--json", default="")
    p.add_argument("--continuous", action="store_true", help="also wfe-continuous 'zyx'")
    p.add_argument("--hi", type=float, default=1000.0)
    p.add_argument("--from-json", default="", help="write the tables from an earlier --json")
    a = p.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    ms = ("wfe-periodic",) + (("wfe-continuous",) if a.continuous else ())
    if a.from_json:
        res = json.loads(Path(a.from_json).read_text())
        res["measured"] = {float(b): v for b, v in res["measured"].items()}
        res["models"] = {m: {t: {float(b): x for b, x in v.items()} for t, v in vs.items()}
                         for m, vs in res["models"].items()}
    else:
        res = run(ms, a.hi)
    if a.json:
        Path(a.json).write_text(json.dumps(res, indent=1))
    text = table(res)
    print(text)
    if a.out:
        Path(a.out).write_text(HEADER + text + "\n")


HEADER = """# The rail seat's roll on the SBB lateral rows

Reproduce: `OPENBLAS_NUM_THREADS=1 python benchmarks/sbb/seat_roll.py --continuous --out
benchmarks/results/results_seat_roll.md` (about 8 min on the shared 2-core machine; the
periodic rows alone, without `--continuous`, in under a minute). Derivation and what it
means for users: docs/supports.md.

Track: site preset, rail loss factor 0.01; wfe-periodic as diagnose_sbb.py --lateral has it
(0.15 m pad in one row, supports 'zy'), wfe-continuous as lateral_waves.py ('zyx'). Seat
'per_spring': every foot spring its own pad - sleeper - ballast chain (the seat rolls with
the foot, as before); 'rigid' (now the default): one rail seat that does not turn, the
foot's roll held by the pad alone.

"""


if __name__ == "__main__":
    main()
