"""The job behind ``railfem dispersion``: free-rail dispersion (CSV, plot, run.json) and
renders of the propagating wave shapes."""
from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np

from ..atomic import prepare_output_dir, write_text_atomic
from ..materials import Material
from ..rail import branches, waveguide, waves
from ..rail.branches import propagating_mask
from ..rail.shapes import wave_shapes
from .common import csv_text, load_or_mesh, progress_logger, slug

log = logging.getLogger(__name__)

__all__ = ["run_dispersion", "DEFAULT_RENDER_FREQUENCY", "DISPERSION_CSV_HEADER"]


#: Frequency (Hz) of the default wave-shape renders: on UIC60 the vertical and lateral
#: bending, torsion, longitudinal and the first web-bending wave all propagate at 2 kHz
#: (web bending cuts on near 1.3 kHz).
DEFAULT_RENDER_FREQUENCY = 2000.0

DISPERSION_CSV_HEADER = """\
# railfem free-rail dispersion
# one row per wave: time dependence exp(+i omega t), wave exp(-i k x)
# frequency_hz : frequency f = omega / (2 pi) in Hz
# wave         : k(omega) runs: wave index at this frequency, sorted by |k|; omega(k) runs:
#                branch number (railfem.rail.branches: modes followed along k by their shapes)
# family       : mirror-symmetry family: symmetric (vertical, longitudinal, foot flapping)
#                or antisymmetric (lateral, torsion, web bending)
# label        : wave type from the mode shape (railfem.rail.labels); omega(k) runs: one type
#                per branch
# k_re, k_im   : real and imaginary part of the wavenumber k in rad/m; k(omega) runs list
#                the positive-going waves (Im k <= 0: decaying towards +x)
# propagating  : 1 when |Im k| <= {max_att} |Re k| (railfem.plotting.MAX_ATTENUATION)
"""


def _dispersion_rows_k_of_omega(disp, max_att):
    """CSV rows of a k(omega) solve: one per finite wave."""
    prop = propagating_mask(disp.k, max_att)
    rows = []
    for i, f in enumerate(disp.frequency):
        for j in range(disp.k.shape[1]):
            k = disp.k[i, j]
            if not np.isfinite(k):
                continue
            rows.append((f, j, disp.family[i, j], disp.label[i, j], k.real, k.imag,
                         int(prop[i, j])))
    return rows


def _csv_header(mesh, guide, material, max_att) -> str:
    header = DISPERSION_CSV_HEADER.replace("{max_att}", f"{max_att:g}")
    return header + (f"# profile {mesh.profile.name}, mesh {mesh.name}, {guide.n_dofs} DOFs, "
                     f"E = {material.E:g} Pa, nu = {material.nu:g}, rho = {material.rho:g} "
                     f"kg/m^3, loss factor {material.loss_factor:g}\n")


def _solve_k_of_omega(guide, frequencies, method, n_waves, progress, max_att):
    """(CSV rows, branches) of a k(omega) run."""
    f = np.atleast_1d(np.asarray(frequencies, dtype=float))
    disp = waves.solve(guide, f, method=method, n_waves=n_waves,
                       progress=progress or progress_logger("dispersion k(omega)"))
    rows = _dispersion_rows_k_of_omega(disp, max_att)
    # the plot follows the propagating waves by their shapes, which waves.solve does
    # not return: a second pass of about the cost of the solve
    br = branches.k_of_omega(guide, np.unique(f), method=method, n_waves=n_waves,
                             progress=progress_logger("dispersion branches"))
    return rows, br


def _solve_omega_of_k(guide, k_values, n_modes, progress):
    """(CSV rows, branches) of an omega(k) run."""
    k = np.atleast_1d(np.asarray(k_values, dtype=float))
    if np.any(~np.isfinite(k)) or np.any(k < 0):
        raise ValueError(f"wavenumbers must be finite and >= 0 rad/m, got {k[:3]}...")
    br = branches.omega_of_k(guide, np.unique(k), n_modes=n_modes,
                             progress=progress or progress_logger("dispersion omega(k)"))
    ok = br.present()
    rows = sorted(((br.frequency[i, b], b, br.family[b], br.label[b], br.k[i, b].real,
                    0.0, 1) for i, b in zip(*np.nonzero(ok))), key=lambda r: (r[4], r[0]))
    return rows, br


def _render_waves(guide, out, render_frequency, method, n_waves, max_renders,
                  window_size) -> list:
    """PNG renders of the propagating waves at ``render_frequency`` in out/renders/."""
    from ..plotting import render as rendering

    renders = []
    shapes = wave_shapes(guide, render_frequency, method=method, n_waves=n_waves)
    if not shapes:
        log.warning("no propagating wave at %g Hz: nothing to render", render_frequency)
    for i, ws in enumerate(shapes[:max_renders]):
        name = f"wave_{i:02d}_{ws.family}_{slug(ws.label)}.png"
        title = (f"{branches.type_in_words(ws.label)} ({ws.family} family)\n"
                 f"{ws.frequency:g} Hz, k = {ws.k.real:.3g} rad/m")
        renders.append(rendering.render_wave_shape(guide.nodes, guide.elements, ws.shape,
                                                   out / "renders" / name, title=title,
                                                   window_size=window_size))
    if len(shapes) > max_renders:
        log.warning("rendered %d of %d propagating waves (max_renders)", max_renders,
                    len(shapes))
    return renders


def _run_record(mesh, guide, material, frequencies, k_values, method, n_waves, n_modes,
                render_frequency, paths) -> dict:
    """run.json of a dispersion run."""
    return {
        "command": "dispersion",
        "profile": mesh.profile.name, "profile_source": mesh.profile.source, "mesh": mesh.name,
        "mesh_source": mesh.source, "mesh_origin_m": list(mesh.origin), "curved": mesh.curved,
        "h_m": mesh.h, "n_dofs": guide.n_dofs, "families": list(guide.families),
        "material": {"E": material.E, "nu": material.nu, "rho": material.rho,
                     "loss_factor": material.loss_factor},
        "mode": "k(omega)" if frequencies is not None else "omega(k)",
        "method": method, "n_waves": n_waves, "n_modes": n_modes,
        "frequencies_hz": None if frequencies is None else [float(x) for x in
                                                            np.atleast_1d(frequencies)],
        "k_rad_per_m": None if k_values is None else [float(x) for x in
                                                      np.atleast_1d(k_values)],
        "render_frequency_hz": render_frequency,
        "files": [str(paths["csv"].name), str(paths["png"].name)]
        + [str(Path("renders") / p.name) for p in paths["renders"]],
    }


def run_dispersion(profile, h: float, out_dir, *, frequencies=None, k_values=None,
                   mesh_file=None, loss_factor: float = 0.0, method: str = "shift-invert",
                   n_waves: int = 40, n_modes: int = 12, mesh_units: str | None = None,
                   mesh_axes: str = "xy", render_frequency: float | None = DEFAULT_RENDER_FREQUENCY,
                   max_renders: int = 12, window_size=(800, 800), progress=None) -> dict:
    """Free-rail dispersion of ``profile`` meshed at ``h`` (m), written to ``out_dir``.

    Exactly one of ``frequencies`` (Hz: k(omega), every positive-going wave the solver
    returns) or ``k_values`` (rad/m: omega(k), the ``n_modes`` lowest modes per family).
    Writes dispersion.csv (columns documented in its header), dispersion.png, run.json and,
    unless ``render_frequency`` is None, PNG renders of the propagating waves at that
    frequency in renders/. Returns a dict of the written paths.
    """
    from .. import plotting
    from ..plotting import MAX_ATTENUATION

    if (frequencies is None) == (k_values is None):
        raise ValueError("give either frequencies (Hz) or k_values (rad/m), not both/neither")
    out = prepare_output_dir(out_dir, "dispersion")
    material = Material.steel(loss_factor)
    mesh = load_or_mesh(profile, h, mesh_file, mesh_units=mesh_units, mesh_axes=mesh_axes)
    guide = waveguide.assemble(mesh, material)
    if frequencies is not None:
        waveguide.check_resolution(guide, np.max(frequencies))
    log.info("dispersion of %s: %d DOFs (%s)", mesh.name, guide.n_dofs,
             ", ".join(f"{k} {f.T.shape[1]}" for k, f in guide.families.items()))
    columns = ["frequency_hz", "wave", "family", "label", "k_re", "k_im", "propagating"]
    header = _csv_header(mesh, guide, material, MAX_ATTENUATION)
    if frequencies is not None:
        rows, br = _solve_k_of_omega(guide, frequencies, method, n_waves, progress,
                                     MAX_ATTENUATION)
    else:
        rows, br = _solve_omega_of_k(guide, k_values, n_modes, progress)
    ax = plotting.plot_branches(br)
    ax.set_title(f"{mesh.profile.name}, h = {mesh.h * 1e3:g} mm, {guide.n_dofs} DOFs")
    paths = {"csv": write_text_atomic(out / "dispersion.csv", csv_text(header, columns, rows))}
    paths["png"] = plotting.save_figure(ax, out / "dispersion.png")
    log.info("wrote %s (%d rows) and %s", paths["csv"], len(rows), paths["png"])
    paths["renders"] = [] if render_frequency is None else _render_waves(
        guide, out, render_frequency, method, n_waves, max_renders, window_size)
    meta = _run_record(mesh, guide, material, frequencies, k_values, method, n_waves,
                       n_modes, render_frequency, paths)
    paths["json"] = write_text_atomic(out / "run.json", json.dumps(meta, indent=2) + "\n")
    return paths
