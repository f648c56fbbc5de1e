"""The free-rail mobility job behind ``railfem mobility --free``."""
from __future__ import annotations

import json
import logging
import time

import numpy as np

from ..rail import waveguide
from ..atomic import prepare_output_dir, write_text_atomic
from .common import load_or_mesh, progress_logger
from ..materials import Material

log = logging.getLogger(__name__)


#: Default response positions (m from the load) of ``railfem mobility``.
DEFAULT_MOBILITY_X = (0.0, 0.3, 0.6, 1.2)

MOBILITY_CSV_COMMENTS = (
    "railfem free-rail mobility Y = v / F (m/s/N); time dependence exp(+i omega t)",
    "unit harmonic force at x = 0 (the force label), spread uniformly over load_length along "
    "the rail; responses at the distances x (m) along the rail in the column labels",
    "columns: frequency_hz, then <response>@x=<m>|<force>_re and _im = real and imaginary "
    "part of the mobility for each response location, position and force",
    "locations <name>_<d>: d = direction x (along the rail), y (lateral) or z (vertical); "
    "head = uniform traction over a patch of the head top (patch_width wide, consistent "
    "nodal loads) and, as a response, the work-conjugate average over that patch; "
    "head_top / foot_sensor = that single node; node<N> = mesh node N",
)


def location_from_spec(guide: waveguide.Waveguide, spec: str, patch_width: float = 0.02):
    """A load or response location from its command-line spelling ``NAME[:DIR]``.

    NAME: ``head`` (patch of ``patch_width`` m across the head top), a single-node set of
    the mesh (``head_top``, ``foot_sensor``) or a node index; DIR: x, y or z (default z).
    Unknown names raise KeyError listing the node sets.
    """
    from ..rail import mobility
    from ..conventions import DIRECTIONS

    name, _, direction = str(spec).strip().partition(":")
    direction = direction.strip().lower() or "z"
    if direction not in DIRECTIONS:
        raise ValueError(f"location {spec!r}: direction must be x, y or z, got {direction!r}")
    if name == "head":
        return mobility.head_patch(guide, patch_width, direction)
    node = int(name) if name.isdigit() else name
    if isinstance(node, str):
        guide.node_set(node)  # KeyError with the available names
    return mobility.point(guide, node, direction)


def run_free_mobility(profile, h: float, out_dir, *, frequencies=None, force: str = "head",
                      responses=("head", "foot_sensor"), x=DEFAULT_MOBILITY_X,
                      patch_width: float = 0.02, load_length: float = 0.02,
                      eta: float = 0.01, mesh_file=None, method: str = "shift-invert",
                      n_waves: int = 40, mesh_units: str | None = None,
                      mesh_axes: str = "xy", progress=None) -> dict:
    """Free-rail point and transfer mobilities of ``profile`` meshed at ``h`` (m).

    frequencies: Hz (default: exact one-third-octave centres 50 Hz - 8 kHz). force and
    responses: :func:`location_from_spec` spellings. x: response distances from the load
    (m). The force is spread over ``load_length`` (m) along the rail (METHOD.md section 1:
    a load on one node of the continuum does not converge with the mesh). Writes
    mobility.csv (:mod:`railfem.io.frf_csv` layout, columns described in its header),
    mobility.png (magnitude and phase) and run.json; returns the paths and the FRF.
    """
    from .. import plotting
    from ..rail import mobility
    from ..io.frf_csv import write_frf_csv
    from ..standards.iec61260 import third_octave_bands

    t0 = time.perf_counter()
    if frequencies is None:
        frequencies = third_octave_bands(50.0, 8000.0).centre
    f = np.atleast_1d(np.asarray(frequencies, dtype=float))
    if f.ndim != 1 or f.size == 0 or not np.all(np.isfinite(f)) or np.any(f <= 0):
        raise ValueError(f"frequencies must be positive finite values in Hz, got {f!r:.80}")
    f = np.unique(f)
    xs = np.atleast_1d(np.asarray(x, dtype=float))
    if xs.ndim != 1 or xs.size == 0 or not np.all(np.isfinite(xs)):
        raise ValueError(f"response positions x must be finite distances in m, got {xs!r:.80}")
    if isinstance(responses, str):
        responses = (responses,)
    out = prepare_output_dir(out_dir, "mobility")
    material = Material.steel(eta)
    mesh = load_or_mesh(profile, h, mesh_file, mesh_units=mesh_units, mesh_axes=mesh_axes)
    guide = waveguide.assemble(mesh, material)
    load = location_from_spec(guide, force, patch_width)
    resp = [location_from_spec(guide, r, patch_width) for r in responses]
    log.info("free mobility of %s (%d DOFs): force %s, %d responses x %d positions, %d "
             "frequencies %.4g-%.4g Hz, %s", mesh.name, guide.n_dofs, load.label, len(resp),
             len(xs), len(f), f[0], f[-1], method)
    frf = mobility.free_mobility(guide, f, load, resp, xs, load_length=load_length,
                                 method=method, n_waves=n_waves,
                                 progress=progress or progress_logger("free mobility"))
    run = (f"profile {mesh.profile.name}, mesh {mesh.name}, {guide.n_dofs} DOFs; E = "
           f"{material.E:g} Pa, nu = {material.nu:g}, rho = {material.rho:g} kg/m^3, loss "
           f"factor {eta:g}; patch_width {patch_width:g} m, load_length {load_length:g} m; "
           f"waves: {method}" + (f" ({n_waves} per family + frozen tail)"
                                 if method == "shift-invert" else " (all)"))
    out.mkdir(parents=True, exist_ok=True)
    paths = {"csv": write_frf_csv(out / "mobility.csv", frf,
                                  comments=MOBILITY_CSV_COMMENTS + (run,))}
    ax_mag, _ = plotting.plot_magnitude_phase(f, frf.values[:, :, 0], list(frf.response))
    ax_mag.set_title(f"Free {mesh.profile.name} rail, h = {mesh.h * 1e3:g} mm: force "
                     f"{load.label}", fontsize="medium")
    paths["png"] = plotting.save_figure(ax_mag.figure, out / "mobility.png")
    meta = {
        "command": "mobility",
        "profile": mesh.profile.name, "profile_source": mesh.profile.source, "mesh": mesh.name,
        "mesh_source": mesh.source, "mesh_origin_m": list(mesh.origin), "curved": mesh.curved,
        "h_m": mesh.h, "n_dofs": guide.n_dofs, "families": list(guide.families),
        "material": {"E": material.E, "nu": material.nu, "rho": material.rho,
                     "loss_factor": eta},
        "force": load.label, "responses": [r.label for r in resp],
        "x_m": [float(v) for v in xs], "patch_width_m": patch_width,
        "load_length_m": load_length, "method": method, "n_waves": n_waves,
        "frequencies_hz": [float(v) for v in f],
        "runtime_s": time.perf_counter() - t0,
        "files": [paths["csv"].name, paths["png"].name],
    }
    paths["json"] = write_text_atomic(out / "run.json", json.dumps(meta, indent=2) + "\n")
    log.info("wrote %s and %s in %.1f s", paths["csv"], paths["png"], meta["runtime_s"])
    paths["frf"] = frf
    return paths


__all__ = ["DEFAULT_MOBILITY_X", "location_from_spec", "run_free_mobility"]
