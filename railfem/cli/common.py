"""What the subcommands share: argument types, the profile and mesh-file options, the
``--use`` list of a fit, the CLI's own error (:class:`BadInput`) and the ``wrote PATH``
lines."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

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


def positive(text: str) -> float:
    return _number(text, ok=lambda v: v > 0, expected="a positive number")


def non_negative(text: str) -> float:
    return _number(text, ok=lambda v: v >= 0, expected="a number >= 0")


def count(text: str) -> int:
    return _number(text, int, ok=lambda v: v >= 1, expected="an integer >= 1")


def kmh(text: str) -> float:
    """A speed given in km/h, as m/s."""
    return positive(text) / 3.6


def index(text: str) -> int:
    return _number(text, int, ok=lambda v: v >= 0, expected="an integer >= 0 (0-based)")


# ------------------------------------------------- options spelt the same by every command
def add_speed(p: argparse.ArgumentParser, prefix: str = "") -> None:
    """--speed-kmh KMH, stored as ``args.speed`` in m/s; the older --speed M/S is still read
    (hidden)."""
    p.add_argument("--speed-kmh", dest="speed", type=kmh, default=None, metavar="KMH",
                   help=f"{prefix}train speed in km/h (overrides the metadata)")
    p.add_argument("--speed", dest="speed", type=positive, default=None,
                   help=argparse.SUPPRESS)


def add_workers(p: argparse.ArgumentParser, what: str = "parallel processes") -> None:
    """--workers N with the one default of every command: all cores, at most 8."""
    p.add_argument("--workers", type=count, default=None, metavar="N",
                   help=f"{what} (default: all cores, at most {MAX_WORKERS})")


MAX_WORKERS = 8


def workers_from_args(args) -> int:
    """--workers, or all cores (at most MAX_WORKERS)."""
    import os

    return args.workers or max(1, min(os.cpu_count() or 1, MAX_WORKERS))


def add_hidden_alias(p, option: str, dest: str, **kwargs) -> None:
    """An older spelling of an option: still read, not shown in --help."""
    p.add_argument(option, dest=dest, help=argparse.SUPPRESS, **kwargs)


def parse_use(text: str) -> tuple[str, ...]:
    """'point,tdr' -> ('point', 'tdr'): the quantities a fit uses (railfem.identify.data)."""
    from ..identify.data import QUANTITIES

    use = tuple(x.strip() for x in text.split(",") if x.strip())
    bad = [u for u in use if u not in QUANTITIES]
    if bad or not use:
        raise ValueError(f"--use {text!r}: give a comma list of {', '.join(QUANTITIES)}")
    return use


def add_profile(p: argparse.ArgumentParser, h_default: float | None = 10.0) -> None:
    p.add_argument("--profile", default="60E1",
                   help="'60E1' (= UIC60, default), 'rect:WIDTHxHEIGHT' in mm, or the path "
                        "of an outline CSV (y,z in mm, counter-clockwise, foot at z = 0)")
    if h_default is not None:
        p.add_argument("--h", type=positive, default=h_default, metavar="MM",
                       help=f"element size in mm (default {h_default:g})")


def add_mesh_file(p: argparse.ArgumentParser) -> None:
    p.add_argument("--mesh", type=Path, default=None, metavar="FILE",
                   help="use this section mesh instead of --profile/--h: a railfem .npz "
                        "(railfem mesh) or any 2-D mesh file meshio reads (Gmsh .msh 2.2 / "
                        "4.x, 3- or 6-node triangles); symmetry is detected")
    p.add_argument("--mesh-units", choices=("m", "mm"), default=None,
                   help="length unit of a --mesh file that is not .npz (required for those)")
    p.add_argument("--mesh-axes", default="xy", metavar="AXES",
                   help="which axes of a --mesh file are lateral and vertical: 'xy' "
                        "(default: x lateral, y vertical), 'xz', '-y,z', ...")


def add_rail_options(g) -> None:
    """``--profile`` and ``--h`` (mm) of the track options, on a parser or a group."""
    g.add_argument("--profile", default=None,
                   help="'60E1' (= UIC60, default), 'rect:WIDTHxHEIGHT' in mm, or the path "
                        "of an outline CSV (y,z in mm, counter-clockwise, foot at z = 0)")
    g.add_argument("--h", type=positive, default=None, metavar="MM",
                   help="element size in mm, 0.5 to 100 (default 10)")


def add_track_options(p: argparse.ArgumentParser, *, rail: bool = True) -> None:
    """The track parameters of ``railfem track`` (rail profile and mesh size unless
    ``rail`` is False, supports, pad geometry, numerics), read by
    :func:`apply_track_options`."""
    g = p.add_argument_group("track parameters (override the preset and the config)")
    if rail:
        add_rail_options(g)
    g.add_argument("--kp", type=non_negative, default=None, metavar="MN/m",
                   help="rail pad stiffness per fastener, MN/m")
    g.add_argument("--eta-p", type=non_negative, default=None, metavar="ETA",
                   help="rail pad loss factor (-)")
    g.add_argument("--kb", type=non_negative, default=None, metavar="MN/m",
                   help="ballast stiffness per fastener and rail, MN/m")
    g.add_argument("--eta-b", type=non_negative, default=None, metavar="ETA",
                   help="ballast loss factor (-)")
    g.add_argument("--ms", type=non_negative, default=None, metavar="KG",
                   help="sleeper mass per rail, kg")
    g.add_argument("--eta-r", type=non_negative, default=None, metavar="ETA",
                   help="rail loss factor (-)")
    g.add_argument("--spacing", type=positive, default=None, metavar="MM",
                   help="sleeper spacing, mm (presets: 600)")
    g.add_argument("--pad-length", type=non_negative, default=None, metavar="MM",
                   help="pad length along the rail, mm (default 150 on discrete and "
                        "periodic models; 0 = point supports, the published configuration)")
    g.add_argument("--n-rows", type=count, default=None,
                   help="spring rows along each pad (default 3)")
    g.add_argument("--n-supports", type=count, default=None,
                   help="supports of the discrete models (default 131)")
    g.add_argument("--n-foot-springs", type=count, default=None,
                   help="springs across the rail foot per row (default 4)")
    g.add_argument("--foot-rule", choices=("midpoint", "nodes"), default=None,
                   help="springs across the foot: midpoint = a distributed bed through the "
                        "element shape functions (default, converges with the mesh); nodes = "
                        "point springs at foot nodes (the published configuration, with "
                        "--n-foot-springs 8 --pad-length 0)")
    g.add_argument("--support-directions", choices=("z", "zy", "zx", "zyx"), default=None,
                   help="directions the supports act in (default z, vertical springs only); "
                        "zyx adds lateral and longitudinal pads and the lateral decay rate")


def mm_length(name: str, value: float | None, low: float, high: float, example: str):
    """A length given in mm on the command line, checked against a sane range, in m."""
    if value is None:
        return None
    if value != 0 and not low <= value <= high:
        raise BadInput(f"{name} {value:g} mm: lengths on this command line are in mm; give "
                       f"a value between {low:g} and {high:g} mm (e.g. {example})")
    return value * 1e-3


def apply_track_options(spec, args):
    """``spec`` (a railfem.spec.TrackSpec) with the track options of
    :func:`add_track_options` given on the command line (and ``args.model``) applied;
    lengths are given in mm there."""
    from dataclasses import replace

    h = mm_length("--h", args.h, 0.5, 100.0, "10")
    spacing = mm_length("--spacing", args.spacing, 100.0, 2000.0, "600")
    pad = mm_length("--pad-length", args.pad_length, 1.0, 1000.0, "150")
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
    return spec.replace(**top)


def finite(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not np.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def report_written(paths) -> None:
    """One ``wrote PATH`` line on stdout per file a job wrote: ``paths`` is a dict (its
    values, in order) or a sequence of paths."""
    for path in (paths.values() if isinstance(paths, dict) else paths):
        sys.stdout.write(f"wrote {path}\n")
