"""Beam section constants computed on the section mesh (independent of the waveguide).

* area, centroid and second moments: exact on the straight-sided triangles;
* St-Venant torsion constant J from the Prandtl stress function: -lap(Phi) = 2 in the
  section, Phi = 0 on its boundary, J = 2 int Phi dA (Timoshenko & Goodier, Theory of
  Elasticity, 3rd ed., section 104);
* shear coefficients from shear-strain energy: with the flexural shear stress of a unit
  shear force, kappa = 1 / (A int |tau|^2 dA). tau = grad(chi), div(tau) = zbar / I,
  tau . n = 0 on the boundary: the Saint-Venant flexure solution for nu = 0 (Cowper 1966,
  J. Appl. Mech. 33, eq. for nu -> 0), which gives 5/6 for a rectangle; Poisson's ratio
  raises it slightly (Cowper: 10(1+nu)/(12+11nu) = 0.850 at nu = 0.3 for a rectangle).
"""
from __future__ import annotations

from dataclasses import dataclass


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
    """(area, centroid_z, I_y, I_z) of the triangulated section, exact for straight sides."""
    v = mesh.vertices[mesh.triangles]  # (nt, 3, 2)
    a, b, c = v[:, 0], v[:, 1], v[:, 2]
    area_t = 0.5 * ((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                    - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    A = area_t.sum()
    cy = (area_t * v[:, :, 0].mean(1)).sum() / A
    cz = (area_t * v[:, :, 1].mean(1)).sum() / A

    def second(q):  # exact int q^2 over a triangle: A/6 (q1^2+q2^2+q3^2+q1q2+q2q3+q3q1)
        s = q[:, 0] ** 2 + q[:, 1] ** 2 + q[:, 2] ** 2 + q[:, 0] * q[:, 1] \
            + q[:, 1] * q[:, 2] + q[:, 2] * q[:, 0]
        return (area_t * s / 6).sum()

    return A, cz, second(v[:, :, 1] - cz), second(v[:, :, 0] - cy)


def _basis(mesh: SectionMesh):
    from skfem import Basis, ElementTriP2, MeshTri

    m = MeshTri(mesh.vertices.T.copy(), mesh.triangles.T.copy())
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
