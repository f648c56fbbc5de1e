"""The pass-by chain on one track (a railfem.spec.TrackSpec):

    roughness spectrum -> narrow-band amplitude at the train speed -> contact filter ->
    wheel and contact receptances -> rail tables of the track -> pass-by (both forms)

:func:`passby_chain` runs it and returns a :class:`PassbyRun`; the pieces are here for the
callers that vary one of them: :func:`default_roughness`, :func:`make_wheel`,
:func:`effective_roughness`. Files (roughness tables, wheel FRFs) are read by the caller
(railfem.io.roughness_table, railfem.io.wheel_frf) and passed in as objects.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np

from ..standards import iec61260
from ..wheelrail import contact
from ..wheelrail import roughness as rough
from ..wheelrail import wheels
from . import passby as P
from .train import TrainLayout

log = logging.getLogger(__name__)

__all__ = ["WHEEL_MODELS", "CONTACT_FILTERS", "default_roughness", "make_wheel",
           "effective_roughness", "PassbyRun", "passby_chain"]

WHEEL_MODELS = ("rigid", "flexible")
CONTACT_FILTERS = contact.FILTERS


def default_roughness() -> rough.RoughnessSpectrum:
    """The default spectrum: 0 dB re 1 um at 10 mm, +10 dB per decade of wavelength."""
    return rough.sloped_spectrum(0.0, 10.0, name="default: 0 dB re 1 um at 10 mm, "
                                                  "+10 dB/decade of wavelength")


def make_wheel(kind="rigid", frequency=None, *, mass=None, progress=None):
    """A wheel model: 'rigid' (RigidWheel), 'flexible' (the FE wheel, modes up to the
    largest of ``frequency``), or a wheel model (anything with ``receptance(f)``, e.g. a
    TabulatedWheel read by railfem.io.wheel_frf) returned as it is. mass: unsprung mass per
    wheel (kg, default wheels.DEFAULT_UNSPRUNG_MASS)."""
    if hasattr(kind, "receptance"):
        return kind
    mass = mass or wheels.DEFAULT_UNSPRUNG_MASS
    if kind == "rigid":
        return wheels.RigidWheel(mass=mass)
    if kind == "flexible":
        if frequency is None:
            raise ValueError("the flexible wheel needs the frequencies it is used at")
        return wheels.flexible_wheel(mass=mass, f_max=float(np.max(frequency)),
                                     progress=progress)
    raise ValueError(f"wheel = {kind!r}: choose 'rigid', 'flexible' or a wheel model (an FRF "
                     "CSV file of the wheel mobility, read by railfem.io.wheel_frf)")


def effective_roughness(spectrum: rough.RoughnessSpectrum, frequency, speed: float,
                        hertz: contact.HertzContact, *, contact_filter: str = "analytical",
                        outside: str = "raise") -> np.ndarray:
    """(nf,) roughness amplitude (m) seen by the wheel-rail contact at the narrow-band
    ``frequency`` (Hz) and train ``speed`` (m/s): the spectrum's band RMS
    (roughness.amplitude_at, ``outside`` as there) times the contact filter's amplitude."""
    f = np.asarray(frequency, dtype=float)
    amp = rough.amplitude_at(spectrum, f, speed, outside=outside)
    return amp * np.sqrt(contact.filter_power(contact_filter, f, speed, hertz))


@dataclass(frozen=True, kw_only=True, eq=False)
class PassbyRun:
    """One pass-by through the chain. result: the requested form; exact, paper: both forms
    (result is one of them). tables: the rail tables (railfem.simulate.passby.RailTables).
    wheel: the wheel model. hertz: the contact. roughness: the spectrum. speed: m/s.
    seconds: {'tables', 'simulation'} wall time."""

    result: P.PassbyResult
    exact: P.PassbyResult
    paper: P.PassbyResult
    tables: P.RailTables
    wheel: object
    hertz: contact.HertzContact
    roughness: rough.RoughnessSpectrum
    speed: float
    seconds: dict


def passby_chain(spec, train: TrainLayout, speed: float, *, frequency=None,
                 roughness: rough.RoughnessSpectrum | None = None, roughness_hold: bool = False,
                 wheel="rigid", wheel_mass=None, wheel_load=None,
                 contact_filter: str = "analytical", form: str = "exact",
                 output: str = "foot", interaction: bool = True, continuous: bool = False,
                 before: float = 30.0, after: float = 30.0, max_distance: float = 30.0,
                 tables: P.RailTables | None = None, cache=None, progress=None,
                 wheel_progress=None) -> PassbyRun:
    """A pass-by of ``train`` at ``speed`` (m/s) on the track ``spec`` (a TrackSpec).

    frequency: narrow-band grid (Hz; default the 1/9-octave points of 100 Hz - 5 kHz; the
    ``tables``' own when tables are given). roughness: the spectrum (default
    default_roughness()); roughness_hold: hold its end levels beyond its wavelengths
    (otherwise an error). wheel: 'rigid', 'flexible' or a wheel model (make_wheel);
    wheel_mass: kg; wheel_load: static load (N, default contact.DEFAULT_WHEEL_LOAD).
    contact_filter: one of CONTACT_FILTERS. form, output, interaction, before, after: as
    railfem.simulate.passby.simulate_passby. continuous, max_distance, cache, progress: as
    rail_tables (tables: reuse rail tables made for ``spec``). wheel_progress: progress of
    the flexible wheel's modes."""
    if contact_filter not in CONTACT_FILTERS:
        raise ValueError(f"contact_filter = {contact_filter!r}: choose one of "
                         f"{CONTACT_FILTERS}")
    t0 = time.perf_counter()
    f = (iec61260.ninth_octave_grid(100.0, 5000.0) if frequency is None else
         np.asarray(frequency, dtype=float)) if tables is None else tables.frequency
    spectrum = roughness or default_roughness()
    # fails early if the spectrum does not cover the frequencies (unless told to hold)
    rough.amplitude_at(spectrum, f, speed, outside="hold" if roughness_hold else "raise")
    wheel = make_wheel(wheel, f, mass=wheel_mass, progress=wheel_progress)
    hz = contact.hertz(wheel_load or contact.DEFAULT_WHEEL_LOAD,
                       wheel_radius=wheels.DEFAULT_WHEEL_RADIUS)
    if tables is None:
        tables = P.rail_tables(spec, f, continuous=continuous, max_distance=max_distance,
                               cache=cache, progress=progress)
    t_tables = time.perf_counter()
    r = effective_roughness(spectrum, f, speed, hz, contact_filter=contact_filter,
                            outside="hold" if roughness_hold else "raise")
    aw, ac = wheel.receptance(f), contact.contact_receptance(hz, f)
    common = dict(output=output, interaction=interaction, before=before, after=after,
                  settings={"speed_m_per_s": speed, "roughness": spectrum.name,
                            "wheel": getattr(wheel, "name", type(wheel).__name__),
                            "contact_filter": contact_filter})
    res = P.simulate_passby(tables, train, aw, ac, r, form=form, **common)
    other = P.simulate_passby(tables, train, aw, ac, r,
                              form="paper" if form == "exact" else "exact", **common)
    exact, paper = (res, other) if form == "exact" else (other, res)
    t_sim = time.perf_counter()
    return PassbyRun(result=res, exact=exact, paper=paper, tables=tables, wheel=wheel,
                     hertz=hz, roughness=spectrum, speed=speed,
                     seconds={"tables": t_tables - t0, "simulation": t_sim - t_tables})
