"""The ``railfem`` command line.

    railfem mesh --profile 60E1 --h 10 --out meshes/       mesh + quality summary
    railfem mesh --shipped                                  regenerate railfem/data/meshes/ (60E1)
    railfem dispersion --profile 60E1 --h 10 --fmin 50 --fmax 5000 --n 100 --out DIR
    railfem dispersion --k-range 0.1 30 60 --out DIR        omega(k) instead of k(omega)
    railfem convergence --profile 60E1 --sizes 20 15 10 7.5 5 --frequencies 1000 --out DIR
    railfem mobility --free --freq 50:8000:60 --response head foot_sensor --x 0 0.3 --out DIR
    railfem passby --preset site --speed-kmh 216 --wheel flexible --signal --out DIR
    railfem tdr passby run1.npz run2.wav --out DIR          pass-by decay rates
    railfem roughness run1.wav --track site --method full --out DIR
    railfem study passby --out DIR                          TDR and roughness error study

Lengths on the command line are in mm (element sizes), frequencies in Hz, wavenumbers in
rad/m. Each subcommand parses its arguments and calls one function of
:mod:`railfem.jobs`; progress and messages go to stderr. Bad input (unknown profile,
unreadable file, impossible values) ends with a one-line message and exit code 2.

New subcommands register in ``COMMANDS`` (name -> (add_arguments, run)).
"""
from __future__ import annotations

import argparse
import logging
import os
import sys
import threading
from pathlib import Path

# The solvers work on many small dense and sparse matrices, where threaded BLAS only
# oversubscribes the cores (measured: the site-track job took 275 s instead of 40 s on 2
# cores with default OpenBLAS threading). Set before numpy loads; the user's value wins.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from . import __version__  # noqa: E402

log = logging.getLogger("railfem.cli")

EXIT_BAD_INPUT = 2


class BadInput(Exception):
    """Raised for user errors detected by the CLI itself."""


# ------------------------------------------------------------------ argument types
def _number(text: str, kind=float, *, ok, expected: str):
    try:
        value = kind(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}") from None
    if not (np.isfinite(value) and ok(value)):
        raise argparse.ArgumentTypeError(f"expected {expected}, got {text!r}")
    return value


def _positive(text: str) -> float:
    return _number(text, ok=lambda v: v > 0, expected="a positive number")


def _non_negative(text: str) -> float:
    return _number(text, ok=lambda v: v >= 0, expected="a number >= 0")


def _count(text: str) -> int:
    return _number(text, int, ok=lambda v: v >= 1, expected="an integer >= 1")


def _add_profile(p: argparse.ArgumentParser, h_default: float | None = 10.0) -> None:
    p.add_argument("--profile", default="60E1",
                   help="'60E1' (= UIC60, default), 'rect:WIDTHxHEIGHT' in mm, or the path "
                        "of an outline CSV (y,z in mm, counter-clockwise, foot at z = 0)")
    if h_default is not None:
        p.add_argument("--h", type=_positive, default=h_default, metavar="MM",
                       help=f"element size in mm (default {h_default:g})")


def _add_mesh_file(p: argparse.ArgumentParser) -> None:
    p.add_argument("--mesh", type=Path, default=None, metavar="FILE",
                   help="use this section mesh instead of --profile/--h: a railfem .npz "
                        "(railfem mesh) or any 2-D mesh file meshio reads (Gmsh .msh 2.2 / "
                        "4.x, 3- or 6-node triangles); symmetry is detected")
    p.add_argument("--mesh-units", choices=("m", "mm"), default=None,
                   help="length unit of a --mesh file that is not .npz (required for those)")
    p.add_argument("--mesh-axes", default="xy", metavar="AXES",
                   help="which axes of a --mesh file are lateral and vertical: 'xy' "
                        "(default: x lateral, y vertical), 'xz', '-y,z', ...")


# ------------------------------------------------------------------------- mesh
def _mesh_args(p: argparse.ArgumentParser) -> None:
    _add_profile(p)
    p.add_argument("--out", type=Path, default=None, metavar="DIR",
                   help="output folder (default: current folder; with --shipped the "
                        "package's railfem/data/meshes/ folder)")
    p.add_argument("--shipped", action="store_true",
                   help="regenerate all shipped meshes (60E1 at 20, 15, 10, 7.5, 5 mm); "
                        "--profile and --h are ignored")


def _mesh_run(args) -> int:
    from . import jobs

    if args.shipped:
        results = jobs.run_shipped_meshes(args.out, progress=jobs.progress_logger("meshes"))
        for r in results:
            sys.stdout.write(jobs.format_mesh_quality(r["quality"]))
        return 0
    r = jobs.run_mesh(args.profile, args.h * 1e-3, args.out or Path("."))
    sys.stdout.write(jobs.format_mesh_quality(r["quality"]))
    sys.stdout.write(f"wrote {r['mesh']}, {r['json']}, {r['txt']}\n")
    return 0


# ------------------------------------------------------------------- dispersion
def _dispersion_args(p: argparse.ArgumentParser) -> None:
    _add_profile(p)
    _add_mesh_file(p)
    g = p.add_argument_group("frequencies (k(omega), default) or wavenumbers (omega(k))")
    g.add_argument("--f-low", "--fmin", dest="fmin", type=_positive, default=None,
                   metavar="HZ", help="lowest frequency in Hz (default 50)")
    g.add_argument("--f-high", "--fmax", dest="fmax", type=_positive, default=None,
                   metavar="HZ", help="highest frequency in Hz (default 5000)")
    g.add_argument("--n", type=_count, default=None,
                   help="number of frequencies from --f-low to --f-high (default 100)")
    g.add_argument("--spacing", choices=("linear", "log"), default="linear",
                   help="frequency spacing between --f-low and --f-high (default linear)")
    g.add_argument("--frequencies", type=_positive, nargs="+", default=None, metavar="HZ",
                   help="explicit list of frequencies in Hz")
    g.add_argument("--k-range", type=_non_negative, nargs=3, default=None,
                   metavar=("KMIN", "KMAX", "NK"),
                   help="omega(k) at NK real wavenumbers from KMIN to KMAX (rad/m)")
    g.add_argument("--n-modes", type=_count, default=12,
                   help="modes per symmetry family for --k-range (default 12)")
    s = p.add_argument_group("solver and renders")
    s.add_argument("--eta-r", "--loss-factor", dest="loss_factor", type=_non_negative,
                   default=0.0, metavar="ETA",
                   help="rail loss factor (default 0: undamped)")
    s.add_argument("--method", choices=("shift-invert", "dense"), default="shift-invert",
                   help="k(omega) solver: shift-invert (the n-waves waves of smallest |k|, "
                        "fast, default) or dense (all waves)")
    s.add_argument("--n-waves", type=_count, default=40,
                   help="waves per family for shift-invert (default 40)")
    s.add_argument("--render-frequency", type=_positive, default=None, metavar="HZ",
                   help="render the propagating wave shapes at this frequency "
                        "(default 2000 Hz)")
    s.add_argument("--no-render", action="store_true", help="skip the wave-shape renders")
    p.add_argument("--out", type=Path, default=Path("railfem-output/dispersion"),
                   metavar="DIR", help="output folder (default railfem-output/dispersion)")


def _dispersion_run(args) -> int:
    from . import jobs

    freq_opts = any(v is not None for v in (args.fmin, args.fmax, args.n))
    if args.k_range is not None and (freq_opts or args.frequencies is not None):
        raise BadInput("--k-range cannot be combined with frequency options")
    if args.frequencies is not None and freq_opts:
        raise BadInput("give either --frequencies or --fmin/--fmax/--n, not both")
    frequencies = k_values = None
    if args.k_range is not None:
        kmin, kmax, nk = args.k_range
        if nk < 1 or nk != int(nk):
            raise BadInput(f"--k-range NK must be an integer >= 1, got {nk:g}")
        if kmax < kmin:
            raise BadInput(f"--k-range needs KMIN <= KMAX, got {kmin:g} > {kmax:g}")
        k_values = np.linspace(kmin, kmax, int(nk))
    elif args.frequencies is not None:
        frequencies = np.array(args.frequencies)
    else:
        fmin = 50.0 if args.fmin is None else args.fmin
        fmax = 5000.0 if args.fmax is None else args.fmax
        n = 100 if args.n is None else args.n
        if fmax < fmin:
            raise BadInput(f"--fmax ({fmax:g} Hz) must not be below --fmin ({fmin:g} Hz)")
        frequencies = (np.geomspace if args.spacing == "log" else np.linspace)(fmin, fmax, n)
    if args.no_render:
        render = None
    else:
        render = (jobs.DEFAULT_RENDER_FREQUENCY if args.render_frequency is None
                  else args.render_frequency)
    paths = jobs.run_dispersion(args.profile, args.h * 1e-3, args.out, frequencies=frequencies,
                                k_values=k_values, mesh_file=args.mesh,
                                mesh_units=args.mesh_units, mesh_axes=args.mesh_axes,
                                loss_factor=args.loss_factor, method=args.method,
                                n_waves=args.n_waves, n_modes=args.n_modes,
                                render_frequency=render)
    sys.stdout.write(f"wrote {paths['csv']}\nwrote {paths['png']}\n")
    for p in paths["renders"]:
        sys.stdout.write(f"wrote {p}\n")
    return 0


# ------------------------------------------------------------------ convergence
def _convergence_args(p: argparse.ArgumentParser) -> None:
    _add_profile(p, h_default=None)
    p.add_argument("--sizes", type=_positive, nargs="+", default=[20, 15, 10, 7.5, 5],
                   metavar="MM", help="element sizes in mm (default 20 15 10 7.5 5)")
    p.add_argument("--frequencies", type=_positive, nargs="*", default=[], metavar="HZ",
                   help="frequencies (Hz) at which the propagating wavenumbers are compared")
    p.add_argument("--n-cut-on", type=_count, default=6,
                   help="number of cross-section cut-on frequencies (default 6)")
    p.add_argument("--reference", choices=("richardson", "finest"), default="richardson",
                   help="error reference: Richardson extrapolation of the three finest "
                        "meshes (default) or the finest mesh")
    p.add_argument("--geometry", choices=("curved", "straight", "both"), default="curved",
                   help="curved 6-node elements (mid-side nodes on the outline, default), "
                        "their straight-sided twins, or both (straight in "
                        "convergence_straight.*)")
    p.add_argument("--shipped", action="store_true",
                   help="use the shipped meshes (railfem/data/meshes/) where there is one for the size "
                        "instead of meshing afresh")
    p.add_argument("--out", type=Path, default=Path("railfem-output/convergence"),
                   metavar="DIR", help="output folder (default railfem-output/convergence)")


def _convergence_run(args) -> int:
    from . import jobs

    sizes = np.array(args.sizes) * 1e-3
    paths = jobs.run_convergence(args.profile, sizes, args.out, frequencies=args.frequencies,
                                 n_cut_on=args.n_cut_on, reference=args.reference,
                                 geometry=args.geometry, use_shipped=args.shipped)
    for suffix in ("", "_straight"):
        if f"study{suffix}" not in paths:
            continue
        st = paths[f"study{suffix}"]
        sys.stdout.write(f"{'curved' if st.curved else 'straight-sided'} 6-node elements\n"
                         "h (mm)  DOFs   cut-on frequencies (Hz)\n")
        for i, h in enumerate(st.sizes):
            sys.stdout.write(f"{h * 1e3:6g} {st.n_dofs[i]:6d}  "
                             + " ".join(f"{v:9.2f}" for v in st.cut_on[i]) + "\n")
        sys.stdout.write("reference     " + " ".join(f"{v:9.2f}" for v in st.cut_on_reference)
                         + f"  ({st.reference['cut_on']})\n")
        sys.stdout.write("error finest  " + " ".join(f"{100 * v:8.4f}%" for v in
                                                     st.cut_on_error[np.argmin(st.sizes)])
                         + "\n")
        sys.stdout.write("rate          " + " ".join(f"{v:9.2f}" for v in st.cut_on_rate) + "\n")
        sys.stdout.write("Richardson p  " + " ".join(f"{v:9.2f}" for v in st.cut_on_order)
                         + "\n")
        sys.stdout.write(f"wrote {paths['csv' + suffix]}\nwrote {paths['png' + suffix]}\n"
                         f"wrote {paths['json' + suffix]}\n")
    return 0


def _track_args(p: argparse.ArgumentParser) -> None:
    from .spec import MODELS, PRESETS

    p.add_argument("--profile", default=None,
                   help="'60E1' (= UIC60, default), 'rect:WIDTHxHEIGHT' in mm, or the path "
                        "of an outline CSV (y,z in mm, counter-clockwise, foot at z = 0)")
    p.add_argument("--h", type=_positive, default=None, metavar="MM",
                   help="element size in mm, 0.5 to 100 (default 10)")
    p.add_argument("--preset", choices=sorted(PRESETS), default=None,
                   help="track parameter set of METHOD.md Table 1 (default site)")
    p.add_argument("--config", type=Path, default=None, metavar="FILE",
                   help="track spec and job settings from a TOML file or from a run.json of "
                        "an earlier run (its 'config' section); options given here override "
                        "it, it overrides the preset")
    p.add_argument("--from-run", type=Path, default=None, metavar="DIR",
                   help="repeat the run whose outputs are in DIR (same as --config "
                        "DIR/run.json)")
    p.add_argument("--model", choices=MODELS, default=None,
                   help="track model (default wfe-discrete)")
    g = p.add_argument_group("track parameters (override the preset and the config)")
    g.add_argument("--kp", type=_non_negative, default=None, metavar="MN/m",
                   help="rail pad stiffness per fastener, MN/m")
    g.add_argument("--eta-p", type=_non_negative, default=None, metavar="ETA",
                   help="rail pad loss factor (-)")
    g.add_argument("--kb", type=_non_negative, default=None, metavar="MN/m",
                   help="ballast stiffness per fastener and rail, MN/m")
    g.add_argument("--eta-b", type=_non_negative, default=None, metavar="ETA",
                   help="ballast loss factor (-)")
    g.add_argument("--ms", type=_non_negative, default=None, metavar="KG",
                   help="sleeper mass per rail, kg")
    g.add_argument("--eta-r", type=_non_negative, default=None, metavar="ETA",
                   help="rail loss factor (-)")
    g.add_argument("--spacing", type=_positive, default=None, metavar="MM",
                   help="sleeper spacing, mm (Table 1: 600)")
    g.add_argument("--pad-length", type=_non_negative, default=None, metavar="MM",
                   help="pad length along the rail, mm (default 150 on discrete and "
                        "periodic models; 0 = point supports, the published configuration)")
    g.add_argument("--n-rows", type=_count, default=None,
                   help="spring rows along each pad (default 3)")
    g.add_argument("--n-supports", type=_count, default=None,
                   help="supports of the discrete models (default 131)")
    g.add_argument("--n-foot-springs", type=_count, default=None,
                   help="springs across the rail foot per row (default 4)")
    g.add_argument("--foot-rule", choices=("midpoint", "nodes"), default=None,
                   help="springs across the foot: midpoint = a distributed bed through the "
                        "element shape functions (default, converges with the mesh); nodes = "
                        "point springs at foot nodes (the published configuration, with "
                        "--n-foot-springs 8 --pad-length 0)")
    g.add_argument("--support-directions", choices=("z", "zy", "zx", "zyx"), default=None,
                   help="directions the supports act in (default z, vertical springs only); "
                        "zyx adds lateral and longitudinal pads and the lateral decay rate")
    j = p.add_argument_group("job")
    j.add_argument("--f-low", type=_positive, default=None, metavar="HZ",
                   help="lowest band (Hz, default 50)")
    j.add_argument("--f-high", type=_positive, default=None, metavar="HZ",
                   help="highest band (Hz, default 8000)")
    j.add_argument("--cache-dir", type=Path, default=None, metavar="DIR",
                   help="folder of the kernel cache (default $RAILFEM_CACHE or "
                        "~/.cache/railfem)")
    j.add_argument("--no-cache", action="store_true",
                   help="keep kernels in memory only (nothing read from or written to disk)")
    p.add_argument("--out", type=Path, default=Path("railfem-output/track"), metavar="DIR",
                   help="output folder (default railfem-output/track)")


def _mm(name: str, value: float | None, low: float, high: float, example: str):
    """A length given in mm on the command line, checked against a sane range, in m."""
    if value is None:
        return None
    if value != 0 and not low <= value <= high:
        raise BadInput(f"{name} {value:g} mm: lengths on this command line are in mm; give "
                       f"a value between {low:g} and {high:g} mm (e.g. {example})")
    return value * 1e-3


def track_spec_from_args(args):
    """(TrackSpec, JobSettings) from the track options: preset < config < options."""
    from dataclasses import replace

    from .spec import preset, spec_from_dict
    from .trackjob import job_from_dict, read_config

    if args.config is not None and args.from_run is not None:
        raise BadInput("give either --config or --from-run, not both")
    h = _mm("--h", args.h, 0.5, 100.0, "10")
    spacing = _mm("--spacing", args.spacing, 100.0, 2000.0, "600")
    pad = _mm("--pad-length", args.pad_length, 1.0, 1000.0, "150")
    source = args.config if args.config is not None else args.from_run
    spec_d, job_d = read_config(source) if source is not None else ({}, {})
    if args.preset:  # an explicit --preset is the base, whatever the config names
        spec_d = {k: x for k, x in spec_d.items() if k != "preset"}
    spec = spec_from_dict(spec_d, base=preset(args.preset) if args.preset else None)
    job = job_from_dict(job_d)
    sup = {k: x for k, x in (("kp", args.kp), ("kb", args.kb)) if x is not None}
    sup = {k: x * 1e6 for k, x in sup.items()}
    sup.update({k: x for k, x in (("eta_p", args.eta_p), ("eta_b", args.eta_b),
                                  ("ms", args.ms)) if x is not None})
    rail = {k: x for k, x in (("profile", args.profile), ("h", h), ("eta", args.eta_r))
            if x is not None}
    top = {k: x for k, x in (("model", args.model), ("spacing", spacing), ("pad_length", pad),
                             ("n_rows", args.n_rows), ("n_supports", args.n_supports),
                             ("support_directions", args.support_directions))
           if x is not None}
    if sup:
        top["support"] = replace(spec.support, **sup)
    if rail:
        top["rail"] = replace(spec.rail, **rail)
    num = {k: x for k, x in (("n_foot_springs", args.n_foot_springs),
                             ("foot_rule", args.foot_rule)) if x is not None}
    if num:
        top["numerics"] = replace(spec.numerics, **num)
    spec = spec.replace(**top)
    jobs = {k: x for k, x in (("f_low", args.f_low), ("f_high", args.f_high)) if x is not None}
    return spec, replace(job, **jobs)


def _track_run(args) -> int:
    from .trackjob import run_track

    spec, job = track_spec_from_args(args)
    cache = False if args.no_cache else args.cache_dir
    s = run_track(spec, args.out, job=job, cache=cache)
    peaks = ", ".join(f"{k} {v:.0f} Hz" for k, v in s["rail_pad_peak_hz"].items())
    sys.stdout.write(f"{s['name']} track, {s['model']}: rail-on-pad peak {peaks}; "
                     f"{s['runtime_s']:.1f} s\n")
    for v in s["files"].values():
        sys.stdout.write(f"wrote {v}\n")
    return 0


# ------------------------------------------------------------------------ pass-by
def _passby_args(p: argparse.ArgumentParser) -> None:
    from .passbyjob import CONTACT_FILTERS
    from .simulate.passby import CONTINUOUS_OF, FORMS, OUTPUTS
    from .supports import PRESETS

    p.add_argument("--config", type=Path, metavar="TOML",
                   help="options from a TOML file (keys = option names with underscores); "
                        "options given here override it")
    p.add_argument("--preset", choices=sorted(PRESETS), help="track (default site)")
    p.add_argument("--model", choices=sorted(CONTINUOUS_OF), help="track model "
                   "(default wfe-discrete)")
    p.add_argument("--train", type=Path, metavar="FILE", help="train layout (TOML/JSON); "
                   "default 6 cars, 24 wheels over 120 m")
    p.add_argument("--speed-kmh", type=_positive, help="train speed (km/h, default 216)")
    p.add_argument("--roughness", type=Path, metavar="FILE", help="roughness spectrum: "
                   "wavelength_m,level_db_re_1um CSV or the SBB wide table")
    p.add_argument("--roughness-hold", action="store_true",
                   help="hold the roughness spectrum's end levels beyond its wavelengths")
    p.add_argument("--wheel", help="rigid (default), flexible, or an FRF CSV file")
    p.add_argument("--f-low", type=_positive, help="lowest band (Hz, default 100)")
    p.add_argument("--f-high", type=_positive, help="highest band (Hz, default 5000)")
    p.add_argument("--form", choices=FORMS, help="incoherent sum: exact (default) or paper")
    p.add_argument("--no-interaction", action="store_true",
                   help="neglect interference between wheels (diagonal rail mobility)")
    p.add_argument("--continuous", action="store_true",
                   help="position-independent rail (continuous support)")
    p.add_argument("--output", choices=OUTPUTS, help="sensor on the rail foot (default) or head")
    p.add_argument("--contact-filter", choices=CONTACT_FILTERS, help="default analytical")
    p.add_argument("--max-distance", type=_positive, metavar="M",
                   help="largest wheel-sensor distance in the rail tables (m, default 30)")
    p.add_argument("--signal", action="store_true", help="also write the time signal")
    p.add_argument("--sample-rate", type=_positive, help="Hz (default 25600)")
    p.add_argument("--noise-fraction", type=_non_negative,
                   help="band noise RMS as a fraction of the band's largest RMS (default 0)")
    p.add_argument("--position-error", type=_non_negative, metavar="M",
                   help="sigma of the wheel-position error of the pulses (m, default 0)")
    p.add_argument("--seed", type=int, help="random seed of the signal (default 0)")
    p.add_argument("--no-speed", action="store_true",
                   help="leave the train speed out of the recording's metadata")
    p.add_argument("--out", type=Path, default=Path("railfem-output/passby"), metavar="DIR",
                   help="output folder (default railfem-output/passby)")


def _passby_run(args) -> int:
    from .passbyjob import read_config, run_passby

    opts = read_config(args.config) if args.config else {}
    given = {"preset": args.preset, "model": args.model, "train": args.train,
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
    s = run_passby(args.out, **opts)
    sys.stdout.write(f"{s['preset']} track ({s['model']}), {s['train']['n_wheels']} wheels, "
                     f"{s['speed_m_per_s'] * 3.6:.0f} km/h: {s['runtime_s']['total']:.1f} s\n")
    for v in s["files"].values():
        sys.stdout.write(f"wrote {v}\n")
    return 0


# --------------------------------------------------------------- free mobility
def _frequency_spec(tokens) -> np.ndarray:
    """'F1 F2 ...' (Hz) or one 'FMIN:FMAX:N' (N log-spaced frequencies)."""
    if len(tokens) == 1 and ":" in tokens[0]:
        parts = tokens[0].split(":")
        try:
            fmin, fmax, n = float(parts[0]), float(parts[1]), int(parts[2])
        except (ValueError, IndexError):
            raise BadInput(f"--freq {tokens[0]!r}: expected FMIN:FMAX:N, e.g. 50:8000:60"
                           ) from None
        if len(parts) != 3 or not (0 < fmin <= fmax < np.inf) or n < 1:
            raise BadInput(f"--freq {tokens[0]!r}: need 0 < FMIN <= FMAX (Hz) and N >= 1")
        return np.geomspace(fmin, fmax, n)
    try:
        f = np.array([float(t) for t in tokens])
    except ValueError:
        raise BadInput(f"--freq expects frequencies in Hz or FMIN:FMAX:N, got {tokens}"
                       ) from None
    if not np.all(np.isfinite(f)) or np.any(f <= 0):
        raise BadInput(f"--freq: frequencies must be positive and finite (Hz), got {tokens}")
    return f


def _finite(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not np.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def _mobility_args(p: argparse.ArgumentParser) -> None:
    _add_profile(p)
    _add_mesh_file(p)
    p.add_argument("--free", action="store_true",
                   help="free (unsupported) rail; the only model of this command, so it is "
                        "also the default")
    p.add_argument("--f-low", type=_positive, default=None, metavar="HZ",
                   help="lowest frequency in Hz (with --f-high and --n: log-spaced)")
    p.add_argument("--f-high", type=_positive, default=None, metavar="HZ",
                   help="highest frequency in Hz")
    p.add_argument("--n", type=_count, default=None,
                   help="number of log-spaced frequencies from --f-low to --f-high "
                        "(default 40)")
    p.add_argument("--frequencies", type=_positive, nargs="+", default=None, metavar="HZ",
                   help="explicit list of frequencies in Hz (default: one-third-octave "
                        "centres 50 Hz - 8 kHz)")
    p.add_argument("--freq", nargs="+", default=None, metavar="HZ",
                   help="older spelling: frequencies in Hz or FMIN:FMAX:N")
    p.add_argument("--force", default="head", metavar="LOC",
                   help="load location NAME[:DIR]: 'head' (patch across the head top, "
                        "default), a single-node set (head_top, foot_sensor) or a node "
                        "index; DIR x, y or z (default z)")
    p.add_argument("--response", nargs="+", default=["head", "foot_sensor"], metavar="LOC",
                   help="response locations, same spelling as --force (default: head "
                        "foot_sensor); 'head' reads the average over the load patch")
    p.add_argument("--x", type=_finite, nargs="+", default=None, metavar="M",
                   help="response distances from the load along the rail in m (default "
                        "0 0.3 0.6 1.2)")
    p.add_argument("--patch-width", type=_positive, default=0.02, metavar="M",
                   help="width of the head load patch in m (default 0.02)")
    p.add_argument("--load-length", type=_non_negative, default=0.02, metavar="M",
                   help="length along the rail over which the force is spread, m (default "
                        "0.02; 0 gives a load concentrated at x = 0)")
    p.add_argument("--eta-r", "--eta", dest="eta", type=_non_negative, default=0.01,
                   metavar="ETA", help="rail loss factor (default 0.01)")
    p.add_argument("--method", choices=("shift-invert", "dense"), default="shift-invert",
                   help="waves kept: shift-invert (the --n-waves smallest |k| per family plus "
                        "the frozen near-field tail, default) or dense (all waves, slow)")
    p.add_argument("--n-waves", type=_count, default=40,
                   help="waves per family for shift-invert (default 40)")
    p.add_argument("--out", type=Path, default=Path("railfem-output/mobility"),
                   metavar="DIR", help="output folder (default railfem-output/mobility)")


def _mobility_frequencies(args):
    """The frequencies of `railfem mobility`: --frequencies, or --f-low/--f-high/--n, or the
    older --freq; None for the default one-third-octave centres."""
    given = [args.frequencies is not None,
             any(v is not None for v in (args.f_low, args.f_high, args.n)),
             args.freq is not None]
    if sum(given) > 1:
        raise BadInput("give the frequencies one way: --frequencies, or --f-low/--f-high/--n")
    if args.frequencies is not None:
        return np.asarray(args.frequencies, dtype=float)
    if given[1]:
        lo = 50.0 if args.f_low is None else args.f_low
        hi = 8000.0 if args.f_high is None else args.f_high
        if not lo < hi:
            raise BadInput(f"--f-low {lo:g} Hz must be below --f-high {hi:g} Hz")
        return np.geomspace(lo, hi, 40 if args.n is None else args.n)
    return None if args.freq is None else _frequency_spec(args.freq)


def _mobility_run(args) -> int:
    from . import mobilityjob

    if args.mesh is None and args.h < 1.0:
        raise BadInput(f"--h is the element size in mm like for the other commands; "
                       f"{args.h:g} mm is too fine (did you mean {args.h * 1e3:g}?)")
    frequencies = _mobility_frequencies(args)
    x = mobilityjob.DEFAULT_MOBILITY_X if args.x is None else args.x
    paths = mobilityjob.run_free_mobility(args.profile, args.h * 1e-3, args.out,
                                          frequencies=frequencies, force=args.force,
                                          responses=args.response, x=x,
                                          patch_width=args.patch_width,
                                          load_length=args.load_length, eta=args.eta,
                                          mesh_file=args.mesh, mesh_units=args.mesh_units,
                                          mesh_axes=args.mesh_axes, method=args.method,
                                          n_waves=args.n_waves)
    sys.stdout.write(f"wrote {paths['csv']}\nwrote {paths['png']}\nwrote {paths['json']}\n")
    return 0


# ------------------------------------------------------------ pass-by decay rate
def _tdr_passby_args(p: argparse.ArgumentParser) -> None:
    p.set_defaults(_run=_tdr_passby_run)
    p.add_argument("recordings", nargs="+", type=Path, metavar="RECORDING",
                   help="pass-by recordings: .npz or .wav, each with a .toml or .json "
                        "metadata file of the same name (quantity, fs_hz, speed_m_s, ...)")
    p.add_argument("--f-low", type=_positive, default=100.0, help="lowest band (Hz)")
    p.add_argument("--f-high", type=_positive, default=5000.0, help="highest band (Hz)")
    p.add_argument("--speed", type=_positive, default=None, metavar="M/S",
                   help="train speed in m/s (overrides the metadata)")
    p.add_argument("--axle-spacing", type=_positive, default=None, metavar="M",
                   help="bogie axle spacing in m, to find the speed when it is not known")
    p.add_argument("--channel", default=None, metavar="NAME",
                   help="channel of multi-channel 'railfem passby' recordings")
    p.add_argument("--l1", type=_positive, default=1.0, metavar="M",
                   help="energy window around each wheel, m (default 1)")
    p.add_argument("--l3-low", type=_positive, default=0.6, metavar="M",
                   help="slope-fit length below --l3-split, m (default 0.6)")
    p.add_argument("--l3-high", type=_positive, default=1.2, metavar="M",
                   help="slope-fit length from --l3-split up, m (default 1.2)")
    p.add_argument("--l3-split", type=_positive, default=1000.0, metavar="HZ",
                   help="band centre frequency where the slope-fit length changes (Hz)")
    p.add_argument("--out", type=Path, default=Path("railfem-output/tdr-passby"),
                   metavar="DIR", help="output folder (default railfem-output/tdr-passby)")


def _tdr_passby_run(args) -> int:
    from .estimators.passby import PassbyOptions
    from .tdrpassbyjob import run_tdr_passby

    opts = PassbyOptions(f_low=args.f_low, f_high=args.f_high, l1=args.l1,
                         l3_low=args.l3_low, l3_high=args.l3_high, l3_split_hz=args.l3_split)
    s = run_tdr_passby(args.recordings, args.out, opts, speed=args.speed,
                       axle_spacing=args.axle_spacing, channel=args.channel)
    for w in s["wheels"]:
        sys.stdout.write(f"{w['name']}: {w['count']} wheels, {w['speed_m_s']:.2f} m/s "
                         f"({w['speed_source']})\n")
    for v in s["files"].values():
        sys.stdout.write(f"wrote {v}\n")
    return 0


# ------------------------------------------------------------------- roughness
def _roughness_args(p: argparse.ArgumentParser) -> None:
    from .roughnessjob import A_TERMS, METHODS
    from .spec import MODELS

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
    p.add_argument("--speed", type=_positive, default=None, metavar="M/S",
                   help="train speed in m/s (overrides the metadata)")
    p.add_argument("--wheel-snr", type=_positive, default=None, metavar="DB",
                   help="wheel detector threshold above the record's median, dB (default "
                        "20; 12 for long trains in short records)")
    p.add_argument("--f-low", type=_positive, default=100.0, help="lowest band (Hz)")
    p.add_argument("--f-high", type=_positive, default=5000.0, help="highest band (Hz)")
    p.add_argument("--out", type=Path, default=Path("railfem-output/roughness"),
                   metavar="DIR", help="output folder (default railfem-output/roughness)")


def _roughness_run(args) -> int:
    from .roughnessjob import run_roughness

    s = run_roughness(args.recordings, args.out, track=args.track, method=args.method,
                      tdr=args.tdr, a_terms=args.a_terms, model=args.model,
                      channel=args.channel, f_low=args.f_low, f_high=args.f_high,
                      wheel=args.wheel, contact_filter=args.contact_filter, speed=args.speed,
                      detect=None if args.wheel_snr is None else {"snr_db": args.wheel_snr})
    sys.stdout.write(f"{s['method']} method on {len(s['recordings'])} recording(s), "
                     f"{s['runtime_s']:.1f} s\n")
    for v in s["files"].values():
        sys.stdout.write(f"wrote {v}\n")
    return 0


# ----------------------------------------------------------------------- studies
def _study_args(p: argparse.ArgumentParser) -> None:
    from .spec import MODELS

    sub = p.add_subparsers(dest="study", metavar="STUDY", required=True)
    s = sub.add_parser("passby", help="error study of the pass-by TDR estimators and the "
                       "roughness methods on simulated pass-bys (docs/roughness.md)")
    s.add_argument("--model", choices=MODELS, default="wfe-discrete")
    s.add_argument("--tracks", nargs="+", default=None, metavar="PRESET",
                   help="presets (default: stiff medium soft very_soft site)")
    s.add_argument("--speeds-kmh", type=_positive, nargs="+", default=None, metavar="KMH",
                   help="one speed per pass-by (default 212 214 216 218)")
    s.add_argument("--noise-fraction", type=_non_negative, default=0.1)
    s.add_argument("--position-error", type=_non_negative, default=0.1, metavar="M")
    s.add_argument("--seed", type=int, default=0)
    s.add_argument("--workers", type=_count, default=2)
    s.add_argument("--sbb", type=Path, default=None, metavar="CSV",
                   help="SBB rail roughness table to plot (default ../shared/... if there)")
    s.add_argument("--out", type=Path, default=Path("railfem-output/study-passby"),
                   metavar="DIR")
    s.set_defaults(_run=_study_run)


def _study_run(args) -> int:
    from .studyjob import SPEEDS_KMH, STUDY_TRACKS, run_passby_study

    s = run_passby_study(args.out, model=args.model, tracks=args.tracks or STUDY_TRACKS,
                         speeds_kmh=args.speeds_kmh or SPEEDS_KMH,
                         noise_fraction=args.noise_fraction,
                         position_error=args.position_error, seed=args.seed,
                         workers=args.workers, sbb=args.sbb,
                         sensitivity_track="site" if "site" in (args.tracks or STUDY_TRACKS)
                         else None)
    sys.stdout.write(f"study passby: {len(s['tracks'])} tracks in "
                     f"{s['timing_s']['total']:.0f} s\n")
    for v in s["files"].values():
        sys.stdout.write(f"wrote {v}\n")
    return 0


#: name -> (add_arguments(parser), run(args) -> exit code, help)
# ------------------------------------------------------------ decay rate from data
def _tdr_args(p: argparse.ArgumentParser) -> None:
    sub = p.add_subparsers(dest="method", metavar="METHOD", required=True)
    h = sub.add_parser("hammer", help="EN 15461 hammer method on a measurement",
                       description="EN 15461 decay rate of a hammer measurement: a dataset "
                       "folder (frf.csv + meta.json) or a TOML descriptor of a CSV/UFF file.")
    h.add_argument("data", type=Path, metavar="DATA", help="dataset folder or .toml descriptor")
    h.add_argument("--sensor", nargs="+", metavar="NAME", help="sensors to use (default all)")
    h.add_argument("--threshold-db", type=_finite, default=-15.0, metavar="DB",
                   help="noise-floor candidates: level re the point FRF below this (default -15)")
    h.add_argument("--floor-drop-db", type=_positive, default=3.0, metavar="DB",
                   help="a tail is a noise floor when it falls less than this (default 3)")
    h.add_argument("--plain-threshold", action="store_true",
                   help="drop everything below the threshold (no flat-tail test)")
    h.add_argument("--attenuation-range", type=_non_negative, nargs=2, metavar=("LOW", "HIGH"),
                   help="also drop positions implying an attenuation outside LOW..HIGH dB/m "
                   "below 400 Hz (e.g. 3 30); off by default")
    h.add_argument("--no-exclusion", action="store_true", help="use every position")
    h.add_argument("--point", choices=("nominal", "realised"), default="nominal",
                   help="weight the point FRF at x = 0 (EN 15461, default) or where it was struck")
    h.add_argument("--out", type=Path, default=Path("railfem-output/tdr"), metavar="DIR",
                   help="output folder (default railfem-output/tdr)")
    h.set_defaults(_run=_tdr_run)
    _tdr_passby_args(sub.add_parser(
        "passby", help="energy iteration and slope fitting on pass-by recordings",
        description="Track decay rate from pass-by recordings (time signals + metadata): "
                    "energy iteration and slope fitting per one-third-octave band."))


def _tdr_run(args) -> int:
    from .estimators.tdr import NO_EXCLUSION, NoiseFloorExclusion
    from .tdrjob import run_tdr_hammer

    if args.no_exclusion:
        exclusion = NO_EXCLUSION
    else:
        exclusion = NoiseFloorExclusion(
            threshold_db=args.threshold_db,
            floor_drop_db=None if args.plain_threshold else args.floor_drop_db,
            attenuation_range=None if args.attenuation_range is None else tuple(args.attenuation_range))
    s = run_tdr_hammer(args.data, args.out, exclusion=exclusion, point=args.point,
                       sensors=args.sensor)
    for name, r in s["decay_rate"].items():
        n_ok = sum(r["suitable"])
        sys.stdout.write(f"{name}: {n_ok} of {len(r['suitable'])} bands suitable\n")
    for v in s["files"].values():
        sys.stdout.write(f"wrote {v}\n")
    return 0


# ------------------------------------------------------------ track parameters from data
def _fit_args(p: argparse.ArgumentParser) -> None:
    from .identify.fit import DEFAULT_PARAMETERS
    from .spec import MODELS

    p.add_argument("data", type=Path, metavar="DATA",
                   help="hammer dataset folder / .toml descriptor, or a decay-rate table .csv")
    p.add_argument("--model", choices=MODELS, default="wfe-discrete",
                   help="track model (default wfe-discrete)")
    p.add_argument("--use", default=None, metavar="Q,Q",
                   help="quantities fitted: point,phase,transfer,tdr (default "
                   "point,transfer,tdr for hammer data, tdr for a table)")
    p.add_argument("--parameters", default=",".join(DEFAULT_PARAMETERS), metavar="P,P",
                   help="parameters fitted: kp,eta_p,kb,eta_b,eta_r,ms,pad_length "
                   f"(default {','.join(DEFAULT_PARAMETERS)})")
    p.add_argument("--preset", default="site", help="spec whose other values are kept "
                   "(Table 1 preset, default site; the data's sleeper spacing is used)")
    p.add_argument("--row", type=_count, metavar="N", default=None,
                   help="table: row N of the selection (0-based)")
    p.add_argument("--select", default=None, metavar="K=V,...",
                   help="table: rows matching e.g. dir=v,sec=B5 (keys dir, sec, date, rail)")
    p.add_argument("--campaign", action="store_true",
                   help="table: fit every selected row (on a Dask cluster)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="Dask scheduler address for --campaign (default: a local cluster)")
    p.add_argument("--transfer-positions", type=_non_negative, nargs="+", metavar="M",
                   help="hammer distances (m) of the transfers fitted (nearest measured)")
    p.add_argument("--f-low", type=_positive, default=None, metavar="HZ",
                   help="lowest frequency (Hz) of the FRF points fitted (default: all)")
    p.add_argument("--f-high", type=_positive, default=None, metavar="HZ",
                   help="highest frequency (Hz) of the FRF points fitted (default: all)")
    p.add_argument("--starts", type=_count, default=8, metavar="N",
                   help="multi-start points (Sobol, default 8)")
    p.add_argument("--workers", type=_count, default=None, metavar="N",
                   help="parallel processes (default: all cores)")
    p.add_argument("--seed", type=int, default=0, help="seed of the start points")
    p.add_argument("--no-profiles", action="store_true", help="skip the profile likelihoods")
    p.add_argument("--out", type=Path, default=Path("railfem-output/fit"), metavar="DIR",
                   help="output folder (default railfem-output/fit)")


def _fit_run(args) -> int:
    from .fitjob import parse_use, run_fit
    from .spec import preset

    use = parse_use(args.use) if args.use else None
    params = tuple(x.strip() for x in args.parameters.split(",") if x.strip())
    s = run_fit(args.data, args.out, model=args.model, use=use, parameters=params,
                select=args.select, row=args.row, campaign=args.campaign,
                scheduler=args.scheduler, base=preset(args.preset), n_starts=args.starts,
                workers=args.workers, seed=args.seed,
                transfer_positions=args.transfer_positions,
                f_range=(None if args.f_low is None and args.f_high is None else
                         (args.f_low or 0.0, args.f_high or float("inf"))),
                profiles=() if args.no_profiles else ("kp", "kb"),
                command=" ".join(sys.argv))
    results = [s["result"]] if "result" in s else [r for r in s["rows"]]
    for r in results:
        for name, p in r["parameters"].items():
            sys.stdout.write(f"{name} = {p['value']:.4g} [{p['ci95'][0]:.3g}, "
                             f"{p['ci95'][1]:.3g}] identifiable: {p['identifiable']}\n")
    sys.stdout.write(f"wrote {Path(args.out) / 'run.json'}\n")
    return 0


def _support_args(p: argparse.ArgumentParser) -> None:
    from .footprints import RULES
    from .supports import PRESETS

    _add_profile(p, h_default=None)
    p.add_argument("--preset", choices=sorted(PRESETS), default="site",
                   help="track parameter set of METHOD.md Table 1 (default site)")
    p.add_argument("--sizes", type=_positive, nargs="+", default=[10, 7.5, 5], metavar="MM",
                   help="section element sizes in mm (default 10 7.5 5)")
    p.add_argument("--width", type=_count, nargs="+", default=[16, 32, 64], metavar="N",
                   help="springs across the foot (default 16 32 64)")
    p.add_argument("--rule", choices=RULES, default="midpoint",
                   help="springs across the foot: midpoint (distributed bed, default) or "
                        "nodes (the published configuration)")
    p.add_argument("--pad-lengths", type=_non_negative, nargs="+", default=[0.0, 0.15],
                   metavar="M", help="pad lengths along the rail in m; 0 = point-like "
                                     "(default 0 0.15)")
    p.add_argument("--rows", type=_count, nargs="+", default=[1, 2, 3, 6], metavar="N",
                   help="spring rows along a pad of finite length (default 1 2 3 6)")
    p.add_argument("--rows-ref", type=_count, default=3,
                   help="rows of the reference case of the h and width sweeps (default 3)")
    p.add_argument("--n-supports", type=_count, default=41,
                   help="discrete supports centred on the sensor span (default 41)")
    p.add_argument("--decay", action="store_true",
                   help="also the EN 15461 decay rates per band (periodic track; slow)")
    p.add_argument("--out", type=Path, default=Path("railfem-output/support-convergence"),
                   metavar="DIR", help="output folder (default railfem-output/support-convergence)")


def _support_run(args) -> int:
    from . import jobs
    from .support_convergence import sweeps

    cases = sweeps(np.array(args.sizes) * 1e-3, args.width, args.rows, args.pad_lengths,
                   rule=args.rule, rows_ref=args.rows_ref)
    res = jobs.run_support_convergence(args.out, cases, preset=args.preset, decay=args.decay,
                                       n_supports=args.n_supports, profile=args.profile)
    sys.stdout.write(res["paths"]["txt"].read_text())
    for v in res["paths"].values():
        sys.stdout.write(f"wrote {v}\n")
    return 0



def _diagnose_args(p: argparse.ArgumentParser) -> None:
    from .spec import MODELS

    p.add_argument("data", type=Path, metavar="DATA",
                   help="hammer dataset folder / .toml descriptor, or a decay-rate table .csv")
    p.add_argument("--model", choices=MODELS, default="wfe-discrete",
                   help="track model (default wfe-discrete)")
    p.add_argument("--effects", default=None, metavar="E,E",
                   help="candidate effects (default: the whole library)")
    p.add_argument("--select", default=None, metavar="K=V,...",
                   help="table: rows matching e.g. dir=v,sec=B5 (keys dir, sec, date, rail)")
    p.add_argument("--group", default="section,date", metavar="K,K",
                   help="table: diagnose rows grouped by these keys (default section,date)")
    p.add_argument("--spacing", type=_positive, default=0.6, metavar="M",
                   help="table: sleeper spacing in m (default 0.6)")
    p.add_argument("--starts", type=_count, default=4, metavar="N",
                   help="multi-start points of the base fit (default 4)")
    p.add_argument("--workers", type=_count, default=1, metavar="N",
                   help="parallel processes of the base fit (default 1)")
    p.add_argument("--out", type=Path, default=Path("railfem-output/diagnose"), metavar="DIR",
                   help="output folder (default railfem-output/diagnose)")


def _diagnose_run(args) -> int:
    from .diagnosejob import run_diagnose

    effects = ([x.strip() for x in args.effects.split(",") if x.strip()]
               if args.effects else None)
    s = run_diagnose(args.data, args.out, model=args.model, select=args.select,
                     group=args.group, spacing=args.spacing, effects=effects,
                     n_starts=args.starts, workers=args.workers, command=" ".join(sys.argv))
    for g in s["groups"]:
        sys.stdout.write(f"{g['name']}: {g['statement']}\n")
    sys.stdout.write(f"wrote {Path(args.out) / 'run.json'}\n")
    return 0


COMMANDS = {
    "mesh": (_mesh_args, _mesh_run, "mesh a rail profile and write a mesh-quality summary"),
    "dispersion": (_dispersion_args, _dispersion_run,
                   "free-rail dispersion curves (CSV, plot) and wave-shape renders"),
    "convergence": (_convergence_args, _convergence_run,
                    "mesh-convergence study of cut-on frequencies and wavenumbers"),
    "mobility": (_mobility_args, _mobility_run,
                 "free-rail point and transfer mobilities (CSV, plot)"),
    "track": (_track_args, _track_run,
              "supported track of a Table 1 preset: mobilities, EN 15461 decay rates, plots"),
    "support-convergence": (_support_args, _support_run,
                            "rail-on-pad peak (and decay rates) vs section mesh, springs "
                            "across the foot and rows along the pad"),
    "tdr": (_tdr_args, _tdr_run, "track decay rate from measured or simulated data"),
    "passby": (_passby_args, _passby_run,
               "train pass-by: rail vibration from roughness, band levels, time signal"),
    "roughness": (_roughness_args, _roughness_run,
                  "combined wheel-rail roughness from pass-by recordings (full, simplified)"),
    "study": (_study_args, _study_run, "error studies on simulated data"),
    "fit": (_fit_args, _fit_run, "track parameters fitted to measured data, with uncertainty"),
    "diagnose": (_diagnose_args, _diagnose_run,
                 "residual of a calibrated model traced to a physical effect, before/after"),
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="railfem",
        description="Railway track vibration with 2.5D waveguide finite elements.")
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="more log output (-vv for debug)")
    parser.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors")
    parser.add_argument("--version", action="version", version=f"railfem {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, (add_args, run, help_text) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        add_args(p)
        p.set_defaults(_run=run)
    return parser


class _StderrHandler(logging.StreamHandler):
    """Writes to whatever sys.stderr is at the time of each record (it may be replaced)."""

    def __init__(self):
        super().__init__(sys.stderr)

    @property
    def stream(self):
        return sys.stderr

    @stream.setter
    def stream(self, value):
        pass


_QUIET_MODULES = ("railfem.meshing", "railfem.waveguide", "railfem.plotting",
                  "railfem.rendering")


def _setup_logging(verbose: int, quiet: bool):
    """Send railfem's log records to stderr; returns a function that undoes it (main() is
    also called in-process, e.g. by tests, and must leave logging as it found it)."""
    level = logging.WARNING if quiet else (logging.DEBUG if verbose > 1 else logging.INFO)
    handler = _StderrHandler()
    handler.setFormatter(logging.Formatter("railfem %(asctime)s %(levelname)s %(message)s",
                                           datefmt="%H:%M:%S"))
    root = logging.getLogger("railfem")
    saved = (root.handlers[:], root.level, root.propagate,
             {n: logging.getLogger(n).level for n in _QUIET_MODULES})
    root.handlers[:] = [handler]
    root.setLevel(level)
    root.propagate = False
    if verbose < 1:  # library chatter below the job level stays out of the way
        for name in _QUIET_MODULES:
            logging.getLogger(name).setLevel(max(level, logging.WARNING))

    def restore():
        root.handlers[:], lvl, root.propagate, levels = saved[0], saved[1], saved[2], saved[3]
        root.setLevel(lvl)
        for n, lv in levels.items():
            logging.getLogger(n).setLevel(lv)

    return restore


def _terminate(signum, frame):
    # SIGTERM (kill, a batch scheduler) unwinds like Ctrl-C, so that temporary files of
    # the atomic writer are removed instead of being left behind
    raise KeyboardInterrupt


def _stdout_closed() -> int:
    """The reader of our stdout went away (``railfem ... | head``): not an error of ours.
    Point stdout at devnull so the interpreter's final flush does not complain again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        pass
    return 0


def main(argv=None) -> int:
    """Entry point of the ``railfem`` command; returns the exit code."""
    import signal

    parser = build_parser()
    args = parser.parse_args(argv)  # exits with code 2 on malformed arguments
    restore_logging = _setup_logging(args.verbose, args.quiet)
    previous_term = None
    if threading.current_thread() is threading.main_thread():
        previous_term = signal.signal(signal.SIGTERM, _terminate)
    try:
        code = int(args._run(args) or 0)
        sys.stdout.flush()
        return code
    except BrokenPipeError:
        return _stdout_closed()
    except (BadInput, ValueError, OSError, KeyError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        log.debug("traceback of the error below", exc_info=True)
        sys.stderr.write(f"railfem {args.command}: error: {msg}\n")
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        sys.stderr.write("railfem: interrupted\n")
        return 130
    finally:
        if previous_term is not None:
            signal.signal(signal.SIGTERM, previous_term)
        restore_logging()


if __name__ == "__main__":  # python -m railfem.cli
    sys.exit(main())
