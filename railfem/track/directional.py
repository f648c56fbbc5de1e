"""The coupling of a uniform discrete track in eigen form for the stiffness of one direction.

A fit of lateral data varies the lateral support chain (kp_lat, eta_p_lat, kb_lat, ...)
while the vertical and longitudinal springs keep the base's stiffness. Per symmetry family
of the rail (railfem.track.coupling.spring_families) the springs split into those of the
varied direction d (Y) and the others (O). With the others' stiffness K_O fixed they are
eliminated once per frequency (a Schur complement):

    X = (I + K_O alpha_OO)^-1 K_O [alpha_OY  alpha_OP]
    alpha~_YY = alpha_YY - alpha_YO X_Y,   alpha~_YP = alpha_YP - alpha_YO X_P
    alpha~_rY = alpha_rY - alpha_rO X_Y,   alpha~_rP = alpha_rP - alpha_rO X_P

which leaves the problem of a track whose springs all act in d with one stiffness k_d per
frequency (spring j: k_d w_j): the vertical fit's eigen form (railfem.identify.spectral)
applies as it is, diag(w) alpha~_YY = V diag(lambda) V^-1 and

    u(k_d) = alpha~_rP - sum_m R_m k_d / (1 + k_d lambda_m),
    R_m = (alpha~_rY V)[:, m] (V^-1 diag(w) alpha~_YP)[m, :],

summed over the families (u = alpha_rP - sum_fam (alpha_rP - u_fam)). A new k_d then
costs a short sum per frequency instead of a coupling solve per family. On a layout
symmetric under x -> -x (is_mirrored) the even and odd parts are reduced apart
(mirror_parts), as railfem.track.coupling solves them: eigenproblems of half the size.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .coupling import DiscreteKernel, mirror_parts, spring_families


@dataclass(frozen=True, kw_only=True, eq=False)
class DirectionalSpectral:
    """Eigen form of a uniform discrete coupling in the stiffness of one direction.

    frequency (nf,) Hz; lam (nf, m) eigenvalues (m/N per unit stiffness share); residue
    (nf, m, n_out, n_pair) R_m; direct (nf, n_out, n_pair) the response with the varied
    springs absent (m/N); direction: the code (0, 1, 2 = x, y, z) of the varied springs."""

    frequency: np.ndarray
    lam: np.ndarray
    residue: np.ndarray
    direct: np.ndarray
    direction: int

    def receptance(self, k: np.ndarray) -> np.ndarray:
        """(nf, n_out, n_pair) receptance (m/N) for the support stiffness k (nf,) N/m of
        the varied direction."""
        k = np.asarray(k, dtype=complex)[:, None]
        g = k / (1.0 + k * self.lam)
        nf, m = self.lam.shape
        gr = g[:, None, :] @ self.residue.reshape(nf, m, -1)
        return self.direct - gr[:, 0, :].reshape(self.direct.shape)

    def derivative(self, k: np.ndarray) -> np.ndarray:
        """(nf, n_out, n_pair) d receptance / d k."""
        k = np.asarray(k, dtype=complex)[:, None]
        g = 1.0 / (1.0 + k * self.lam) ** 2
        return -np.einsum("fm,fmop->fop", g, self.residue)


def _family_part(kernel: DiscreteKernel, cols, K_sets, pattern, direction, jr, jf, i,
                 mirror: bool):
    """(lam, residue, held) of one family's springs ``cols`` at frequency i: held (n_out,
    n_pair) the share of the other directions' springs in the response (alpha_rO X_P).
    ``mirror``: the even and odd parts of a mirror-symmetric layout solved separately."""
    n_s = kernel.shape[0]
    n_p = len(cols)
    d = kernel.spring_direction[cols]
    n_out = kernel.rs.shape[2]
    ss = kernel.ss[i][:, cols][:, :, cols]  # (n_u, p, q)
    alpha = ss[kernel.ss_index].transpose(0, 2, 1, 3).reshape(n_s * n_p, -1)
    B = kernel.sP[i][:, cols][kernel.sP_index[:, jf]].transpose(0, 2, 1).reshape(
        n_s * n_p, -1)  # (springs, pair)
    G = kernel.rs[i][:, :, cols][kernel.rs_index[jr]]  # (pair, s, o, p)
    G = G.transpose(2, 0, 1, 3).reshape(n_out, len(jr), -1)  # (o, pair, springs)
    on = np.tile(d == direction, n_s)
    w = (np.asarray(pattern, dtype=float)[:, None] * kernel.spring_weight[cols][None, :]
         ).ravel()
    K = (K_sets[:, d] * kernel.spring_weight[cols][None, :]).ravel()
    if not mirror:
        return _reduced(alpha, B, G, on, w, K)
    lam, res, held = [], [], 0.0
    for R, JR, sg, m in mirror_parts(n_s, d):
        sm = sg * m
        part = _reduced(alpha[np.ix_(R, R)] + alpha[np.ix_(R, JR)] * sm[None, :],
                        (B[R] + sg[:, None] * B[JR]) / 2, G[:, :, R] + G[:, :, JR] * sm,
                        on[R], w[R], K[R])
        lam.append(part[0])
        res.append(part[1])
        held = held + part[2]
    return np.concatenate(lam), np.concatenate(res), held


def _reduced(alpha, B, G, on, w, K):
    """(lam, residue, held) of the springs ``on`` (the varied direction) with the others
    (stiffness K[~on]) eliminated: alpha (n, n), B (n, pair), G (o, pair, n)."""
    Y, O = np.flatnonzero(on), np.flatnonzero(~on)
    held = 0.0
    if len(O):
        KO = K[O]
        S = np.eye(len(O)) + KO[:, None] * alpha[np.ix_(O, O)]
        X = np.linalg.solve(S, KO[:, None] * np.concatenate([alpha[np.ix_(O, Y)], B[O]],
                                                            axis=1))
        XY, XP = X[:, :len(Y)], X[:, len(Y):]
        aYY = alpha[np.ix_(Y, Y)] - alpha[np.ix_(Y, O)] @ XY
        bY = B[Y] - alpha[np.ix_(Y, O)] @ XP
        gY = G[:, :, Y] - G[:, :, O] @ XY
        held = np.einsum("opn,np->op", G[:, :, O], XP)
    else:
        aYY, bY, gY = alpha[np.ix_(Y, Y)], B[Y], G[:, :, Y]
    lam, V = np.linalg.eig(w[Y, None] * aYY)
    dd = np.linalg.solve(V, w[Y, None] * bY)  # (m, pair)
    c = np.einsum("opn,nm->mop", gY, V)
    return lam, c * dd[:, None, :], held


def is_mirrored(kernel: DiscreteKernel, pattern, K_all) -> bool:
    """Whether the coupling is symmetric under x -> -x: springs at -x_s with equal shares
    and stiffness, alpha_ss(-x) = s_p s_q alpha_ss(x) (s = -1 for longitudinal springs)."""
    xs = kernel.spring_x
    if len(xs) < 2 or not np.array_equal(np.round(xs, 12), -np.round(xs[::-1], 12)):
        return False
    pattern = np.asarray(pattern, dtype=float)
    if not (np.array_equal(pattern, pattern[::-1]) and np.array_equal(K_all, K_all[:, ::-1])):
        return False
    u = np.round(kernel.ss_sep, 12)
    j = np.searchsorted(u, -u)
    if np.any(j >= len(u)) or not np.array_equal(u[np.minimum(j, len(u) - 1)], -u):
        return False
    sign = np.where(np.asarray(kernel.spring_direction) == 0, -1.0, 1.0)
    scale = np.abs(kernel.ss).max(axis=(1, 2, 3), keepdims=True)
    mirrored = kernel.ss[:, j] * (sign[:, None] * sign[None, :])[None, None]
    return bool(np.all(np.abs(kernel.ss - mirrored) <= 1e-12 * scale))


def directional_spectral(kernel: DiscreteKernel, stiffness, pattern, direction: str,
                         jr, jf) -> DirectionalSpectral:
    """The eigen form of ``couple_discrete(kernel, stiffness)`` at the pairs (jr[i], jf[i])
    in the stiffness of the springs acting in ``direction`` ('x', 'y', 'z'; or 'r', the
    roll, for a kernel with the roll column), the other directions held at ``stiffness``.

    stiffness: (nf, n_s, 3) or (nf, n_s, 4) the spring-set stiffness per direction
    (railfem.track.wfe.spring_stiffness; its ``direction`` component is not used).
    pattern: (n_s,) share of a support carried by each spring set (the layout's springs'
    weight): the varied springs' stiffness is k (nf,) times pattern times the kernel's
    spring weights."""
    code = {"x": 0, "y": 1, "z": 2, "r": 3}[direction]
    K_all = np.asarray(stiffness, dtype=complex)
    nf = len(kernel.frequency)
    n_s = kernel.shape[0]
    if K_all.ndim != 3 or K_all.shape[:2] != (nf, n_s) or K_all.shape[2] <= code:
        raise ValueError(f"stiffness has shape {K_all.shape}, expected (n_freq, n_sets, 3 "
                         f"or 4) = ({nf}, {n_s}, ...) with a component for {direction!r}")
    if not np.any(kernel.spring_direction == code):
        raise ValueError(f"the kernel has no springs acting in {direction!r}")
    if code == 2 and np.any(kernel.spring_direction == 4):
        raise ValueError("the kernel's vertical pair differences (the pad against the foot's "
                         "roll) change with the vertical pad but would be held: vary the "
                         "vertical chain by the direct coupling")
    if not np.all(np.isfinite(K_all)):
        raise ValueError("the held springs must have finite stiffness")
    jr, jf = np.asarray(jr).ravel(), np.asarray(jf).ravel()
    groups = [g for g in spring_families(kernel.ss)]
    mirror = is_mirrored(kernel, pattern, K_all)
    lam, res, direct = [], [], []
    free = np.stack([kernel.rP[i][kernel.rP_index[jr, jf]].T for i in range(nf)])
    for i in range(nf):
        parts = [_family_part(kernel, g, K_all[i], pattern, code, jr, jf, i, mirror)
                 for g in groups if np.any(kernel.spring_direction[g] == code)]
        held = [couple_family_direct(kernel, g, K_all[i], jr, jf, i)
                for g in groups if not np.any(kernel.spring_direction[g] == code)]
        lam.append(np.concatenate([p[0] for p in parts]))
        res.append(np.concatenate([p[1] for p in parts]))
        direct.append(free[i] - sum(p[2] for p in parts) - sum(free[i] - h for h in held))
    return DirectionalSpectral(frequency=np.asarray(kernel.frequency), lam=np.stack(lam),
                               residue=np.stack(res), direct=np.stack(direct),
                               direction=code)


def couple_family_direct(kernel: DiscreteKernel, cols, K_set, jr, jf, i) -> np.ndarray:
    """(n_out, n_pair) response with the springs ``cols`` (a family without springs in the
    varied direction) at their fixed stiffness K_set (n_s, 3 or 4), frequency i."""
    n_s = kernel.shape[0]
    d = kernel.spring_direction[cols]
    ss = kernel.ss[i][:, cols][:, :, cols]
    alpha = ss[kernel.ss_index].transpose(0, 2, 1, 3).reshape(n_s * len(cols), -1)
    B = kernel.sP[i][:, cols][kernel.sP_index[:, jf]].transpose(0, 2, 1).reshape(
        n_s * len(cols), -1)
    G = kernel.rs[i][:, :, cols][kernel.rs_index[jr]].transpose(2, 0, 1, 3).reshape(
        kernel.rs.shape[2], len(jr), -1)
    K = (K_set[:, d] * kernel.spring_weight[cols][None, :]).ravel()
    F = np.linalg.solve(np.eye(len(K)) + K[:, None] * alpha, K[:, None] * B)
    return kernel.rP[i][kernel.rP_index[jr, jf]].T - np.einsum("opn,np->op", G, F)
