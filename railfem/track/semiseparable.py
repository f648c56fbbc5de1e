"""The discrete-support coupling of a long uniform layout as a sparse chain of waves.

On identical, equally spaced supports (n_r rows of n_p springs each, a block of
nb = n_r n_p springs per support) the free-rail receptance between supports n apart is a
block-Toeplitz sequence T_n (nb x nb). Beyond the smoothing window every term of the
residue sum is a wave, T_n = sum_m c_m exp(-i k_m n d) for n >= 1 (and the mirrored
waves for n <= -1), so the sequence has the state-space form

    T_n = C A^(n-1) B   (n >= 1),        T_-n = C' A'^(n-1) B'   (n >= 1)

with A of the size of the waves that reach the next support (9..12 on 60E1 for
d = 0.6 m up to 8.6 kHz: the near-field waves of the frozen tail die within a few cm).
The realisation is identified from the kernel's own blocks (``realise``: the
Ho-Kalman / eigensystem-realisation algorithm on a block Hankel matrix) and checked
against every T_n of the kernel; the coupling (diag(a) + diag(b) alpha) F = rhs then reads,
with the forward wave amplitudes w_s = sum_{t<s} A^(s-1-t) B F_t arriving at support s
and the backward ones v_s = sum_{t>s} A'^(t-s-1) B' F_t,

    (diag(a_s) + diag(b_s) T_0) F_s + diag(b_s) (C w_s + C' v_s) = rhs_s
    w_s = A w_(s-1) + B F_(s-1),         v_s = A' v_(s+1) + B' F_(s+1)

a sparse system of n_s n_p + 2 (N - 1) r unknowns in place of the dense n_s n_p one: its
LU costs O(N (nb + r)^2) against O((N nb)^3). It is the transfer-matrix form of the
track, written on the waves, solved by a sparse LU (scipy.sparse.linalg.splu) instead
of a sweep. The result equals the dense solve to round-off (the realisation's error is
checked per frequency; a frequency whose realisation misses ``tol`` is left to the
dense solve).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: relative error (to the largest block entry) the realisation of T_n must meet
REALISE_TOL = 1e-11
#: singular values of the block Hankel matrix kept, relative to the largest
RANK_TOL = 1e-14
#: blocks per side of the Hankel matrix (uses T_1 .. T_2L)
HANKEL_BLOCKS = 6


@dataclass(frozen=True, kw_only=True, eq=False)
class ChainPlan:
    """The block-Toeplitz layout of a kernel's springs: n_sup supports of n_rows rows;
    index[n + n_sup - 1, a, b] the kernel's separation index (ss_sep) of row a of one
    support and row b of the support n before it."""

    n_sup: int
    n_rows: int
    n_p: int
    index: np.ndarray

    @property
    def nb(self) -> int:
        return self.n_rows * self.n_p

    def blocks(self, ss_i: np.ndarray) -> np.ndarray:
        """(2 n_sup - 1, nb, nb) T_n for n = -(n_sup - 1) .. n_sup - 1 from ss[i]
        (n_u, n_p, n_p); rows and columns ordered (row, spring) as the kernel's sets."""
        T = ss_i[self.index]  # (m, a, b, p, q)
        m, R = self.index.shape[:2]
        return T.transpose(0, 1, 3, 2, 4).reshape(m, R * self.n_p, R * self.n_p)


def chain_plan(spring_x: np.ndarray, ss_index: np.ndarray, n_p: int,
               min_supports: int = 2 * HANKEL_BLOCKS + 2) -> ChainPlan | None:
    """The ChainPlan of sets at ``spring_x`` (n_s,) with separation index ``ss_index``
    (n_s, n_s) when they are identical supports at equal spacing (the fewest rows per
    support that fits), else None."""
    xs = np.asarray(spring_x, dtype=float)
    n_s = len(xs)
    for R in range(1, n_s // min_supports + 1):
        if n_s % R:
            continue
        N = n_s // R
        X = xs.reshape(N, R)
        d = X[1, 0] - X[0, 0]
        if d <= 0 or not np.allclose(X - X[:1], d * np.arange(N)[:, None], rtol=0,
                                     atol=1e-9):
            continue
        Ind = ss_index.reshape(N, R, N, R)
        n = np.arange(N)
        idx = np.empty((2 * N - 1, R, R), dtype=np.int64)
        idx[N - 1 + n] = Ind[n, :, 0, :]
        idx[N - 1 - n] = Ind[0, :, n, :]
        full = idx[N - 1 + n[:, None] - n[None, :]]  # (N, N, R, R)
        if np.array_equal(full.transpose(0, 2, 1, 3), Ind):
            return ChainPlan(n_sup=N, n_rows=R, n_p=n_p, index=idx)
    return None


def realise(T: np.ndarray, n_blocks: int = HANKEL_BLOCKS, rank_tol: float = RANK_TOL):
    """(C, A, B) with T[n - 1] = C A^(n-1) B, from the block Hankel matrix of T[0 .. 2L-1]
    (Ho-Kalman: H0 = U S V^H truncated at rank_tol, A = S^-1/2 U^H H1 V S^-1/2)."""
    L, nb = n_blocks, T.shape[1]
    H0 = np.block([[T[i + j] for j in range(L)] for i in range(L)])
    H1 = np.block([[T[i + j + 1] for j in range(L)] for i in range(L)])
    U, s, Vh = np.linalg.svd(H0)
    if not s[0] > 0:  # no wave reaches the next support
        return np.zeros((nb, 1)), np.zeros((1, 1)), np.zeros((1, nb))
    r = int(np.sum(s > rank_tol * s[0]))
    sq = np.sqrt(s[:r])
    A = (U[:, :r].conj().T @ H1 @ Vh[:r].conj().T) / sq[:, None] / sq[None, :]
    return U[:nb, :r] * sq[None, :], A, sq[:, None] * Vh[:r, :nb]


def realisation_error(C, A, B, T) -> float:
    """max over n of |C A^(n-1) B - T[n-1]|."""
    X, err = B, 0.0
    for Tn in T:
        err = max(err, float(np.abs(C @ X - Tn).max()))
        X = A @ X
    return err


def _padded(real, r: int):
    """A realisation (C, A, B) grown to r states by states that are never excited."""
    C, A, B = real
    k = A.shape[0]
    Cp = np.zeros((C.shape[0], r), dtype=complex)
    Ap = np.zeros((r, r), dtype=complex)
    Bp = np.zeros((r, B.shape[1]), dtype=complex)
    Cp[:, :k], Ap[:k, :k], Bp[:k] = C, A, B
    return Cp, Ap, Bp


def sweep(T0, forward, backward, a, b, rhs, N: int) -> np.ndarray:
    """F (q, N nb, n_rhs) of the chain, for q problems at once (frequencies: T0 (q, nb, nb),
    the realisations' matrices (q, ...), a, b (q, N nb), rhs (q, N nb, n_rhs)). Each
    support's own springs are eliminated first (F_s = z_s - Z_s^f w_s - Z_s^b v_s, one
    nb x nb solve per support, or one for all when the supports are identical), leaving the
    waves:

        w_(s+1) = (A - B Z_s^f) w_s - B Z_s^b v_s + B z_s           (w_0 = 0)
        v_(s-1) = -B' Z_s^f w_s + (A' - B' Z_s^b) v_s + B' z_s      (v_(N-1) = 0)

    swept left to right as w_s = X_s v_(s-1) + y_s (the reflection of the supports left of
    s and their sources: bounded, as the waves are), then v back from the right end."""
    Cf, Af, Bf = forward
    Cb, Ab, Bb = backward
    q, nb = T0.shape[:2]
    rf, rb, n_rhs = Af.shape[1], Ab.shape[1], rhs.shape[-1]
    ab, bb = a.reshape(q, N, nb), b.reshape(q, N, nb)
    rhs = rhs.reshape(q, N, nb, n_rhs)
    W = np.concatenate([Cf, Cb], axis=-1)[:, None] * bb[..., None]  # (q, N, nb, rf + rb)
    if np.all(ab == ab[:, :1]) and np.all(bb == bb[:, :1]):  # identical supports
        local = bb[:, 0, :, None] * T0
        local[:, np.arange(nb), np.arange(nb)] += ab[:, 0]
        Zw = np.linalg.solve(local, W[:, 0])[:, None]  # (q, 1, nb, r)
        z = np.linalg.solve(local, rhs.transpose(0, 2, 1, 3).reshape(q, nb, N * n_rhs))
        z = z.reshape(q, nb, N, n_rhs).transpose(0, 2, 1, 3)
    else:
        local = bb[..., None] * T0[:, None]
        local[..., np.arange(nb), np.arange(nb)] += ab
        Z = np.linalg.solve(local, np.concatenate([W, rhs], axis=-1))
        Zw, z = Z[..., :rf + rb], Z[..., rf + rb:]
    Gw, Gz = Bf[:, None] @ Zw, Bb[:, None] @ Zw  # (q, N or 1, r, rf + rb)
    shape = (q, N)
    Ff = np.broadcast_to(Af[:, None] - Gw[..., :rf], shape + (rf, rf))
    Fb = np.broadcast_to(-Gw[..., rf:], shape + (rf, rb))
    Vf = np.broadcast_to(-Gz[..., :rf], shape + (rb, rf))
    Vb = np.broadcast_to(Ab[:, None] - Gz[..., rf:], shape + (rb, rb))
    fz, vz = Bf[:, None] @ z, Bb[:, None] @ z  # (q, N, r, n_rhs)
    I_b = np.eye(rb)
    XY = np.concatenate([Fb[:, 0], fz[:, 0]], axis=-1)  # [X y]: w_1 = X v_0 + y
    XYs = [XY]
    Pp = [None] * N  # [Pv pv]: v_(s-1) = Pv v_s + pv
    for s_ in range(1, N):
        # v_(s-1) = Vf w_s + Vb v_s + vz with w_s = X v_(s-1) + y
        VXY = Vf[:, s_] @ XY
        rhs_v = np.concatenate([Vb[:, s_], vz[:, s_] + VXY[..., rb:]], axis=-1)
        Pp[s_] = np.linalg.solve(I_b - VXY[..., :rb], rhs_v)
        if s_ < N - 1:  # w_(s+1) = Ff w_s + Fb v_s + fz
            FXY = Ff[:, s_] @ XY
            XY = FXY[..., :rb] @ Pp[s_]
            XY[..., :rb] += Fb[:, s_]
            XY[..., rb:] += FXY[..., rb:] + fz[:, s_]
            XYs.append(XY)
    v = np.zeros((q, N, rb, n_rhs), dtype=complex)  # v_(N-1) = 0
    for s_ in range(N - 1, 0, -1):
        v[:, s_ - 1] = Pp[s_][..., :rb] @ v[:, s_] + Pp[s_][..., rb:]
    XYa = np.stack(XYs, axis=1)  # (q, N - 1, rf, rb + n_rhs)
    w = np.zeros((q, N, rf, n_rhs), dtype=complex)  # w_0 = 0
    w[:, 1:] = XYa[..., :rb] @ v[:, :-1] + XYa[..., rb:]
    return (z - Zw[..., :rf] @ w - Zw[..., rf:] @ v).reshape(q, N * nb, n_rhs)


def chain_solve(plan: ChainPlan, ss: np.ndarray, a: np.ndarray, b: np.ndarray,
                rhs: np.ndarray, tol: float = REALISE_TOL) -> list:
    """F of (diag(a) + diag(b) alpha_ss) F = rhs (springs set-major as the kernel's) for
    q frequencies at once: ss (q, n_u, n_p, n_p) the kernel's spring receptances, a, b
    (q, n), rhs (q, n, n_rhs). A list of q arrays (n, n_rhs), None where the waves'
    realisation of alpha_ss misses ``tol`` (the caller solves that frequency densely)."""
    N = plan.n_sup
    ok, T0, fw, bw = [], [], [], []
    for i in range(len(ss)):
        T = plan.blocks(ss[i])
        scale = np.abs(T).max()
        fwd, bwd = T[N:], T[N - 2::-1]  # T_1, T_2, ... and T_-1, T_-2, ...
        forward, backward = realise(fwd), realise(bwd)
        err = max(realisation_error(*forward, fwd), realisation_error(*backward, bwd))
        if err <= tol * scale:
            ok.append(i)
            T0.append(T[N - 1])
            fw.append(forward)
            bw.append(backward)
    out = [None] * len(ss)
    if not ok:
        return out
    rf, rb = max(x[1].shape[0] for x in fw), max(x[1].shape[0] for x in bw)
    forward = [np.stack(m) for m in zip(*(_padded(x, rf) for x in fw))]
    backward = [np.stack(m) for m in zip(*(_padded(x, rb) for x in bw))]
    F = sweep(np.stack(T0), forward, backward, a[ok], b[ok], rhs[ok], N)
    for j, i in enumerate(ok):
        if np.all(np.isfinite(F[j])):
            out[i] = F[j]
    return out
