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
    """Label each column of reduced shapes phi (n_r, nw)."""
    full = ops.T @ phi_reduced
    M = guide.M
    cz = float(np.sum(M.diagonal()[guide.node_dofs[:, 2]] * guide.nodes[:, 1])
               / M.diagonal()[guide.node_dofs[:, 2]].sum())
    rigid = {}
    for name, r in _rigid_basis(guide.nodes, cz).items():
        g = np.zeros(guide.n_dofs)
        g[guide.node_dofs.ravel()] = r
        rigid[name] = g
    # torsion and lateral translation are not M-orthogonal for a monosymmetric section:
    # project onto span{lateral, torsion} and attribute by the larger coefficient
    Ml = {name: M @ g for name, g in rigid.items()}
    labels = []
    height = np.ptp(guide.nodes[:, 1])
    zmin = guide.nodes[:, 1].min()
    for j in range(full.shape[1]):
        u = full[:, j]
        total = np.real(np.vdot(u, M @ u))
        best, share = None, 0.0
        for name in ("longitudinal", "vertical bending"):
            c = np.vdot(rigid[name], M @ u) / np.vdot(rigid[name], Ml[name])
            s = abs(c) ** 2 * np.real(np.vdot(rigid[name], Ml[name])) / total
            if s > share:
                best, share = name, s
        G = np.column_stack([rigid["lateral bending"], rigid["torsion"]])
        Gm = G.T @ M @ G
        coef = np.linalg.solve(Gm, G.T @ (M @ u))
        s2 = float(np.real(np.conj(coef) @ Gm @ coef) / total)
        if s2 > share:
            parts = np.abs(coef) ** 2 * np.diag(Gm)
            best, share = ("lateral bending", "torsion")[int(np.argmax(parts))], s2
        if share < RIGID_SHARE:
            best = _cross_section_label(guide, ops.family, u, zmin, height)
        labels.append(best)
    return labels


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
