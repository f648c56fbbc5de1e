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
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..rail import meshing
from ..rail.profiles import RailProfile, get_profile

log = logging.getLogger(__name__)

__all__ = ["Progress", "progress_logger", "progress_bar_enabled", "LogProgress",
           "watch_progress", "FIT_PROGRESS", "slug", "resolve_profile", "load_or_mesh", "csv_text"]


# ----------------------------------------------------------------------- progress
ETA_AFTER = 3  # steps timed before a time left is given (the first one holds the set-up)
#: the fit's steps as progress bars (watch_progress): multi-start points, kernels,
#: profile points (railfem.identify.profiling.run_tasks) and campaign rows
FIT_PROGRESS = (
    ("railfem.identify.fit", r"^fit: (?P<what>.+?) (?P<done>\d+)/(?P<total>\d+) done", {}),
    ("railfem.identify.campaign", r"done, (?P<done>\d+)/(?P<total>\d+),",
     {"what": "campaign rows"}),
)


def progress_bar_enabled(stream=None) -> bool:
    """Whether a progress bar is drawn: on a terminal (``stream``, default stderr) and
    when the railfem loggers pass INFO (not under ``railfem -q``)."""
    stream = sys.stderr if stream is None else stream
    isatty = getattr(stream, "isatty", None)
    try:
        tty = bool(isatty()) if isatty is not None else False
    except ValueError:  # a closed stream
        tty = False
    return tty and logging.getLogger("railfem").isEnabledFor(logging.INFO)


class Progress:
    """``progress(done, total)``: a tqdm bar on a terminal (progress_bar_enabled), else
    '<what>: done/total (pct)' log lines, the first and the last and otherwise at most one
    per ``min_interval`` seconds. The time left is given only once ETA_AFTER steps have
    been timed, from the end of the first step (which holds the set-up: kernels, meshes)."""

    def __init__(self, what: str, total: int | None = None, *, min_interval: float = 2.0,
                 logger=None, stream=None, bar: bool | None = None):
        self.what, self.total, self.min_interval = what, total, min_interval
        self.logger = logger or log
        self.stream = sys.stderr if stream is None else stream
        self.bar_on = progress_bar_enabled(self.stream) if bar is None else bar
        self.bar = None
        self.t0 = time.monotonic()
        self.t_first = None
        self.first_done = 0
        self.last = -np.inf

    def eta(self, done: int, total: int | None, now: float) -> float | None:
        """Seconds left, or None before ETA_AFTER steps were timed."""
        if total is None or self.t_first is None or done - self.first_done < ETA_AFTER:
            return None
        rate = (now - self.t_first) / (done - self.first_done)
        return rate * max(total - done, 0)

    def __call__(self, done: int, total: int | None = None) -> None:
        total = self.total if total is None else total
        now = time.monotonic()
        if self.t_first is None and done >= 1:
            self.t_first, self.first_done = now, done
        eta = self.eta(done, total, now)
        if self.bar_on:
            self._draw(done, total, eta)
            return
        if done in (1, total) or now - self.last >= self.min_interval:
            self.last = now
            pct = f" ({100.0 * done / total:.0f} %)" if total else ""
            left = "" if eta is None else f", ~{eta:.0f} s left"
            self.logger.info("%s: %d/%s%s, %.1f s elapsed%s", self.what, done,
                             total if total else "?", pct, now - self.t0, left)

    def _draw(self, done, total, eta) -> None:
        from tqdm import tqdm

        from tqdm.contrib.logging import logging_redirect_tqdm

        new = self.bar is None or (total is not None and self.bar.total != total)
        if new:
            self.close()
            fmt = ("{desc}: {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt} "
                   "[{elapsed}{postfix}]" if total else "{desc}: {n_fmt} [{elapsed}{postfix}]")
            self.bar = tqdm(total=total, desc=self.what, file=self.stream, leave=False,
                            dynamic_ncols=True, bar_format=fmt)
            # the CLI's log records (railfem's own stderr handler) go above the bar
            lg = logging.getLogger("railfem")
            own = any(isinstance(h, logging.StreamHandler) for h in lg.handlers)
            self.redirect = logging_redirect_tqdm(loggers=[lg]) if own else None
            if self.redirect is not None:
                self.redirect.__enter__()
                for h in lg.handlers:
                    h.addFilter(hide_shown)
        self.bar.set_postfix_str("" if eta is None else f"~{eta:.0f} s left", refresh=False)
        self.bar.update(done - self.bar.n)
        if new:
            self.bar.refresh()  # the first step at once (tqdm waits mininterval)
        if total and done >= total:
            self.close()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None
            if self.redirect is not None:
                self.redirect.__exit__(None, None, None)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


class LogProgress(logging.Handler):
    """Progress bars driven by the library's log records (the library only logs): a
    record whose message matches ``pattern`` advances the bar named by its group 'what'
    (else ``what``) to its group 'done' of 'total' (else: one more of ``total``)."""

    def __init__(self, pattern: str, *, what: str = "", total: int | None = None,
                 stream=None):
        super().__init__(logging.INFO)
        self.pattern, self.what, self.total = re.compile(pattern), what, total
        self.stream, self.count, self.bars = stream, 0, {}

    def emit(self, record) -> None:
        m = self.pattern.search(record.getMessage())
        if m is None:
            return
        record.progress_shown = True  # the bar shows it: not a log line as well
        g = m.groupdict()
        what = g.get("what") or self.what
        self.count += 1
        done = int(g["done"]) if g.get("done") else self.count
        total = int(g["total"]) if g.get("total") else self.total
        bar = self.bars.get(what)
        if bar is None or bar.bar is None and bar.t_first is not None:
            bar = self.bars[what] = Progress(what, total, stream=self.stream, bar=True)
        bar(done, total)

    def close(self) -> None:
        for bar in self.bars.values():
            bar.close()
        super().close()


@contextmanager
def watch_progress(*watches, stream=None):
    """Progress bars for the duration of a library call, on a terminal only
    (progress_bar_enabled): each watch is (logger name, pattern, options of LogProgress)."""
    if not progress_bar_enabled(stream):
        yield
        return
    handlers = [(logging.getLogger(name), LogProgress(pattern, stream=stream, **opts))
                for name, pattern, opts in watches]
    out = list(logging.getLogger("railfem").handlers)
    for h in out:
        h.addFilter(hide_shown)
    for lg, h in handlers:
        lg.addHandler(h)
    try:
        yield
    finally:
        for lg, h in handlers:
            lg.removeHandler(h)
            h.close()
        for h in out:
            h.removeFilter(hide_shown)


def hide_shown(record) -> bool:
    """A handler filter: drop the log records a progress bar shows."""
    return not getattr(record, "progress_shown", False)


def progress_logger(what: str, *, min_interval: float = 2.0, logger=None):
    """A ``progress(done, total)`` callback (:class:`Progress`): a bar on a terminal, log
    lines otherwise."""
    return Progress(what, min_interval=min_interval, logger=logger)


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
