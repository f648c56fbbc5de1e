"""The ``railfem`` command line.

    railfem mesh --profile 60E1 --h 10 --out meshes/       mesh + quality summary
    railfem mesh --shipped                                  regenerate meshes/ (60E1)
    railfem dispersion --profile 60E1 --h 10 --fmin 50 --fmax 5000 --n 100 --out DIR
    railfem dispersion --k-range 0.1 30 60 --out DIR        omega(k) instead of k(omega)
    railfem convergence --profile 60E1 --sizes 20 15 10 7.5 5 --frequencies 1000 --out DIR
    railfem mobility --free --freq 50:8000:60 --response head foot_sensor --x 0 0.3 --out DIR

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
from pathlib import Path

# The solvers work on many small dense and sparse matrices, where threaded BLAS only
# oversubscribes the cores (measured: the site-track job took 275 s instead of 40 s on 2
# cores with default OpenBLAS threading). Set before numpy loads; the user's value wins.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

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


# ------------------------------------------------------------------------- mesh
def _mesh_args(p: argparse.ArgumentParser) -> None:
    _add_profile(p)
    p.add_argument("--out", type=Path, default=None, metavar="DIR",
                   help="output folder (default: current folder; with --shipped the "
                        "package's meshes/ folder)")
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
    p.add_argument("--mesh", type=Path, default=None, metavar="FILE.npz",
                   help="use this saved mesh (railfem mesh) instead of --profile/--h")
    g = p.add_argument_group("frequencies (k(omega), default) or wavenumbers (omega(k))")
    g.add_argument("--fmin", type=_positive, default=None, metavar="HZ",
                   help="lowest frequency in Hz (default 50)")
    g.add_argument("--fmax", type=_positive, default=None, metavar="HZ",
                   help="highest frequency in Hz (default 5000)")
    g.add_argument("--n", type=_count, default=None,
                   help="number of frequencies from fmin to fmax (default 100)")
    g.add_argument("--spacing", choices=("linear", "log"), default="linear",
                   help="frequency spacing between fmin and fmax (default linear)")
    g.add_argument("--frequencies", type=_positive, nargs="+", default=None, metavar="HZ",
                   help="explicit list of frequencies in Hz")
    g.add_argument("--k-range", type=_non_negative, nargs=3, default=None,
                   metavar=("KMIN", "KMAX", "NK"),
                   help="omega(k) at NK real wavenumbers from KMIN to KMAX (rad/m)")
    g.add_argument("--n-modes", type=_count, default=12,
                   help="modes per symmetry family for --k-range (default 12)")
    s = p.add_argument_group("solver and renders")
    s.add_argument("--loss-factor", type=_non_negative, default=0.0,
                   help="rail loss factor eta (default 0: undamped)")
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
    p.add_argument("--out", type=Path, default=Path("railfem-output/convergence"),
                   metavar="DIR", help="output folder (default railfem-output/convergence)")


def _convergence_run(args) -> int:
    from . import jobs

    sizes = np.array(args.sizes) * 1e-3
    paths = jobs.run_convergence(args.profile, sizes, args.out, frequencies=args.frequencies,
                                 n_cut_on=args.n_cut_on, reference=args.reference)
    st = paths["study"]
    sys.stdout.write("h (mm)  DOFs   cut-on frequencies (Hz)\n")
    for i, h in enumerate(st.sizes):
        sys.stdout.write(f"{h * 1e3:6g} {st.n_dofs[i]:6d}  "
                         + " ".join(f"{v:9.1f}" for v in st.cut_on[i]) + "\n")
    sys.stdout.write("reference     " + " ".join(f"{v:9.1f}" for v in st.cut_on_reference)
                     + f"  ({st.reference['cut_on']})\n")
    sys.stdout.write("rate          " + " ".join(f"{v:9.2f}" for v in st.cut_on_rate) + "\n")
    sys.stdout.write(f"wrote {paths['csv']}\nwrote {paths['png']}\nwrote {paths['json']}\n")
    return 0


def _track_args(p: argparse.ArgumentParser) -> None:
    from .supports import PRESETS
    from .trackjob import MODELS

    _add_profile(p)
    p.add_argument("--preset", choices=sorted(PRESETS), default="site",
                   help="track parameter set of METHOD.md Table 1 (default site)")
    p.add_argument("--model", choices=MODELS, default="wfe-discrete",
                   help="track model (default wfe-discrete)")
    p.add_argument("--f-low", type=_positive, default=50.0, help="lowest band (Hz)")
    p.add_argument("--f-high", type=_positive, default=8000.0, help="highest band (Hz)")
    p.add_argument("--n-supports", type=_count, default=131,
                   help="discrete supports centred on the sensor span (default 131)")
    p.add_argument("--pad-length", type=_non_negative, default=0.0, metavar="M",
                   help="pad length along the rail (m); 0 = point supports (default)")
    p.add_argument("--n-rows", type=_count, default=1, help="spring rows per pad")
    p.add_argument("--n-foot-springs", type=_count, default=8,
                   help="springs across the rail foot (default 8)")
    p.add_argument("--out", type=Path, default=Path("railfem-output/track"), metavar="DIR",
                   help="output folder (default railfem-output/track)")


def _track_run(args) -> int:
    from .trackjob import run_track

    s = run_track(args.preset, args.model, args.out, profile=args.profile, h=args.h * 1e-3,
                  mesh_file=getattr(args, "mesh_file", None), f_low=args.f_low,
                  f_high=args.f_high, n_supports=args.n_supports, pad_length=args.pad_length,
                  n_rows=args.n_rows, n_f=args.n_foot_springs)
    peaks = ", ".join(f"{k} {v:.0f} Hz" for k, v in s["rail_pad_peak_hz"].items())
    sys.stdout.write(f"{s['preset']} track, {s['model']}: rail-on-pad peak {peaks}; "
                     f"{s['runtime_s']:.1f} s\n")
    for v in s["files"].values():
        sys.stdout.write(f"wrote {v}\n")
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
    p.add_argument("--mesh", type=Path, default=None, metavar="FILE.npz",
                   help="use this saved mesh (railfem mesh) instead of --profile/--h")
    p.add_argument("--free", action="store_true",
                   help="free (unsupported) rail; the only model of this command, so it is "
                        "also the default")
    p.add_argument("--freq", nargs="+", default=None, metavar="HZ",
                   help="frequencies in Hz, or FMIN:FMAX:N for N log-spaced ones (default: "
                        "one-third-octave centres 50 Hz - 8 kHz)")
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
    p.add_argument("--eta", type=_non_negative, default=0.01,
                   help="rail loss factor (default 0.01)")
    p.add_argument("--method", choices=("shift-invert", "dense"), default="shift-invert",
                   help="waves kept: shift-invert (the --n-waves smallest |k| per family plus "
                        "the frozen near-field tail, default) or dense (all waves, slow)")
    p.add_argument("--n-waves", type=_count, default=40,
                   help="waves per family for shift-invert (default 40)")
    p.add_argument("--out", type=Path, default=Path("railfem-output/mobility"),
                   metavar="DIR", help="output folder (default railfem-output/mobility)")


def _mobility_run(args) -> int:
    from . import mobilityjob

    if args.mesh is None and args.h < 1.0:
        raise BadInput(f"--h is the element size in mm like for the other commands; "
                       f"{args.h:g} mm is too fine (did you mean {args.h * 1e3:g}?)")
    frequencies = None if args.freq is None else _frequency_spec(args.freq)
    x = mobilityjob.DEFAULT_MOBILITY_X if args.x is None else args.x
    paths = mobilityjob.run_free_mobility(args.profile, args.h * 1e-3, args.out,
                                          frequencies=frequencies, force=args.force,
                                          responses=args.response, x=x,
                                          patch_width=args.patch_width,
                                          load_length=args.load_length, eta=args.eta,
                                          mesh_file=args.mesh, method=args.method,
                                          n_waves=args.n_waves)
    sys.stdout.write(f"wrote {paths['csv']}\nwrote {paths['png']}\nwrote {paths['json']}\n")
    return 0


#: name -> (add_arguments(parser), run(args) -> exit code, help)
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
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="railfem",
        description="Railway track vibration with 2.5D waveguide finite elements.")
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="more log output (-vv for debug)")
    parser.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors")
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


def main(argv=None) -> int:
    """Entry point of the ``railfem`` command; returns the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)  # exits with code 2 on malformed arguments
    restore_logging = _setup_logging(args.verbose, args.quiet)
    try:
        return int(args._run(args) or 0)
    except (BadInput, ValueError, OSError, KeyError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        log.debug("traceback of the error below", exc_info=True)
        sys.stderr.write(f"railfem {args.command}: error: {msg}\n")
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        sys.stderr.write("railfem: interrupted\n")
        return 130
    finally:
        restore_logging()


if __name__ == "__main__":  # python -m railfem.cli
    sys.exit(main())
