"""Jobs behind the command line: each turns a few parameters into files in a folder.

The CLI (:mod:`railfem.cli`) only parses arguments and calls one function here; the same
functions serve scripts and notebooks. Every file is written atomically (temporary file in
the target folder, then ``os.replace``), so an interrupted job never leaves a truncated
output behind. Progress goes to the ``railfem`` loggers (stderr under the CLI).
"""
from __future__ import annotations

import csv
import io
import json
import logging
import os
import re
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..rail import branches
from ..rail import meshing
from ..rail import section
from ..rail import waveguide
from ..rail import waves
from ..atomic import (
    json_safe, prepare_output_dir, write_bytes_atomic, write_text, write_text_atomic,
)
from ..materials import Material
from ..rail.profiles import EN13674_60E1, RailProfile, get_profile, polygon_properties

log = logging.getLogger(__name__)


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


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", str(text).lower()).strip("-") or "wave"


def _resolve_profile(profile) -> RailProfile:
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
    return meshing.get_mesh(_resolve_profile(profile), h)


# ---------------------------------------------------------------------------- mesh
def mesh_quality(mesh: meshing.SectionMesh) -> dict:
    """Mesh-quality summary: counts, DOFs, angles, aspect ratios, section-property errors.

    aspect ratio = circumradius / (2 inradius) (1 for an equilateral triangle). Section
    properties of the triangulation are compared with the exact polygon of the outline
    (and, for 60E1, with EN 13674-1).
    """
    v, t = mesh.vertices, mesh.triangles
    p = v[t]  # (nt, 3, 2)
    e = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 1], p[:, 0] - p[:, 2]], axis=1)
    L = np.linalg.norm(e, axis=2)  # (nt, 3) edge lengths
    area = 0.5 * np.abs(e[:, 0, 0] * (-e[:, 2, 1]) - e[:, 0, 1] * (-e[:, 2, 0]))
    ang = []
    for i in range(3):  # angle at vertex i between edges to the other two vertices
        a, b = -e[:, (i + 2) % 3], e[:, i]
        cosv = np.sum(a * b, axis=1) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
        ang.append(np.degrees(np.arccos(np.clip(cosv, -1, 1))))
    ang = np.stack(ang, axis=1)
    s = L.sum(axis=1) / 2
    inradius = area / s
    circumradius = L.prod(axis=1) / (4 * area)
    aspect = circumradius / (2 * inradius)
    n_p2 = len(mesh.nodes)

    A, cz, Iy, Iz = section.moments(mesh)
    poly = polygon_properties(mesh.profile.outline)
    mesh_props = {"area": A, "centroid_z": cz, "I_y": Iy, "I_z": Iz}
    straight = dict(zip(mesh_props, section.moments(mesh.straight())))
    vs_polygon = {k: float(val / getattr(poly, k) - 1) for k, val in mesh_props.items()}
    guide = waveguide.assemble(mesh)
    q = {
        "profile": mesh.profile.name,
        "profile_source": mesh.profile.source,
        "mesh_source": mesh.source,
        "h_m": float(mesh.h),
        "curved": bool(mesh.curved),
        "max_midside_offset_m": mesh.midside_offset,
        "min_jacobian_ratio": float(meshing.min_jacobian_ratio(mesh).min()),
        "n_vertices": int(len(v)),
        "n_triangles": int(len(t)),
        "n_p2_nodes": int(n_p2),
        "n_dofs": int(3 * n_p2),
        "n_dofs_family": {k: int(f.T.shape[1]) for k, f in guide.families.items()},
        "min_angle_deg": float(ang.min()),
        "max_angle_deg": float(ang.max()),
        "max_aspect_ratio": float(aspect.max()),
        "mean_aspect_ratio": float(aspect.mean()),
        "edge_length_m": {"min": float(L.min()), "mean": float(L.mean()), "max": float(L.max())},
        "section_properties": {k: float(val) for k, val in mesh_props.items()},
        "section_properties_straight_sided": {k: float(val) for k, val in straight.items()},
        "polygon_properties": {k: float(getattr(poly, k)) for k in mesh_props},
        "relative_error_vs_polygon": vs_polygon,
        "node_sets": {k: int(len(s_)) for k, s_ in guide.node_sets.items()},
    }
    if mesh.profile.name.upper() in ("60E1", "UIC60"):
        q["relative_error_vs_EN13674_1"] = {k: float(mesh_props[k] / EN13674_60E1[k] - 1)
                                            for k in EN13674_60E1}
        q["relative_error_vs_EN13674_1_straight_sided"] = {
            k: float(straight[k] / EN13674_60E1[k] - 1) for k in EN13674_60E1}
    try:
        import gmsh

        q["gmsh_version"] = gmsh.__version__
    except Exception:  # pragma: no cover - gmsh missing only on broken installs
        pass
    return q


def format_mesh_quality(q: dict) -> str:
    """Human-readable text of :func:`mesh_quality`."""
    lines = [
        f"mesh {q['profile']} at h = {q['h_m'] * 1e3:g} mm",
        f"  {'curved' if q['curved'] else 'straight-sided'} 6-node triangles: mid-side nodes "
        f"up to {q['max_midside_offset_m'] * 1e3:.3g} mm off the chords, smallest det J "
        f"ratio {q['min_jacobian_ratio']:.3f}",
        f"  vertices {q['n_vertices']}, triangles {q['n_triangles']}, "
        f"P2 nodes {q['n_p2_nodes']}, DOFs {q['n_dofs']} "
        + "(" + ", ".join(f"{k} {n}" for k, n in q["n_dofs_family"].items()) + ")",
        f"  min angle {q['min_angle_deg']:.1f} deg, max angle {q['max_angle_deg']:.1f} deg, "
        f"max aspect ratio {q['max_aspect_ratio']:.2f} (mean {q['mean_aspect_ratio']:.3f})",
        "  edge length (mm): min {min:.2f}, mean {mean:.2f}, max {max:.2f}".format(
            **{k: x * 1e3 for k, x in q["edge_length_m"].items()}),
        "  section property          mesh        polygon     error",
    ]
    units = {"area": (1e4, "cm^2"), "centroid_z": (1e3, "mm"), "I_y": (1e8, "cm^4"),
             "I_z": (1e8, "cm^4")}
    for k, (s, u) in units.items():
        lines.append(f"  {k:<12s} ({u:<4s}) {q['section_properties'][k] * s:11.4f} "
                     f"{q['polygon_properties'][k] * s:11.4f} "
                     f"{q['relative_error_vs_polygon'][k] * 100:+8.3f} %")
    if "relative_error_vs_EN13674_1" in q:
        lines.append("  vs EN 13674-1 60E1: " + ", ".join(
            f"{k} {err * 100:+.3f} %" for k, err in q["relative_error_vs_EN13674_1"].items()))
        lines.append("  (straight-sided: " + ", ".join(
            f"{k} {err * 100:+.3f} %"
            for k, err in q["relative_error_vs_EN13674_1_straight_sided"].items()) + ")")
    lines.append("  node sets: " + ", ".join(f"{k} {n}" for k, n in q["node_sets"].items()))
    if "gmsh_version" in q:
        lines.append(f"  gmsh {q['gmsh_version']}")
    return "\n".join(lines) + "\n"


def run_mesh(profile, h: float, out_dir) -> dict:
    """Mesh ``profile`` at element size ``h`` (m); write <name>.npz, <name>_quality.json and
    <name>_quality.txt in ``out_dir``. Returns {'mesh', 'json', 'txt', 'quality'}."""
    prof = _resolve_profile(profile)
    out = prepare_output_dir(out_dir, "mesh")
    mesh = meshing.mesh_profile(prof, h)
    npz = meshing.save_mesh(mesh, out / f"{mesh.name}.npz")
    q = mesh_quality(mesh)
    js = write_text_atomic(out / f"{mesh.name}_quality.json", json.dumps(q, indent=2) + "\n")
    txt = write_text_atomic(out / f"{mesh.name}_quality.txt", format_mesh_quality(q))
    log.info("wrote %s (%d vertices, %d triangles, %d DOFs)", npz, q["n_vertices"],
             q["n_triangles"], q["n_dofs"])
    return {"mesh": npz, "json": js, "txt": txt, "quality": q}


def run_shipped_meshes(out_dir=None, progress=None) -> list[dict]:
    """Regenerate the shipped meshes (60E1 at meshing.SHIPPED_H) in ``out_dir``
    (default: the package's railfem/data/meshes/ folder)."""
    out_dir = meshing.MESH_DIR if out_dir is None else Path(out_dir)
    results = []
    for i, h in enumerate(meshing.SHIPPED_H):
        results.append(run_mesh(meshing.DEFAULT_PROFILE, h, out_dir))
        if progress:
            progress(i + 1, len(meshing.SHIPPED_H))
    return results


# ---------------------------------------------------------------------- dispersion
@dataclass(frozen=True, kw_only=True)
class WaveShape:
    """One wave at one frequency with its full cross-section shape.

    shape: (n_nodes, 3) complex (u_x, u_y, u_z) per P2 node of ``guide.nodes``, scaled to
    unit norm and phased so that the in-plane part is real (the axial part of a
    propagating wave is then imaginary).
    """

    family: str
    frequency: float
    k: complex
    label: str
    propagating: bool
    shape: np.ndarray


def wave_shapes(guide: waveguide.Waveguide, frequency_hz: float, *, method: str = "shift-invert",
                n_waves: int = 40, propagating_only: bool = True,
                max_attenuation: float | None = None) -> list[WaveShape]:
    """Waves of both families at one frequency with per-node shapes (T @ phi mapped through
    ``guide.node_dofs``), sorted by family then by decreasing Re k."""
    from ..rail.labels import label_waves
    from ..plotting import MAX_ATTENUATION, propagating_mask

    max_att = MAX_ATTENUATION if max_attenuation is None else max_attenuation
    out = []
    for fam in guide.families:
        ops = waves.FamilyOperators(guide, fam)
        w = waves.waves_at(ops, 2 * np.pi * frequency_hz, method=method, n_waves=n_waves)
        labels = label_waves(guide, ops, w)
        prop = propagating_mask(w.k, max_att)
        order = np.argsort(-w.k.real)
        for j in order:
            if propagating_only and not prop[j]:
                continue
            full = ops.T @ w.phi[:, j]
            u = full[guide.node_dofs]  # (n, 3)
            inplane = u[:, 1:].ravel()
            big = inplane[np.argmax(np.abs(inplane))] if np.any(inplane) else 1.0
            u = u * np.exp(-1j * np.angle(big))
            u = u / np.linalg.norm(u)
            out.append(WaveShape(family=fam, frequency=float(frequency_hz), k=complex(w.k[j]),
                                 label=str(labels[j]), propagating=bool(prop[j]), shape=u))
    return out


def _dispersion_rows_k_of_omega(disp, max_att):
    from ..plotting import propagating_mask

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


def _csv_text(header: str, columns, rows) -> str:
    buf = io.StringIO()
    buf.write(header)
    wr = csv.writer(buf, lineterminator="\n")
    wr.writerow(columns)
    for r in rows:
        wr.writerow([f"{x:.10g}" if isinstance(x, (float, np.floating)) else x for x in r])
    return buf.getvalue()


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
    from ..plotting import render as rendering
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
    paths = {}
    columns = ["frequency_hz", "wave", "family", "label", "k_re", "k_im", "propagating"]
    header = DISPERSION_CSV_HEADER.replace("{max_att}", f"{MAX_ATTENUATION:g}")
    header += (f"# profile {mesh.profile.name}, mesh {mesh.name}, {guide.n_dofs} DOFs, "
               f"E = {material.E:g} Pa, nu = {material.nu:g}, rho = {material.rho:g} kg/m^3, "
               f"loss factor {material.loss_factor:g}\n")
    if frequencies is not None:
        f = np.atleast_1d(np.asarray(frequencies, dtype=float))
        disp = waves.solve(guide, f, method=method, n_waves=n_waves,
                           progress=progress or progress_logger("dispersion k(omega)"))
        rows = _dispersion_rows_k_of_omega(disp, MAX_ATTENUATION)
        # the plot follows the propagating waves by their shapes, which waves.solve does
        # not return: a second pass of about the cost of the solve
        br = branches.k_of_omega(guide, np.unique(f), method=method, n_waves=n_waves,
                                 progress=progress_logger("dispersion branches"))
    else:
        k = np.atleast_1d(np.asarray(k_values, dtype=float))
        if np.any(~np.isfinite(k)) or np.any(k < 0):
            raise ValueError(f"wavenumbers must be finite and >= 0 rad/m, got {k[:3]}...")
        br = branches.omega_of_k(guide, np.unique(k), n_modes=n_modes,
                                 progress=progress or progress_logger("dispersion omega(k)"))
        ok = br.present()
        rows = sorted(((br.frequency[i, b], b, br.family[b], br.label[b], br.k[i, b].real,
                        0.0, 1) for i, b in zip(*np.nonzero(ok))), key=lambda r: (r[4], r[0]))
    ax = plotting.plot_branches(br)
    ax.set_title(f"{mesh.profile.name}, h = {mesh.h * 1e3:g} mm, {guide.n_dofs} DOFs")
    paths["csv"] = write_text_atomic(out / "dispersion.csv", _csv_text(header, columns, rows))
    paths["png"] = plotting.save_figure(ax, out / "dispersion.png")
    log.info("wrote %s (%d rows) and %s", paths["csv"], len(rows), paths["png"])

    renders = []
    if render_frequency is not None:
        shapes = wave_shapes(guide, render_frequency, method=method, n_waves=n_waves)
        if not shapes:
            log.warning("no propagating wave at %g Hz: nothing to render", render_frequency)
        for i, ws in enumerate(shapes[:max_renders]):
            name = f"wave_{i:02d}_{ws.family}_{_slug(ws.label)}.png"
            title = (f"{branches.type_in_words(ws.label)} ({ws.family} family)\n"
                     f"{ws.frequency:g} Hz, k = {ws.k.real:.3g} rad/m")
            renders.append(rendering.render_wave_shape(guide.nodes, guide.elements, ws.shape,
                                                       out / "renders" / name, title=title,
                                                       window_size=window_size))
        if len(shapes) > max_renders:
            log.warning("rendered %d of %d propagating waves (max_renders)", max_renders,
                        len(shapes))
    paths["renders"] = renders
    meta = {
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
        + [str(Path("renders") / p.name) for p in renders],
    }
    paths["json"] = write_text_atomic(out / "run.json", json.dumps(meta, indent=2) + "\n")
    return paths


# --------------------------------------------------------------------- convergence
def convergence_table(study) -> str:
    """CSV text of a :class:`railfem.studies.convergence.ConvergenceStudy`: one row per mesh size,
    then the reference values and observed rates as rows labelled in the first column."""
    cols = ["h_mm", "n_dofs"] + [f"n_dofs_{fam}" for fam in study.n_dofs_family]
    qnames = [f"cut_on_{j + 1}_{fam}_hz" for j, fam in enumerate(study.cut_on_family)]
    knames = []
    for q, f in enumerate(study.frequencies):
        for j in range(study.wavenumbers.shape[2]):
            if study.wave_family[q, j]:
                knames.append(f"k_{f:g}hz_{study.wave_family[q, j]}_"
                              f"{_slug(study.wave_label[q, j])}_rad_per_m")
            else:
                knames.append(f"k_{f:g}hz_{j}_rad_per_m")
    nf, nw = study.wavenumbers.shape[1:]
    header = (
        "# railfem mesh-convergence study\n"
        f"# profile {study.profile}, {'curved' if study.curved else 'straight-sided'} 6-node "
        f"elements; reference: {study.reference}\n"
        "# rows: one per element size h; then 'reference' (Richardson extrapolation of the "
        "three finest meshes, or the finest mesh), 'rate' (observed order: slope of "
        "log|relative error| vs log h) and 'richardson_order' (order of the Richardson fit)\n"
        "# cut_on_*: cut-on frequencies (Hz) of the cross-section modes at k = 0, tracked "
        "by symmetry family and rank; k_*: Re k (rad/m) of the propagating waves\n")
    rows = []
    for i, h in enumerate(study.sizes):
        rows.append([h * 1e3, int(study.n_dofs[i])]
                    + [int(v[i]) for v in study.n_dofs_family.values()]
                    + list(study.cut_on[i]) + list(study.wavenumbers[i].reshape(nf * nw)))
    blank = [""] * (1 + len(study.n_dofs_family))
    rows.append(["reference"] + blank + list(study.cut_on_reference)
                + list(study.wavenumber_reference.reshape(nf * nw)))
    rows.append(["rate"] + blank + list(study.cut_on_rate)
                + list(study.wavenumber_rate.reshape(nf * nw)))
    rows.append(["richardson_order"] + blank + list(study.cut_on_order) + [""] * (nf * nw))
    return _csv_text(header, cols + qnames + knames, rows)


def _convergence_plot(sizes, errors, labels, title, path):
    from .. import plotting

    keep = np.any(np.abs(errors) > 1e-12, axis=0)  # round-off-only series say nothing
    ax = plotting.plot_convergence(sizes * 1e3, errors[:, keep],
                                   [lab for lab, k in zip(labels, keep) if k],
                                   xlabel="Element size h (mm)",
                                   ylabel="Relative error vs reference")
    ax.set_title(title)
    return plotting.save_figure(ax, path)


def run_convergence(profile, sizes, out_dir, *, frequencies=(), n_cut_on: int = 6,
                    reference: str = "richardson", progress=None, geometry: str = "curved",
                    use_shipped: bool = False) -> dict:
    """Run :func:`railfem.studies.convergence.convergence_study` and write convergence.csv,
    convergence.png (log-log relative error of the cut-on frequencies against h with fitted
    slopes), convergence_wavenumbers.png (the same for the wavenumbers, when frequencies
    are given) and convergence.json (all arrays).

    geometry: 'curved' (6-node elements with mid-side nodes on the outline, default),
    'straight' (the straight-sided twins) or 'both' (curved in the files above, straight in
    convergence_straight.csv / .png / .json). use_shipped: take the shipped meshes where
    they exist instead of meshing afresh."""
    from ..studies.convergence import convergence_study

    if geometry not in ("curved", "straight", "both"):
        raise ValueError(f"geometry must be 'curved', 'straight' or 'both', got {geometry!r}")
    out = prepare_output_dir(out_dir, "convergence")
    runs = {"curved": [True], "straight": [False], "both": [True, False]}[geometry]
    paths = {}
    for curved in runs:
        study = convergence_study(_resolve_profile(profile), sizes, frequencies=frequencies,
                                  n_cut_on=n_cut_on, reference=reference, curved=curved,
                                  use_shipped=use_shipped,
                                  progress=progress or progress_logger("convergence (meshes)"))
        suffix = "_straight" if (geometry == "both" and not curved) else ""
        written = _write_convergence(study, out, suffix)
        if suffix:
            paths.update({f"{k}{suffix}": v for k, v in written.items()})
        else:
            paths.update(written)
    return paths


def _write_convergence(study, out: Path, suffix: str) -> dict:
    kind = "curved" if study.curved else "straight-sided"
    paths = {"csv": write_text_atomic(out / f"convergence{suffix}.csv",
                                      convergence_table(study))}
    labels = [f"cut-on {j + 1} ({fam[:4]}.), {ref:.0f} Hz" for j, (fam, ref) in
              enumerate(zip(study.cut_on_family, study.cut_on_reference))]
    paths["png"] = _convergence_plot(study.sizes, np.abs(study.cut_on_error), labels,
                                     f"{study.profile} ({kind}): cut-on frequencies "
                                     f"({study.reference['cut_on']})",
                                     out / f"convergence{suffix}.png")
    nf, nw = study.wavenumbers.shape[1:]
    err, labels = [], []
    for q, f in enumerate(study.frequencies):
        for j in range(nw):
            if study.wave_family[q, j]:
                err.append(np.abs(study.wavenumber_error[:, q, j]))
                labels.append(f"{study.wave_label[q, j]} @ {f:g} Hz")
    if err:
        paths["png_wavenumbers"] = _convergence_plot(
            study.sizes, np.column_stack(err), labels,
            f"{study.profile} ({kind}): wavenumbers ({study.reference['wavenumbers']})",
            out / f"convergence{suffix}_wavenumbers.png")

    def arr(x):
        return json_safe(np.asarray(x).tolist())

    data = {k: arr(getattr(study, k)) for k in (
        "sizes", "n_dofs", "cut_on", "cut_on_family", "cut_on_rank", "frequencies",
        "wave_family", "wave_label", "cut_on_reference", "cut_on_error", "cut_on_rate",
        "cut_on_order", "wavenumber_reference", "wavenumber_rate")}
    data["wavenumbers"] = arr(study.wavenumbers)
    data["wavenumber_error"] = arr(study.wavenumber_error)
    data["profile"], data["reference"] = study.profile, study.reference
    data["curved"] = study.curved
    data["n_dofs_family"] = {k: arr(v) for k, v in study.n_dofs_family.items()}
    paths["json"] = write_text_atomic(out / f"convergence{suffix}.json",
                                      json.dumps(data, indent=1, allow_nan=False) + "\n")
    paths["study"] = study
    log.info("wrote %s and %s", paths["csv"], paths["png"])
    return paths


def run_support_convergence(out_dir, cases: dict, *, preset: str = "site",
                            decay: bool = False, n_supports: int = 41, profile: str = "60E1",
                            progress=None) -> dict:
    """Run :func:`railfem.studies.support_convergence.support_study` and write peaks.csv,
    peaks.txt (the table) and, with ``decay``, decay_rates.csv."""
    from ..studies import support_convergence as sc

    out = prepare_output_dir(out_dir, "support-convergence")
    res = sc.support_study(cases, preset, decay=decay, n_supports=n_supports, profile=profile,
                           progress=progress or progress_logger("support convergence"))
    paths = {"csv": write_text_atomic(out / "peaks.csv", sc.peak_csv(res["peaks"])),
             "txt": write_text_atomic(out / "peaks.txt", sc.peak_table(res["peaks"]) + "\n")}
    if decay:
        paths["decay_csv"] = write_text_atomic(out / "decay_rates.csv", sc.decay_csv(res["decay"]))
    return {"paths": paths, **res}
