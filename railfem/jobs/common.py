"""What the jobs share: progress logging, file-name slugs, the section mesh of a job and
CSV text with a comment header.

A job (one module per command in this package) turns a few parameters into files
in a folder; the CLI (:mod:`railfem.cli`) only parses arguments and calls one job
function, and the same functions serve scripts and notebooks. Every file is written
through :mod:`railfem.atomic`, so an interrupted job never leaves a truncated output
behind. Progress goes to the ``railfem`` loggers (stderr under the CLI). Jobs import this
module only, never each other.
"""
from __future__ import annotations

import csv
import io
import logging
import os
import re
import time
from pathlib import Path

import numpy as np

from ..rail import meshing
from ..rail.profiles import RailProfile, get_profile

log = logging.getLogger(__name__)

__all__ = ["progress_logger", "slug", "resolve_profile", "load_or_mesh", "csv_text"]


# ----------------------------------------------------------------------- utilities
def progress_logger(what: str, *, min_interval: float = 2.0, logger=None):
    """A ``progress(done, total)`` callback that logs '<what>: done/total (pct)' lines.

    It logs the first and the last call and otherwise at most once per ``min_interval``
    seconds, so long loops show progress without flooding the log.
    """
    logger = logger or log
    state = {"last": -np.inf, "t0": time.monotonic()}

    def progress(done: int, total: int) -> None:
        now = time.monotonic()
        if done in (1, total) or now - state["last"] >= min_interval:
            state["last"] = now
            elapsed = now - state["t0"]
            eta = elapsed / done * (total - done) if done else float("nan")
            logger.info("%s: %d/%d (%.0f %%), %.1f s elapsed, ~%.0f s left", what, done,
                        total, 100.0 * done / total, elapsed, eta)

    return progress


def slug(text: str) -> str:
    """``text`` as a file-name part: lower case, runs of other characters as one '-'."""
    return re.sub(r"[^a-z0-9]+", "-", str(text).lower()).strip("-") or "wave"


def resolve_profile(profile) -> RailProfile:
    """A RailProfile from a name, 'rect:WxH', an outline CSV path, or a RailProfile."""
    return get_profile(profile) if isinstance(profile, (str, os.PathLike)) else profile


def load_or_mesh(profile, h: float, mesh_file=None, *, mesh_units: str | None = None,
                 mesh_axes: str = "xy") -> meshing.SectionMesh:
    """The mesh from ``mesh_file`` if given, else the shipped mesh or a new Gmsh mesh.

    A ``.npz`` file is a railfem mesh (:func:`railfem.rail.meshing.load_mesh`); any other file
    is read with meshio (:func:`railfem.rail.meshing.read_mesh`) and needs ``mesh_units`` ('m'
    or 'mm') and ``mesh_axes`` (file axes that are lateral and vertical, e.g. 'xy')."""
    if mesh_file is not None:
        if Path(mesh_file).suffix.lower() == ".npz":
            return meshing.load_mesh(mesh_file)
        if mesh_units is None:
            raise ValueError(f"mesh file {mesh_file}: give its length unit (--mesh-units m "
                             "or mm; mesh_units= in Python)")
        return meshing.read_mesh(mesh_file, units=mesh_units, axes=mesh_axes)
    return meshing.get_mesh(resolve_profile(profile), h)


def csv_text(header: str, columns, rows) -> str:
    """``header`` (comment lines), then the CSV of ``columns`` and ``rows`` (floats with 10
    significant digits)."""
    buf = io.StringIO()
    buf.write(header)
    wr = csv.writer(buf, lineterminator="\n")
    wr.writerow(columns)
    for r in rows:
        wr.writerow([f"{x:.10g}" if isinstance(x, (float, np.floating)) else x for x in r])
    return buf.getvalue()
