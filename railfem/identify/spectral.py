"""The coupling solve of a uniform discrete track as a rational function of one number.

On a uniform track every spring set carries the same support dynamic stiffness K_s(omega)
times a fixed share (railfem.track.coupling: spring j of set s has K_s(omega) w_s p_j), so at
each frequency the support parameters (kp, eta_p, kb, eta_b, ms) enter the coupled
response only through the complex scalar K_s. With A = diag(w) alpha_ss diagonalised once,
A = V diag(lambda) V^-1, the coupling of railfem.track.coupling becomes

    u(K_s) = alpha_rP - sum_m R_m K_s / (1 + K_s lambda_m),
    R_m = (alpha_rs V)[:, m] (V^-1 diag(w) alpha_sP)[m, :]

so a new parameter set costs one short sum per frequency instead of a dense solve, and the
derivative du/dK_s = -sum_m R_m / (1 + K_s lambda_m)^2 comes for free. The eigen-solve
(once per kernel) is split into the even and odd parts of a mirror-symmetric layout, as
couple_discrete does; ``SpectralCoupling.check`` compares with couple_discrete.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from railfem.track import kernelcache
from railfem.track.coupling import DiscreteKernel, couple_discrete


@dataclass(frozen=True, kw_only=True, eq=False)
class SpectralCoupling:
    """Eigen form of a uniform discrete coupling at selected (response, force) pairs.

    frequency: (nf,) Hz. lam: (nf, m) eigenvalues of diag(w) alpha_ss (m/N per unit
    stiffness share). residue: (nf, m, n_out, n_pair) R_m. direct: (nf, n_out, n_pair)
    alpha_rP (m/N). The pairs are the (jr, jf) entries the caller asked for.
    """

    frequency: np.ndarray
    lam: np.ndarray
    residue: np.ndarray
    direct: np.ndarray

    def receptance(self, Ks: np.ndarray, *, batched: bool = False) -> np.ndarray:
        """(nf, n_out, n_pair) receptance for the support stiffness Ks (nf,) N/m.
        batched: the sum as one batched matrix product (several times faster for the sizes
        of a hammer test; the same sum in another order, equal to rounding)."""
        Ks = np.asarray(Ks, dtype=complex)[:, None]
        g = Ks / (1.0 + Ks * self.lam)
        if batched:
            nf, m = self.lam.shape
            gr = g[:, None, :] @ self.residue.reshape(nf, m, -1)  # (nf, 1, n_out n_pair)
            return self.direct - gr[:, 0, :].reshape(self.direct.shape)
        return self.direct - np.einsum("fm,fmop->fop", g, self.residue)

    def derivative(self, Ks: np.ndarray) -> np.ndarray:
        """(nf, n_out, n_pair) d receptance / d Ks."""
        Ks = np.asarray(Ks, dtype=complex)[:, None]
        g = 1.0 / (1.0 + Ks * self.lam) ** 2
        return -np.einsum("fm,fmop->fop", g, self.residue)


def _gathers(kernel: DiscreteKernel, pattern: np.ndarray):
    """Flat indices of alpha_ss (n, n), alpha_sP (n, n_fx), alpha_rs (n_out n_rx, n) and the
    spring shares w (n,), springs set-major as in railfem.track.coupling."""
    n_s, n_p, n_rx, n_fx = kernel.shape
    n_out = kernel.rs.shape[2]
    n = n_s * n_p
    pp = np.arange(n_p)
    ss = ((kernel.ss_index[:, None, :, None] * n_p + pp[None, :, None, None]) * n_p
          + pp[None, None, None, :]).reshape(n, n)
    sP = (kernel.sP_index[:, None, :] * n_p + pp[None, :, None]).reshape(n, n_fx)
    oo = np.arange(n_out)
    rs = ((kernel.rs_index[None, :, :, None] * n_out + oo[:, None, None, None]) * n_p
          + pp[None, None, None, :]).reshape(n_out * n_rx, n)
    w = (np.asarray(pattern, dtype=float)[:, None] * kernel.spring_weight[None, :]).ravel()
    return ss, sP, rs, w


def _parts(kernel: DiscreteKernel, pattern: np.ndarray):
    """[(rows, cols_mirror, sign, count)]: the even and odd parts of a mirror-symmetric
    layout (springs at -x_s, equal shares, alpha_ss even in the separation), else the whole
    system as one part."""
    xs, n_p = kernel.spring_x, len(kernel.spring_weight)
    n_s = len(xs)
    whole = [(np.arange(n_s * n_p), None, 0.0, None)]
    if n_s < 2 or not np.array_equal(np.round(xs, 12), -np.round(xs[::-1], 12)):
        return whole
    if not np.allclose(pattern, pattern[::-1], rtol=0, atol=0):
        return whole
    u = np.round(kernel.ss_sep, 12)
    j = np.searchsorted(u, -u)
    if np.any(j >= len(u)) or not np.array_equal(u[np.minimum(j, len(u) - 1)], -u):
        return whole
    scale = np.abs(kernel.ss).max(axis=(1, 2, 3), keepdims=True)
    if np.any(np.abs(kernel.ss - kernel.ss[:, j]) > 1e-12 * scale):
        return whole
    n_h = n_s // 2
    flat = lambda sets: (sets[:, None] * n_p + np.arange(n_p)[None, :]).ravel()  # noqa: E731
    even_sets = np.arange(n_h + n_s % 2)
    odd_sets = np.arange(n_h)
    # the centre set (odd n_s) is its own mirror image: counted once in the even part
    once = np.repeat(even_sets < n_h, n_p).astype(float)
    parts = [(flat(even_sets), flat(n_s - 1 - even_sets), 1.0, once)]
    if n_h:
        parts.append((flat(odd_sets), flat(n_s - 1 - odd_sets), -1.0, np.ones(n_h * n_p)))
    return parts


def spectral_coupling(kernel: DiscreteKernel, pattern, jr: np.ndarray,
                      jf: np.ndarray) -> SpectralCoupling:
    """The eigen form of ``couple_discrete(kernel, Ks[:, None] * pattern)`` at the pairs
    (jr[i], jf[i]) (response index, force index of the kernel), for any Ks (nf,).

    pattern: (n_s,) share of K_s carried by each spring set (1 for point supports)."""
    n_s, n_p, n_rx, n_fx = kernel.shape
    pattern = np.asarray(pattern, dtype=float)
    if pattern.shape != (n_s,):
        raise ValueError(f"pattern has shape {pattern.shape}, expected ({n_s},)")
    jr, jf = np.asarray(jr).ravel(), np.asarray(jf).ravel()
    n_out = kernel.rs.shape[2]
    ss_i, sP_i, rs_i, w = _gathers(kernel, pattern)
    nf = len(kernel.frequency)
    parts = _parts(kernel, pattern)
    m = sum(len(p[0]) for p in parts)
    lam = np.empty((nf, m), dtype=complex)
    residue = np.empty((nf, m, n_out, len(jr)), dtype=complex)
    direct = np.empty((nf, n_out, len(jr)), dtype=complex)
    oo = np.arange(n_out)
    rP_i = kernel.rP_index[None, :, :] * n_out + oo[:, None, None]  # (n_out, n_rx, n_fx)
    # the eigen-decompositions: shared with kernels of the same springs (kernelcache)
    key = kernelcache.eigen_key(kernel, w, [(rows, mirror, None if mirror is None else
                                             sign * once) for rows, mirror, sign, once in parts])
    known = kernelcache.eigen_get(key)
    pairs = [] if known is None else known
    for i in range(nf):
        ssr = kernel.ss[i].ravel()
        alpha = ssr[ss_i]
        B = kernel.sP[i].ravel()[sP_i][:, jf]  # (n, n_pair)
        G = kernel.rs[i].ravel()[rs_i].reshape(n_out, n_rx, -1)[:, jr, :]  # (o, pair, n)
        direct[i] = kernel.rP[i].ravel()[rP_i][:, jr, jf]
        k0 = 0
        if known is None:
            pairs.append([])
        for j, (rows, mirror, sign, once) in enumerate(parts):
            if mirror is None:
                a, b, g = alpha, B, G
            else:
                a = None if known is not None else \
                    alpha[np.ix_(rows, rows)] + sign * once[None, :] * alpha[np.ix_(rows, mirror)]
                b = (B[rows] + sign * B[mirror]) / 2
                g = G[:, :, rows] + sign * once[None, None, :] * G[:, :, mirror]
            if known is None:
                pairs[i].append(np.linalg.eig(w[rows, None] * a))
            lam_p, V = pairs[i][j]
            d = np.linalg.solve(V, w[rows, None] * b)  # (mm, pair)
            c = np.einsum("opn,nm->mop", g, V)
            k1 = k0 + len(rows)
            lam[i, k0:k1] = lam_p
            residue[i, k0:k1] = c * d[:, None, :]
            k0 = k1
    if known is None:
        kernelcache.eigen_put(key, pairs)
    return SpectralCoupling(frequency=np.asarray(kernel.frequency), lam=lam,
                            residue=residue, direct=direct)


def check(sc: SpectralCoupling, kernel: DiscreteKernel, pattern, jr, jf, Ks) -> float:
    """Largest relative difference between the eigen form and couple_discrete at Ks (nf,)
    (relative to the largest response per frequency)."""
    K = np.asarray(Ks, dtype=complex)[:, None] * np.asarray(pattern, dtype=float)[None, :]
    ref = couple_discrete(kernel, K)[:, :, np.asarray(jr).ravel(), np.asarray(jf).ravel()]
    got = sc.receptance(Ks)
    scale = np.abs(ref).max(axis=(1, 2), keepdims=True)
    return float((np.abs(got - ref) / scale).max())
