"""Beam section constants computed on the section mesh (independent of the waveguide).

* area, centroid and second moments: Gauss quadrature of order 6 on the elements, exact on
  straight-sided and on curved (quadratic-geometry) 6-node triangles alike (x^2 det J is a
  polynomial of degree 6 on the reference triangle);
* St-Venant torsion constant J from the Prandtl stress function: -lap(Phi) = 2 in the
  section, Phi = 0 on its boundary, J = 2 int Phi dA (Timoshenko & Goodier, Theory of
  Elasticity, 3rd ed., section 104);
* shear coefficients from shear-strain energy: with the flexural shear stress of a unit
  shear force, kappa = 1 / (A int |tau|^2 dA). tau = grad(chi), div(tau) = zbar / I,
  tau . n = 0 on the boundary: the Saint-Venant flexure solution for nu = 0 (Cowper 1966,
  J. Appl. Mech. 33, eq. for nu -> 0), which gives 5/6 for a rectangle; Poisson's ratio
  raises it slightly (Cowper: 10(1+nu)/(12+11nu) = 0.850 at nu = 0.3 for a rectangle).

The Timoshenko section built from these constants is
``railfem.track.beams.BeamSection.from_mesh`` (this module knows nothing of the beams).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import meshing
from .meshing import SectionMesh


@dataclass(frozen=True, kw_only=True)
class SectionConstants:
    """area (m^2), centroid_z (m), I_y (m^4, vertical bending), I_z (m^4, lateral bending),
    J (m^4, St-Venant torsion), kappa_z / kappa_y (-, shear coefficients for vertical /
    lateral shear), I_p (m^4, polar moment about the centroid)."""

    area: float
    centroid_z: float
    I_y: float
    I_z: float
    J: float
    kappa_z: float
    kappa_y: float

    @property
    def I_p(self) -> float:
        return self.I_y + self.I_z


def moments(mesh: SectionMesh) -> tuple[float, float, float, float]:
    """(area, centroid_z, I_y, I_z) of the meshed section (curved or straight elements)."""
    from skfem import Basis, ElementTriP1

    basis = Basis(meshing.skfem_mesh(mesh), ElementTriP1(), intorder=6)
    x = basis.mapping.F(basis.X)  # (2, nt, nq) quadrature points
    dx = basis.dx  # (nt, nq) weights times |det J|
    A = float(dx.sum())
    cy, cz = (float((x[i] * dx).sum() / A) for i in (0, 1))
    return (A, cz, float(((x[1] - cz) ** 2 * dx).sum()), float(((x[0] - cy) ** 2 * dx).sum()))


def _basis(mesh: SectionMesh):
    from skfem import Basis, ElementTriP2

    m = meshing.skfem_mesh(mesh)
    return m, Basis(m, ElementTriP2())


def torsion_constant(mesh: SectionMesh) -> float:
    from skfem import condense, solve
    from skfem.models.poisson import laplace, unit_load

    m, basis = _basis(mesh)
    K = laplace.assemble(basis)
    f = 2.0 * unit_load.assemble(basis)
    phi = solve(*condense(K, f, D=basis.get_dofs()))
    return float(2.0 * f @ phi / 2.0)  # f = 2 int N: int Phi = f.phi / 2, J = 2 int Phi


def shear_coefficient(mesh: SectionMesh, direction: str = "z") -> float:
    """Energy shear coefficient for a shear force along y or z (nu = 0 flexure solution)."""
    from skfem import LinearForm, solve
    from skfem.models.poisson import laplace, mass

    A, cz, Iy, Iz = moments(mesh)
    m, basis = _basis(mesh)
    axis, centre, inertia = (1, cz, Iy) if direction == "z" else (0, 0.0, Iz)

    @LinearForm
    def load(v, w):
        return (w.x[axis] - centre) / inertia * v

    K = laplace.assemble(basis)
    # weak form of lap(chi) = zbar/I with zero normal flux: K chi = -b; the tiny mass term
    # removes the constant null space without changing gradients (b has zero mean)
    chi = solve(K + 1e-12 * K.diagonal().mean() * mass.assemble(basis), -load.assemble(basis))
    energy = chi @ K @ chi
    return float(1.0 / (A * energy))


def section_constants(mesh: SectionMesh) -> SectionConstants:
    A, cz, Iy, Iz = moments(mesh)
    return SectionConstants(area=A, centroid_z=cz, I_y=Iy, I_z=Iz, J=torsion_constant(mesh),
                            kappa_z=shear_coefficient(mesh, "z"),
                            kappa_y=shear_coefficient(mesh, "y"))


def warping(mesh: SectionMesh) -> dict:
    """Shear centre and warping constant from the St-Venant warping function (Vlasov).

    lap(phi) = 0 in the section with d phi/dn = z n_y - y n_z (coordinates about the
    centroid; Timoshenko & Goodier, section 104); the shear centre is the pole about which
    the warping is orthogonal to y: z_S - z_C = int(phi y) dA / I_z (y_S = 0 on a section
    symmetric about y = 0), and the warping constant Gamma = int phi_S^2 dA with the
    sectorial coordinate phi_S of that pole, of zero mean. Returns z_s (m, shear-centre
    height in the mesh's coordinates), e = z_C - z_S (m) and Gamma (m^6). For 60E1:
    e = 35 mm, Gamma = 1.6e-8 m^6 (tests/test_lateral.py)."""
    from skfem import BilinearForm, LinearForm, solve
    from skfem.helpers import dot, grad

    A, cz, Iy, Iz = moments(mesh)
    _, basis = _basis(mesh)

    @BilinearForm
    def lap(u, v, w):
        return dot(grad(u), grad(v))

    @BilinearForm
    def mass(u, v, w):
        return u * v

    @LinearForm
    def flux(v, w):  # int (z, -y) . grad v dA: the Neumann datum in weak form
        return (w.x[1] - cz) * v.grad[0] - w.x[0] * v.grad[1]

    @LinearForm
    def first_y(v, w):
        return w.x[0] * v

    K, M = lap.assemble(basis), mass.assemble(basis)
    # the small mass term fixes the free constant; the mean is removed below
    phi = solve(K + 1e-10 * K.diagonal().mean() / M.diagonal().mean() * M, flux.assemble(basis))
    one = np.ones_like(phi)
    phi -= (one @ M @ phi) / (one @ M @ one)
    dz = float(first_y.assemble(basis) @ phi) / Iz
    phi_s = phi - dz * basis.project(lambda x: x[0])
    return {"z_s": cz + dz, "e": -dz, "Gamma": float(phi_s @ M @ phi_s)}
