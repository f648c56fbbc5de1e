"""Which wave carries a transfer: per-wave contributions and the cross-section content of
each wave of the WFE rail on a continuous support (METHOD.md sections 1 and 2).

The residue sum of the waveguide writes any transfer as a sum over the positive-going waves
k_n (railfem.rail.greens.residue_sum),

    u(x) = sum_n c_n(x),   c_n(x) = -i (R phi_n) (psi_n^T F / d_n) K_n(x),

with K_n the wave's propagation factor (exp(-i k_n |x|) outside the load's smoothing window).
``wave_contributions`` returns the c_n themselves, so a table shows which wave dominates the
transfer at each distance; their sum is the receptance of ``wave_sum`` (the same wave set).
``section_content`` says what each wave does to the cross-section (lateral, vertical, roll,
axial, deformation shares of its kinetic energy; lateral motion of head and foot; the
height about which the section rocks). ``continuous_wave_sets`` gives the wave sets and
response projections of the continuously supported track exactly as
railfem.track.wfe.continuous_receptance uses them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..rail.greens import wave_kernels
from ..rail.mobility import FamilyResponse, Location, check_frequency, wave_terms
from ..rail.waveguide import Waveguide
from ..rail.waves import Waves, frozen_tail, join, waves_at
from .wfe import excited_families, supported_operators

__all__ = ["wave_contributions", "SectionContent", "section_content", "continuous_wave_sets"]

#: Head and foot regions (fractions of the section height from the underside) over which
#: the lateral motions head_y and foot_y are averaged.
HEAD_FRACTION, FOOT_FRACTION = 0.8, 0.2


def wave_contributions(fr: FamilyResponse, w: Waves, x, L_force: float = 0.0,
                       L_resp: float = 0.0) -> np.ndarray:
    """Per-wave receptances c_n (nw, n_out, nx, n_in) in m/N of the family's wave set ``w``
    at response positions x (m, relative to the load centre), the load spread over L_force
    and the response averaged over L_resp (m): their sum over the first axis is
    railfem.rail.mobility.wave_sum(fr, w, x, L_force, L_resp) (which leaves out, beyond a
    wave's reach, terms below e^-35 of the wave's amplitude)."""
    x = np.atleast_1d(np.asarray(x, dtype=float))
    if x.ndim != 1 or not np.all(np.isfinite(x)):
        raise ValueError("response positions x must be a 1-D array of finite values (m)")
    Rphi, a, Rphi_m, b = wave_terms(fr, w)
    fwd, bwd = wave_kernels(w.k, x, L_force, L_resp)
    direct = Rphi.T[:, :, None, None] * a[:, None, None, :] * fwd[:, None, :, None]
    mirror = Rphi_m.T[:, :, None, None] * b[:, None, None, :] * bwd[:, None, :, None]
    return -1j * (direct + mirror)


@dataclass(frozen=True, kw_only=True)
class SectionContent:
    """Cross-section content of waves (arrays of shape (nw,)).

    Shares of the wave's kinetic energy (mass metric, sum 1): lateral (rigid translation
    u_y), vertical (u_z), roll (rigid rotation about the rail axis through the centroid),
    axial (all u_x motion: the section's bending rotation and warping), deformation (the
    in-plane motion no rigid motion explains: web bending, foot flapping).
    head_y, foot_y: mass-weighted mean lateral displacement of the head and of the foot
    (complex, same normalisation as the shape). pivot_z: height (m, from the foot underside)
    of the point whose rigid lateral motion vanishes, Re(z_c + v / theta); inf for no roll.
    """

    lateral: np.ndarray
    vertical: np.ndarray
    roll: np.ndarray
    axial: np.ndarray
    deformation: np.ndarray
    head_y: np.ndarray
    foot_y: np.ndarray
    pivot_z: np.ndarray


def _rigid_inplane(guide: Waveguide, zc: float) -> np.ndarray:
    """(N, 3) lateral translation, vertical translation, roll about (0, zc)."""
    R = np.zeros((guide.n_dofs, 3))
    y, z = guide.nodes[:, 0], guide.nodes[:, 1] - zc
    R[guide.node_dofs[:, 1], 0] = 1.0
    R[guide.node_dofs[:, 2], 1] = 1.0
    R[guide.node_dofs[:, 1], 2] = -z
    R[guide.node_dofs[:, 2], 2] = y
    return R


def _mean_lateral(guide: Waveguide, full: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    m = guide.M.diagonal()[guide.node_dofs[nodes, 1]]
    return (m @ full[guide.node_dofs[nodes, 1]]) / m.sum()


def section_content(guide: Waveguide, T, phi: np.ndarray) -> SectionContent:
    """SectionContent of the shapes phi (n_r, nw) of a family with full DOFs u = T phi
    (Waves.phi and Waveguide.families[name].T)."""
    full = np.asarray(T @ phi)
    M = guide.M
    z0 = guide.nodes[:, 1].min()
    ez, zz = np.zeros(guide.n_dofs), np.zeros(guide.n_dofs)
    ez[guide.node_dofs[:, 2]] = 1.0
    zz[guide.node_dofs[:, 2]] = guide.nodes[:, 1]
    zc = float((ez @ (M @ zz)) / (ez @ (M @ ez)))  # centroid: rigid motions M-orthogonal
    Mu = M @ full
    total = np.real(np.einsum("ij,ij->j", full.conj(), Mu))
    ax = np.zeros(guide.n_dofs)
    ax[guide.node_dofs[:, 0]] = 1.0
    axial = np.real(np.einsum("ij,ij->j", (ax[:, None] * full).conj(),
                              M @ (ax[:, None] * full))) / total
    R = _rigid_inplane(guide, zc)
    G = R.T @ (M @ R)
    coef = np.linalg.solve(G, (M @ R).T @ full)  # mass-metric projection on rigid motions
    energy = np.abs(coef) ** 2 * np.diag(G)[:, None] / total  # G diagonal about (0, zc)
    inplane = 1.0 - axial
    deformation = np.clip(inplane - energy.sum(axis=0), 0.0, None)
    with np.errstate(divide="ignore", invalid="ignore"):
        pivot = np.where(np.abs(coef[2]) > 1e-12 * np.abs(coef).max(axis=0),
                         np.real(zc + coef[0] / coef[2]) - z0, np.inf)
    h = np.ptp(guide.nodes[:, 1])
    head = np.flatnonzero(guide.nodes[:, 1] > z0 + HEAD_FRACTION * h)
    foot = np.flatnonzero(guide.nodes[:, 1] < z0 + FOOT_FRACTION * h)
    return SectionContent(lateral=energy[0], vertical=energy[1], roll=energy[2], axial=axial,
                          deformation=deformation, head_y=_mean_lateral(guide, full, head),
                          foot_y=_mean_lateral(guide, full, foot), pivot_z=pivot)


def continuous_wave_sets(guide: Waveguide, params, spacing: float, frequency, *,
                         load: Location, outputs: list[Location], directions: str = "z",
                         n_waves: int = 40, tail: bool = True):
    """Per frequency, [(FamilyResponse, Waves)] over the families the load excites: the
    waves of the rail on the continuous support ``params`` (per metre K_d(omega)/spacing in
    ``directions``, railfem.track.wfe.supported_operators) and the load/response
    projections, as railfem.track.wfe.continuous_receptance sums them (n_waves smallest |k|
    by shift-invert, plus the frozen near-field tail). A list of length len(frequency)."""
    f = check_frequency(frequency)
    R = np.column_stack([o.weights for o in outputs])
    parts = []
    for fam in excited_families(guide, [load]):
        ops = supported_operators(guide, params, spacing, fam, directions)
        fr = FamilyResponse(guide, fam, load.weights[:, None], R)
        t = frozen_tail(ops, 2 * np.pi * f.min(), n_waves) if tail else None
        parts.append((fr, ops, t))
    out = []
    for fi in f:
        sets = []
        for fr, ops, t in parts:
            w = waves_at(ops, 2 * np.pi * fi, method="shift-invert", n_waves=n_waves)
            sets.append((fr, w if t is None else join(w, t)))
        out.append(sets)
    return out
