"""Which wave carries the lateral far field of the SBB-like track at 100-200 Hz, and why
the model's lateral decay rate stays at 2-4 dB/m where Niederwangen measures 9-14 dB/m.

    OPENBLAS_NUM_THREADS=1 python benchmarks/sbb/lateral_waves.py \
        [--out benchmarks/results/results_lateral_waves.md] [--json /tmp/lw.json] [--quick]

Track: the site preset on a continuous support (wfe-continuous: the support K_d(omega) /
spacing per metre spread over the foot underside, acting vertically, laterally and
longitudinally, support_directions 'zyx'; 'r' added when k_roll > 0), 60E1 10 mm mesh,
rail loss factor 0.01 (as scripts/lateral_fits.py and diagnose_sbb.py --lateral). Lateral
hammer and sensor on the side face of the head (railfem.models 'head_lateral').

1. Waves at the band centres: wavenumber, decay 8.686 |Im k|, cross-section content
   (railfem.track.wavecontent.section_content) and each wave's contribution to the lateral
   head transfer at EN 15461 distances (railfem.track.wavecontent.wave_contributions);
   their sum against railfem.models.receptance (the model's own transfer).
2. EN 15461 lateral decay rate per band (1/9-octave grid, the standard's 29 positions) of
   the whole transfer and of the carrying wave alone; the whole one against
   railfem.models.decay_rate.
3. Sweeps of what acts on the carrying wave, within literature ranges.
4. Closed form of the carrying wave (the rail rocking about its foot): where the measured
   decay puts the roll restraint, against the pad's own roll stiffness.
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
from scipy.optimize import brentq

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

import railfem as rf  # noqa: E402
from railfem import models  # noqa: E402
from railfem.io.tdr_table import SBB_NIEDERWANGEN_COLUMNS, read_decay_rate_table  # noqa: E402
from railfem.standards import en15461, iec61260  # noqa: E402
from railfem.track import lateral_beam  # noqa: E402
from railfem.track.directions import PAD_ROLL, directional_stiffness, roll_inertia  # noqa: E402
from railfem.track.sleeper import TWO_LAYER_ASSUMED  # noqa: E402
from railfem.track.wavecontent import (  # noqa: E402
    continuous_wave_sets, section_content, wave_contributions)

TABLE = Path("/work/shared/measured_data/sbb_niederwangen/tdr_niederwangen_wide.csv")
BANDS = (100.0, 125.0, 160.0, 200.0)
CONTEXT = (250.0, 315.0, 400.0, 500.0, 630.0, 800.0, 1000.0)
SHOW_X = (0.3, 1.2, 3.0, 6.0, 12.0, 19.8)  # m: distances of the contribution table
ETA_R = 0.01
#: the rail seat (SupportParameters.seat): 'rigid' is the library's default; the tables of
#: results_lateral_waves.md are of 'per_spring' (the seat rolling with the foot), --seat
SEAT = {"seat": "rigid"}
log = logging.getLogger("lateral_waves")


def with_seat(spec):
    return spec.replace(support=dataclasses.replace(spec.support, seat=SEAT["seat"]))


def base_spec():
    return with_seat(rf.preset("site", model="wfe-continuous", support_directions="zyx")
                     .replace(eta_r=ETA_R))


def rail_of(spec):
    n = spec.numerics
    return models.wfe_rail(spec.rail, n.patch_width, n.n_foot_springs, n.foot_rule,
                           models.spring_directions(spec))


def en_separations(spec):
    """(positions, response-minus-load separations) of the EN 15461 test as
    railfem.models.decay_rate realises it (position 0 at the hammer offset)."""
    xs, pos, hx = models.hammer_x(spec)
    return pos, xs - hx


# ------------------------------------------------------------------ waves and contributions


def contributions(spec, f, x):
    """Per frequency: list over families of (FamilyResponse, Waves, c (nw, nx))."""
    rail = rail_of(spec)
    sets = continuous_wave_sets(rail.guide, spec.support, spec.spacing, f,
                                load=rail.loads["head_lateral"],
                                outputs=[rail.outputs["head_lateral"]],
                                directions=models.spring_directions(spec),
                                n_waves=spec.numerics.n_waves, tail=spec.numerics.tail)
    L = spec.numerics.load_length
    return [[(fr, w, wave_contributions(fr, w, x, L, 0.0)[:, 0, :, 0]) for fr, w in s]
            for s in sets]


def carrier(parts, x, at=3.0):
    """(family index, wave index) of the wave with the largest contribution at ``at`` m."""
    j = int(np.argmin(np.abs(np.abs(x) - at)))
    best = max(((i, n, abs(c[n, j])) for i, (_, _, c) in enumerate(parts)
                for n in range(c.shape[0])), key=lambda t: t[2])
    return best[0], best[1]


def en_decay(f, Y, pos):
    """EN 15461 band decay rates (dB/m) from receptances Y (nf, npos)."""
    r = en15461.decay_rate(f, 2j * np.pi * f[:, None] * Y, pos)
    return {float(c): float(d) for c, d in zip(r.frequency, r.decay_rate)}


def band_decays(spec, bands):
    """EN 15461 decay rate per band of the whole lateral transfer and of its carrying
    wave alone, and the carrier's wave at each band centre."""
    pos, x = en_separations(spec)
    f = iec61260.ninth_octave_grid(min(bands), max(bands))
    keep = np.array([any(abs(fi / b - 1) < 0.13 for b in bands) for fi in f])
    f = f[keep]
    P = contributions(spec, f, x)
    tot = np.array([sum(c.sum(0) for _, _, c in parts) for parts in P])
    car = []
    for parts in P:
        i, n = carrier(parts, x)
        car.append(parts[i][2][n])
    out = {"whole": en_decay(f, tot, pos), "carrier": en_decay(f, np.array(car), pos),
           "wave": {}}
    for b in bands:
        i_f = int(np.argmin(np.abs(f - b)))
        parts = P[i_f]
        i, n = carrier(parts, x)
        fr, w, c = parts[i]
        sc = section_content(rail_of(spec).guide, fr.ops.T, w.phi[:, [n]])
        out["wave"][b] = {"k": [float(w.k[n].real), float(w.k[n].imag)],
                          "db_per_m": float(-8.686 * w.k[n].imag),
                          "family": fr.ops.family, "pivot_z": float(sc.pivot_z[0]),
                          "foot_over_head": float(abs(sc.foot_y[0] / sc.head_y[0])),
                          "roll": float(sc.roll[0]), "lateral": float(sc.lateral[0])}
    return out


def wave_table(spec, f, n_show=6):
    """Per frequency: every wave with a contribution above 1 % of the transfer at one of
    SHOW_X (at most n_show, by |k|): k, decay, content, |c_n| / |Y| at SHOW_X; and the
    largest relative difference of the wave sum from railfem.models.receptance."""
    x = -np.array((0.02,) + SHOW_X)
    P = contributions(spec, f, x)
    direct = models.receptance(spec, f, [0.0], x, outputs=("head_lateral",),
                               force="head_lateral", cache=False)[:, 0, :, 0]
    guide = rail_of(spec).guide
    out = []
    for i, parts in enumerate(P):
        tot = sum(c.sum(0) for _, _, c in parts)
        err = float(np.max(np.abs(tot - direct[i]) / np.abs(direct[i])))
        rows = []
        for fr, w, c in parts:
            share = np.abs(c) / np.abs(tot)[None, :]
            pick = np.flatnonzero(share[:, 1:].max(axis=1) > 0.01)[:n_show]
            if not len(pick):
                continue
            sc = section_content(guide, fr.ops.T, w.phi[:, pick])
            for j, n in enumerate(pick):
                rows.append({
                    "family": fr.ops.family, "n": int(n),
                    "k": [float(w.k[n].real), float(w.k[n].imag)],
                    "db_per_m": float(-8.686 * w.k[n].imag),
                    "wavelength": float(2 * np.pi / abs(w.k[n].real)),
                    "lateral": float(sc.lateral[j]), "roll": float(sc.roll[j]),
                    "vertical": float(sc.vertical[j]), "axial": float(sc.axial[j]),
                    "deformation": float(sc.deformation[j]), "pivot_z": float(sc.pivot_z[j]),
                    "head_y": abs(complex(sc.head_y[j])), "foot_y": abs(complex(sc.foot_y[j])),
                    "share": [float(s) for s in share[n]],
                    "point_share": float(share[n, 0])})
        out.append({"f": float(f[i]), "error_vs_model": err, "waves": rows,
                    "Y": [float(abs(v)) for v in tot]})
    return out


# ------------------------------------------------------------------ the closed form


def section():
    spec = base_spec()
    return lateral_beam.LateralSection.from_mesh(models.rail_mesh(spec.rail), spec.rail.material())


def rocking_constants(ls):
    """(B, GJ, J_f) of the rail rocking about its foot underside (z = 0) with the foot held
    laterally: v_s = -z_s theta, so per metre B theta'''' - GJ theta'' + (k_theta -
    omega^2 J_f) theta = 0 with B = E I_z z_s^2 + E Gamma (lateral bending of the section
    turning about the foot, plus warping), J_f = rho (I_p + A z_C^2) (polar inertia about
    the foot)."""
    B = ls.E * ls.I_z * ls.z_s ** 2 + ls.E * ls.Gamma
    zc = ls.z_s + ls.e
    return B, ls.G * ls.J, ls.rho * (ls.I_p + ls.area * zc ** 2)


def rocking_k(ls, omega, k_theta):
    """The two positive-going wavenumbers (rad/m) of the rocking wave per metre of roll
    restraint k_theta (N m/rad per m, complex): B k^4 + GJ* k^2 + k_theta - omega^2 J_f = 0,
    rail loss factor on B and GJ. Sorted by decay, least first."""
    B, GJ, Jf = rocking_constants(ls)
    c = 1 + 1j * ls.eta
    k2 = np.roots([B * c, GJ * c, k_theta - omega ** 2 * Jf])
    k = np.sqrt(k2.astype(complex))
    k = np.where(k.imag > 0, -k, k)
    return k[np.argsort(-k.imag)]


def required_roll(ls, omega, decay_db, eta_theta, spacing):
    """Roll restraint per support (N m/rad, loss factor eta_theta) at which the rocking
    wave's least decay is decay_db (dB/m); None if no value in [1e3, 1e9] reaches it."""
    def gap(k_sup):
        k = rocking_k(ls, omega, k_sup * (1 + 1j * eta_theta) / spacing)
        return -8.686 * k[0].imag - decay_db
    lo, hi = 1e3, 1e9
    if gap(lo) * gap(hi) > 0:
        return None
    return float(np.exp(brentq(lambda lk: gap(np.exp(lk)), np.log(lo), np.log(hi),
                               xtol=1e-9)))


def sleeper_roll(spec, omega, W):
    """Roll restraint per support (N m/rad) of the pad's roll stiffness kp* W^2 / 12 in series
    with the sleeper turning under the seat: a rail's share J of the sleeper's rocking
    inertia (railfem.track.directions.roll_inertia) on the ballast's rocking stiffness kb*
    times the same lever moment J / ms (uniform bed under the sleeper). Returns (K, J)."""
    s = spec.support
    J = roll_inertia(s)
    lever = J / s.ms
    k_pad = s.kp * (1 + 1j * s.eta_p) * W ** 2 / 12
    k_bal = s.kb * (1 + 1j * s.eta_b) * lever - omega ** 2 * J
    return k_pad * k_bal / (k_pad + k_bal), J


def closed_form(spec, measured):
    ls = section()
    B, GJ, Jf = rocking_constants(ls)
    W = 0.146  # m: 60E1 foot width (the mesh's underside)
    kz = {b: complex(directional_stiffness(spec.support, 2 * np.pi * b, PAD_ROLL)) for b in
          BANDS + CONTEXT[:2]}  # the vertical springs against the roll (the seat's)
    pad_roll = spec.support.kp * W ** 2 / 12
    rows = []
    for b in BANDS + CONTEXT[:2]:
        w = 2 * np.pi * b
        chain_roll = kz[b] * W ** 2 / 12  # N m/rad per support: the vertical springs
        k_model = rocking_k(ls, w, chain_roll / spec.spacing)[0]
        k_pad = rocking_k(ls, w, (pad_roll * (1 + 1j * spec.support.eta_p)) / spec.spacing)[0]
        req = required_roll(ls, w, measured[b], spec.support.eta_p, spec.spacing)
        k_sl, J = sleeper_roll(spec, w, W)
        k_slw = rocking_k(ls, w, k_sl / spec.spacing)[0]
        rows.append({"band": b, "chain_roll": [chain_roll.real, chain_roll.imag],
                     "model_db": float(-8.686 * k_model.imag), "k_model": [k_model.real,
                                                                          k_model.imag],
                     "pad_db": float(-8.686 * k_pad.imag),
                     "sleeper_roll": [k_sl.real, k_sl.imag], "sleeper_J": J,
                     "sleeper_db": float(-8.686 * k_slw.imag),
                     "measured": measured[b], "required_k_roll": req,
                     "cut_on_hz_pad": float(np.sqrt(pad_roll / spec.spacing / Jf) / 2 / np.pi)})
    return {"B": B, "GJ": GJ, "J_f": Jf, "pad_roll": pad_roll, "W": W, "rows": rows}


# ------------------------------------------------------------------ sweeps


def variants(spec):
    s = spec.support
    pad_roll = s.kp * 0.146 ** 2 / 12
    R = dataclasses.replace
    yield "base (site preset, continuous)", spec
    for v in (20e6, 300e6):
        yield f"kp_lat {v / 1e6:.0f} MN/m", spec.replace(support=R(s, kp_lat=v))
    yield "eta_p_lat 1.0", spec.replace(support=R(s, eta_p_lat=1.0))
    for v in (2e7, 1e8):
        yield f"k_clip {v / 1e6:.0f} MN/m (eta 0.1)", spec.replace(
            support=R(s, k_clip=v, eta_clip=0.1))
    for v in (1e5, 3e5, 6e5, pad_roll, 3e6):
        yield f"k_roll {v / 1e6:.2g} MN m/rad (eta 0.25)", spec.replace(
            support=R(s, k_roll=v, eta_roll=0.25))
    yield f"k_roll {pad_roll / 1e6:.2g} MN m/rad, eta_roll 0.5", spec.replace(
        support=R(s, k_roll=pad_roll, eta_roll=0.5))
    for v in (5e6, 100e6):
        yield f"kb_lat {v / 1e6:.0f} MN/m", spec.replace(support=R(s, kb_lat=v))
    yield "eta_b_lat 2.0", spec.replace(support=R(s, eta_b_lat=2.0))
    for v in (40.0, 300.0):
        yield f"ms_lat {v:.0f} kg", spec.replace(support=R(s, ms_lat=v))
    yield "flexible sleeper", spec.replace(sleeper="flexible")
    yield "ballast mass (two-layer, assumed)", spec.replace(**TWO_LAYER_ASSUMED)
    for v in (200e6, 1500e6):
        yield f"kp {v / 1e6:.0f} MN/m (vertical pad)", spec.replace(support=R(s, kp=v))
    for v in (0.003, 0.05):
        yield f"rail loss factor {v}", spec.replace(eta_r=v)
    yield "kb_lat inf (sleeper held laterally)", spec.replace(support=R(s, kb_lat=np.inf))


def sweep(spec, bands, quick=False):
    out = []
    for name, s in variants(spec):
        if quick and not name.startswith(("base", "k_roll")):
            continue
        t0 = time.perf_counter()
        d = band_decays(s, bands)
        d["name"], d["seconds"] = name, time.perf_counter() - t0
        log.info("%s: %s (%.0f s)", name, {b: round(v, 2) for b, v in d["whole"].items()},
                 d["seconds"])
        out.append(d)
    return out


# ------------------------------------------------------------------ measured and the note


def measured_lateral():
    """{band: median, min, max over the 15 lateral rows, rail_to_rail: median |left -
    right| over the groups with both rails} (dB/m)."""
    rows = [r for r in read_decay_rate_table(TABLE, columns=SBB_NIEDERWANGEN_COLUMNS).rows()
            if r.direction == "y"]
    f = np.asarray(rows[0].frequency, dtype=float)
    v = np.stack([np.asarray(r.decay_rate, dtype=float) for r in rows])
    by: dict = {}
    for r, vi in zip(rows, v):
        by.setdefault((r.metadata.section, r.metadata.date), []).append(vi)
    pairs = np.array([abs(a - b) for a, b in (g for g in by.values() if len(g) == 2)])
    r2r = np.nanmedian(pairs, axis=0)
    return {float(c): {"median": float(m), "min": float(lo), "max": float(hi),
                       "rail_to_rail": float(d)}
            for c, m, lo, hi, d in zip(f, np.nanmedian(v, 0), np.nanmin(v, 0),
                                       np.nanmax(v, 0), r2r)}


def grip_spec(spec, eta=0.25):
    """The base with the pad's own roll stiffness k_roll = kp W^2 / 12 (uniform pad over
    the foot width W, sleeper not rolling with the foot) at loss factor eta."""
    s = spec.support
    return spec.replace(support=dataclasses.replace(s, k_roll=s.kp * 0.146 ** 2 / 12,
                                                    eta_roll=eta))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default=str(ROOT / "benchmarks/results/results_lateral_waves.md"))
    p.add_argument("--json", default="")
    p.add_argument("--quick", action="store_true", help="base and k_roll variants only")
    p.add_argument("--from-json", default="", help="write the table from an earlier --json")
    p.add_argument("--periodic", action="store_true", help="also the EN 15461 lateral decay "
                   "rate of the discrete-support track (wfe-periodic), base and with the "
                   "pad's roll stiffness")
    p.add_argument("--seat", default="rigid", choices=("rigid", "per_spring"),
                   help="the rail seat (SupportParameters.seat); the note's tables: per_spring")
    a = p.parse_args(argv)
    SEAT["seat"] = a.seat
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    if a.from_json:  # the closed form is cheap: recomputed
        res = json.loads(Path(a.from_json).read_text())
        res["closed_form"] = closed_form(base_spec(), {float(b): v["median"] for b, v in
                                                       res["measured"].items()})
    else:
        res = run(a.quick)
        if a.periodic:
            res["periodic"] = periodic_check()
    if a.json:
        Path(a.json).write_text(json.dumps(res, indent=1, default=float))
    from lateral_waves_report import markdown  # the tables (same folder)

    args = list(sys.argv[1:] if argv is None else argv)
    if a.from_json:  # the table is the full run's: say how to redo that
        i = args.index("--from-json")
        del args[i:i + 2]
        if res.get("periodic") and "--periodic" not in args:
            args.append("--periodic")
    cmd = "OPENBLAS_NUM_THREADS=1 python benchmarks/sbb/lateral_waves.py " + " ".join(args)
    Path(a.out).write_text(markdown(res, cmd.strip()))


def periodic_check(bands=(100.0, 315.0)) -> dict:
    """EN 15461 lateral decay rate (dB/m) of the discrete-support track as diagnose_sbb.py
    --lateral has it (wfe-periodic, 0.15 m pad in one row, supports 'zy'), base and with
    the pad's roll stiffness (grip_spec): {tag: {band: value}}."""
    spec = with_seat(rf.preset("site", model="wfe-periodic", pad_length=0.15, n_rows=1,
                               support_directions="zy").replace(eta_r=ETA_R))
    f = iec61260.ninth_octave_grid(*bands)
    out = {}
    for tag, s in (("base", spec), ("grip", grip_spec(spec))):
        r = models.decay_rate(s, f, output="head_lateral")
        out[tag] = {float(c): float(d) for c, d in zip(r.frequency, r.decay_rate)}
        log.info("periodic %s: %s", tag, out[tag])
    return out


def run(quick=False) -> dict:
    spec = base_spec()
    meas = measured_lateral()
    f = np.array(BANDS + CONTEXT)
    t0 = time.perf_counter()
    tables = {"base": wave_table(spec, f), "grip": wave_table(grip_spec(spec), f)}
    log.info("wave tables %.0f s", time.perf_counter() - t0)
    grid = iec61260.ninth_octave_grid(min(BANDS), max(CONTEXT))
    model_en = models.decay_rate(spec, grid, output="head_lateral", cache=False)
    return {"tables": tables, "base_bands": band_decays(spec, BANDS + CONTEXT),
            "model_decay_rate": {float(c): float(d) for c, d in
                                 zip(model_en.frequency, model_en.decay_rate)},
            "measured": meas,
            "closed_form": closed_form(spec, {b: meas[b]["median"] for b in meas}),
            "sweep": sweep(spec, BANDS + CONTEXT[:2], quick=quick)}


if __name__ == "__main__":
    main()
