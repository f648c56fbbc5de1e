"""The ``railfem`` command line.

    railfem mesh --profile 60E1 --h 10 --out meshes/       mesh + quality summary
    railfem mesh --shipped                                  regenerate railfem/data/meshes/ (60E1)
    railfem dispersion --profile 60E1 --h 10 --f-low 50 --f-high 5000 --n 100 --out DIR
    railfem dispersion --k-range 0.1 30 60 --out DIR        omega(k) instead of k(omega)
    railfem convergence --profile 60E1 --sizes 20 15 10 7.5 5 --frequencies 1000 --out DIR
    railfem mobility --free --freq 50:8000:60 --response head foot_sensor --x 0 0.3 --out DIR
    railfem passby --preset site --speed-kmh 216 --wheel flexible --signal --out DIR
    railfem tdr passby run1.npz run2.wav --out DIR          pass-by decay rates
    railfem roughness run1.wav --track site --method full --out DIR
    railfem study passby --out DIR                          TDR and roughness error study

Lengths on the command line are in mm (element sizes), frequencies in Hz, wavenumbers in
rad/m. Each subcommand parses its arguments and calls one job function (one module per
command in :mod:`railfem.jobs`); progress and messages go to stderr. Bad input (unknown profile,
unreadable file, impossible values) ends with a one-line message and exit code 2.

New subcommands register in ``COMMANDS`` (name -> (add_arguments, run, help)). The
subcommands live by concern in :mod:`.rail` (mesh, dispersion, convergence, mobility),
:mod:`.track` (track, support-convergence), :mod:`.measure` (tdr, fit, diagnose) and
:mod:`.passby` (passby, roughness, study); what they share is in :mod:`.common`.
"""
from __future__ import annotations

import argparse
import logging
import os
import sys
import threading

# The solvers work on many small dense and sparse matrices, where threaded BLAS only
# oversubscribes the cores (measured: the site-track job took 275 s instead of 40 s on 2
# cores with default OpenBLAS threading). Set before numpy loads; the user's value wins.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

from .. import __version__  # noqa: E402
from ..atomic import output_scope  # noqa: E402
from .common import EXIT_BAD_INPUT, BadInput  # noqa: E402
from .cache import cache_args, cache_run  # noqa: E402
from .measure import (diagnose_args, diagnose_run, fit_args, fit_run,  # noqa: E402
                      tdr_args, tdr_run)
from .passby import (passby_args, passby_run, roughness_args, roughness_run,  # noqa: E402
                     study_args, study_run)
from .rail import (convergence_args, convergence_run, dispersion_args,  # noqa: E402
                   dispersion_run, frequency_spec, mesh_args, mesh_run, mobility_args,
                   mobility_frequencies, mobility_run)
from .track import (support_args, support_run, track_args, track_run,  # noqa: E402
                    track_spec_from_args)

log = logging.getLogger("railfem.cli")

__all__ = ["main", "build_parser", "COMMANDS", "BadInput", "EXIT_BAD_INPUT",
           "track_spec_from_args"]

# names of the single-module railfem.cli that tests call
_frequency_spec = frequency_spec
_mobility_frequencies = mobility_frequencies

#: name -> (add_arguments(parser), run(args) -> exit code, help)
COMMANDS = {
    "mesh": (mesh_args, mesh_run, "mesh a rail profile and write a mesh-quality summary"),
    "dispersion": (dispersion_args, dispersion_run,
                   "free-rail dispersion curves (CSV, plot) and wave-shape renders"),
    "convergence": (convergence_args, convergence_run,
                    "mesh-convergence study of cut-on frequencies and wavenumbers"),
    "mobility": (mobility_args, mobility_run,
                 "free-rail point and transfer mobilities (CSV, plot)"),
    "track": (track_args, track_run,
              "supported track (a preset or a config): mobilities, EN 15461 decay rates, plots"),
    "support-convergence": (support_args, support_run,
                            "rail-on-pad peak (and decay rates) vs section mesh, springs "
                            "across the foot and rows along the pad"),
    "tdr": (tdr_args, tdr_run, "track decay rate from measured or simulated data"),
    "passby": (passby_args, passby_run,
               "train pass-by: rail vibration from roughness, band levels, time signal"),
    "roughness": (roughness_args, roughness_run,
                  "combined wheel-rail roughness from pass-by recordings (full, simplified)"),
    "study": (study_args, study_run, "error studies on simulated data"),
    "fit": (fit_args, fit_run, "track parameters fitted to measured data, with uncertainty"),
    "diagnose": (diagnose_args, diagnose_run,
                 "residual of a calibrated model traced to a physical effect, before/after"),
    "cache": (cache_args, cache_run, "the kernel cache: folder, size and cap (info); clear"),
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


_QUIET_MODULES = ("railfem.rail.meshing", "railfem.rail.waveguide", "railfem.plotting",
                  "railfem.plotting.render")


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
        with output_scope():  # INCOMPLETE in the output folder until the job ends
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
