"""Pass-by subcommands: ``passby``, ``roughness`` and ``study``."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .common import (add_speed, add_track_options, add_workers, apply_track_options,
                     non_negative, positive, report_written, workers_from_args)


# ------------------------------------------------------------------------ pass-by
def passby_args(p: argparse.ArgumentParser) -> None:
    from ..simulate.chain import CONTACT_FILTERS
    from ..simulate.passby import CONTINUOUS_OF, FORMS, OUTPUTS
    from ..spec import PRESETS

    p.add_argument("--config", type=Path, metavar="TOML",
                   help="options from a TOML file (keys = option names with underscores); "
                        "options given here override it")
    p.add_argument("--preset", choices=sorted(PRESETS), help="track (default site)")
    p.add_argument("--model", choices=sorted(CONTINUOUS_OF), help="track model "
                   "(default wfe-discrete)")
    add_track_options(p)
    p.add_argument("--train", type=Path, metavar="FILE", help="train layout (TOML/JSON); "
                   "default 6 cars, 24 wheels over 120 m")
    p.add_argument("--speed-kmh", type=positive, metavar="KMH",
                   help="train speed in km/h (default 216)")
    p.add_argument("--roughness", type=Path, metavar="FILE", help="roughness spectrum: "
                   "wavelength_m,level_db_re_1um CSV or the SBB wide table")
    p.add_argument("--roughness-hold", action="store_true",
                   help="hold the roughness spectrum's end levels beyond its wavelengths")
    p.add_argument("--wheel", help="rigid (default), flexible, or an FRF CSV file")
    p.add_argument("--f-low", type=positive, metavar="HZ", help="lowest band (Hz, default 100)")
    p.add_argument("--f-high", type=positive, metavar="HZ",
                   help="highest band (Hz, default 5000)")
    p.add_argument("--form", choices=FORMS, help="incoherent sum: exact (default) or paper")
    p.add_argument("--no-interaction", action="store_true",
                   help="neglect interference between wheels (diagonal rail mobility)")
    p.add_argument("--continuous", action="store_true",
                   help="position-independent rail (continuous support)")
    p.add_argument("--output", choices=OUTPUTS, help="sensor on the rail foot (default) or head")
    p.add_argument("--contact-filter", choices=CONTACT_FILTERS, help="default analytical")
    p.add_argument("--max-distance", type=positive, metavar="M",
                   help="largest wheel-sensor distance in the rail tables (m, default 30)")
    p.add_argument("--signal", action="store_true", help="also write the time signal")
    p.add_argument("--sample-rate", type=positive, help="Hz (default 25600)")
    p.add_argument("--noise-fraction", type=non_negative,
                   help="band noise RMS as a fraction of the band's largest RMS (default 0)")
    p.add_argument("--position-error", type=non_negative, metavar="M",
                   help="sigma of the wheel-position error of the pulses (m, default 0)")
    p.add_argument("--seed", type=int, help="random seed of the signal (default 0)")
    p.add_argument("--no-speed", action="store_true",
                   help="leave the train speed out of the recording's metadata")
    p.add_argument("--out", type=Path, default=Path("railfem-output/passby"), metavar="DIR",
                   help="output folder (default railfem-output/passby)")


def passby_run(args) -> int:
    from ..jobs.passby import read_config, run_passby
    from ..spec import preset

    opts = read_config(args.config) if args.config else {}
    # the track: the preset (option < config < site) with the config's model, then the
    # track options as in 'railfem track'
    name = opts.pop("preset", "site")
    base = preset(args.preset or name, model=opts.pop("model", "wfe-discrete"))
    track = apply_track_options(base, args)
    given = {"train": args.train,
             "speed_kmh": args.speed_kmh, "roughness": args.roughness, "wheel": args.wheel,
             "f_low": args.f_low, "f_high": args.f_high, "form": args.form,
             "output": args.output, "contact_filter": args.contact_filter,
             "max_distance": args.max_distance, "sample_rate": args.sample_rate,
             "noise_fraction": args.noise_fraction, "position_error": args.position_error,
             "seed": args.seed}
    opts.update({k: (str(v) if isinstance(v, Path) else v) for k, v in given.items()
                 if v is not None})
    for flag, key, value in ((args.no_interaction, "interaction", False),
                             (args.continuous, "continuous", True), (args.signal, "signal", True),
                             (args.roughness_hold, "roughness_hold", True),
                             (args.no_speed, "speed_known", False)):
        if flag:
            opts[key] = value
    s = run_passby(args.out, track=track, **opts)
    sys.stdout.write(f"{s['preset']} track ({s['model']}), {s['train']['n_wheels']} wheels, "
                     f"{s['speed_m_per_s'] * 3.6:.0f} km/h: {s['runtime_s']['total']:.1f} s\n")
    report_written(s["files"])
    return 0


# ------------------------------------------------------------------- roughness
def roughness_args(p: argparse.ArgumentParser) -> None:
    from ..jobs.roughness import A_TERMS, METHODS
    from ..spec import MODELS

    p.add_argument("recordings", nargs="+", type=Path, metavar="RECORDING",
                   help="pass-by recordings (.npz/.wav + .toml/.json metadata)")
    p.add_argument("--track", required=True, metavar="SPEC",
                   help="preset name, TOML track spec, 'railfem track' run.json or "
                        "'railfem fit' fit.json")
    p.add_argument("--model", choices=MODELS, default=None, help="override the track model")
    p.add_argument("--method", choices=METHODS, default="full", help="default full")
    p.add_argument("--tdr", default=None, metavar="SOURCE",
                   help="decay rate for the simplified method: energy, slope, model, "
                        "hammer:DATA or a decay-rate table file")
    p.add_argument("--a-terms", choices=A_TERMS, default="model",
                   help="A1, A2 of the simplified method from the track model (default) or "
                        "the original defaults (A1 = 0, continuous track, flexible wheel)")
    p.add_argument("--channel", default=None, metavar="NAME",
                   help="channel of multi-channel recordings")
    p.add_argument("--wheel", default="rigid", help="rigid (default), flexible or an FRF CSV")
    p.add_argument("--contact-filter", default="analytical",
                   help="analytical (default), numerical or none")
    add_speed(p)
    p.add_argument("--wheel-snr", type=positive, default=None, metavar="DB",
                   help="wheel detector threshold above the record's median, dB (default "
                        "20; 12 for long trains in short records)")
    p.add_argument("--f-low", type=positive, default=100.0, metavar="HZ",
                   help="lowest band (Hz, default 100)")
    p.add_argument("--f-high", type=positive, default=5000.0, metavar="HZ",
                   help="highest band (Hz, default 5000)")
    p.add_argument("--out", type=Path, default=Path("railfem-output/roughness"),
                   metavar="DIR", help="output folder (default railfem-output/roughness)")


def roughness_run(args) -> int:
    from ..jobs.roughness import run_roughness

    s = run_roughness(args.recordings, args.out, track=args.track, method=args.method,
                      tdr=args.tdr, a_terms=args.a_terms, model=args.model,
                      channel=args.channel, f_low=args.f_low, f_high=args.f_high,
                      wheel=args.wheel, contact_filter=args.contact_filter, speed=args.speed,
                      detect=None if args.wheel_snr is None else {"snr_db": args.wheel_snr})
    sys.stdout.write(f"{s['method']} method on {len(s['recordings'])} recording(s), "
                     f"{s['runtime_s']:.1f} s\n")
    report_written(s["files"])
    return 0


# ----------------------------------------------------------------------- studies
def study_args(p: argparse.ArgumentParser) -> None:
    from ..spec import MODELS

    sub = p.add_subparsers(dest="study", metavar="STUDY", required=True)
    s = sub.add_parser("passby", help="error study of the pass-by TDR estimators and the "
                       "roughness methods on simulated pass-bys (docs/roughness.md)")
    s.add_argument("--model", choices=MODELS, default="wfe-discrete")
    s.add_argument("--tracks", nargs="+", default=None, metavar="PRESET",
                   help="presets (default: stiff medium soft very_soft site)")
    s.add_argument("--speeds-kmh", type=positive, nargs="+", default=None, metavar="KMH",
                   help="one speed per pass-by (default 212 214 216 218)")
    s.add_argument("--noise-fraction", type=non_negative, default=0.1)
    s.add_argument("--position-error", type=non_negative, default=0.1, metavar="M")
    s.add_argument("--seed", type=int, default=0)
    add_workers(s, "parallel processes, one track each")
    s.add_argument("--sbb", type=Path, default=None, metavar="CSV",
                   help="SBB rail roughness table to plot (default ../shared/... if there)")
    s.add_argument("--out", type=Path, default=Path("railfem-output/study-passby"),
                   metavar="DIR")
    s.set_defaults(_run=study_run)


def study_run(args) -> int:
    from ..jobs.study import SPEEDS_KMH, STUDY_TRACKS, run_passby_study

    s = run_passby_study(args.out, model=args.model, tracks=args.tracks or STUDY_TRACKS,
                         speeds_kmh=args.speeds_kmh or SPEEDS_KMH,
                         noise_fraction=args.noise_fraction,
                         position_error=args.position_error, seed=args.seed,
                         workers=workers_from_args(args), sbb=args.sbb,
                         sensitivity_track="site" if "site" in (args.tracks or STUDY_TRACKS)
                         else None)
    sys.stdout.write(f"study passby: {len(s['tracks'])} tracks in "
                     f"{s['timing_s']['total']:.0f} s\n")
    report_written(s["files"])
    return 0
