"""Axisymmetric finite element wheel with circumferential harmonics (METHOD.md section 4).

The wheel cross-section is meshed in the (r, z) plane (r radial, z axial along the axle)
with P2 triangles. Harmonic n of the symmetric family is

    u_r = U_r(r, z) cos(n theta),  u_z = U_z(r, z) cos(n theta),  u_theta = U_t(r, z) sin(n theta)

and the engineering strains in (rr, zz, tt, rz, rt, tz) order are

    e_rr = U_r,r    e_zz = U_z,z    e_tt = (U_r + n U_t) / r    g_rz = U_r,z + U_z,r
    g_rt = U_t,r - (U_t + n U_r) / r                              g_tz = U_t,z - n U_z / r

(the cos terms carry cos(n theta), the last two sin(n theta)). Integrating over theta
gives 2D forms times c_n = integral cos^2 = pi (n >= 1) or 2 pi (n = 0, where the sin
terms and U_t drop out); the strain is affine in n, so K(n) = K00 + n (K0n + Kn0) + n^2 Knn
is assembled once. The antisymmetric family (cos and sin swapped) has the same modes for
n >= 1 and is not needed for a force at theta = 0.

A radial (or axial) point force F at (r_c, z_c, theta = 0) does virtual work F dU_r(r_c, z_c)
in every harmonic, so with mass-normalised modes phi of K(n), M(n) the receptance at the
force is the modal sum

    alpha(omega) = sum_n [ sum_m phi_nm(c)^2 / (omega_nm^2 (1 + i eta_nm) - omega^2) + R_n ]

R_n the residual (static) compliance of the modes above the cut-off, evaluated at a
negative shift. The axle is a rigid lumped mass: the bore moves as a rigid ring carrying
``axle_mass`` (n = 0: axial translation; n = 1: translation in the plane of theta = 0, the
rocking rotation held by the stiff axle; n >= 2: the bore does not deform). At low
frequency the wheel is then a rigid mass m_wheel + axle_mass.
"""
from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..materials import Material

log = logging.getLogger(__name__)

__all__ = ["WheelSection", "WheelMesh", "AxisymmetricWheel", "HarmonicModes", "mesh_section",
           "rectangle_mesh", "assemble", "harmonic_modes", "default_damping",
           "DEFAULT_WHEEL_H"]

DEFAULT_WHEEL_H = 0.012  # m, element size of the default wheel mesh (P2)


@dataclass(frozen=True, kw_only=True)
class WheelSection:
    """Parametric wheel cross-section (all lengths in m; z = 0 at the back face of the rim,
    the flange side; z grows towards the field side).

    radius: tread (rolling) radius at the running circle. rim_inner_radius: inner radius of
    the rim. rim_width: axial rim width. flange_height, flange_thickness: flange on the back
    side. web_thickness, web_centre: straight web between hub and rim, axial centre.
    hub_outer_radius, bore_radius: hub radii. hub_z: (z0, z1) axial extent of the hub.
    contact_z: axial position of the running circle (contact point).
    """

    radius: float = 0.46
    rim_inner_radius: float = 0.40
    rim_width: float = 0.135
    flange_height: float = 0.028
    flange_thickness: float = 0.033
    web_thickness: float = 0.025
    web_centre: float = 0.070
    hub_outer_radius: float = 0.13
    bore_radius: float = 0.095
    hub_z: tuple[float, float] = (-0.02, 0.155)
    contact_z: float = 0.070

    def __post_init__(self):
        for name in ("radius", "rim_inner_radius", "rim_width", "flange_thickness",
                     "web_thickness", "hub_outer_radius", "bore_radius"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise ValueError(f"WheelSection.{name} = {v!r} m: give a positive length")
        if self.flange_height < 0:
            raise ValueError(f"WheelSection.flange_height = {self.flange_height!r} m: >= 0")
        if not (self.bore_radius < self.hub_outer_radius < self.rim_inner_radius
                < self.radius):
            raise ValueError("WheelSection radii must grow: bore_radius < hub_outer_radius < "
                             "rim_inner_radius < radius")
        w0, w1 = self.web_centre - self.web_thickness / 2, self.web_centre + self.web_thickness / 2
        h0, h1 = self.hub_z
        if not (h0 < w0 and w1 < h1 and 0 < w0 and w1 < self.rim_width):
            raise ValueError("the web must lie inside the rim width and the hub width: check "
                             "web_centre, web_thickness, rim_width and hub_z")
        if not (self.flange_thickness < self.contact_z < self.rim_width):
            raise ValueError(f"contact_z = {self.contact_z!r} m must lie on the tread, between "
                             f"the flange ({self.flange_thickness} m) and the rim width")

    def outline(self) -> np.ndarray:
        """Closed polygon (k, 2) of (r, z) vertices, counter-clockwise, one vertex at the
        contact point."""
        R, ri, W = self.radius, self.rim_inner_radius, self.rim_width
        w0 = self.web_centre - self.web_thickness / 2
        w1 = self.web_centre + self.web_thickness / 2
        h0, h1 = self.hub_z
        rb, rh = self.bore_radius, self.hub_outer_radius
        pts = [(rb, h0), (rh, h0), (rh, w0), (ri, w0), (ri, 0.0)]
        if self.flange_height > 0:
            pts += [(R + self.flange_height, 0.0), (R + self.flange_height,
                                                    self.flange_thickness)]
        else:
            pts += [(R, 0.0)]
        pts += [(R, self.flange_thickness), (R, self.contact_z), (R, W), (ri, W), (ri, w1),
                (rh, w1), (rh, h1), (rb, h1)]
        out = np.array(pts, dtype=float)
        # counter-clockwise in the (r, z) plane
        area = 0.5 * np.sum(out[:, 0] * np.roll(out[:, 1], -1) - np.roll(out[:, 0], -1) * out[:, 1])
        return out if area > 0 else out[::-1]


@dataclass(frozen=True, kw_only=True)
class WheelMesh:
    """Linear triangulation of a wheel section: vertices (nv, 2) as (r, z) in m, triangles
    (nt, 3); contact: (r, z) of the contact point; bore_radius: nodes with r = bore_radius
    (within 1e-9 m) attach to the axle (None: a free body); h: element size (m)."""

    vertices: np.ndarray
    triangles: np.ndarray
    contact: tuple[float, float]
    bore_radius: float | None
    h: float


def mesh_section(section: WheelSection | None = None, h: float = DEFAULT_WHEEL_H) -> WheelMesh:
    """Gmsh triangulation of the wheel section outline with element size h (m)."""
    import gmsh

    section = section or WheelSection()
    if not (np.isfinite(h) and 0 < h < section.radius):
        raise ValueError(f"h = {h!r} m: give an element size between 0 and the wheel radius")
    poly = section.outline()
    gmsh.initialize(["-noenv"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("wheel")
        geo = gmsh.model.geo
        tags = [geo.addPoint(r, z, 0.0, h) for r, z in poly]
        lines = [geo.addLine(tags[i], tags[(i + 1) % len(tags)]) for i in range(len(tags))]
        geo.addPlaneSurface([geo.addCurveLoop(lines)])
        geo.synchronize()
        gmsh.model.mesh.generate(2)
        node_tags, coords, _ = gmsh.model.mesh.getNodes()
        types, _, elem_nodes = gmsh.model.mesh.getElements(2)
    finally:
        gmsh.finalize()
    xyz = coords.reshape(-1, 3)[:, :2]
    index = {int(t): i for i, t in enumerate(node_tags)}
    tri = np.array([index[int(t)] for t in elem_nodes[list(types).index(2)]]).reshape(-1, 3)
    used = np.unique(tri)
    remap = -np.ones(len(xyz), dtype=np.int64)
    remap[used] = np.arange(len(used))
    v, t = xyz[used], remap[tri]
    # counter-clockwise triangles
    d = (v[t[:, 1], 0] - v[t[:, 0], 0]) * (v[t[:, 2], 1] - v[t[:, 0], 1]) \
        - (v[t[:, 2], 0] - v[t[:, 0], 0]) * (v[t[:, 1], 1] - v[t[:, 0], 1])
    t[d < 0] = t[d < 0][:, [0, 2, 1]]
    log.info("wheel section mesh: %d vertices, %d triangles (h = %.1f mm)", len(v), len(t),
             h * 1e3)
    return WheelMesh(vertices=v, triangles=t, contact=(section.radius, section.contact_z),
                     bore_radius=section.bore_radius, h=h)


def rectangle_mesh(r0: float, r1: float, z0: float, z1: float, nr: int, nz: int, *,
                   contact: tuple[float, float] | None = None,
                   bore_radius: float | None = None) -> WheelMesh:
    """Structured triangulation of the rectangle [r0, r1] x [z0, z1] (rings, discs, tests).
    contact defaults to (r1, (z0 + z1)/2); bore_radius=None is a free body."""
    from skfem import MeshTri

    m = MeshTri.init_tensor(np.linspace(r0, r1, nr + 1), np.linspace(z0, z1, nz + 1))
    return WheelMesh(vertices=m.p.T.copy(), triangles=m.t.T.copy(),
                     contact=contact or (r1, 0.5 * (z0 + z1)), bore_radius=bore_radius,
                     h=max((r1 - r0) / nr, (z1 - z0) / nz))


# ---------------------------------------------------------------------------- forms
def _strain0(u, r):
    """The n-independent part of the strain (rr, zz, tt, rz, rt, tz)."""
    g = u.grad
    return (g[0, 0], g[1, 1], u[0] / r, g[0, 1] + g[1, 0], g[2, 0] - u[2] / r, g[2, 1])


def _strain_n(u, r):
    """The coefficient of n in the strain."""
    return (0.0 * u[0], 0.0 * u[0], u[2] / r, 0.0 * u[0], -u[0] / r, -u[1] / r)


def _energy(e, f, lam, mu):
    normal = e[0] * f[0] + e[1] * f[1] + e[2] * f[2]
    shear = e[3] * f[3] + e[4] * f[4] + e[5] * f[5]
    return lam * (e[0] + e[1] + e[2]) * (f[0] + f[1] + f[2]) + 2 * mu * normal + mu * shear


def _forms():
    from skfem import BilinearForm

    @BilinearForm
    def k00(u, v, w):
        r = w.x[0]
        return _energy(_strain0(v, r), _strain0(u, r), w.lam, w.mu) * r

    @BilinearForm
    def k0n(u, v, w):  # e0(v)^T D en(u): K(n) = K00 + n (K0n + K0n^T) + n^2 Knn
        r = w.x[0]
        return _energy(_strain0(v, r), _strain_n(u, r), w.lam, w.mu) * r

    @BilinearForm
    def knn(u, v, w):
        r = w.x[0]
        return _energy(_strain_n(v, r), _strain_n(u, r), w.lam, w.mu) * r

    @BilinearForm
    def mass(u, v, w):
        return w.rho * (u[0] * v[0] + u[1] * v[1] + u[2] * v[2]) * w.x[0]

    return k00, k0n, knn, mass


@dataclass(frozen=True, kw_only=True, eq=False)
class AxisymmetricWheel:
    """Assembled harmonic matrices (before the c_n factor and the constraints).

    K00, K0n, Knn, M: (3 N, 3 N) sparse on the P2 nodes; node_dofs: (N, 3) DOF of
    (U_r, U_z, U_t) per node; nodes: (N, 2) (r, z); elements: (m, 6) P2 connectivity;
    contact_node: node at the contact; bore_nodes: nodes on the bore (empty: free body);
    axle_mass: rigid lumped mass on the bore (kg); material; mass: wheel mass (kg).
    """

    K00: sp.csr_matrix
    K0n: sp.csr_matrix
    Knn: sp.csr_matrix
    M: sp.csr_matrix
    node_dofs: np.ndarray
    nodes: np.ndarray
    elements: np.ndarray
    contact_node: int
    bore_nodes: np.ndarray
    axle_mass: float
    material: Material
    mass: float

    def stiffness(self, n: int) -> sp.csr_matrix:
        """K(n) including c_n (pi, or 2 pi for n = 0)."""
        c = 2 * math.pi if n == 0 else math.pi
        return (c * (self.K00 + n * (self.K0n + self.K0n.T) + n * n * self.Knn)).tocsr()

    def mass_matrix(self, n: int) -> sp.csr_matrix:
        c = 2 * math.pi if n == 0 else math.pi
        return (c * self.M).tocsr()


def assemble(mesh: WheelMesh, material: Material | None = None, *,
             axle_mass: float = 0.0) -> AxisymmetricWheel:
    """Assemble the harmonic forms on P2 triangles (scikit-fem)."""
    from skfem import Basis, ElementTriP2, ElementVector, MeshTri

    material = material or Material.steel()
    if not (axle_mass >= 0):  # inf: the bore is clamped
        raise ValueError(f"axle_mass = {axle_mass!r} kg: give a mass >= 0 (inf clamps the "
                         "bore)")
    if np.min(mesh.vertices[:, 0]) <= 0:
        raise ValueError("the wheel section must lie at r > 0 (a bore or hole at the axis)")
    m = MeshTri(mesh.vertices.T.copy(), mesh.triangles.T.copy())
    basis = Basis(m, ElementVector(ElementTriP2(), 3))
    lam, mu = (x.real for x in Material(E=material.E, nu=material.nu, rho=material.rho).lame())
    k00, k0n, knn, mform = _forms()
    K00 = k00.assemble(basis, lam=lam, mu=mu).tocsr()
    K0n = k0n.assemble(basis, lam=lam, mu=mu).tocsr()
    Knn = knn.assemble(basis, lam=lam, mu=mu).tocsr()
    M = mform.assemble(basis, rho=material.rho).tocsr()
    nv = m.p.shape[1]
    nodes = np.vstack([m.p.T, m.p[:, m.facets].mean(axis=1).T])
    node_dofs = np.hstack([basis.nodal_dofs, basis.facet_dofs]).T.astype(np.int64)
    elements = np.vstack([m.t, nv + m.t2f[[0, 1, 2]]]).T
    contact = int(np.argmin(np.hypot(nodes[:, 0] - mesh.contact[0],
                                     nodes[:, 1] - mesh.contact[1])))
    if math.hypot(*(nodes[contact] - mesh.contact)) > 1e-6:
        raise ValueError(f"no mesh node at the contact point {mesh.contact}: put a vertex "
                         "there (WheelSection.outline does)")
    if mesh.bore_radius is None:
        bore = np.array([], dtype=np.int64)
    else:
        bore = np.nonzero(np.abs(nodes[:, 0] - mesh.bore_radius) < 1e-9)[0]
        if len(bore) == 0:
            raise ValueError(f"no mesh nodes on the bore r = {mesh.bore_radius} m")
    ones = np.zeros(M.shape[0])
    ones[node_dofs[:, 0]] = 1.0
    mass = float(2 * math.pi * ones @ M @ ones)  # n = 0 axial-free translation: 2 pi int rho r
    log.info("assembled wheel: %d nodes, %d DOFs, mass %.1f kg (+ axle %.1f kg)",
             len(nodes), M.shape[0], mass, axle_mass)
    return AxisymmetricWheel(K00=K00, K0n=K0n, Knn=Knn, M=M, node_dofs=node_dofs, nodes=nodes,
                             elements=elements, contact_node=contact, bore_nodes=bore,
                             axle_mass=float(axle_mass), material=material, mass=mass)


def _reduction(wheel: AxisymmetricWheel, n: int) -> tuple[sp.csr_matrix, int | None]:
    """T with u = T q for harmonic n; the index in q of the rigid-ring DOF (or None)."""
    ndof = wheel.M.shape[0]
    nd = wheel.node_dofs
    drop = set()
    if n == 0:
        drop |= set(nd[:, 2].tolist())  # no U_t in the n = 0 symmetric family
    bore = wheel.bore_nodes
    ring = None
    if len(bore):
        drop |= set(nd[bore].ravel().tolist())
        if math.isinf(wheel.axle_mass):
            pass  # clamped bore
        elif n == 0:
            ring = [(d, 1.0) for d in nd[bore, 1]]  # axial translation
        elif n == 1:  # translation along theta = 0: U_r = q, U_t = -q
            ring = [(d, 1.0) for d in nd[bore, 0]] + [(d, -1.0) for d in nd[bore, 2]]
    keep = np.array(sorted(set(range(ndof)) - drop), dtype=np.int64)
    rows, cols, vals = list(keep), list(range(len(keep))), [1.0] * len(keep)
    ring_col = None
    if ring is not None:
        ring_col = len(keep)
        for d, s in ring:
            rows.append(d)
            cols.append(ring_col)
            vals.append(s)
    ncol = len(keep) + (ring is not None)
    return sp.csr_matrix((vals, (rows, cols)), shape=(ndof, ncol)), ring_col


@dataclass(frozen=True, kw_only=True, eq=False)
class HarmonicModes:
    """Modes of one harmonic n below the cut-off.

    n: harmonic. frequency: (m,) natural frequencies (Hz; a rigid-body mode is 0).
    shapes: (m, N, 3) mass-normalised (U_r, U_z, U_t) per node. residual: (2, 2) static
    compliance of the truncated modes between (radial, axial) contact forces (m/N).
    """

    n: int
    frequency: np.ndarray
    shapes: np.ndarray
    residual: np.ndarray

    def contact_constants(self, contact_node: int) -> np.ndarray:
        """(m, 2) mode amplitudes (radial, axial) at the contact node."""
        return self.shapes[:, contact_node, :2]


def harmonic_modes(wheel: AxisymmetricWheel, n: int, f_cut: float, *,
                   shift_hz: float = 20.0) -> HarmonicModes:
    """All modes of harmonic n below f_cut (Hz) by shift-invert Lanczos, with the residual
    compliance of the rest at the contact (evaluated at omega^2 = -(2 pi shift_hz)^2)."""
    if int(n) != n or n < 0:
        raise ValueError(f"harmonic n = {n!r}: give an integer >= 0")
    T, ring = _reduction(wheel, int(n))
    K = (T.T @ wheel.stiffness(int(n)) @ T).tocsc()
    M = (T.T @ wheel.mass_matrix(int(n)) @ T).tocsc()
    if ring is not None and 0 < wheel.axle_mass < math.inf:
        M = M + sp.csc_matrix(([wheel.axle_mass], ([ring], [ring])), shape=M.shape)
    s = (2 * math.pi * shift_hz) ** 2
    lu = spla.splu((K + s * M).tocsc())
    opinv = spla.LinearOperator(K.shape, matvec=lu.solve, dtype=float)
    ndof = K.shape[0]
    k = min(24, ndof - 2)
    target = (2 * math.pi * f_cut) ** 2
    while True:
        # shift-invert about -s (mode 3 of ARPACK, M inner product): lowest lambda first
        lam, vec = spla.eigsh(K, k=k, M=M, sigma=-s, which="LM", OPinv=opinv, tol=1e-10)
        if lam.max() > target or k >= ndof - 2:
            break
        k = min(2 * k, ndof - 2)
    order = np.argsort(lam)
    lam, vec = lam[order], vec[:, order]
    keep = lam <= target
    lam, vec = lam[keep], vec[:, keep]
    vec = vec / np.sqrt(np.einsum("ij,ij->j", vec, M @ vec))
    full = (T @ vec).T.reshape(len(lam), T.shape[0])  # no rows when no mode is below f_cut
    shapes = full[:, wheel.node_dofs]  # (m, N, 3)
    # residual compliance of the truncated modes between radial and axial contact forces
    e = np.zeros((T.shape[0], 2))
    e[wheel.node_dofs[wheel.contact_node, 0], 0] = 1.0
    e[wheel.node_dofs[wheel.contact_node, 1], 1] = 1.0
    er = T.T @ e
    static = er.T @ lu.solve(er)
    phi = shapes[:, wheel.contact_node, :2]
    kept = np.einsum("mi,mj,m->ij", phi, phi, 1 / (np.maximum(lam, 0.0) + s))
    freq = np.sqrt(np.maximum(lam, 0.0)) / (2 * math.pi)
    freq[freq < 0.5] = 0.0  # rigid-body modes (numerically ~1e-2 Hz)
    return HarmonicModes(n=int(n), frequency=freq, shapes=shapes, residual=static - kept)


def default_damping(n: int) -> float:
    """Modal damping ratio of a harmonic-n wheel mode: 1e-3 (n = 0), 1e-2 (n = 1, modes
    coupled with the axle and primary suspension), 1e-4 (n >= 2). Assumed values of the
    order used in the rolling-noise literature (see docs/wheels.md)."""
    return 1e-3 if n == 0 else (1e-2 if n == 1 else 1e-4)


def all_modes(wheel: AxisymmetricWheel, n_max: int | None, f_cut: float,
              progress=None) -> list[HarmonicModes]:
    """harmonic_modes for n = 0 .. n_max; n_max=None: up to the first harmonic n >= 2 with
    no mode below f_cut (the lowest mode of a harmonic rises with n from there on)."""
    out = []
    t0 = time.perf_counter()
    limit = 200 if n_max is None else int(n_max)
    for n in range(limit + 1):
        out.append(harmonic_modes(wheel, n, f_cut))
        if progress:
            progress(n + 1, limit + 1)
        if n_max is None and n >= 2 and out[-1].frequency.size == 0:
            break
    log.info("wheel modes n = 0..%d below %.0f Hz: %d modes in %.1f s", len(out) - 1, f_cut,
             sum(len(h.frequency) for h in out), time.perf_counter() - t0)
    return out
