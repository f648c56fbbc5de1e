"""Assembly of the waveguide matrices K0, K1, K2, M on a P2 section mesh, node sets, and the
mirror-symmetry reduction into symmetric (vertical/longitudinal) and antisymmetric
(lateral/torsional) wave families."""
from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from .materials import Material
from .meshing import SectionMesh

log = logging.getLogger(__name__)

# Sign of each displacement component (u_x, u_y, u_z) under the mirror y -> -y for the
# symmetric family (vertical bending, longitudinal, foot flapping); the antisymmetric family
# (lateral bending, torsion, web bending) has the opposite signs.
MIRROR_SIGNS = {"symmetric": np.array([1, -1, 1]), "antisymmetric": np.array([-1, 1, -1])}
FAMILIES = tuple(MIRROR_SIGNS)


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

    @property
    def n_dofs(self) -> int:
        return self.K0.shape[0]

    def dof(self, node: int | str, direction: str | int = "z") -> int:
        """Global DOF of a node (index or single-node set name) in direction x/y/z."""
        from .conventions import DIRECTIONS

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
            raise KeyError(f"unknown node set {name!r}; this mesh has {sorted(self.node_sets)}")
        return self.node_sets[name]


def assemble(mesh: SectionMesh, material: Material | None = None) -> Waveguide:
    """Assemble K0, K1, K2, M with scikit-fem P2 (6-node triangle) vector elements."""
    from skfem import Basis, ElementTriP2, ElementVector, MeshTri

    from . import forms

    material = material or Material.steel()
    m = MeshTri(mesh.vertices.T.copy(), mesh.triangles.T.copy())
    if m.t.shape[1] != len(mesh.triangles):
        raise ValueError("scikit-fem dropped triangles of the section mesh")
    basis = Basis(m, ElementVector(ElementTriP2(), 3))
    lam, mu = (x.real for x in Material(E=material.E, nu=material.nu, rho=material.rho).lame())
    K0 = forms.k0.assemble(basis, lam=lam, mu=mu).tocsr()
    K1 = forms.k1.assemble(basis, lam=lam, mu=mu).tocsr()
    K2 = forms.k2.assemble(basis, lam=lam, mu=mu).tocsr()
    M = forms.mass.assemble(basis, rho=material.rho).tocsr()
    nv = m.p.shape[1]
    nodes = np.vstack([m.p.T, m.p[:, m.facets].mean(axis=1).T])
    node_dofs = np.hstack([basis.nodal_dofs, basis.facet_dofs]).T.astype(np.int64)
    elements = np.vstack([m.t, nv + m.t2f[[0, 1, 2]]]).T
    # skfem's t2f rows are edges (0,1), (1,2), (0,2): the third is edge (2,0) as documented.
    boundary = _boundary_nodes(m, nv)
    sets = default_node_sets(nodes, boundary, mesh)
    fams = {name: _family(name, nodes, node_dofs) for name in FAMILIES}
    log.info("assembled %s: %d nodes, %d DOFs (families %s)", mesh.name, len(nodes),
             K0.shape[0], {k: f.T.shape[1] for k, f in fams.items()})
    return Waveguide(K0=K0, K1=K1, K2=K2, M=M, material=material, mesh=mesh, nodes=nodes,
                     elements=elements, node_dofs=node_dofs, node_sets=sets, families=fams)


def _boundary_nodes(m, nv: int) -> np.ndarray:
    bf = m.boundary_facets()
    return np.unique(np.concatenate([m.facets[:, bf].ravel(), nv + bf]))


def default_node_sets(nodes: np.ndarray, boundary: np.ndarray, mesh: SectionMesh) -> dict:
    """head_top (one node), foot_underside (boundary nodes on the lowest line, sorted by y),
    foot_sensor (one node on the top of the foot, off the centreline), boundary."""
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
        y_s = FOOT_SENSOR_FRACTION * nodes[under, 0].max()
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


def _family(name: str, nodes: np.ndarray, node_dofs: np.ndarray) -> Family:
    signs = MIRROR_SIGNS[name]
    tol = 1e-9 * np.ptp(nodes[:, 1])
    tree = cKDTree(nodes)
    dist, image = tree.query(nodes * [-1.0, 1.0])
    if dist.max() > 1e3 * tol:
        raise ValueError("section mesh is not mirror-symmetric about y = 0")
    rows, cols, vals, comp = [], [], [], []
    col = 0
    for i in np.nonzero(nodes[:, 0] >= -tol)[0]:
        on_axis = image[i] == i
        for c in range(3):
            if on_axis and signs[c] < 0:
                continue  # a component odd under the mirror vanishes on the axis
            rows.append(node_dofs[i, c]); cols.append(col); vals.append(1.0)
            if not on_axis:
                rows.append(node_dofs[image[i], c]); cols.append(col); vals.append(float(signs[c]))
            comp.append(c)
            col += 1
    T = sp.csr_matrix((vals, (rows, cols)), shape=(node_dofs.size, col))
    return Family(name=name, T=T, component=np.array(comp))


def reduced(guide: Waveguide, family: str) -> tuple:
    """(K0, K1, K2, M) restricted to one symmetry family: T^T X T (real, sparse)."""
    T = guide.families[family].T
    return tuple((T.T @ X @ T).tocsr() for X in (guide.K0, guide.K1, guide.K2, guide.M))
