"""Quality of a section mesh: element shapes, DOFs and section-property errors.

:func:`mesh_quality` measures a :class:`~railfem.rail.meshing.SectionMesh` (triangle angles
and aspect ratios, DOFs per symmetry family, area and second moments against the exact
outline polygon and, for 60E1, EN 13674-1); :func:`format_mesh_quality` is its text.
"""
from __future__ import annotations

import numpy as np

from . import section
from .meshing import SectionMesh, min_jacobian_ratio
from .profiles import EN13674_60E1, polygon_properties
from .waveguide import assemble

__all__ = ["mesh_quality", "format_mesh_quality"]


def mesh_quality(mesh: SectionMesh) -> dict:
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
    guide = assemble(mesh)
    q = {
        "profile": mesh.profile.name,
        "profile_source": mesh.profile.source,
        "mesh_source": mesh.source,
        "h_m": float(mesh.h),
        "curved": bool(mesh.curved),
        "max_midside_offset_m": mesh.midside_offset,
        "min_jacobian_ratio": float(min_jacobian_ratio(mesh).min()),
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
