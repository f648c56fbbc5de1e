"""Cross-section meshes: Gmsh triangulation of a profile, mirrored about the web axis.

The right half (y >= 0) of the outline is meshed with Gmsh and mirrored, so the mesh is
exactly symmetric and vertical (symmetric) and lateral (antisymmetric) waves separate. The
outline is split at its corners (turning angle above ``CORNER_ANGLE_DEG``) and each smooth
run between corners becomes one Gmsh spline through the outline points: this keeps the
curved head, fillets and foot toe smooth without forcing a mesh node at each of the
hundreds of digitised points, and works unchanged for any outline (a rectangle has four
straight runs). The triangulation is linear (3-node); the finite element space on it is P2,
so every element is a 6-node triangle with straight sides and midside nodes (see
``waveguide``). Node sets are found geometrically on the P2 nodes, never from Gmsh tags,
which survive neither mirroring nor scikit-fem's renumbering.
"""
from __future__ import annotations

import logging
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .profiles import RailProfile, get_profile, half_outline

log = logging.getLogger(__name__)

CORNER_ANGLE_DEG = 10.0
MESH_DIR = Path(__file__).resolve().parents[1] / "meshes"
DEFAULT_PROFILE = "60E1"
DEFAULT_H = 0.010  # m; default element size of the shipped mesh
SHIPPED_H = (0.020, 0.015, 0.010, 0.0075, 0.005)


@dataclass(frozen=True, kw_only=True)
class SectionMesh:
    """A mirror-symmetric linear triangulation of a cross-section.

    vertices: (nv, 2) (y, z) coordinates in m. triangles: (nt, 3) vertex indices,
    counter-clockwise. h: target element size (m). profile: the outline meshed.
    """

    vertices: np.ndarray
    triangles: np.ndarray
    h: float
    profile: RailProfile

    def __post_init__(self):
        v, t = np.asarray(self.vertices, float), np.asarray(self.triangles, np.int64)
        if v.ndim != 2 or v.shape[1] != 2 or t.ndim != 2 or t.shape[1] != 3:
            raise ValueError(f"mesh needs vertices (n, 2) and triangles (m, 3); got "
                             f"{v.shape} and {t.shape}")
        if t.min() < 0 or t.max() >= len(v):
            raise ValueError("mesh triangles reference vertices that do not exist")
        object.__setattr__(self, "vertices", v)
        object.__setattr__(self, "triangles", t)

    @property
    def name(self) -> str:
        return f"{self.profile.name}_h{self.h * 1e3:g}mm"


def _corner_indices(pts: np.ndarray) -> list[int]:
    """Indices of an open polyline's interior points where the direction turns sharply."""
    d = np.diff(pts, axis=0)
    ang = np.arctan2(d[:, 1], d[:, 0])
    turn = np.abs((np.diff(ang) + np.pi) % (2 * np.pi) - np.pi)
    return [i + 1 for i in np.nonzero(turn > np.radians(CORNER_ANGLE_DEG))[0]]


def _gmsh_half(half: np.ndarray, h: float) -> tuple[np.ndarray, np.ndarray]:
    import gmsh

    gmsh.initialize(["-noenv"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("section")
        geo = gmsh.model.geo
        tags = [geo.addPoint(y, z, 0.0, h) for y, z in half]
        breaks = [0, *_corner_indices(half), len(half) - 1]
        curves = []
        for a, b in zip(breaks[:-1], breaks[1:]):
            seg = tags[a:b + 1]
            curves.append(geo.addLine(*seg) if len(seg) == 2 else geo.addSpline(seg))
        curves.append(geo.addLine(tags[-1], tags[0]))  # the mirror axis, top to bottom
        geo.addPlaneSurface([geo.addCurveLoop(curves)])
        geo.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMin", 0.3 * h)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        gmsh.option.setNumber("Mesh.Algorithm", 6)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.optimize("Laplace2D")
        node_tags, coords, _ = gmsh.model.mesh.getNodes()
        _, elem_nodes = gmsh.model.mesh.getElementsByType(2)  # 3-node triangles
    finally:
        gmsh.finalize()
    xyz = coords.reshape(-1, 3)[:, :2]
    index = {int(t): i for i, t in enumerate(node_tags)}
    tri = np.array([index[int(t)] for t in elem_nodes], dtype=np.int64).reshape(-1, 3)
    used = np.unique(tri)
    remap = -np.ones(len(xyz), dtype=np.int64)
    remap[used] = np.arange(len(used))
    return xyz[used], remap[tri]


def _mirror(vertices: np.ndarray, triangles: np.ndarray, tol: float):
    on_axis = np.abs(vertices[:, 0]) < tol
    vertices = vertices.copy()
    vertices[on_axis, 0] = 0.0
    off = np.nonzero(~on_axis)[0]
    image = np.arange(len(vertices))
    image[off] = len(vertices) + np.arange(len(off))
    mirrored = vertices[off] * [-1.0, 1.0]
    all_v = np.vstack([vertices, mirrored])
    # mirroring reverses orientation: swap two vertices to keep counter-clockwise order
    tri_m = image[triangles][:, [0, 2, 1]]
    return all_v, np.vstack([triangles, tri_m])


def _orient_ccw(v: np.ndarray, t: np.ndarray) -> np.ndarray:
    a, b, c = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
    area2 = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    t = t.copy()
    t[area2 < 0] = t[area2 < 0][:, [0, 2, 1]]
    return t


def mesh_profile(profile: RailProfile | str = DEFAULT_PROFILE, h: float = DEFAULT_H) -> SectionMesh:
    """Mesh a profile with Gmsh at element size h (m), mirror-symmetric about y = 0."""
    if isinstance(profile, str):
        profile = get_profile(profile)
    if not (np.isfinite(h) and 0 < h < profile.height):
        raise ValueError(f"element size h must be in (0, {profile.height:.3g}) m, got {h!r} "
                         "(give metres, e.g. 0.01 for 10 mm)")
    half = half_outline(profile)
    v, t = _gmsh_half(half, h)
    v, t = _mirror(v, t, tol=1e-9 * profile.height)
    t = _orient_ccw(v, t)
    log.info("meshed %s at h = %.4g m: %d vertices, %d triangles", profile.name, h, len(v), len(t))
    return SectionMesh(vertices=v, triangles=t, h=h, profile=profile)


def save_mesh(mesh: SectionMesh, path) -> Path:
    """Write the mesh (with its outline) to .npz atomically."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, suffix=".npz")
    os.close(fd)
    os.chmod(tmp, 0o644)  # mkstemp makes 0600 files; shipped meshes must be world-readable
    try:
        np.savez(tmp, vertices=mesh.vertices, triangles=mesh.triangles, h=mesh.h,
                 outline=mesh.profile.outline, name=mesh.profile.name, source=mesh.profile.source)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def load_mesh(path) -> SectionMesh:
    path = Path(path)
    try:
        d = np.load(path, allow_pickle=False)
        prof = RailProfile(name=str(d["name"]), outline=d["outline"], source=str(d["source"]))
        return SectionMesh(vertices=d["vertices"], triangles=d["triangles"], h=float(d["h"]),
                           profile=prof)
    except (OSError, KeyError, ValueError) as exc:
        raise ValueError(f"cannot read railfem mesh file {path}: {exc}. Regenerate it with "
                         "'railfem mesh'") from exc


def shipped_path(profile_name: str = DEFAULT_PROFILE, h: float = DEFAULT_H) -> Path:
    return MESH_DIR / f"{profile_name}_h{h * 1e3:g}mm.npz"


def get_mesh(profile: RailProfile | str = DEFAULT_PROFILE, h: float = DEFAULT_H) -> SectionMesh:
    """The shipped mesh when there is one for (profile, h), else a new Gmsh mesh."""
    name = profile if isinstance(profile, str) else profile.name
    if name.upper() == "UIC60":
        name = "60E1"
    path = shipped_path(name, h)
    if path.exists():
        mesh = load_mesh(path)
        if isinstance(profile, RailProfile) and not np.array_equal(mesh.profile.outline,
                                                                   profile.outline):
            return mesh_profile(profile, h)
        return mesh
    return mesh_profile(profile, h)
