"""Wave-type labels from mode shapes.

A shape is projected, in the mass metric, onto the rigid motions of the section
(translations along x, y, z and the rotation about the x axis). A shape carried mostly by
one of them is a beam-type wave; otherwise it is a cross-section wave, named by where it
deforms: symmetric shapes dominated by the foot are *foot flapping*, antisymmetric ones whose
head and foot rotate in opposite senses are *web bending*; on an asymmetric section (one
family 'full') both tests apply.
"""
from __future__ import annotations

import weakref

import numpy as np

from .sparseblocks import real_times

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


class _Basis:
    """What the labels of one family's shapes need, computed once per operators: the
    rigid motions' mass projections in the family's reduced DOFs and the node index sets."""

    def __init__(self, guide, ops):
        M = guide.M
        mz = M.diagonal()[guide.node_dofs[:, 2]]
        cz = float(np.sum(mz * guide.nodes[:, 1]) / mz.sum())
        basis = _rigid_basis(guide.nodes, cz)
        R = np.zeros((guide.n_dofs, len(NAMES)))
        for j, name in enumerate(NAMES):
            R[guide.node_dofs.ravel(), j] = basis[name]
        self.T = ops.T
        self.MR = np.ascontiguousarray(ops.T.T @ (M @ R))  # (n_r, 4): T^T M r
        self.RMR = R.T @ (M @ R)  # (4, 4) real
        self.M_r = (ops.T.T @ M @ ops.T).tocsr()  # the family's mass: u^H M u = phi^H M_r phi
        nodes = guide.nodes
        zmin, height = nodes[:, 1].min(), np.ptp(nodes[:, 1])
        self.foot = nodes[:, 1] < zmin + 0.2 * height
        self.head = nodes[:, 1] > zmin + 0.8 * height
        self.dofs = guide.node_dofs


NAMES = ("longitudinal", "vertical bending", "lateral bending", "torsion")
_bases: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def _basis(guide, ops) -> _Basis:
    hit = _bases.get(ops)
    if hit is None or hit[0] is not guide:
        hit = (guide, _Basis(guide, ops))
        _bases[ops] = hit
    return hit[1]


def label_shapes(guide, ops, phi_reduced: np.ndarray) -> list[str]:
    """Label each column of reduced shapes phi (n_r, nw): the mass-metric projections of
    all columns on the rigid motions at once (products with the family's reduced matrices,
    built once per operators), the cross-section tests of the other columns at once."""
    b = _basis(guide, ops)
    phi = np.asarray(phi_reduced)
    total = np.real(np.einsum("ij,ij->j", phi.conj(), real_times(b.M_r, phi)))
    RMu = b.MR.T @ phi  # r^T M u (M symmetric)
    RMR = b.RMR
    share = np.zeros(phi.shape[1])
    best = np.full(phi.shape[1], -1)
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
    out = [NAMES[k] if sh >= RIGID_SHARE else "" for k, sh in zip(best, share)]
    rest = np.nonzero(share < RIGID_SHARE)[0]
    if len(rest):
        for j, name in zip(rest, _cross_section_labels(b, ops.family, b.T @ phi[:, rest])):
            out[j] = name
    return out


def _cross_section_labels(b: _Basis, family: str, u: np.ndarray) -> list[str]:
    """Cross-section wave names of full shapes u (N, m), all columns at once."""
    amp = np.abs(u[b.dofs]) ** 2  # (n, 3, m)
    foot_dominated = amp[b.foot].sum(axis=(0, 1)) > 0.5 * amp.sum(axis=(0, 1))
    web = np.zeros(u.shape[1], dtype=bool)
    if b.head.any() and b.foot.any():
        # head and foot lateral motion in opposite directions: the web bends
        uy = u[b.dofs[:, 1]]
        web = np.real(uy[b.head].mean(axis=0) * np.conj(uy[b.foot].mean(axis=0))) < 0
    if family == "symmetric":
        return ["foot flapping" if f else "cross-section (sym.)" for f in foot_dominated]
    other = "cross-section (antisym.)" if family == "antisymmetric" else "cross-section"
    return ["foot flapping" if family == "full" and f else "web bending" if w else other
            for f, w in zip(foot_dominated, web)]


def label_waves(guide, ops, waves) -> list[str]:
    return label_shapes(guide, ops, waves.phi)
