"""Wave-type labels from mode shapes.

A shape is projected, in the mass metric, onto the rigid motions of the section
(translations along x, y, z and the rotation about the x axis). A shape carried mostly by
one of them is a beam-type wave; otherwise it is a cross-section wave, named by where it
deforms: symmetric shapes dominated by the foot are *foot flapping*, antisymmetric ones whose
head and foot rotate in opposite senses are *web bending*; on an asymmetric section (one
family 'full') both tests apply.
"""
from __future__ import annotations

import numpy as np

RIGID_SHARE = 0.5  # share of kinetic energy a beam-type wave must have in its rigid motion


def _rigid_basis(nodes: np.ndarray, centroid_z: float) -> dict:
    n = len(nodes)
    y, z = nodes[:, 0], nodes[:, 1] - centroid_z
    zero, one = np.zeros(n), np.ones(n)
    return {
        "longitudinal": np.column_stack([one, zero, zero]).ravel(),
        "lateral bending": np.column_stack([zero, one, zero]).ravel(),
        "vertical bending": np.column_stack([zero, zero, one]).ravel(),
        "torsion": np.column_stack([zero, -z, y]).ravel(),
    }


def _node_ordered(guide, v_full: np.ndarray) -> np.ndarray:
    return v_full[guide.node_dofs.ravel()]


def label_shapes(guide, ops, phi_reduced: np.ndarray) -> list[str]:
    """Label each column of reduced shapes phi (n_r, nw): the mass-metric projections of
    all columns on the rigid motions at once (one sparse product M phi)."""
    full = ops.T @ phi_reduced
    M = guide.M
    cz = float(np.sum(M.diagonal()[guide.node_dofs[:, 2]] * guide.nodes[:, 1])
               / M.diagonal()[guide.node_dofs[:, 2]].sum())
    names = ("longitudinal", "vertical bending", "lateral bending", "torsion")
    basis = _rigid_basis(guide.nodes, cz)
    R = np.zeros((guide.n_dofs, len(names)))
    for j, name in enumerate(names):
        R[guide.node_dofs.ravel(), j] = basis[name]
    MR = M @ R
    RMR = R.T @ MR  # (4, 4) real
    Mu = M @ full
    total = np.real(np.einsum("ij,ij->j", full.conj(), Mu))
    RMu = MR.T @ full  # r^T M u (M symmetric)
    share = np.zeros(full.shape[1])
    best = np.full(full.shape[1], -1)
    for j in (0, 1):  # longitudinal, vertical bending
        s = np.abs(RMu[j] / RMR[j, j]) ** 2 * RMR[j, j] / total
        better = s > share
        best, share = np.where(better, j, best), np.where(better, s, share)
    # torsion and lateral translation are not M-orthogonal for a monosymmetric section:
    # project onto span{lateral, torsion} and attribute by the larger coefficient
    Gm = RMR[2:, 2:]
    coef = np.linalg.solve(Gm, RMu[2:])
    s2 = np.real(np.einsum("ij,ij->j", coef.conj(), Gm @ coef)) / total
    better = s2 > share
    pick = 2 + np.argmax(np.abs(coef) ** 2 * np.diag(Gm)[:, None], axis=0)
    best, share = np.where(better, pick, best), np.where(better, s2, share)
    height = np.ptp(guide.nodes[:, 1])
    zmin = guide.nodes[:, 1].min()
    return [names[b] if sh >= RIGID_SHARE else
            _cross_section_label(guide, ops.family, full[:, j], zmin, height)
            for j, (b, sh) in enumerate(zip(best, share))]


def _cross_section_label(guide, family: str, u: np.ndarray, zmin: float, height: float) -> str:
    nodes = guide.nodes
    amp = np.abs(u[guide.node_dofs]) ** 2  # (n, 3)
    foot = nodes[:, 1] < zmin + 0.2 * height
    head = nodes[:, 1] > zmin + 0.8 * height
    foot_dominated = amp[foot].sum() > 0.5 * amp.sum()
    if family == "symmetric":
        return "foot flapping" if foot_dominated else "cross-section (sym.)"
    if family == "full" and foot_dominated:  # no symmetry split: test both kinds
        return "foot flapping"
    uy = u[guide.node_dofs[:, 1]]
    if head.any() and foot.any():
        # head and foot lateral motion in opposite directions: the web bends
        if np.real(np.mean(uy[head]) * np.conj(np.mean(uy[foot]))) < 0:
            return "web bending"
    return "cross-section (antisym.)" if family == "antisymmetric" else "cross-section"


def label_waves(guide, ops, waves) -> list[str]:
    return label_shapes(guide, ops, waves.phi)
