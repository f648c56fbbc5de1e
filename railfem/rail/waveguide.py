"""Assembly of the waveguide matrices K0, K1, K2, M on a P2 section mesh (curved or
straight-sided), node sets, and the wave families: a mirror-symmetric mesh splits into
symmetric (vertical/longitudinal) and antisymmetric (lateral/torsional) families, any other
mesh is solved as one family 'full' (T = identity). Code downstream iterates over
``guide.families``."""
from __future__ import annotations

import logging
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from ..materials import Material
from .meshing import SectionMesh, skfem_mesh
from ..validators import warn_once

log = logging.getLogger(__name__)

#: Relative tolerance (of the section size) for a mesh to count as mirror-symmetric: node
#: coordinates written with 7 significant digits still pass, a mesh made asymmetric on
#: purpose (a worn head, a mesh of the whole outline) does not.
MESH_SYMMETRY_TOL = 1e-6

# Sign of each displacement component (u_x, u_y, u_z) under the mirror y -> -y for the
# symmetric family (vertical bending, longitudinal, foot flapping); the antisymmetric family
# (lateral bending, torsion, web bending) has the opposite signs.
MIRROR_SIGNS = {"symmetric": np.array([1, -1, 1]), "antisymmetric": np.array([-1, 1, -1])}
FAMILIES = tuple(MIRROR_SIGNS)  # of a symmetric mesh; iterate over guide.families


#: The node sets found on every mesh where the geometry allows (default_node_sets).
KNOWN_NODE_SETS = {
    "head_top": "the boundary node on top of the head nearest the centreline",
    "foot_underside": "the boundary nodes on the flat underside of the foot",
    "foot_sensor": "a node on the upper surface of the foot, off the centreline",
    "boundary": "all boundary nodes",
}


@dataclass(frozen=True, kw_only=True)
class Family:
    """A symmetry family: full DOFs u = T u_r. component: (u_x, u_y, u_z) index of each
    reduced DOF (0 = axial)."""

    name: str
    T: sp.csr_matrix
    component: np.ndarray


@dataclass(frozen=True, kw_only=True)
class Waveguide:
    """Real stiffness matrices K0, K1, K2 (N/m^... per unit length, stiffness before the loss
    factor), mass M, on N = 3 n_nodes DOFs ordered by ``node_dofs``.

    nodes: (n, 2) P2 node coordinates (y, z) in m. elements: (m, 6) P2 connectivity (three
    vertices, then midside nodes of edges 01, 12, 20). node_dofs: (n, 3) DOF index of
    (u_x, u_y, u_z) at each node. node_sets: named node index arrays. loss_factor: eta.
    """

    K0: sp.csr_matrix
    K1: sp.csr_matrix
    K2: sp.csr_matrix
    M: sp.csr_matrix
    material: Material
    mesh: SectionMesh
    nodes: np.ndarray
    elements: np.ndarray
    node_dofs: np.ndarray
    node_sets: dict = field(default_factory=dict)
    families: dict = field(default_factory=dict)

    @property
    def loss_factor(self) -> float:
        return self.material.loss_factor

    def with_loss_factor(self, eta: float) -> "Waveguide":
        """The same section and matrices with the rail's loss factor eta (no re-assembly:
        the matrices are stored before the loss factor)."""
        return replace(self, material=replace(self.material, loss_factor=float(eta)))

    @property
    def n_dofs(self) -> int:
        return self.K0.shape[0]

    def dof(self, node: int | str, direction: str | int = "z") -> int:
        """Global DOF of a node (index or single-node set name) in direction x/y/z."""
        from ..conventions import DIRECTIONS

        c = DIRECTIONS[direction] if isinstance(direction, str) else int(direction)
        return int(self.node_dofs[self.node(node), c])

    def node(self, node: int | str) -> int:
        if isinstance(node, str):
            ids = self.node_set(node)
            if len(ids) != 1:
                raise ValueError(f"node set {node!r} holds {len(ids)} nodes, expected one")
            return int(ids[0])
        if not 0 <= int(node) < len(self.nodes):
            raise ValueError(f"node index {node} outside 0..{len(self.nodes) - 1}")
        return int(node)

    def node_set(self, name: str) -> np.ndarray:
        if name not in self.node_sets:
            if name in KNOWN_NODE_SETS:
                raise KeyError(
                    f"node set {name!r} ({KNOWN_NODE_SETS[name]}) was not found on this mesh "
                    f"(it has {sorted(self.node_sets)}); give it to waveguide.assemble as "
                    f"node_sets={{{name!r}: (y, z)}} in m or as node indices")
            raise KeyError(f"unknown node set {name!r}; this mesh has {sorted(self.node_sets)}")
        return self.node_sets[name]


def assemble(mesh: SectionMesh, material: Material | None = None, *,
             node_sets: dict | None = None, symmetry_tol: float = MESH_SYMMETRY_TOL) -> Waveguide:
    """Assemble K0, K1, K2, M with scikit-fem P2 (6-node triangle) vector elements.

    A curved mesh is assembled on scikit-fem's quadratic-geometry triangles (``MeshTri2``,
    isoparametric), a straight-sided one on ``MeshTri1``. The guide's nodes and elements are
    the mesh's own. node_sets: optional user node sets that replace the geometric defaults,
    name -> node indices or a (y, z) point in m (nearest boundary node). symmetry_tol:
    relative tolerance (of the section size) of the mirror-symmetry detection: a symmetric
    mesh splits into the 'symmetric' and 'antisymmetric' families, any other mesh is one
    family 'full'.
    """
    from skfem import Basis, ElementTriP2, ElementVector

    from . import forms

    material = material or Material.steel()
    nv = mesh.n_vertices
    m = skfem_mesh(mesh)
    basis = Basis(m, ElementVector(ElementTriP2(), 3))
    lam, mu = (x.real for x in Material(E=material.E, nu=material.nu, rho=material.rho).lame())
    K0 = forms.k0.assemble(basis, lam=lam, mu=mu).tocsr()
    K1 = forms.k1.assemble(basis, lam=lam, mu=mu).tocsr()
    K2 = forms.k2.assemble(basis, lam=lam, mu=mu).tocsr()
    M = forms.mass.assemble(basis, rho=material.rho).tocsr()
    # DOFs of the mesh's nodes: corners are skfem's vertices, mid-side nodes its facets
    facet_of_mid = _facets_of_midside_nodes(m, mesh)
    node_dofs = np.zeros((len(mesh.nodes), 3), dtype=np.int64)
    node_dofs[:nv] = basis.nodal_dofs.T
    node_dofs[nv:] = basis.facet_dofs[:, facet_of_mid[nv:]].T
    if not np.allclose(basis.doflocs[:, node_dofs[:, 0]].T, mesh.nodes,
                       atol=1e-9 * mesh.profile.size):
        raise ValueError("the section mesh's nodes do not match scikit-fem's DOF locations")
    nodes, elements = mesh.nodes, mesh.elements
    bf = m.boundary_facets()
    boundary = np.unique(np.concatenate([m.facets[:, bf].ravel(),
                                         np.nonzero(np.isin(facet_of_mid, bf))[0]]))
    sets = default_node_sets(nodes, boundary, mesh)
    sets.update(user_node_sets(node_sets or {}, nodes, boundary))
    image = mirror_image(nodes, elements, symmetry_tol * mesh.profile.size)
    if image is None:
        fams = {"full": Family(name="full", T=sp.identity(node_dofs.size, format="csr"),
                               component=_dof_components(node_dofs))}
    else:
        fams = {name: _family(name, nodes, node_dofs, image) for name in MIRROR_SIGNS}
    log.info("assembled %s (%s): %d nodes, %d DOFs (families %s)", mesh.name,
             "curved" if mesh.curved else "straight-sided", len(nodes), K0.shape[0],
             {k: f.T.shape[1] for k, f in fams.items()})
    return Waveguide(K0=K0, K1=K1, K2=K2, M=M, material=material, mesh=mesh, nodes=nodes,
                     elements=elements, node_dofs=node_dofs, node_sets=sets, families=fams)


def _facets_of_midside_nodes(m, mesh: SectionMesh) -> np.ndarray:
    """(n_nodes,) skfem facet index of each mid-side node (-1 for corners)."""
    nv = mesh.n_vertices
    key = np.sort(m.facets, axis=0)
    fkey = key[0].astype(np.int64) * nv + key[1]
    order = np.argsort(fkey)
    e = mesh.elements
    ends = np.vstack([e[:, [0, 1]], e[:, [1, 2]], e[:, [2, 0]]])
    mids = np.concatenate([e[:, 3], e[:, 4], e[:, 5]])
    ekey = ends.min(1) * nv + ends.max(1)
    pos = order[np.searchsorted(fkey, ekey, sorter=order)]
    if not np.array_equal(fkey[pos], ekey):
        raise ValueError("an element edge of the section mesh is not a scikit-fem facet")
    out = -np.ones(len(mesh.nodes), dtype=np.int64)
    out[mids] = pos
    if np.any(out[nv:] < 0):
        raise ValueError("a mid-side node of the section mesh belongs to no edge")
    return out


def _dof_components(node_dofs: np.ndarray) -> np.ndarray:
    comp = np.empty(node_dofs.size, dtype=np.int64)
    for c in range(3):
        comp[node_dofs[:, c]] = c
    return comp


def mirror_image(nodes: np.ndarray, elements: np.ndarray, tol: float):
    """Node index of each node's mirror image about y = 0, or None when the mesh is not
    mirror-symmetric within tol (m): every node must have an image and every element a
    mirrored element (so that the matrices commute with the mirror)."""
    dist, image = cKDTree(nodes).query(nodes * [-1.0, 1.0])
    if dist.max() > tol or np.any(image[image] != np.arange(len(nodes))):
        return None
    corners = np.sort(elements[:, :3], axis=1)
    mirrored = np.sort(image[elements[:, :3]], axis=1)
    if set(map(tuple, corners.tolist())) != set(map(tuple, mirrored.tolist())):
        return None
    return image


def user_node_sets(given: dict, nodes: np.ndarray, boundary: np.ndarray) -> dict:
    """Node sets a user gave: name -> node indices, or a (y, z) point in m (the nearest
    boundary node)."""
    out = {}
    for name, val in given.items():
        arr = np.asarray(val)
        if arr.dtype.kind == "f" and arr.shape == (2,):
            d = np.hypot(nodes[boundary, 0] - arr[0], nodes[boundary, 1] - arr[1])
            out[name] = np.array([boundary[np.argmin(d)]])
            continue
        idx = np.atleast_1d(arr).astype(np.int64)
        if arr.dtype.kind not in "iu" or idx.min() < 0 or idx.max() >= len(nodes):
            raise ValueError(f"node set {name!r}: give node indices in 0..{len(nodes) - 1} "
                             f"or a (y, z) point in m, got {val!r}")
        out[name] = idx
    return out


def default_node_sets(nodes: np.ndarray, boundary: np.ndarray, mesh: SectionMesh) -> dict:
    """head_top (one node), foot_underside (boundary nodes on the lowest line, sorted by y),
    foot_sensor (one node on the top of the foot, off the centreline), boundary.

    On any mesh: head_top is the boundary node nearest to (0, z_max); foot_underside the
    boundary nodes within 0.1 % of the height of z_min; foot_sensor the node of the foot's
    upper surface at FOOT_SENSOR_FRACTION of the underside's half-width right of its middle.
    A set that cannot be found is left out (asking for it names it, see Waveguide.node_set).
    """
    from .profiles import FOOT_SENSOR_FRACTION

    prof = mesh.profile
    zmin, zmax = nodes[:, 1].min(), nodes[:, 1].max()
    tol = 1e-3 * prof.height
    bnodes = nodes[boundary]
    top = boundary[np.argmin(np.hypot(bnodes[:, 0], bnodes[:, 1] - zmax))]
    under = boundary[bnodes[:, 1] <= zmin + tol]
    under = under[np.argsort(nodes[under, 0])]
    sets = {"head_top": np.array([top]), "foot_underside": under, "boundary": boundary}
    if len(under) >= 2:
        y0, y1 = nodes[under, 0].min(), nodes[under, 0].max()
        y_s = 0.5 * (y0 + y1) + FOOT_SENSOR_FRACTION * 0.5 * (y1 - y0)
        # the foot's upper surface above y_s: lowest boundary node clearly above the underside
        near = boundary[(np.abs(nodes[boundary, 0] - y_s) < 0.6 * mesh.h)
                        & (nodes[boundary, 1] > zmin + tol)]
        if len(near):
            dist = np.hypot(nodes[near, 0] - y_s, nodes[near, 1] - zmin)
            sets["foot_sensor"] = np.array([near[np.argmin(dist)]])
    return sets


def nearest_boundary_node(guide: Waveguide, y: float, z: float) -> int:
    b = guide.node_sets["boundary"]
    return int(b[np.argmin(np.hypot(guide.nodes[b, 0] - y, guide.nodes[b, 1] - z))])


def _family(name: str, nodes: np.ndarray, node_dofs: np.ndarray, image: np.ndarray) -> Family:
    signs = MIRROR_SIGNS[name]
    rows, cols, vals, comp = [], [], [], []
    col = 0
    # one representative per mirror pair (the node on the +y side) and every axis node
    keep = (image == np.arange(len(nodes))) | (nodes[:, 0] > nodes[image, 0])
    for i in np.nonzero(keep)[0]:
        on_axis = image[i] == i
        for c in range(3):
            if on_axis and signs[c] < 0:
                continue  # a component odd under the mirror vanishes on the axis
            rows.append(node_dofs[i, c])
            cols.append(col)
            vals.append(1.0)
            if not on_axis:
                rows.append(node_dofs[image[i], c])
                cols.append(col)
                vals.append(float(signs[c]))
            comp.append(c)
            col += 1
    T = sp.csr_matrix((vals, (rows, cols)), shape=(node_dofs.size, col))
    return Family(name=name, T=T, component=np.array(comp))


def reduced(guide: Waveguide, family: str) -> tuple:
    """(K0, K1, K2, M) restricted to one symmetry family: T^T X T (real, sparse)."""
    T = guide.families[family].T
    return tuple((T.T @ X @ T).tocsr() for X in (guide.K0, guide.K1, guide.K2, guide.M))


#: Fewest elements per shortest wavelength before results are flagged as under-resolved.
MIN_ELEMENTS_PER_WAVELENGTH = 6.0


def elements_per_wavelength(guide: Waveguide, frequency: float) -> float:
    """Longest element edge of the section mesh divided into the shortest wavelength at
    ``frequency`` (Hz). The shortest waves in a free rail at high frequency are surface
    (Rayleigh) waves slightly slower than shear waves: c_R ~ 0.92 sqrt(G / rho)."""
    e = guide.elements
    edge = np.linalg.norm(guide.nodes[e[:, [0, 1, 2]]] - guide.nodes[e[:, [1, 2, 0]]], axis=2)
    c_rayleigh = 0.92 * np.sqrt(guide.material.G / guide.material.rho)
    return float(c_rayleigh / frequency / edge.max())


def check_resolution(guide: Waveguide, frequency: float) -> float:
    """Log a warning when the mesh has fewer than MIN_ELEMENTS_PER_WAVELENGTH elements per
    shortest wavelength at ``frequency`` (Hz); returns the number."""
    n = elements_per_wavelength(guide, float(frequency))
    if n < MIN_ELEMENTS_PER_WAVELENGTH:
        limit = n * float(frequency) / MIN_ELEMENTS_PER_WAVELENGTH
        warn_once(log, "the section mesh %s has %.1f elements per shortest (Rayleigh) "
                  "wavelength at %.4g Hz, fewer than %g: results above about %.4g Hz are not "
                  "reliable; use a finer mesh", guide.mesh.name, n, frequency,
                  MIN_ELEMENTS_PER_WAVELENGTH, limit)
    return n
