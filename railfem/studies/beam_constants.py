"""Timoshenko track with catalogue or mesh section constants: how much the choice matters.

The Timoshenko reference tracks (``railfem.track.beams``) need A, I and kappa. Two sources:
EN 13674-1 catalogue values (``BeamSection.catalogue``, kappa = 0.4 from METHOD.md) or the
constants of the section mesh (``BeamSection.from_mesh``: area and I by quadrature
on the curved mesh, kappa from the flexural shear problem). :func:`constants_difference`
computes the discrete-track point mobility with both and reports the level difference per
one-third-octave band.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..track import beams
from ..rail import meshing
from ..materials import Material
from ..standards import iec61260
from ..spec import preset as get_preset
from ..track.supports import uniform_layout

#: Offset (m) of the point-mobility force from the sensor, as in the track job.
POINT_OFFSET = 0.02


@dataclass(frozen=True, kw_only=True)
class ConstantsDifference:
    """band: (nb,) exact one-third-octave centres (Hz). catalogue_db, mesh_db: (nb,) band
    RMS point-mobility level (dB re 1 m/s/N) with each set of constants; difference_db =
    mesh_db - catalogue_db. catalogue, mesh: the two BeamSections. pinned_pinned_hz:
    {'catalogue', 'mesh'}."""

    band: np.ndarray
    catalogue_db: np.ndarray
    mesh_db: np.ndarray
    difference_db: np.ndarray
    catalogue: beams.BeamSection
    mesh: beams.BeamSection
    pinned_pinned_hz: dict


def constants_difference(preset: str = "site", mesh: meshing.SectionMesh | None = None, *,
                         f_low: float = 50.0, f_high: float = 5000.0,
                         n_supports: int = 131) -> ConstantsDifference:
    """Timoshenko discrete-track point mobility (sensor at mid-span, force 20 mm away, on a
    1/9-octave grid) with catalogue and with mesh constants (default mesh: the shipped
    curved 60E1 at 10 mm), band RMS per one-third-octave band and their difference."""
    tp = get_preset(preset)
    mesh = mesh or meshing.get_mesh("60E1", meshing.DEFAULT_H)
    material = Material.steel(tp.rail.eta)
    secs = {"catalogue": beams.BeamSection.catalogue(material),
            "mesh": beams.BeamSection.from_mesh(mesh, material)}
    f = iec61260.ninth_octave_grid(f_low, f_high)
    bands = iec61260.third_octave_bands(f_low, f_high)
    layout = uniform_layout(tp.support, tp.spacing, n_supports)
    xs = tp.spacing / 2
    level = {}
    for name, bs in secs.items():
        a = beams.discrete_track_receptance(bs, layout, 2 * np.pi * f, [xs + POINT_OFFSET],
                                            [xs])
        Y = 1j * 2 * np.pi * f * np.asarray(a).reshape(len(f))
        level[name] = 20 * np.log10(iec61260.band_average(f, Y, bands))
    return ConstantsDifference(
        band=bands.centre, catalogue_db=level["catalogue"], mesh_db=level["mesh"],
        difference_db=level["mesh"] - level["catalogue"], catalogue=secs["catalogue"],
        mesh=secs["mesh"],
        pinned_pinned_hz={k: beams.pinned_pinned_frequency(bs, tp.spacing)
                          for k, bs in secs.items()})
