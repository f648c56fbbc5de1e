"""Supported-track subcommands: ``track`` and ``support-convergence``."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from .common import (BadInput, add_profile, add_rail_options, add_track_options,
                     apply_track_options, count, non_negative, positive, report_written)


def track_args(p: argparse.ArgumentParser) -> None:
    from ..spec import MODELS, PRESETS

    add_rail_options(p)
    p.add_argument("--preset", choices=sorted(PRESETS), default=None,
                   help="track parameter set: generic stiff ... very_soft pads, or the "
                        "unloaded site track (docs/presets.md; default site)")
    p.add_argument("--config", type=Path, default=None, metavar="FILE",
                   help="track spec and job settings from a TOML file or from a run.json of "
                        "an earlier run (its 'config' section); options given here override "
                        "it, it overrides the preset")
    p.add_argument("--from-run", type=Path, default=None, metavar="DIR",
                   help="repeat the run whose outputs are in DIR (same as --config "
                        "DIR/run.json)")
    p.add_argument("--model", choices=MODELS, default=None,
                   help="track model (default wfe-discrete)")
    add_track_options(p, rail=False)
    j = p.add_argument_group("job")
    j.add_argument("--f-low", type=positive, default=None, metavar="HZ",
                   help="lowest band (Hz, default 50)")
    j.add_argument("--f-high", type=positive, default=None, metavar="HZ",
                   help="highest band (Hz, default 8000)")
    j.add_argument("--cache-dir", type=Path, default=None, metavar="DIR",
                   help="folder of the kernel cache (default $RAILFEM_CACHE or "
                        "~/.cache/railfem)")
    j.add_argument("--no-cache", action="store_true",
                   help="keep kernels in memory only (nothing read from or written to disk)")
    p.add_argument("--out", type=Path, default=Path("railfem-output/track"), metavar="DIR",
                   help="output folder (default railfem-output/track)")


def track_spec_from_args(args):
    """(TrackSpec, JobSettings) from the track options: preset < config < options."""
    from dataclasses import replace

    from ..io.config import read_track_config
    from ..jobs.track import job_from_dict
    from ..spec import preset, spec_from_dict

    if args.config is not None and args.from_run is not None:
        raise BadInput("give either --config or --from-run, not both")
    source = args.config if args.config is not None else args.from_run
    spec_d, job_d = read_track_config(source) if source is not None else ({}, {})
    if args.preset:  # an explicit --preset is the base, whatever the config names
        spec_d = {k: x for k, x in spec_d.items() if k != "preset"}
    try:
        spec = spec_from_dict(spec_d, base=preset(args.preset) if args.preset else None)
        job = job_from_dict(job_d)
    except (ValueError, KeyError) as exc:
        if source is None:
            raise
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        raise BadInput(f"config {source}: {msg}") from None
    spec = apply_track_options(spec, args)
    jobs = {k: x for k, x in (("f_low", args.f_low), ("f_high", args.f_high)) if x is not None}
    return spec, replace(job, **jobs)


def track_run(args) -> int:
    from ..jobs.track import run_track

    spec, job = track_spec_from_args(args)
    cache = False if args.no_cache else args.cache_dir
    s = run_track(spec, args.out, job=job, cache=cache)
    peaks = ", ".join(f"{k} {v:.0f} Hz" for k, v in s["rail_pad_peak_hz"].items())
    sys.stdout.write(f"{s['name']} track, {s['model']}: rail-on-pad peak {peaks}; "
                     f"{s['runtime_s']:.1f} s\n")
    report_written(s["files"])
    return 0


def support_args(p: argparse.ArgumentParser) -> None:
    from ..spec import FOOT_RULES as RULES
    from ..track.supports import PRESETS

    add_profile(p, h_default=None)
    p.add_argument("--preset", choices=sorted(PRESETS), default="site",
                   help="track parameter set: generic stiff ... very_soft pads, or the "
                        "unloaded site track (docs/presets.md; default site)")
    p.add_argument("--sizes", type=positive, nargs="+", default=[10, 7.5, 5], metavar="MM",
                   help="section element sizes in mm (default 10 7.5 5)")
    p.add_argument("--width", type=count, nargs="+", default=[16, 32, 64], metavar="N",
                   help="springs across the foot (default 16 32 64)")
    p.add_argument("--rule", choices=RULES, default="midpoint",
                   help="springs across the foot: midpoint (distributed bed, default) or "
                        "nodes (the published configuration)")
    p.add_argument("--pad-lengths", type=non_negative, nargs="+", default=[0.0, 0.15],
                   metavar="M", help="pad lengths along the rail in m; 0 = point-like "
                                     "(default 0 0.15)")
    p.add_argument("--rows", type=count, nargs="+", default=[1, 2, 3, 6], metavar="N",
                   help="spring rows along a pad of finite length (default 1 2 3 6)")
    p.add_argument("--rows-ref", type=count, default=3,
                   help="rows of the reference case of the h and width sweeps (default 3)")
    p.add_argument("--n-supports", type=count, default=41,
                   help="discrete supports centred on the sensor span (default 41)")
    p.add_argument("--decay", action="store_true",
                   help="also the EN 15461 decay rates per band (periodic track; slow)")
    p.add_argument("--out", type=Path, default=Path("railfem-output/support-convergence"),
                   metavar="DIR", help="output folder (default railfem-output/support-convergence)")


def support_run(args) -> int:
    from ..jobs.support_convergence import run_support_convergence

    res = run_support_convergence(args.out, sizes=np.array(args.sizes) * 1e-3,
                                  widths=args.width, rows=args.rows,
                                  pad_lengths=args.pad_lengths, rule=args.rule,
                                  rows_ref=args.rows_ref, preset=args.preset,
                                  decay=args.decay, n_supports=args.n_supports,
                                  profile=args.profile)
    sys.stdout.write(res["text"])
    report_written(res["paths"])
    return 0
