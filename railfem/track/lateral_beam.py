"""The rail in lateral bending coupled with torsion: a bending-torsion beam reference for
the lateral WFE track (METHOD.md section 3, lateral).

Unknowns per cross-section (v, psi, theta): lateral displacement of the shear centre,
bending rotation and twist. The receptance is summed over the beam's four positive-going
waves by residues (railfem.rail.greens.residue_sum), as the vertical beams of
railfem.track.beams are.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import validators
from ..rail import section as rail_section
from ..rail.greens import residue_sum
from .supports import SupportParameters

@dataclass(frozen=True, kw_only=True)
class LateralSection:
    """A rail in lateral bending (Timoshenko) coupled with torsion (Vlasov) through the
    offset of its shear centre from its centroid.

    Unknowns per cross-section (v, psi, theta): lateral displacement of the shear centre
    (m), bending rotation (rad), twist about the x axis (rad); a point (y, z) moves
    laterally by v - (z - z_s) theta and vertically by y theta (rigid cross-section).
    Potential energy per metre: E I_z psi'^2 + kappa G A (v' - psi)^2 + G J theta'^2
    + E Gamma theta''^2; kinetic: rho A (v - e theta)^2 + rho I_z psi^2 + rho I_p theta^2
    (centroid motion, I_p about the centroid). E* and G* carry the loss factor eta.

    E, G (Pa), rho (kg/m^3), eta (-), area (m^2), I_z (m^4, lateral bending), kappa_y (-),
    J (m^4, St-Venant), Gamma (m^6, warping), I_p (m^4, polar about the centroid),
    z_s (m, shear-centre height), e = z_C - z_s (m).
    """

    E: float
    G: float
    rho: float
    eta: float
    area: float
    I_z: float
    kappa_y: float
    J: float
    Gamma: float
    I_p: float
    z_s: float
    e: float

    @classmethod
    def from_mesh(cls, mesh, material) -> "LateralSection":
        """Constants of the meshed section (railfem.rail.section) and the material."""
        sc = rail_section.section_constants(mesh)
        wp = rail_section.warping(mesh)
        return cls(E=material.E, G=material.G, rho=material.rho, eta=material.loss_factor,
                   area=sc.area, I_z=sc.I_z, kappa_y=sc.kappa_y, J=sc.J, Gamma=wp["Gamma"],
                   I_p=sc.I_p, z_s=wp["z_s"], e=wp["e"])

    def point(self, y: float, z: float, direction: str = "y") -> np.ndarray:
        """Generalised weights (3,) of the displacement at (y, z) in direction 'y' or 'z'
        (a force there loads the unknowns with the same weights)."""
        if direction == "y":
            return np.array([1.0, 0.0, -(z - self.z_s)])
        if direction == "z":
            return np.array([0.0, 0.0, float(y)])
        raise ValueError(f"direction {direction!r}: the lateral beam has 'y' and 'z' points")


def lateral_matrices(section: LateralSection, omega: float, k_y=0.0, k_theta=0.0,
                     z_spring: float = 0.0):
    """(A4, A2, A1, A0) of A(k) = k^4 A4 + k^2 A2 + k A1 + A0 (3 x 3) for exp(-i k x):
    the lateral beam with a foundation per metre of lateral stiffness k_y (N/m^2) at height
    z_spring (m, the foot underside) and rotational stiffness k_theta (N m/m/rad)."""
    c = 1 + 1j * section.eta
    s = section.kappa_y * section.G * section.area * c
    EI, GJ = section.E * section.I_z * c, section.G * section.J * c
    EG = section.E * section.Gamma * c
    rA = section.rho * section.area
    M = np.array([[rA, 0, -rA * section.e], [0, section.rho * section.I_z, 0],
                  [-rA * section.e, 0, section.rho * (section.I_p + section.area * section.e**2)]])
    h = section.z_s - z_spring  # a spring at z_spring stretches by v + h theta
    A4 = np.zeros((3, 3), dtype=complex)
    A4[2, 2] = EG
    A2 = np.diag([s, EI, GJ]).astype(complex)
    A1 = np.array([[0, 1j * s, 0], [-1j * s, 0, 0], [0, 0, 0]], dtype=complex)
    A0 = (np.diag([0, s, 0]) + k_y * np.array([[1, 0, h], [0, 0, 0], [h, 0, h * h]])
          + k_theta * np.diag([0, 0, 1]) - omega**2 * M).astype(complex)
    return A4, A2, A1, A0


def lateral_waves(section: LateralSection, omega: float, k_y=0.0, k_theta=0.0,
                  z_spring: float = 0.0):
    """Positive-going waves (Im k < 0) of the lateral beam: (k (4,), phi (3, 4), psi (3, 4),
    d (4,)) with A(k_n) phi_n = 0, psi_n^T A(k_n) = 0 and d_n = psi_n^T A'(k_n) phi_n.

    det A(k) is a polynomial of degree 8 in k, even (A(-k) = T A(k) T, T flipping psi): its
    coefficients come from samples on a circle (exact up to round-off), its roots from the
    companion matrix. Needs damping (eta > 0 or a lossy foundation) so that no root is real."""
    A4, A2, A1, A0 = lateral_matrices(section, omega, k_y, k_theta, z_spring)
    r0 = 5.0  # rad/m: scale of the roots (bending to shear near field)
    n = 16
    kk = r0 * np.exp(2j * np.pi * np.arange(n) / n)
    det = [np.linalg.det(k**4 * A4 + k**2 * A2 + k * A1 + A0) for k in kk]
    coef = np.fft.fft(det) / n  # coefficient j of det(r0 z) in z^j
    roots = r0 * np.polynomial.polynomial.polyroots(coef[:9])
    if np.any(np.abs(roots.imag) <= 1e-9 * np.abs(roots)):
        raise ValueError("the lateral beam has an undamped real wavenumber: give a loss "
                         "factor eta > 0 or a lossy foundation")
    k = roots[roots.imag < 0]
    if len(k) != 4:
        raise ValueError(f"expected 4 positive-going lateral waves, found {len(k)}")
    k = k[np.argsort(np.abs(k))]
    phi, psi, d = np.empty((3, 4), complex), np.empty((3, 4), complex), np.empty(4, complex)
    for j, kn in enumerate(k):
        u, _, vh = np.linalg.svd(kn**4 * A4 + kn**2 * A2 + kn * A1 + A0)
        phi[:, j], psi[:, j] = vh[-1].conj(), u[:, -1].conj()
        d[j] = psi[:, j] @ (4 * kn**3 * A4 + 2 * kn * A2 + A1) @ phi[:, j]
    return k, phi, psi, d


def lateral_receptance(section: LateralSection, omega, x, force, response, *, k_y=0.0,
                       k_theta=0.0, z_spring: float = 0.0, load_length: float = 0.0,
                       response_length: float = 0.0) -> np.ndarray:
    """Receptance (nf, n_out, nx, n_in) of the infinite lateral beam on a continuous
    foundation (k_y, k_theta may be omega-shaped): forces with generalised weights
    ``force`` (n_in, 3) at x = 0, spread over load_length, responses ``response``
    (n_out, 3) at x (m), averaged over response_length (railfem.rail.greens.residue_sum).

    Residues: A(k)^-1 has the pole phi psi^T / ((k - k_n) d_n) at each root; x >= 0 sums
    the roots with Im k < 0, x < 0 their mirrors -k_n with T phi_n, T psi_n."""
    w = np.atleast_1d(np.asarray(omega, dtype=float))
    F = np.atleast_2d(np.asarray(force, dtype=float)).T  # (3, n_in)
    R = np.atleast_2d(np.asarray(response, dtype=float))  # (n_out, 3)
    x = np.atleast_1d(np.asarray(x, dtype=float))
    ky = np.broadcast_to(np.asarray(k_y, dtype=complex), w.shape)
    kt = np.broadcast_to(np.asarray(k_theta, dtype=complex), w.shape)
    T = np.array([1.0, -1.0, 1.0])
    out = np.empty((len(w), R.shape[0], len(x), F.shape[1]), dtype=complex)
    for i, wi in enumerate(w):
        k, phi, psi, d = lateral_waves(section, wi, ky[i], kt[i], z_spring)
        terms = (R @ phi, (psi.T @ F) / d[:, None], R @ (T[:, None] * phi),
                 (psi.T @ (T[:, None] * F)) / d[:, None])
        out[i] = residue_sum(terms, k, x, load_length, response_length)
    return out


def lateral_track_receptance(section: LateralSection, support_params: SupportParameters,
                             spacing: float, omega, x, force, response, *, bed_moment: float,
                             z_foot: float, load_length: float = 0.0,
                             response_length: float = 0.0) -> np.ndarray:
    """The lateral beam on the continuous support of METHOD.md section 2 acting laterally
    and vertically: lateral stiffness K_y(omega)/spacing per metre at the foot underside
    (height z_foot, m) and rotational stiffness K_z-(omega)/spacing * bed_moment, where
    bed_moment (m^2) is the second moment of the vertical bed's distribution across the foot
    about the web axis (W^2/12 for a uniform bed of width W) and K_z- the vertical pad
    springs' chain against the foot's roll (railfem.track.directions.PAD_ROLL: the pad
    alone on the default rigid seat, the whole chain with seat 'per_spring'), plus the
    fastening's roll restraint k_roll / spacing (SupportParameters). Shapes as
    lateral_receptance."""
    from .directions import PAD_ROLL, directional_stiffness

    w = np.atleast_1d(validators.finite_array("omega", omega, "rad/s"))
    if np.any(w < 0):
        raise ValueError("omega must be >= 0 rad/s (angular frequency, not Hz)")
    ky = directional_stiffness(support_params, w, "y") / spacing
    kt = (directional_stiffness(support_params, w, PAD_ROLL) / spacing * bed_moment
          + directional_stiffness(support_params, w, "r") / spacing)  # + the grip's roll
    return lateral_receptance(section, w, x, force, response, k_y=ky, k_theta=kt,
                              z_spring=z_foot, load_length=load_length,
                              response_length=response_length)
