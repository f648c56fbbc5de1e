"""Subcommands on measured data: ``tdr`` (hammer, pass-by), ``fit``, ``diagnose``."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .common import (add_speed, add_workers, count, finite, index, mm_length, non_negative,
                     parse_use, positive, report_written, workers_from_args)


# ------------------------------------------------------------ pass-by decay rate
def recording_args(p: argparse.ArgumentParser, prefix: str = "") -> None:
    """The options that say what the recordings do not: speed, axle spacing, channel."""
    add_speed(p, prefix)
    p.add_argument("--axle-spacing", type=positive, default=None, metavar="M",
                   help=f"{prefix}bogie axle spacing in m, to find the speed when it is not "
                        "known")
    p.add_argument("--channel", default=None, metavar="NAME",
                   help=f"{prefix}channel of multi-channel 'railfem passby' recordings")


def tdr_passby_args(p: argparse.ArgumentParser) -> None:
    p.set_defaults(_run=tdr_passby_run)
    p.add_argument("recordings", nargs="+", type=Path, metavar="RECORDING",
                   help="pass-by recordings: .npz or .wav, each with a .toml or .json "
                        "metadata file of the same name (quantity, fs_hz, speed_m_s, ...)")
    p.add_argument("--f-low", type=positive, default=100.0, metavar="HZ",
                   help="lowest band (Hz, default 100)")
    p.add_argument("--f-high", type=positive, default=5000.0, metavar="HZ",
                   help="highest band (Hz, default 5000)")
    recording_args(p)
    p.add_argument("--l1", type=positive, default=1.0, metavar="M",
                   help="energy window around each wheel, m (default 1)")
    p.add_argument("--l3-low", type=positive, default=0.6, metavar="M",
                   help="slope-fit length below --l3-split, m (default 0.6)")
    p.add_argument("--l3-high", type=positive, default=1.2, metavar="M",
                   help="slope-fit length from --l3-split up, m (default 1.2)")
    p.add_argument("--l3-split", type=positive, default=1000.0, metavar="HZ",
                   help="band centre frequency where the slope-fit length changes (Hz)")
    p.add_argument("--out", type=Path, default=Path("railfem-output/tdr-passby"),
                   metavar="DIR", help="output folder (default railfem-output/tdr-passby)")


def tdr_passby_run(args) -> int:
    from ..estimators.passby import PassbyOptions
    from ..jobs.tdr_passby import run_tdr_passby

    opts = PassbyOptions(f_low=args.f_low, f_high=args.f_high, l1=args.l1,
                         l3_low=args.l3_low, l3_high=args.l3_high, l3_split_hz=args.l3_split)
    s = run_tdr_passby(args.recordings, args.out, opts, speed=args.speed,
                       axle_spacing=args.axle_spacing, channel=args.channel)
    for w in s["wheels"]:
        sys.stdout.write(f"{w['name']}: {w['count']} wheels, {w['speed_m_s']:.2f} m/s "
                         f"({w['speed_source']})\n")
    report_written(s["files"])
    return 0


# ------------------------------------------------------------ decay rate from data
def tdr_args(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="method", metavar="METHOD", required=True)
    h = sub.add_parser("hammer", help="EN 15461 hammer method on a measurement",
                       description="EN 15461 decay rate of a hammer measurement: a dataset "
                       "folder (frf.csv + meta.json) or a TOML descriptor of a CSV/UFF file.")
    h.add_argument("data", type=Path, metavar="DATA", help="dataset folder or .toml descriptor")
    h.add_argument("--sensor", nargs="+", metavar="NAME", help="sensors to use (default all)")
    h.add_argument("--threshold-db", type=finite, default=-15.0, metavar="DB",
                   help="noise-floor candidates: level re the point FRF below this (default -15)")
    h.add_argument("--floor-drop-db", type=positive, default=3.0, metavar="DB",
                   help="a tail is a noise floor when it falls less than this (default 3)")
    h.add_argument("--plain-threshold", action="store_true",
                   help="drop everything below the threshold (no flat-tail test)")
    h.add_argument("--attenuation-range", type=non_negative, nargs=2, metavar=("LOW", "HIGH"),
                   help="also drop positions implying an attenuation outside LOW..HIGH dB/m "
                   "below 400 Hz (e.g. 3 30); off by default")
    h.add_argument("--no-exclusion", action="store_true", help="use every position")
    h.add_argument("--point", choices=("nominal", "realised"), default="nominal",
                   help="weight the point FRF at x = 0 (EN 15461, default) or where it was struck")
    h.add_argument("--out", type=Path, default=Path("railfem-output/tdr"), metavar="DIR",
                   help="output folder (default railfem-output/tdr)")
    h.set_defaults(_run=tdr_run)
    tdr_passby_args(sub.add_parser(
        "passby", help="energy iteration and slope fitting on pass-by recordings",
        description="Track decay rate from pass-by recordings (time signals + metadata): "
                    "energy iteration and slope fitting per one-third-octave band."))


def tdr_run(args) -> int:
    from ..estimators.tdr import NO_EXCLUSION, NoiseFloorExclusion
    from ..jobs.tdr_hammer import run_tdr_hammer

    if args.no_exclusion:
        exclusion = NO_EXCLUSION
    else:
        exclusion = NoiseFloorExclusion(
            threshold_db=args.threshold_db,
            floor_drop_db=None if args.plain_threshold else args.floor_drop_db,
            attenuation_range=(None if args.attenuation_range is None
                               else tuple(args.attenuation_range)))
    s = run_tdr_hammer(args.data, args.out, exclusion=exclusion, point=args.point,
                       sensors=args.sensor)
    for name, r in s["decay_rate"].items():
        n_ok = sum(r["suitable"])
        sys.stdout.write(f"{name}: {n_ok} of {len(r['suitable'])} bands suitable\n")
    report_written(s["files"])
    return 0


# ------------------------------------------------------------ track parameters from data
def fit_args(p: argparse.ArgumentParser) -> None:
    from ..params import BASE_PARAMETERS as DEFAULT_PARAMETERS
    from ..spec import MODELS

    p.add_argument("data", type=Path, metavar="DATA",
                   help="hammer dataset folder / .toml descriptor, or a decay-rate table .csv")
    p.add_argument("--model", choices=MODELS, default="wfe-discrete",
                   help="track model (default wfe-discrete)")
    p.add_argument("--use", default=None, metavar="Q,Q",
                   help="quantities fitted: point,phase,transfer,tdr (default "
                   "point,transfer,tdr for hammer data, tdr for a table)")
    p.add_argument("--parameters", default=None, metavar="P,P",
                   help="parameters fitted: kp,eta_p,kb,eta_b,eta_r,ms,pad_length, laterally "
                   "kp_lat,eta_p_lat,kb_lat,eta_b_lat,ms_lat (default "
                   f"{','.join(DEFAULT_PARAMETERS)}; lateral rows: "
                   "kp_lat,eta_p_lat,kb_lat,eta_b_lat)")
    base_args(p)
    p.add_argument("--row", type=index, metavar="N", default=None,
                   help="table: row N of the selection (0-based)")
    p.add_argument("--select", default=None, metavar="K=V,...",
                   help="table: rows matching e.g. dir=v,sec=B5 (keys dir, sec, date, rail)")
    p.add_argument("--directions", choices=("z", "y"), default=None,
                   help="table: the decay-rate rows fitted, z vertical or y lateral (a lateral "
                        "row is fitted on a track whose supports act vertically and "
                        "laterally, as diagnose models it); default: the rows --select gives")
    p.add_argument("--campaign", action="store_true",
                   help="table: fit every selected row (on a Dask cluster)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="Dask scheduler address for --campaign (default: a local cluster)")
    p.add_argument("--transfer-positions", type=non_negative, nargs="+", metavar="M",
                   help="hammer distances (m) of the transfers fitted (nearest measured)")
    p.add_argument("--f-low", type=positive, default=None, metavar="HZ",
                   help="lowest frequency (Hz) of the FRF points fitted (default: all)")
    p.add_argument("--f-high", type=positive, default=None, metavar="HZ",
                   help="highest frequency (Hz) of the FRF points fitted (default: all)")
    p.add_argument("--starts", type=count, default=8, metavar="N",
                   help="multi-start points (Sobol, default 8)")
    add_workers(p)
    p.add_argument("--seed", type=int, default=0, help="seed of the start points")
    p.add_argument("--no-profiles", action="store_true", help="skip the profile likelihoods")
    discrepancy_args(p)
    p.add_argument("--out", type=Path, default=Path("railfem-output/fit"), metavar="DIR",
                   help="output folder (default railfem-output/fit)")


def base_args(p: argparse.ArgumentParser) -> None:
    """The base model's options, the same for fit and diagnose (railfem.identify.base)."""
    p.add_argument("--preset", default="site", help="spec whose other values are kept (a "
                   "preset of docs/presets.md, default site; the data's sleeper spacing is used)")
    p.add_argument("--pad-length", type=non_negative, default=None, metavar="MM",
                   help="support footprint of the base model: a pad of this length in mm "
                        "(one spring row spread over it); default 0, point supports (fit: "
                        "add pad_length to --parameters to profile it; diagnose compares "
                        "pad lengths as the pad_length effect)")


def discrepancy_args(p: argparse.ArgumentParser) -> None:
    """The model-form discrepancy option, the same for fit and diagnose."""
    p.add_argument("--discrepancy", choices=("ensemble", "none"), default="ensemble",
                   help="model-form discrepancy the residuals and intervals carry: "
                        "'ensemble' (default: the base model's own discretisation variants, "
                        "straight edges, another mesh size and spring count, per band) or "
                        "'none' (noise alone)")


def discrepancy_from_args(args):
    """--discrepancy as the library takes it: 'ensemble' or None."""
    return None if args.discrepancy == "none" else args.discrepancy


def base_from_args(args):
    """The base TrackSpec of fit and diagnose from their options (before the data's spacing
    is applied): railfem.identify.base.default_base (--pad-length in mm, as in ``railfem
    track``)."""
    from ..identify.base import default_base

    pad = mm_length("--pad-length", args.pad_length, 1.0, 1000.0, "150")
    return default_base(args.model, preset_name=args.preset, pad_length=pad)


def f_range_from_args(args):
    """(low, high) Hz from --f-low / --f-high, None when neither is given."""
    if args.f_low is None and args.f_high is None:
        return None
    return (args.f_low or 0.0, args.f_high or float("inf"))


def fit_run(args) -> int:
    from ..identify.base import describe_base
    from ..jobs.fit import run_fit

    base = base_from_args(args)
    use = parse_use(args.use) if args.use else None
    params = (None if args.parameters is None else
              tuple(x.strip() for x in args.parameters.split(",") if x.strip()))
    s = run_fit(args.data, args.out, model=args.model, use=use, parameters=params,
                select=args.select, row=args.row, directions=args.directions,
                campaign=args.campaign,
                scheduler=args.scheduler, base=base, n_starts=args.starts,
                workers=workers_from_args(args), seed=args.seed,
                transfer_positions=args.transfer_positions, f_range=f_range_from_args(args),
                profiles=() if args.no_profiles else ("kp", "kb"),
                discrepancy=discrepancy_from_args(args), command=" ".join(sys.argv))
    sys.stdout.write(f"base model: {s.get('base') or describe_base(base, s['parameters'])}\n")
    from ..jobs.fit import parameter_line

    if "summary" in s:
        sys.stdout.write("\n".join(s["summary"]) + "\n")
    for r in s.get("rows", []):
        sys.stdout.write(f"row {r['row']} ({r['folder']}):\n")
        for name, p in r["parameters"].items():
            sys.stdout.write("  " + parameter_line(dict(p, name=name)) + "\n")
        report_written(r["files"])
    report_written(s["files"])
    return 0


def diagnose_args(p: argparse.ArgumentParser) -> None:
    from ..spec import MODELS

    p.add_argument("data", type=Path, nargs="+", metavar="DATA",
                   help="hammer dataset folder / .toml descriptor, a decay-rate table .csv, "
                        "or pass-by recordings (.npz/.wav with their metadata files)")
    p.add_argument("--model", choices=MODELS, default="wfe-discrete",
                   help="track model (default wfe-discrete)")
    p.add_argument("--effects", default=None, metavar="E,E",
                   help="candidate effects (default: the library but random_support; "
                        "'all': every one)")
    p.add_argument("--select", default=None, metavar="K=V,...",
                   help="table: rows matching e.g. dir=v,sec=B5 (keys dir, sec, date, rail)")
    p.add_argument("--group", default="section,date", metavar="K,K",
                   help="table: diagnose rows grouped by these keys (default section,date)")
    p.add_argument("--spacing", type=positive, default=0.6, metavar="M",
                   help="table, pass-by: sleeper spacing in m (default 0.6)")
    p.add_argument("--passby-method", choices=("energy", "slope"), default="energy",
                   help="pass-by: decay-rate estimator (default energy iteration)")
    recording_args(p, "pass-by: ")
    p.add_argument("--f-low", type=positive, default=None, metavar="HZ",
                   help="hammer data: lowest frequency (Hz) of the FRF points diagnosed "
                        "(default: all); pass-by: lowest band (default 100)")
    p.add_argument("--f-high", type=positive, default=None, metavar="HZ",
                   help="hammer data: highest frequency (Hz) of the FRF points diagnosed "
                        "(default: all); pass-by: highest band (default 5000)")
    base_args(p)
    p.add_argument("--starts", type=count, default=4, metavar="N",
                   help="multi-start points of the base fit (default 4)")
    add_workers(p, "parallel processes of the base fit, the candidates' screening and "
                   "the pairs")
    p.add_argument("--reference", type=Path, default=None, metavar="REF",
                   help="diagnose against a reference section: REF a dataset or decay-rate "
                        "table of it (rows of the same date where the table has them), or "
                        "its fit.json (railfem fit) or diagnosis.json; the base is calibrated "
                        "on REF and held there, so the residual shows what differs")
    p.add_argument("--reference-select", default=None, metavar="K=V,...",
                   help="table REF: its rows, e.g. section=A (as --select)")
    discrepancy_args(p)
    p.add_argument("--out", type=Path, default=Path("railfem-output/diagnose"), metavar="DIR",
                   help="output folder (default railfem-output/diagnose)")


def diagnose_run(args) -> int:
    from ..jobs.diagnose import run_diagnose

    effects = ([x.strip() for x in args.effects.split(",") if x.strip()]
               if args.effects else None)
    effects = "all" if effects == ["all"] else effects
    passby = dict(method=args.passby_method, channel=args.channel, speed=args.speed,
                  axle_spacing=args.axle_spacing,
                  f_low=100.0 if args.f_low is None else args.f_low,
                  f_high=5000.0 if args.f_high is None else args.f_high)
    s = run_diagnose(args.data, args.out, model=args.model, select=args.select,
                     group=args.group, spacing=args.spacing, effects=effects,
                     n_starts=args.starts, workers=workers_from_args(args), passby=passby,
                     f_range=f_range_from_args(args), base=base_from_args(args),
                     reference=args.reference, reference_select=args.reference_select,
                     discrepancy=discrepancy_from_args(args), command=" ".join(sys.argv))
    for g in s["groups"]:
        lines = g.get("summary") or [g["statement"]]
        sys.stdout.write(f"{g['name']}: " + "\n  ".join(lines) + "\n")
        report_written(g["files"])
    report_written([Path(args.out) / "run.json"])
    return 0
