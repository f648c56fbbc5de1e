"""Cross-section meshes: curved 6-node (isoparametric P2) triangles from Gmsh or from a file.

A :class:`SectionMesh` is a second-order triangulation: every element has three corner
nodes and three mid-side nodes (edges 01, 12, 20), and the mid-side nodes of boundary edges
lie on the curved outline, so assembling on the quadratic geometry (scikit-fem
``MeshTri2``, see :mod:`railfem.rail.waveguide`) leaves a geometry error of O(h^3) instead of the
O(h^2) of straight-sided elements on a curved outline. ``SectionMesh.straight()`` gives the
same triangulation with the mid-side nodes moved to the chord midpoints (the straight-sided
P2 mesh, kept for convergence comparisons).

Gmsh meshing (:func:`mesh_profile`): a digitised outline (``RailProfile.smooth``, e.g. 60E1)
is split at its corners (turning angle above ``CORNER_ANGLE_DEG``) and each smooth run
between corners becomes one Gmsh spline through the outline points, so the curved head,
fillets and foot toe stay smooth without a mesh node at each digitised point (a rectangle
has four straight runs). A polygon outline (``smooth`` False, what a CSV outline is unless
the file asks for smoothing) is meshed with straight edges between its points, every point
a corner. A meshed area more than ``AREA_TOL`` off the outline polygon's is logged as a
warning (splines rounding corners that were meant to be sharp). A mirror-symmetric
outline (``RailProfile.symmetric``) is meshed on its right half and mirrored, so the mesh
is exactly symmetric and its waves split into two families; an asymmetric outline is
meshed whole and never mirrored (one wave family).
After the linear mesh, Gmsh raises the order to 2, placing mid-side nodes on the splines.

Any mesh in (:func:`read_mesh`): a 2-D mesh file that meshio reads (Gmsh ``.msh`` 2.2 and
4.x, ...) with 3- or 6-node triangles, the user stating its length unit and which file axes
are lateral and vertical. Symmetry is detected on the assembled mesh
(:func:`railfem.rail.waveguide.mirror_image`), not demanded. Node sets are found geometrically
on the nodes (:func:`railfem.rail.waveguide.default_node_sets`), never from file tags.
"""
from __future__ import annotations

import logging
import re
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..atomic import atomic_path
from .profiles import (RailProfile, get_profile, half_outline, mirror_deviation,
                       polygon_properties)
from ..validators import show

log = logging.getLogger(__name__)

CORNER_ANGLE_DEG = 45.0  # a sharper turn at one outline point is a corner of the section
STRAIGHT_ANGLE_DEG = 0.05  # a point turning less is inside a straight run
AREA_TOL = 0.005  # relative difference of meshed and polygon area that is reported
MESH_DIR = Path(__file__).resolve().parents[1] / "data" / "meshes"  # package data: works installed
DEFAULT_PROFILE = "60E1"
DEFAULT_H = 0.010  # m; default element size of the shipped mesh
#: Shipped 60E1 meshes (m). 3.5 and 2.5 mm carry the convergence study below 5 mm, where
#: the cut-ons converge at the P2 rate (coarser meshes are pre-asymptotic: the 16.5 mm web
#: is one or two elements thick).
SHIPPED_H = (0.020, 0.015, 0.010, 0.0075, 0.005, 0.0035, 0.0025)
FORMAT_VERSION = 2  # .npz layout: 2 = 6-node elements (nodes, elements); 1 had vertices only

# Barycentric sample points for the Jacobian check of curved elements: the corners, edge
# midpoints and interior points (det J is quadratic on a P2 triangle).
_JAC_SAMPLES = np.array([[0, 0], [1, 0], [0, 1], [.5, 0], [.5, .5], [0, .5], [1 / 3, 1 / 3],
                         [.2, .2], [.6, .2], [.2, .6]])


@dataclass(frozen=True, kw_only=True)
class SectionMesh:
    """A second-order (6-node) triangulation of a cross-section.

    nodes: (n, 2) (y, z) coordinates in m; the corner nodes come first (0 .. n_vertices-1),
    then the mid-side nodes. elements: (m, 6) node indices: corners counter-clockwise, then
    the mid-side nodes of edges 01, 12, 20. h: element size (m; target size of a Gmsh mesh,
    longest edge of a read one). profile: the outline (for a read mesh, its boundary).
    source: how the mesh was made. origin: (y, z) position (m) of railfem's origin in the
    frame of a mesh file (the file's lateral/vertical coordinates = nodes + origin).
    """

    nodes: np.ndarray
    elements: np.ndarray
    h: float
    profile: RailProfile
    source: str = "gmsh"
    origin: tuple = (0.0, 0.0)

    def __post_init__(self):
        p, e = np.asarray(self.nodes, float), np.asarray(self.elements, np.int64)
        if p.ndim != 2 or p.shape[1] != 2 or e.ndim != 2 or e.shape[1] != 6 or not len(e):
            raise ValueError(f"a section mesh needs nodes (n, 2) and 6-node elements (m, 6); "
                             f"got {p.shape} and {e.shape}")
        if e.min() < 0 or e.max() >= len(p):
            raise ValueError("mesh elements reference nodes that do not exist")
        if not np.all(np.isfinite(p)):
            raise ValueError("mesh nodes have NaN or inf coordinates")
        nv = int(e[:, :3].max()) + 1
        if e[:, 3:].min() < nv or len(np.unique(e[:, :3])) != nv:
            raise ValueError("mesh nodes must list the corner nodes first; use "
                             "meshing.canonical() to renumber")
        a = _corner_area2(p, e)
        if np.any(a <= 0):
            raise ValueError(f"{np.count_nonzero(a <= 0)} mesh element(s) are degenerate or "
                             "clockwise")
        object.__setattr__(self, "nodes", p)
        object.__setattr__(self, "elements", e)
        object.__setattr__(self, "origin", tuple(float(v) for v in self.origin))

    @property
    def name(self) -> str:
        return f"{self.profile.name}_h{self.h * 1e3:g}mm"

    @property
    def n_vertices(self) -> int:
        return int(self.elements[:, :3].max()) + 1

    @property
    def vertices(self) -> np.ndarray:
        """(nv, 2) corner node coordinates (the linear triangulation)."""
        return self.nodes[: self.n_vertices]

    @property
    def triangles(self) -> np.ndarray:
        """(m, 3) corner indices, counter-clockwise."""
        return self.elements[:, :3]

    @property
    def midside_offset(self) -> float:
        """Largest distance (m) of a mid-side node from its chord midpoint (0: straight)."""
        e = self.elements
        mid = 0.5 * (self.nodes[e[:, [0, 1, 2]]] + self.nodes[e[:, [1, 2, 0]]])
        return float(np.linalg.norm(self.nodes[e[:, 3:]] - mid, axis=2).max())

    @property
    def curved(self) -> bool:
        return self.midside_offset > 1e-9 * self.profile.size

    def straight(self) -> "SectionMesh":
        """The same triangulation with straight sides (mid-side nodes at chord midpoints)."""
        p = self.nodes.copy()
        e = self.elements
        for j, (a, b) in enumerate(((0, 1), (1, 2), (2, 0))):
            p[e[:, 3 + j]] = 0.5 * (self.nodes[e[:, a]] + self.nodes[e[:, b]])
        return replace(self, nodes=p, source=f"{self.source} (straight-sided)")


def skfem_mesh(mesh: SectionMesh):
    """The scikit-fem mesh: quadratic geometry (MeshTri2) when curved, else MeshTri1.

    Its vertices are the mesh's corner nodes in the same order."""
    from skfem import MeshTri1, MeshTri2

    if mesh.curved:
        m = MeshTri2(mesh.nodes.T.copy(), mesh.elements.T.copy())
    else:
        m = MeshTri1(mesh.vertices.T.copy(), mesh.triangles.T.copy())
    if m.t.shape[1] != len(mesh.elements) or m.t.max() + 1 != mesh.n_vertices:
        raise ValueError("scikit-fem dropped elements or nodes of the section mesh")
    return m


def _corner_area2(p: np.ndarray, e: np.ndarray) -> np.ndarray:
    a, b, c = p[e[:, 0]], p[e[:, 1]], p[e[:, 2]]
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])


def canonical(nodes: np.ndarray, elements: np.ndarray):
    """Renumber a 6-node mesh corners first, drop unused nodes, orient counter-clockwise."""
    nodes, e = np.asarray(nodes, float), np.asarray(elements, np.int64).copy()
    cw = _corner_area2(nodes, e) < 0
    e[cw] = e[cw][:, [0, 2, 1, 5, 4, 3]]
    corners = np.unique(e[:, :3])
    mids = np.setdiff1d(np.unique(e[:, 3:]), corners)
    if len(mids) != len(np.unique(e[:, 3:])):
        raise ValueError("a node of the mesh is both a corner and a mid-side node")
    order = np.concatenate([corners, mids])
    new = -np.ones(len(nodes), np.int64)
    new[order] = np.arange(len(order))
    return nodes[order], new[e]


def from_linear(vertices: np.ndarray, triangles: np.ndarray):
    """(nodes, elements) of the straight-sided 6-node mesh on a linear triangulation."""
    v, t = np.asarray(vertices, float), np.asarray(triangles, np.int64)
    edges = np.vstack([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    uniq, inv = np.unique(np.sort(edges, axis=1), axis=0, return_inverse=True)
    mids = 0.5 * (v[uniq[:, 0]] + v[uniq[:, 1]])
    mid_index = len(v) + inv.reshape(3, -1).T
    return canonical(np.vstack([v, mids]), np.hstack([t, mid_index]))


def min_jacobian_ratio(mesh: SectionMesh) -> np.ndarray:
    """(m,) smallest det J of each curved element over sample points, relative to the
    straight element's (1 for a straight element; <= 0 means the element is inverted)."""
    L = np.column_stack([1 - _JAC_SAMPLES.sum(1), _JAC_SAMPLES])  # (ns, 3) barycentric
    # derivatives of the six P2 shape functions w.r.t. (xi, eta) at each sample
    xi, eta, l0 = _JAC_SAMPLES[:, 0], _JAC_SAMPLES[:, 1], L[:, 0]
    dxi = np.column_stack([1 - 4 * l0, 4 * xi - 1, 0 * xi, 4 * (l0 - xi), 4 * eta, -4 * eta])
    deta = np.column_stack([1 - 4 * l0, 0 * xi, 4 * eta - 1, -4 * xi, 4 * xi, 4 * (l0 - eta)])
    X = mesh.nodes[mesh.elements]  # (m, 6, 2)
    J = [np.einsum("sn,mnc->msc", d, X) for d in (dxi, deta)]  # (m, ns, 2) each
    det = J[0][..., 0] * J[1][..., 1] - J[0][..., 1] * J[1][..., 0]
    return det.min(axis=1) / _corner_area2(mesh.nodes, mesh.elements)


# ------------------------------------------------------------------------- Gmsh
def _turning(pts: np.ndarray, closed: bool) -> np.ndarray:
    """Turning angle (rad, + = left) at each vertex (closed) or interior vertex (open)."""
    q = np.vstack([pts[-1:], pts, pts[:1]]) if closed else pts
    d = np.diff(q, axis=0)
    ang = np.arctan2(d[:, 1], d[:, 0])
    return (np.diff(ang) + np.pi) % (2 * np.pi) - np.pi


def _curves(pts: np.ndarray, closed: bool,
            smooth: bool = True) -> list[tuple[str, list[int]]]:
    """Split an outline into Gmsh curves: ('line', [i, j]) for each straight run of three or
    more collinear points and each single segment between corners, ('spline', [i, ..., j])
    for each curved run. Breaks are corners (turning above CORNER_ANGLE_DEG) and the ends of
    straight runs, so a flat foot underside stays exactly flat and a fillet is one smooth
    spline nearly tangent to its neighbours. Not ``smooth``: every point is a corner (one
    line per segment: the polygon). Indices run past len(pts) for a closed outline."""
    n = len(pts)
    turn = np.abs(_turning(pts, closed))
    if closed:
        vert = np.arange(n)
    else:
        vert = np.arange(1, n - 1)
    flat = np.zeros(n, bool)
    flat[vert] = turn < np.radians(STRAIGHT_ANGLE_DEG)
    corner = np.zeros(n, bool)
    corner[vert] = turn > np.radians(CORNER_ANGLE_DEG) if smooth else True
    if not closed:
        corner[[0, -1]] = True
    # segment s (from point s to s + 1) is straight when it lies in a run of >= 3 collinear
    # points: one of its ends is a flat vertex
    seg_n = n if closed else n - 1
    seg = np.arange(seg_n)
    straight = flat[seg] | flat[(seg + 1) % n]
    brk = corner.copy()
    for s in seg:  # a break wherever straight and curved segments meet
        if straight[s] != straight[(s - 1) % seg_n] and (closed or s > 0):
            brk[s] = True
    idx = list(np.nonzero(brk)[0])
    if closed:
        while len(idx) < 3:  # a closed smooth outline still needs three curves
            b = np.sort(idx) if idx else np.array([0])
            gaps = np.diff(np.append(b, b[0] + n))
            i = int(np.argmax(gaps))
            idx = sorted(set(idx) | {int((b[i] + max(gaps[i] // 2, 1)) % n)})
        ends = list(zip(idx, idx[1:] + [idx[0] + n]))
    else:
        ends = list(zip(idx[:-1], idx[1:]))
    out = []
    for a, b in ends:
        run = list(range(a, b + 1))
        if b - a == 1 or straight[a % seg_n]:
            out.append(("line", [a, b]))
        else:
            out.append(("spline", run))
    return out


def _gmsh_p2(pts: np.ndarray, h: float, *, closed: bool,
             smooth: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Second-order Gmsh mesh of an outline: a closed polygon, or an open half outline from
    the bottom axis crossing to the top one (closed along the axis by a straight line);
    ``smooth``: splines through the points between corners (_curves)."""
    import gmsh

    gmsh.initialize(["-noenv"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("section")
        geo = gmsh.model.geo
        n = len(pts)
        tags = {}

        runs = _curves(pts, closed, smooth)
        # mesh size at each curve end: h, or the length of a shorter adjacent curve, so that
        # a short curve (a small fillet) is one mesh edge and no triangle has all three
        # corners on it (such ears come out nearly flat once their edges are curved)
        size = {}
        for _, run in runs:
            q = pts[np.array(run) % n]
            length = float(np.linalg.norm(np.diff(q, axis=0), axis=1).sum())
            for i in (run[0] % n, run[-1] % n):
                size[i] = min(size.get(i, h), max(length, 0.3 * h) if length < h else h)

        def point(i):
            if i % n not in tags:
                tags[i % n] = geo.addPoint(pts[i % n, 0], pts[i % n, 1], 0.0,
                                           size.get(i % n, h))
            return tags[i % n]

        curves = []
        for kind, run in runs:
            ids = [point(i) for i in run]
            curves.append(geo.addLine(*ids) if kind == "line" else geo.addSpline(ids))
        if not closed:
            curves.append(geo.addLine(point(n - 1), point(0)))  # the mirror axis, downwards
        geo.addPlaneSurface([geo.addCurveLoop(curves)])
        geo.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMin", 0.3 * h)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        gmsh.option.setNumber("Mesh.Algorithm", 6)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.optimize("Laplace2D")
        gmsh.model.mesh.setOrder(2)  # mid-side nodes of boundary edges on the splines
        node_tags, coords, _ = gmsh.model.mesh.getNodes()
        _, elem_nodes = gmsh.model.mesh.getElementsByType(9)  # 6-node triangles
    finally:
        gmsh.finalize()
    xyz = coords.reshape(-1, 3)[:, :2]
    index = np.zeros(int(node_tags.max()) + 1, dtype=np.int64)
    index[node_tags.astype(np.int64)] = np.arange(len(node_tags))
    return canonical(xyz, index[elem_nodes.astype(np.int64)].reshape(-1, 6))


def _mirror(nodes: np.ndarray, elements: np.ndarray, tol: float):
    """The mesh of a right half joined with its mirror image about y = 0."""
    on_axis = np.abs(nodes[:, 0]) < tol
    nodes = nodes.copy()
    nodes[on_axis, 0] = 0.0
    off = np.nonzero(~on_axis)[0]
    image = np.arange(len(nodes))
    image[off] = len(nodes) + np.arange(len(off))
    all_p = np.vstack([nodes, nodes[off] * [-1.0, 1.0]])
    # mirroring reverses orientation: corners (0, 2, 1), edges 20, 12, 01
    mirrored = image[elements][:, [0, 2, 1, 5, 4, 3]]
    return canonical(all_p, np.vstack([elements, mirrored]))


def mesh_profile(profile: RailProfile | str = DEFAULT_PROFILE, h: float = DEFAULT_H, *,
                 curved: bool = True, symmetric: bool | None = None) -> SectionMesh:
    """Mesh a profile with Gmsh at element size h (m) with 6-node triangles.

    curved: mid-side nodes on the outline (default) or at the chord midpoints.
    symmetric: None (default) mirrors a half mesh when the outline is mirror-symmetric
    (``RailProfile.symmetric``) and meshes an asymmetric outline whole; True demands a
    symmetric outline (error otherwise); False meshes the whole outline in any case.
    """
    if isinstance(profile, str):
        profile = get_profile(profile)
    if not (np.isfinite(h) and 0 < h < profile.height):
        raise ValueError(f"element size h must be in (0, {profile.height:.3g}) m, got {show(h)} "
                         "(give metres, e.g. 0.01 for 10 mm)")
    dev = mirror_deviation(profile.outline)
    if symmetric and not profile.symmetric:
        raise ValueError(f"profile {profile.name!r} is not mirror-symmetric about y = 0: a "
                         f"mirrored point lies {dev * 1e3:.3g} mm off the outline; mesh it "
                         "whole (symmetric=None or False)")
    if profile.symmetric if symmetric is None else symmetric:
        nodes, elements = _gmsh_p2(half_outline(profile), h, closed=False,
                                   smooth=profile.smooth)
        nodes, elements = _mirror(nodes, elements, tol=1e-9 * profile.height)
        how = f"right half mirrored (outline symmetric to {dev * 1e6:.3g} um)"
    else:
        nodes, elements = _gmsh_p2(profile.outline, h, closed=True, smooth=profile.smooth)
        how = f"whole outline (mirror deviation {dev * 1e3:.3g} mm)"
    mesh = SectionMesh(nodes=nodes, elements=elements, h=h, profile=profile,
                       source=f"gmsh, {how}")
    bad = min_jacobian_ratio(mesh) <= 0
    if bad.any():
        raise ValueError(f"{np.count_nonzero(bad)} curved element(s) of {mesh.name} are "
                         "inverted by their mid-side nodes; use a smaller h or curved=False")
    log.info("meshed %s at h = %.4g m (%s): %d nodes, %d elements", profile.name, h, how,
             len(nodes), len(elements))
    check_area(mesh)
    return mesh if curved else mesh.straight()


def mesh_area(mesh: SectionMesh) -> float:
    """Area (m^2) of the 6-node mesh with its curved sides: Green's theorem on each element
    edge, Simpson's rule (exact: the integrand is a cubic on a quadratic edge)."""
    p, e = mesh.nodes, mesh.elements
    area = 0.0
    for i, j, m in ((0, 1, 3), (1, 2, 4), (2, 0, 5)):
        a, b, c = p[e[:, i]], p[e[:, j]], p[e[:, m]]
        ends = ((a, 4 * c - 3 * a - b, 1.0), (c, b - a, 4.0), (b, a - 4 * c + 3 * b, 1.0))
        for q, dq, w in ends:  # point, tangent and Simpson weight at t = 0, 1/2, 1
            area += w * float(np.sum(q[:, 0] * dq[:, 1] - q[:, 1] * dq[:, 0])) / 12.0
    return area


def check_area(mesh: SectionMesh) -> float:
    """Relative difference of the meshed area and the outline polygon's; a warning when it
    exceeds AREA_TOL (splines through the points rounding corners meant to be sharp)."""
    poly = polygon_properties(mesh.profile.outline).area
    diff = mesh_area(mesh) / poly - 1.0
    if abs(diff) > AREA_TOL:
        log.warning("the mesh of %s has an area %+.2f %% off its outline polygon (splines "
                    "through the outline points, RailProfile.smooth); if the outline is a "
                    "polygon with sharp corners give smooth=False (a CSV outline without "
                    "the '# smooth' line)", mesh.profile.name, 100 * diff)
    return diff


# ------------------------------------------------------------------- .npz files
def save_mesh(mesh: SectionMesh, path) -> Path:
    """Write the mesh (with its outline) to .npz atomically (railfem.atomic)."""
    path = Path(path)
    with atomic_path(path, mode=0o644) as tmp:  # shipped meshes must be world-readable
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, format_version=FORMAT_VERSION, nodes=mesh.nodes,
                                elements=mesh.elements, h=mesh.h, outline=mesh.profile.outline,
                                name=mesh.profile.name, source=mesh.profile.source,
                                mesh_source=mesh.source, origin=np.array(mesh.origin))
    return path


def load_mesh(path) -> SectionMesh:
    """Read a mesh written by :func:`save_mesh`."""
    path = Path(path)
    try:
        d = np.load(path, allow_pickle=False)
        if "format_version" not in d and "vertices" in d:
            raise ValueError("it holds a straight-sided 3-node mesh in the old format "
                             "(before curved 6-node sections)")
        if int(d["format_version"]) != FORMAT_VERSION:
            raise ValueError(f"format version {int(d['format_version'])}, this railfem reads "
                             f"{FORMAT_VERSION}")
        prof = RailProfile(name=str(d["name"]), outline=d["outline"], source=str(d["source"]))
        return SectionMesh(nodes=d["nodes"], elements=d["elements"], h=float(d["h"]),
                           profile=prof, source=str(d["mesh_source"]),
                           origin=tuple(d["origin"]))
    except (OSError, KeyError, ValueError) as exc:
        raise ValueError(f"cannot read railfem mesh file {path}: {exc}. Regenerate it with "
                         "'railfem mesh'") from exc


def shipped_path(profile_name: str = DEFAULT_PROFILE, h: float = DEFAULT_H) -> Path:
    return MESH_DIR / f"{profile_name}_h{h * 1e3:g}mm.npz"


def get_mesh(profile: RailProfile | str = DEFAULT_PROFILE, h: float = DEFAULT_H, *,
             curved: bool = True) -> SectionMesh:
    """The shipped mesh when there is one for (profile, h), else a new Gmsh mesh;
    curved=False gives its straight-sided twin."""
    name = profile if isinstance(profile, str) else profile.name
    if name.upper() == "UIC60":
        name = "60E1"
    path = shipped_path(name, h)
    mesh = None
    if path.exists():
        mesh = load_mesh(path)
        if isinstance(profile, RailProfile) and not np.array_equal(mesh.profile.outline,
                                                                   profile.outline):
            mesh = None
    if mesh is None:
        mesh = mesh_profile(profile, h)
    return mesh if curved else mesh.straight()


# ------------------------------------------------------------------ mesh files
AXES_HELP = ("two file axes, lateral then vertical, each x, y or z with an optional sign: "
             "'xy' (default), 'x,z', '-y,z'")


def parse_axes(axes: str) -> tuple[tuple[int, float], tuple[int, float]]:
    """'xy', 'x,z', '-y,z' -> ((column, sign) lateral, (column, sign) vertical)."""
    m = re.fullmatch(r"\s*([+-]?)([xyz])\s*,?\s*([+-]?)([xyz])\s*", str(axes).lower())
    if not m or m.group(2) == m.group(4):
        raise ValueError(f"mesh axes {axes!r}: give {AXES_HELP}")
    col = {"x": 0, "y": 1, "z": 2}
    return ((col[m.group(2)], -1.0 if m.group(1) == "-" else 1.0),
            (col[m.group(4)], -1.0 if m.group(3) == "-" else 1.0))


def _boundary_outline(nodes: np.ndarray, elements: np.ndarray) -> np.ndarray:
    """The outer boundary loop as a polygon through corner and mid-side nodes."""
    e = elements
    edges = np.vstack([e[:, [0, 1, 3]], e[:, [1, 2, 4]], e[:, [2, 0, 5]]])
    key = np.sort(edges[:, :2], axis=1)
    _, first, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    bnd = edges[first[counts == 1]]
    nxt = {int(a): (int(b), int(m)) for a, b, m in bnd}
    loops, seen = [], set()
    for start in nxt:
        if start in seen:
            continue
        loop, a = [], start
        while a not in seen and a in nxt:
            seen.add(a)
            b, m = nxt[a]
            loop += [a, m]
            a = b
        loops.append(nodes[loop])
    area = [abs(0.5 * np.sum(q[:, 0] * np.roll(q[:, 1], -1) - np.roll(q[:, 0], -1) * q[:, 1]))
            for q in loops]
    return loops[int(np.argmax(area))]


def read_mesh(path, *, units: str, axes: str = "xy", name: str | None = None) -> SectionMesh:
    """A section mesh from any 2-D mesh file meshio reads (Gmsh .msh 2.2 / 4.x, ...).

    units: 'm' or 'mm', the length unit of the file's coordinates. axes: which file axes
    are lateral and vertical (:data:`AXES_HELP`). The triangles (3-node: straight sides;
    6-node: curved, mid-side nodes as in the file) are kept; lines and points are ignored.
    The mesh is placed in railfem's frame: y = 0 at the middle of its lateral extent (the
    mirror axis, if it is symmetric), z = 0 at its lowest point; ``origin`` records the
    shift, so file coordinates = nodes + origin (in m, lateral/vertical).
    """
    import meshio

    path = Path(path)
    scale = {"m": 1.0, "mm": 1e-3}.get(units)
    if scale is None:
        raise ValueError(f"mesh units must be 'm' or 'mm', got {units!r}")
    (cy, sy), (cz, sz) = parse_axes(axes)
    if not path.is_file():
        raise FileNotFoundError(f"mesh file not found: {path}")
    try:
        m = meshio.read(path)
    except Exception as exc:  # meshio raises many types for unreadable files
        raise ValueError(f"cannot read mesh file {path} with meshio: {exc}") from exc
    blocks = {c.type: c.data for c in m.cells if c.type in ("triangle", "triangle6")}
    if len(blocks) != 1:
        raise ValueError(f"mesh file {path}: expected one kind of triangles (3-node or "
                         f"6-node), found {sorted(blocks) or 'none'} among "
                         f"{sorted({c.type for c in m.cells})}")
    kind = next(iter(blocks))
    cells = np.vstack([c.data for c in m.cells if c.type == kind]).astype(np.int64)
    pts = np.asarray(m.points, float)
    if pts.shape[1] < 3:
        pts = np.hstack([pts, np.zeros((len(pts), 3 - pts.shape[1]))])
    used = np.unique(cells)
    normal = ({0, 1, 2} - {cy, cz}).pop()
    span = np.ptp(pts[used][:, [cy, cz]], axis=0).max()
    if np.ptp(pts[used, normal]) > 1e-9 * span:
        raise ValueError(f"mesh file {path}: the section is not flat in the file's "
                         f"{'xyz'[cy]}-{'xyz'[cz]} plane ({'xyz'[normal]} varies by "
                         f"{np.ptp(pts[used, normal]):.3g}); check --mesh-axes")
    yz = np.column_stack([sy * pts[:, cy], sz * pts[:, cz]]) * scale
    height = np.ptp(yz[used, 1])
    if height > 1.0 or height < 1e-3:
        hint = "mm" if height > 1.0 else "m"
        raise ValueError(f"mesh file {path}: the section is {height:.3g} m high in units "
                         f"{units!r}; that is no rail: are the coordinates in {hint}?")
    nodes, elements = (canonical(yz, cells) if kind == "triangle6"
                       else from_linear(yz, cells))
    origin = np.array([0.5 * (nodes[:, 0].min() + nodes[:, 0].max()), nodes[:, 1].min()])
    nodes = nodes - origin
    prof = RailProfile(name=name or path.stem, outline=_boundary_outline(nodes, elements),
                       source=f"boundary of {path}")
    edge = np.linalg.norm(nodes[elements[:, [0, 1, 2]]] - nodes[elements[:, [1, 2, 0]]], axis=2)
    mesh = SectionMesh(nodes=nodes, elements=elements, h=float(edge.max()), profile=prof,
                       source=f"{path} ({kind}, {units}, axes {axes})", origin=tuple(origin))
    log.info("read %s: %d nodes, %d %s elements, %s", path, len(nodes), len(elements), kind,
             "curved" if mesh.curved else "straight-sided")
    return mesh
