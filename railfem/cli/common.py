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


def index(text: str) -> int:
    return _number(text, int, ok=lambda v: v >= 0, expected="an integer >= 0 (0-based)")


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
