"""Free-rail subcommands: ``mesh``, ``dispersion``, ``convergence``, ``mobility``."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from .common import (BadInput, add_hidden_alias, add_mesh_file, add_profile, count, finite,
                     non_negative, positive, report_written)


# ------------------------------------------------------------------------- mesh
def mesh_args(p: argparse.ArgumentParser) -> None:
    add_profile(p)
    p.add_argument("--out", type=Path, default=None, metavar="DIR",
                   help="output folder (default: current folder; with --shipped the "
                        "package's railfem/data/meshes/ folder)")
    p.add_argument("--shipped", action="store_true",
                   help="regenerate all shipped meshes (60E1 at 20, 15, 10, 7.5, 5 mm); "
                        "--profile and --h are ignored")


def mesh_run(args) -> int:
    from ..jobs.mesh import run_mesh, run_shipped_meshes
    from ..rail.quality import format_mesh_quality

    if args.shipped:
        for r in run_shipped_meshes(args.out):
            sys.stdout.write(format_mesh_quality(r["quality"]))
        return 0
    r = run_mesh(args.profile, args.h * 1e-3, args.out or Path("."))
    sys.stdout.write(format_mesh_quality(r["quality"]))
    sys.stdout.write(f"wrote {r['mesh']}, {r['json']}, {r['txt']}\n")
    return 0


# ------------------------------------------------------------------- dispersion
def dispersion_args(p: argparse.ArgumentParser) -> None:
    add_profile(p)
    add_mesh_file(p)
    g = p.add_argument_group("frequencies (k(omega), default) or wavenumbers (omega(k))")
    g.add_argument("--f-low", dest="fmin", type=positive, default=None,
                   metavar="HZ", help="lowest frequency in Hz (default 50)")
    g.add_argument("--f-high", dest="fmax", type=positive, default=None,
                   metavar="HZ", help="highest frequency in Hz (default 5000)")
    add_hidden_alias(g, "--fmin", "fmin", type=positive, default=None)
    add_hidden_alias(g, "--fmax", "fmax", type=positive, default=None)
    g.add_argument("--n", type=count, default=None,
                   help="number of frequencies from --f-low to --f-high (default 100)")
    g.add_argument("--spacing", choices=("linear", "log"), default="linear",
                   help="frequency spacing between --f-low and --f-high (default linear)")
    g.add_argument("--frequencies", type=positive, nargs="+", default=None, metavar="HZ",
                   help="explicit list of frequencies in Hz")
    g.add_argument("--k-range", type=non_negative, nargs=3, default=None,
                   metavar=("KMIN", "KMAX", "NK"),
                   help="omega(k) at NK real wavenumbers from KMIN to KMAX (rad/m)")
    g.add_argument("--n-modes", type=count, default=12,
                   help="modes per symmetry family for --k-range (default 12)")
    s = p.add_argument_group("solver and renders")
    s.add_argument("--eta-r", "--loss-factor", dest="loss_factor", type=non_negative,
                   default=0.0, metavar="ETA",
                   help="rail loss factor (default 0: undamped)")
    s.add_argument("--method", choices=("shift-invert", "dense"), default="shift-invert",
                   help="k(omega) solver: shift-invert (the n-waves waves of smallest |k|, "
                        "fast, default) or dense (all waves)")
    s.add_argument("--n-waves", type=count, default=40,
                   help="waves per family for shift-invert (default 40)")
    s.add_argument("--render-frequency", type=positive, default=None, metavar="HZ",
                   help="render the propagating wave shapes at this frequency "
                        "(default 2000 Hz)")
    s.add_argument("--no-render", action="store_true", help="skip the wave-shape renders")
    p.add_argument("--out", type=Path, default=Path("railfem-output/dispersion"),
                   metavar="DIR", help="output folder (default railfem-output/dispersion)")


def dispersion_run(args) -> int:
    from ..jobs.dispersion import DEFAULT_RENDER_FREQUENCY, run_dispersion

    freq_opts = any(v is not None for v in (args.fmin, args.fmax, args.n))
    if args.k_range is not None and (freq_opts or args.frequencies is not None):
        raise BadInput("--k-range cannot be combined with frequency options")
    if args.frequencies is not None and freq_opts:
        raise BadInput("give either --frequencies or --f-low/--f-high/--n, not both")
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
            raise BadInput(f"--f-high ({fmax:g} Hz) must not be below --f-low ({fmin:g} Hz)")
        frequencies = (np.geomspace if args.spacing == "log" else np.linspace)(fmin, fmax, n)
    if args.no_render:
        render = None
    else:
        render = (DEFAULT_RENDER_FREQUENCY if args.render_frequency is None
                  else args.render_frequency)
    paths = run_dispersion(args.profile, args.h * 1e-3, args.out, frequencies=frequencies,
                           k_values=k_values, mesh_file=args.mesh,
                           mesh_units=args.mesh_units, mesh_axes=args.mesh_axes,
                           loss_factor=args.loss_factor, method=args.method,
                           n_waves=args.n_waves, n_modes=args.n_modes,
                           render_frequency=render)
    report_written([paths["csv"], paths["png"], *paths["renders"]])
    return 0


# ------------------------------------------------------------------ convergence
def convergence_args(p: argparse.ArgumentParser) -> None:
    add_profile(p, h_default=None)
    p.add_argument("--sizes", type=positive, nargs="+", default=[20, 15, 10, 7.5, 5],
                   metavar="MM", help="element sizes in mm (default 20 15 10 7.5 5)")
    p.add_argument("--frequencies", type=positive, nargs="*", default=[], metavar="HZ",
                   help="frequencies (Hz) at which the propagating wavenumbers are compared")
    p.add_argument("--n-cut-on", type=count, default=6,
                   help="number of cross-section cut-on frequencies (default 6)")
    p.add_argument("--reference", choices=("richardson", "finest"), default="richardson",
                   help="error reference: Richardson extrapolation of the three finest "
                        "meshes (default) or the finest mesh")
    p.add_argument("--geometry", choices=("curved", "straight", "both"), default="curved",
                   help="curved 6-node elements (mid-side nodes on the outline, default), "
                        "their straight-sided twins, or both (straight in "
                        "convergence_straight.*)")
    p.add_argument("--shipped", action="store_true",
                   help="use the shipped meshes (railfem/data/meshes/) where there is one "
                        "for the size instead of meshing afresh")
    p.add_argument("--out", type=Path, default=Path("railfem-output/convergence"),
                   metavar="DIR", help="output folder (default railfem-output/convergence)")


def convergence_run(args) -> int:
    from ..jobs.convergence import run_convergence

    sizes = np.array(args.sizes) * 1e-3
    paths = run_convergence(args.profile, sizes, args.out, frequencies=args.frequencies,
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
        report_written([paths["csv" + suffix], paths["png" + suffix],
                        paths["json" + suffix]])
    return 0


# --------------------------------------------------------------- free mobility
def frequency_spec(tokens) -> np.ndarray:
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


def mobility_args(p: argparse.ArgumentParser) -> None:
    add_profile(p)
    add_mesh_file(p)
    p.add_argument("--free", action="store_true",
                   help="free (unsupported) rail; the only model of this command, so it is "
                        "also the default")
    p.add_argument("--f-low", type=positive, default=None, metavar="HZ",
                   help="lowest frequency in Hz (with --f-high and --n: log-spaced)")
    p.add_argument("--f-high", type=positive, default=None, metavar="HZ",
                   help="highest frequency in Hz")
    p.add_argument("--n", type=count, default=None,
                   help="number of log-spaced frequencies from --f-low to --f-high "
                        "(default 40)")
    p.add_argument("--frequencies", type=positive, nargs="+", default=None, metavar="HZ",
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
    p.add_argument("--x", type=finite, nargs="+", default=None, metavar="M",
                   help="response distances from the load along the rail in m (default "
                        "0 0.3 0.6 1.2)")
    p.add_argument("--patch-width", type=positive, default=0.02, metavar="M",
                   help="width of the head load patch in m (default 0.02)")
    p.add_argument("--load-length", type=non_negative, default=0.02, metavar="M",
                   help="length along the rail over which the force is spread, m (default "
                        "0.02; 0 gives a load concentrated at x = 0)")
    p.add_argument("--eta-r", "--eta", dest="eta", type=non_negative, default=0.01,
                   metavar="ETA", help="rail loss factor (default 0.01)")
    p.add_argument("--method", choices=("shift-invert", "dense"), default="shift-invert",
                   help="waves kept: shift-invert (the --n-waves smallest |k| per family plus "
                        "the frozen near-field tail, default) or dense (all waves, slow)")
    p.add_argument("--n-waves", type=count, default=40,
                   help="waves per family for shift-invert (default 40)")
    p.add_argument("--out", type=Path, default=Path("railfem-output/mobility"),
                   metavar="DIR", help="output folder (default railfem-output/mobility)")


def mobility_frequencies(args):
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
    return None if args.freq is None else frequency_spec(args.freq)


def mobility_run(args) -> int:
    from ..jobs import mobility as mobilityjob

    if args.mesh is None and args.h < 1.0:
        raise BadInput(f"--h is the element size in mm like for the other commands; "
                       f"{args.h:g} mm is too fine (did you mean {args.h * 1e3:g}?)")
    frequencies = mobility_frequencies(args)
    x = mobilityjob.DEFAULT_MOBILITY_X if args.x is None else args.x
    paths = mobilityjob.run_free_mobility(args.profile, args.h * 1e-3, args.out,
                                          frequencies=frequencies, force=args.force,
                                          responses=args.response, x=x,
                                          patch_width=args.patch_width,
                                          load_length=args.load_length, eta=args.eta,
                                          mesh_file=args.mesh, mesh_units=args.mesh_units,
                                          mesh_axes=args.mesh_axes, method=args.method,
                                          n_waves=args.n_waves)
    report_written([paths["csv"], paths["png"], paths["json"]])
    return 0
