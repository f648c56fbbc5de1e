"""Deviating supports on a uniform discrete track by a low-rank (Woodbury) update of the
uniform coupling (railfem.track.coupling): voided sleepers, random support factors and
their closed-form tangents, without a new coupling solve per evaluation.
"""
from __future__ import annotations

import numpy as np

from . import kernelcache
from .coupling import DiscreteKernel, mirror_plan


#: working memory of SupportUpdate.receptance per block of frequencies (bytes)
WORK_BYTES = 64e6


class SupportUpdate:
    """A uniform discrete track (``kernel``, re-centred on each response-force pair as
    railfem.models does) with some supports' stiffness changed, by a low-rank (Woodbury)
    update of the uniform coupling.

    With W the springs' shares of the support stiffness K (``pattern`` per set times the
    kernel's spring_weight), M0 = W^-1 / K + alpha_ss; diag(W) alpha_ss = V diag(lam) V^-1
    is diagonalised once per frequency (the even and odd parts of the mirror-symmetric
    layout separately), so M0^-1 = V diag(K h) V^-1 W, h = 1 / (1 + K lam), for any K.
    Changing supports J to k_J changes the springs E of J: M = M0 + E D E^T,
    D = diag(1 / (k_J w) - 1 / (K w)), a rank-(springs of J) update, and

        u = u_0 + a (I + D C)^-1 D b,   C = E^T M0^-1 E,  a = alpha_rs M0^-1 E,
                                        b = E^T M0^-1 alpha_sP

    (u_0 the uniform track; exact, any number of supports and factors). Support J (counted
    from the support at x = 0) of pair p sits at kernel support ``centre + J - shift[p]``,
    shift[p] = round((x_r + x_P) / 2 spacing); a support outside a pair's window is left
    out for that pair. Memory: two (n, n) complex arrays per frequency, n the springs."""

    def __init__(self, kernel: DiscreteKernel, pattern, jr, jf, shift, n_rows: int = 1):
        n_s, n_p, _, _ = kernel.shape
        if np.any(np.asarray(kernel.spring_direction) != 2):
            raise ValueError("SupportUpdate takes vertical springs only")
        self.n_p, self.n_rows = n_p, int(n_rows)
        self.n_sup = n_s // self.n_rows
        self.centre = (self.n_sup - 1) // 2
        self.shift = np.asarray(shift, dtype=int)
        jr, jf = np.asarray(jr).ravel(), np.asarray(jf).ravel()
        n = n_s * n_p
        self.w = (np.asarray(pattern, dtype=float)[:, None]
                  * kernel.spring_weight[None, :]).ravel()
        pp = np.arange(n_p)
        ss_flat = ((kernel.ss_index[:, None, :, None] * n_p + pp[None, :, None, None]) * n_p
                   + pp[None, None, None, :]).reshape(n, n)
        sP_flat = (kernel.sP_index[:, None, :] * n_p + pp[None, :, None]).reshape(n, -1)
        n_out = kernel.rs.shape[2]
        oo = np.arange(n_out)
        rs_flat = ((kernel.rs_index[None, :, :, None] * n_out + oo[:, None, None, None]) * n_p
                   + pp[None, None, None, :]).reshape(n_out, -1, n)
        rP_flat = kernel.rP_index[None, :, :] * n_out + oo[:, None, None]
        plan = mirror_plan(kernel, np.ones((1, n_s)), ss_flat)
        if plan is None:
            plan = [dict(R=np.arange(n), JR=np.arange(n), sg=np.ones(n), m=np.zeros(n))]
        self.parts = plan
        nf = len(kernel.frequency)
        self.lam = np.empty((nf, n), dtype=complex)
        self.V = [np.empty((nf, len(p["R"]), len(p["R"])), dtype=complex) for p in plan]
        self.Vw = [np.empty_like(v) for v in self.V]
        self.GV = np.empty((nf, n_out, len(jr), n), dtype=complex)
        self.VB = np.empty((nf, n, len(jr)), dtype=complex)
        self.direct = np.empty((nf, n_out, len(jr)), dtype=complex)
        # the eigen-decompositions: those of the eigen form of the same kernel if at hand
        key = kernelcache.eigen_key(kernel, self.w, [(p["R"], p["JR"], p["m"] * p["sg"])
                                                     for p in plan])
        known = kernelcache.eigen_get(key)
        pairs = [] if known is None else known
        for i in range(nf):
            ssr = kernel.ss[i].ravel()
            alpha = ssr[ss_flat]
            B = kernel.sP[i].ravel()[sP_flat][:, jf]
            G = kernel.rs[i].ravel()[rs_flat][:, jr, :]
            self.direct[i] = kernel.rP[i].ravel()[rP_flat][:, jr, jf]
            k0 = 0
            if known is None:
                pairs.append([])
            for j, p in enumerate(plan):
                R, JR, ms = p["R"], p["JR"], p["m"] * p["sg"]
                wR = self.w[R]
                if known is None:
                    pairs[i].append(np.linalg.eig(wR[:, None] * (
                        alpha[np.ix_(R, R)] + ms[None, :] * alpha[np.ix_(R, JR)])))
                lam, V = pairs[i][j]
                Vw = np.linalg.inv(V) * wR[None, :]
                k1 = k0 + len(R)
                self.lam[i, k0:k1], self.V[j][i], self.Vw[j][i] = lam, V, Vw
                self.GV[i, :, :, k0:k1] = (G[:, :, R] + ms * G[:, :, JR]) @ V
                self.VB[i, k0:k1] = Vw @ ((B[R] + p["sg"][:, None] * B[JR]) / 2)
                k0 = k1
        if known is None:
            kernelcache.eigen_put(key, pairs)
        self._rows_key, self._rows = None, None  # the last _rows_cols
        self._products_key, self._products = None, {}  # the last _products_for
        self._maps = []  # per part: position of each spring in R and in JR (-1: absent)
        for p in plan:
            pr, pj = np.full(n, -1), np.full(n, -1)
            pr[p["R"]] = np.arange(len(p["R"]))
            pj[p["JR"]] = np.arange(len(p["JR"]))
            self._maps.append((pr, pj))

    @property
    def nbytes(self) -> int:
        """Memory held (bytes)."""
        return int(sum(v.nbytes + w.nbytes for v, w in zip(self.V, self.Vw))
                   + self.GV.nbytes + self.VB.nbytes
                   + (0 if self._rows is None else sum(x.nbytes for x in self._rows))
                   + sum(a.nbytes for block in self._products.values()
                         for a in block.values()))

    @property
    def springs_per_support(self) -> int:
        return self.n_rows * self.n_p

    def _rows_cols(self, U: np.ndarray):
        """Rows U of V (nf, u, n) and columns U of V^-1 W (nf, n, u), in the full spring
        space, at every frequency; the last U's are kept (a fit asks for the same supports
        call after call)."""
        key = U.tobytes()
        if self._rows_key == key:
            return self._rows
        rows, cols = [], []
        for j, p in enumerate(self.parts):
            pr, pj = self._maps[j]
            a, b = pr[U], pj[U]
            ms = np.where(b >= 0, (p["m"] * p["sg"])[np.maximum(b, 0)], 0.0)
            sg = np.where(b >= 0, p["sg"][np.maximum(b, 0)], 0.0)
            V, Vw = self.V[j], self.Vw[j]
            rows.append(np.where(a[None, :, None] >= 0, V[:, np.maximum(a, 0)], 0.0)
                        + ms[None, :, None] * V[:, np.maximum(b, 0)])
            cols.append((np.where(a[None, None, :] >= 0, Vw[:, :, np.maximum(a, 0)], 0.0)
                         + sg[None, None, :] * Vw[:, :, np.maximum(b, 0)]) / 2)
        self._rows_key, self._rows = None, None  # the old pair freed before the new one
        self._rows = (np.concatenate(rows, axis=2), np.concatenate(cols, axis=1))
        self._rows_key = key
        return self._rows

    def _products_for(self, K, U, pairs) -> dict:
        """The products of the uniform track that depend on K, the springs U and the pairs
        alone, per block of frequencies ({(first, stop): {name: array}}), kept from the
        last call: a least-squares step asks for the residual and then the tangents at the
        same K, and a refit with the base held asks for the same K call after call."""
        key = (K.tobytes(), U.tobytes(), np.asarray(pairs).tobytes())
        if self._products_key != key:
            self._products_key, self._products = key, {}
        return self._products

    def _gather(self, indices, pairs):
        """The kernel springs the supports ``indices`` take over the pairs ``pairs`` (their
        union U), per pair the position of each one's springs in U (pair, m springs) and
        whether it is inside the window."""
        s = self.centre + np.asarray(indices, dtype=int)[None, :] - self.shift[pairs, None]
        ok = (s >= 0) & (s < self.n_sup)
        k = self.springs_per_support
        sp = (np.where(ok, s, 0)[:, :, None] * k + np.arange(k)).reshape(len(s), -1)
        ok = np.repeat(ok, k, axis=1)
        U, pos = np.unique(sp, return_inverse=True)
        return U, pos.reshape(sp.shape), ok

    def receptance(self, K, k_dev, indices, gradient: bool = False, pairs=None,
                   uniform: bool = False):
        """(nf, n_out, n_pair) receptance with the supports ``indices`` at dynamic
        stiffness k_dev (nf, m) and all others at K (nf,) (N/m per support); with
        ``gradient`` also d receptance / d k_dev, (nf, n_out, n_pair, m), and with
        ``uniform`` as well d receptance / d K (nf, n_out, n_pair), k_dev held. pairs: the
        pairs wanted (indices; default all). A support at k_dev = K (a factor of one) only
        has its derivative computed: it does not enter the solve (so tangents of many
        unchanged supports cost little more than the changed ones). The frequencies are
        taken in blocks (batched products and solves, a bounded working memory)."""
        K = np.asarray(K, dtype=complex)
        k_dev = np.asarray(k_dev, dtype=complex).reshape(len(K), -1)
        pairs = np.arange(len(self.shift)) if pairs is None else np.asarray(pairs, dtype=int)
        U, pos, ok = self._gather(indices, pairs)
        # every pair in order: views of the stored arrays instead of gathered copies
        sel = slice(None) if np.array_equal(pairs, np.arange(len(self.shift))) else pairs
        m_sup, k = k_dev.shape[1], self.springs_per_support
        wsp = self.w[:k]  # the shares of one support's springs (a uniform pattern)
        act = np.repeat(np.any(k_dev != K[:, None], axis=0), k)
        ia, ip = np.flatnonzero(act), np.flatnonzero(~act)
        nf, n_out = self.direct.shape[:2]
        n_pair, n = len(pairs), self.lam.shape[1]
        u = np.empty((nf, n_out, n_pair), dtype=complex)
        du = np.empty((nf, n_out, n_pair, m_sup), dtype=complex) if gradient else None
        Vu, Vc = self._rows_cols(U)
        D = ((1.0 / k_dev[:, :, None] - 1.0 / K[:, None, None])
             / wsp[None, None, :]).reshape(nf, 1, -1) * ok[None]  # (nf, pair, m k)
        dk = (-1.0 * ok[None] / (k_dev[:, :, None] ** 2 * wsp[None, None, :])
              .reshape(nf, 1, -1)) if gradient else None
        per_f = 16 * (n_pair * (3 * len(ia) ** 2 + 2 * len(ia) * len(ip)
                                + n_out * (n + 2 * len(U) + 2 * m_sup * k)) + len(U) * n)
        step = max(1, int(WORK_BYTES // max(per_f, 1)))
        duK = np.empty((nf, n_out, n_pair), dtype=complex) if gradient and uniform else None
        # D_j = (1 / k_j - 1 / K) / w_j: d D_j / d K on every spring of the supports
        dKD = ok[None] / (K[:, None, None] ** 2 * np.tile(wsp, m_sup)[None, None, :])
        products = self._products_for(K, U, pairs)
        for i0 in range(0, nf, step):
            f = slice(i0, min(nf, i0 + step))
            pre = products.setdefault((f.start, f.stop), {})
            out = self._block(f, K[f], D[f], Vu[f], Vc[f], pairs, sel, pos, ia, ip,
                              gradient, uniform, pre)
            u[f] = out[0]
            if gradient:
                nb = out[0].shape[0]
                du[f] = (out[1] * dk[f][:, None]).reshape(nb, n_out, n_pair, m_sup, k).sum(-1)
            if duK is not None:
                duK[f] = out[2] + (out[1] * dKD[f][:, None]).sum(-1)
        if duK is not None:
            return u, du, duK
        return (u, du) if gradient else u

    def _uniform(self, f, K, Vu, Vc, sel, pre: dict) -> dict:
        """The uniform track's part of a block (``pre``, filled once per K): u0, C on the
        springs U (MU), a = alpha_rs M0^-1 E (R), b = E^T M0^-1 alpha_sP (Q)."""
        if "MU" not in pre:
            nb, n_out = len(K), self.direct.shape[1]
            Kh = K[:, None] / (1.0 + K[:, None] * self.lam[f])  # (nb, n)
            GV = self.GV[f][:, :, sel]  # (nb, o, pair, n)
            VB = self.VB[f][:, :, sel]  # (nb, n, pair)
            n_pair = VB.shape[2]
            KVc, KVB = Kh[:, :, None] * Vc, Kh[:, :, None] * VB
            pre["u0"] = self.direct[f][:, :, sel] - np.einsum("fopn,fnp->fop", GV, KVB)
            GV = GV.reshape(nb, n_out * n_pair, -1)
            pre["MU"] = Vu @ KVc  # (nb, u, u)
            pre["R"] = (GV @ KVc).reshape(nb, n_out, n_pair, -1)
            pre["Q"] = np.swapaxes(Vu @ KVB, 1, 2)  # (nb, pair, u)
        return pre

    def _uniform_dK(self, f, K, Vu, Vc, sel, pre: dict) -> dict:
        """d/dK of the uniform part (D held): Kh -> h^2 = 1 / (1 + K lam)^2 in u0, C, a and
        b (``pre``, filled once per K)."""
        if "dMU" not in pre:
            nb, n_out = len(K), self.direct.shape[1]
            h2 = 1.0 / (1.0 + K[:, None] * self.lam[f]) ** 2
            GV = self.GV[f][:, :, sel]  # (nb, o, pair, n)
            VB = self.VB[f][:, :, sel]  # (nb, n, pair)
            n_pair = VB.shape[2]
            HVc, HVB = h2[:, :, None] * Vc, h2[:, :, None] * VB
            pre["dR"] = (GV.reshape(nb, n_out * n_pair, -1) @ HVc).reshape(nb, n_out,
                                                                            n_pair, -1)
            pre["dQ"] = np.swapaxes(Vu @ HVB, 1, 2)
            pre["dMU"] = Vu @ HVc
            pre["du0"] = np.einsum("fopn,fnp->fop", GV, HVB)
        return pre

    def _block(self, f, K, D, Vu, Vc, pairs, sel, pos, ia, ip, gradient, uniform=False,
               pre=None):
        """receptance at the frequencies ``f`` (a slice): (u, d u / d D or None, d u / d K
        through the uniform coupling, D held, or None). Pairs
        on the same re-centred supports (equal shift) share their update matrix
        A = I + D C: one factorisation serves them all, and the tangents' transposed solve
        comes from it as well (A^-T a = a - C A^-1 D a, C = C^T to round-off). ``pre``:
        the uniform part at this K (_uniform), kept between calls."""
        nb, n_out, n_pair = len(K), self.direct.shape[1], len(pairs)
        pre = self._uniform(f, K, Vu, Vc, sel, {} if pre is None else pre)
        u0, MU, R, Q = pre["u0"], pre["MU"], pre["R"], pre["Q"]
        p = np.arange(n_pair)[:, None]
        pa = pos[:, ia]
        Da = D[:, :, ia]
        _, rep, grp = np.unique(self.shift[pairs], return_index=True, return_inverse=True)
        slot = np.array([np.count_nonzero(grp[:j] == grp[j]) for j in range(n_pair)], int)
        n_g, n_slot, m_a = len(rep), int(slot.max()) + 1 if n_pair else 1, len(ia)
        pg = pa[rep]
        C = MU[:, pg[:, :, None], pg[:, None, :]]  # (nb, group, m_a, m_a)
        Ct = np.swapaxes(C, -1, -2)
        A = Da[:, rep, :, None] * C
        A[..., np.arange(m_a), np.arange(m_a)] += 1.0
        a, b = R[:, :, p, pa], Q[:, p, pa]  # (nb, o, pair, m_a), (nb, pair, m_a)
        ncol = 1 + (n_out if gradient else 0)
        rhs = np.zeros((nb, n_g, n_slot, ncol, m_a), dtype=complex)
        rhs[:, grp, slot, 0] = Da * b
        if gradient:
            rhs[:, grp, slot, 1:] = Da[:, :, None] * np.moveaxis(a, 1, 2)
        # groups of equal size solved together: no solves of the padding slots
        classes = [(np.flatnonzero(np.bincount(grp, minlength=n_g) == c), c)
                   for c in np.unique(np.bincount(grp, minlength=n_g))]
        z = np.zeros_like(rhs)
        for g_c, c in classes:
            r = rhs[:, g_c, :c].reshape(nb, len(g_c), c * ncol, m_a)
            z[:, g_c, :c] = np.swapaxes(np.linalg.solve(A[:, g_c], np.swapaxes(r, -1, -2)),
                                        -1, -2).reshape(nb, len(g_c), c, ncol, m_a)

        def gmul(x, m):  # x (nb, group, slot, ..., m_a) @ m (nb, group, m_a, q), by class
            out = np.zeros(x.shape[:-1] + (m.shape[-1],), dtype=complex)
            for g_c, c in classes:
                xc = x[:, g_c, :c]
                rows = int(np.prod(xc.shape[2:-1]))  # explicit: m_a may be 0
                out[:, g_c, :c] = (xc.reshape(nb, len(g_c), rows, m_a) @ m[:, g_c]).reshape(
                    xc.shape[:-1] + (m.shape[-1],))
            return out

        y = z[:, grp, slot, 0]  # (nb, pair, m_a)
        u = u0 + np.einsum("fopm,fpm->fop", a, y)
        if not gradient:
            return u, None, None

        def per_pair(x):  # (nb, group, slot, ...) -> (nb, pair, ...)
            return x[:, grp, slot]

        # du/dD_j = [(I + D C)^-T a]_j (b - C y)_j; for a spring with D_j = 0 the first
        # factor is a_j - sum_k C_kj D_k w_k (k active) and y_j = 0
        zy = z[:, :, :, 0]  # (nb, group, slot, m_a)
        Cy = per_pair(gmul(zy, Ct))
        CzA = per_pair(gmul(z[:, :, :, 1:], Ct))
        w = np.moveaxis(np.moveaxis(a, 1, 2) - CzA, 2, 1)  # (nb, o, pair, m_a)
        dD = np.empty((nb, n_out, n_pair, pos.shape[1]), dtype=complex)
        dD[..., ia] = w * (b - Cy)[:, None]
        if len(ip):
            pp_ = pos[:, ip]
            ppg = pp_[rep]
            C_ap = MU[:, pg[:, :, None], ppg[:, None, :]]
            C_pa = MU[:, ppg[:, :, None], pg[:, None, :]]  # (nb, group, m_p, m_a)
            wD = np.zeros((nb, n_g, n_slot, n_out, m_a), dtype=complex)
            wD[:, grp, slot] = np.moveaxis(w * Da[:, None], 1, 2)
            wC = per_pair(gmul(wD, C_ap))  # (nb, pair, o, m_p)
            w_p = R[:, :, p, pp_] - np.moveaxis(wC, 2, 1)
            Cpy = per_pair(gmul(zy, np.swapaxes(C_pa, -1, -2)))
            dD[..., ip] = w_p * (Q[:, p, pp_] - Cpy)[:, None]
        if not uniform:
            return u, dD, None
        # d/dK with D held: du = du0 + da y + (w D) (db - dC y)
        pre = self._uniform_dK(f, K, Vu, Vc, sel, pre)
        dR, dQ, dMU, du0 = pre["dR"], pre["dQ"], pre["dMU"], pre["du0"]
        dCy = per_pair(gmul(zy, np.swapaxes(dMU[:, pg[:, :, None], pg[:, None, :]], -1, -2)))
        duK = (np.einsum("fopm,fpm->fop", dR[:, :, p, pa], y) - du0
               + np.einsum("fopm,fpm->fop", w * Da[:, None], dQ[:, p, pa] - dCy))
        return u, dD, duK
