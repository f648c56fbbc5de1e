"""The model at a record's geometry, for any spec an effect produces, cheaply.

* uniform discrete tracks (wfe-discrete, timoshenko-discrete): one parameter-free kernel
  per (rail loss factor, pad length) and record, covering at once every geometry shift the
  candidate effects ask for (sensor and hammer position errors), in the eigen form of the
  coupling (railfem.identify.spectral): a support change, a pad law or a rail absorber then
  costs a short sum per frequency (milliseconds);
* anything else (deviating supports, the periodic and continuous models): the door
  (railfem.models.receptance), whose kernels are cached by content, so a deviation change
  costs the coupling solve. Deviating supports need positions well inside the supported
  stretch: n_supports is raised so that 20 m of supports lie beyond every position.

It is the fit's forward model (railfem.identify.forward) with the diagnosis's options: the
record's own geometry uses the fit's SpectralEngine (same kernels, same content keys),
shifted geometries one checked eigen form (checked_coupling) over all of them, the door
its door_receptance; the eigen form is summed as a batched product, and a beam with
deviating supports gets a Woodbury update (Deviations) with closed-form derivatives.
"""
from __future__ import annotations

import logging
import math
from dataclasses import replace

import numpy as np

from railfem import models
from railfem.identify.forward import Geometry, SpectralEngine, checked_coupling, door_receptance
from railfem.identify.spectral import SpectralCoupling
from railfem.track.supports import SupportParameters, dynamic_stiffness

log = logging.getLogger(__name__)

MARGIN = 20.0  # m of supports beyond the outermost position of a track with deviations


def plain_support(p: SupportParameters) -> SupportParameters:
    """The support without the diagnosis hooks (what a kernel's check uses)."""
    return SupportParameters(kp=p.kp, eta_p=p.eta_p, ms=p.ms, kb=p.kb, eta_b=p.eta_b)


def shifted(record, shift) -> tuple[float, np.ndarray]:
    """(sensor x, force x) of ``record`` with the sensor moved by shift[0] and the hammer
    positions (not the point) by shift[1] (m)."""
    t = record.fit
    ds, dh = float(shift[0]), float(shift[1])
    sx = float(t.sensor_x) + ds
    pos = np.asarray(t.positions, dtype=float) + np.where(np.arange(len(t.positions)) > 0,
                                                          dh, 0.0)
    return sx, sx + pos


class Evaluator:
    """receptance(spec, record, shift) -> (nf, n_out, n_pos) m/N at the record's geometry.

    shifts: {record name: [(sensor shift, hammer shift), ...]} the geometry effects will
    ask for (one kernel serves them all); cache: the door's kernel cache."""

    def __init__(self, *, cache=False, shifts=None):
        self.cache = cache
        self.shifts = {k: sorted({(0.0, 0.0), *map(tuple, v)}) for k, v in
                       (shifts or {}).items()}
        self._banks: dict = {}
        self.n_kernels = 0

    def receptance(self, spec, record, shift=(0.0, 0.0)) -> np.ndarray:
        shift = (float(shift[0]), float(shift[1]))
        if spec.kind.is_discrete and spec.uniform:
            if shift == (0.0, 0.0):
                sc = self._plain(spec, record)
            else:
                shifts = self.shifts.get(record.name, [(0.0, 0.0)])
                if shift not in shifts:  # an unregistered shift: a kernel of its own
                    shifts = [(0.0, 0.0), shift]
                sc = self._bank(spec, record, tuple(shifts))[shift]
            a = sc.receptance(dynamic_stiffness(spec.support, 2 * np.pi * sc.frequency),
                              batched=True)
            n_out = len(record.fit.outputs)
            return np.repeat(a, n_out, axis=1) if a.shape[1] != n_out else a
        t = record.fit
        sx, fx = shifted(record, shift)
        if self._woodbury(spec, shift):
            return self._deviations(spec, record)
        if spec.deviations:
            need = int(2 * math.ceil((max(np.abs(fx).max(), abs(sx)) + MARGIN)
                                     / spec.spacing) + 1)
            if spec.n_supports < need:
                spec = spec.replace(n_supports=need)
        return door_receptance(spec, t.frequency, sx, fx, t.outputs, cache=self.cache)

    def tangents(self, spec, record, shift=(0.0, 0.0)):
        """(receptance, {(support index, 'kp' | 'kb'): d receptance / d ln factor}) of a
        beam track with deviating supports (the Woodbury path, exact derivatives), or None
        where that path does not serve the spec (a shift, pads in rows, a WFE rail)."""
        if not self._woodbury(spec, shift):
            return None
        return self._deviations(spec, record, gradient=True)

    @staticmethod
    def _woodbury(spec, shift) -> bool:
        """The Woodbury path serves a beam on point supports with deviations, unshifted,
        every deviating support keeping some stiffness (1/k enters the update)."""
        return (spec.is_beam and spec.kind.is_discrete and bool(spec.deviations)
                and tuple(map(float, shift)) == (0.0, 0.0) and spec.pad_length == 0
                and all(min(d.kp, d.kb) > 0 for d in spec.deviations))

    def _deviations(self, spec, record, gradient: bool = False):
        """A beam track with deviating supports: the uniform track's eigen form plus a
        rank-m (Woodbury) update; exact, see Deviations."""
        uni = spec.replace(deviations=())
        key = (record.geometry_key, "deviations", spec.model, float(spec.rail.eta),
               spec.spacing, spec.n_supports, spec.rail, spec.numerics)
        if key not in self._banks:
            t = record.fit
            canon = uni.replace(support=plain_support(uni.support))
            log.info("diagnosis: eigen form of the beam track for deviating supports "
                     "(%s, eta_r %.4g)", record.name, spec.rail.eta)
            kernel, jr, jf = models.discrete_kernel(canon, t.frequency, t.force_x,
                                                    [t.sensor_x], outputs=t.outputs,
                                                    cache=self.cache)
            self._banks[key] = Deviations(kernel, jr[0], jf[0], t.sensor_x, t.force_x,
                                          spec.spacing)
            self.n_kernels += 1
        w = 2 * np.pi * record.fit.frequency
        K = dynamic_stiffness(uni.support, w)
        k_dev = np.column_stack([dynamic_stiffness(d.apply(uni.support), w)
                                 for d in spec.deviations])
        n_out = len(record.fit.outputs)
        idx = [d.index for d in spec.deviations]
        if not gradient:
            a = self._banks[key].receptance(K, k_dev, idx)
            return np.repeat(a[:, None, :], n_out, axis=1)
        a, da = self._banks[key].receptance(K, k_dev, idx, gradient=True)
        h = 1e-7
        tangent = {}
        for j, d in enumerate(spec.deviations):
            for which in ("kp", "kb"):
                dk = (dynamic_stiffness(replace(d, **{which: getattr(d, which) * math.exp(h)})
                                        .apply(uni.support), w) - k_dev[:, j]) / h
                tangent[(d.index, which)] = np.repeat((da[:, :, j] * dk[:, None])[:, None],
                                                      n_out, axis=1)
        return np.repeat(a[:, None, :], n_out, axis=1), tangent

    def _plain(self, spec, record) -> SpectralCoupling:
        """The record's own geometry: railfem.identify's engine, so the kernel and its
        eigen form computed by the base fit are reused (same content keys)."""
        key = (record.geometry_key, "plain", spec.model, float(spec.rail.eta),
               float(spec.pad_length), spec.spacing, spec.n_rows, spec.n_supports,
               spec.rail, spec.numerics)
        if key not in self._banks:
            t = record.fit
            geo = Geometry(frequency=t.frequency, outputs=t.outputs, sensor_x=t.sensor_x,
                           force_x=t.force_x)
            log.info("diagnosis: kernel of %s for %s (eta_r %.4g, pad length %.3g m)",
                     spec.model, record.name, spec.rail.eta, spec.pad_length)
            canon = spec.replace(support=plain_support(spec.support))
            self._banks[key] = SpectralEngine(canon, geo, cache=self.cache).coupling
            self.n_kernels += 1
        return self._banks[key]

    def _bank(self, spec, record, shifts) -> dict:
        key = (record.geometry_key, shifts, spec.model, float(spec.rail.eta),
               float(spec.pad_length), spec.spacing, spec.n_rows, spec.n_supports, spec.rail,
               spec.numerics)
        if key in self._banks:
            return self._banks[key]
        t = record.fit
        geo = [shifted(record, s) for s in shifts]
        rx = np.unique(np.round([g[0] for g in geo], 10))
        fx = np.unique(np.round(np.concatenate([g[1] for g in geo]), 10))
        canon = spec.replace(support=plain_support(spec.support))
        log.info("diagnosis: kernel of %s for %s (eta_r %.4g, pad length %.3g m, %d "
                 "geometries)", spec.model, record.name, spec.rail.eta, spec.pad_length,
                 len(shifts))
        kernel, jr, jf = models.discrete_kernel(canon, t.frequency, fx, rx,
                                                outputs=t.outputs, cache=self.cache)
        self.n_kernels += 1
        pairs_r, pairs_f, sel = [], [], {}
        for s, (sx, f_) in zip(shifts, geo):
            r = int(np.searchsorted(rx, round(sx, 10)))
            c = np.searchsorted(fx, np.round(f_, 10))
            sel[s] = np.arange(len(pairs_r), len(pairs_r) + len(c))
            pairs_r += [jr[r, ci] for ci in c]
            pairs_f += [jf[r, ci] for ci in c]
        sc = checked_coupling(kernel, canon, np.array(pairs_r), np.array(pairs_f),
                              (canon.support,), t.frequency)
        bank = {s: SpectralCoupling(frequency=sc.frequency, lam=sc.lam,
                                    residue=sc.residue[..., idx], direct=sc.direct[..., idx])
                for s, idx in sel.items()}
        self._banks[key] = bank
        return bank


class Deviations:
    """A uniform beam track (one spring per support) with m supports' stiffnesses changed
    (Woodbury). With alpha_ss = V diag(lam) V^-1 (per frequency), K the uniform support's
    dynamic stiffness and M0 = I/K + alpha_ss, M0^-1 = V diag(K h) V^-1 with
    h = 1 / (1 + K lam). Changing the supports J to k_J is M = M0 + E D E^T,
    D = diag(1/k_J - 1/K), and

        u = alpha_rP - alpha_rs M^-1 alpha_sP
          = u_0 + a (I + D C)^-1 D b,   C = E^T M0^-1 E,  a = alpha_rs M0^-1 E,
                                        b = E^T M0^-1 alpha_sP

    (u_0 the uniform track; exact, any m, any factors including 0 change). Each hammer pair
    is solved on supports re-centred on it (railfem.models), so support J sits at kernel
    index centre + J - round((x_s + x_P) / 2d); a deviation outside a pair's window is
    left out for that pair."""

    def __init__(self, kernel, jr, jf, sensor_x, force_x, spacing):
        n_s = kernel.ss_index.shape[0]
        if len(kernel.spring_weight) != 1:
            raise ValueError("Deviations needs one spring per support (the beam)")
        nf = len(kernel.frequency)
        n_pair = len(jf)
        self.centre = (n_s - 1) // 2
        self.k = np.round((sensor_x + np.asarray(force_x)) / (2 * spacing)).astype(int)
        self.n_s = n_s
        self.lam = np.empty((nf, n_s), dtype=complex)
        self.VB = np.empty((nf, n_s, n_pair), dtype=complex)  # V^-1 alpha_sP (pairs)
        self.GV = np.empty((nf, n_pair, n_s), dtype=complex)  # alpha_rs V (pairs)
        self.direct = np.empty((nf, n_pair), dtype=complex)
        self.V = np.empty((nf, n_s, n_s), dtype=complex)
        self.Vinv = np.empty((nf, n_s, n_s), dtype=complex)
        for i in range(nf):
            A = kernel.ss[i][kernel.ss_index, 0, 0]
            B = kernel.sP[i][kernel.sP_index, 0][:, jf]
            G = kernel.rs[i][kernel.rs_index, 0, 0][jr, :]
            lam, V = np.linalg.eig(A)
            Vinv = np.linalg.inv(V)
            self.lam[i], self.V[i], self.Vinv[i] = lam, V, Vinv
            self.VB[i] = Vinv @ B
            self.GV[i] = G @ V
            self.direct[i] = kernel.rP[i][kernel.rP_index, 0][jr, jf]
        self._gathered: dict = {}

    def _gather(self, indices: tuple):
        """The kernel indices the deviating supports take over all pairs (their union U)
        and, per pair, where each one sits in U and whether it is inside the window."""
        if indices not in self._gathered:
            j = self.centre + np.asarray(indices)[None, :] - self.k[:, None]  # (pair, m)
            ok = (j >= 0) & (j < self.n_s)
            U, pos = np.unique(np.where(ok, j, 0), return_inverse=True)
            if len(self._gathered) > 64:
                self._gathered.clear()
            self._gathered[indices] = (U, pos.reshape(j.shape), ok)
        return self._gathered[indices]

    def receptance(self, K, k_dev, indices, gradient: bool = False):
        """(nf, n_pair) receptance with the supports ``indices`` (absolute) at dynamic
        stiffnesses k_dev (nf, m) and all others at K (nf,); with ``gradient`` also its
        derivative with respect to each k_dev, (nf, n_pair, m)."""
        K = np.asarray(K, dtype=complex)[:, None]
        Kh = K / (1.0 + K * self.lam)  # (nf, n)
        u0 = self.direct - np.einsum("fpm,fm,fmp->fp", self.GV, Kh, self.VB)
        U, pos, ok = self._gather(tuple(int(i) for i in indices))
        VU = self.V[:, U, :] * Kh[:, None, :]  # (nf, u, n): rows U of V diag(K h)
        VinvU = self.Vinv[:, :, U]  # (nf, n, u)
        MU = VU @ VinvU  # M0^-1 on U x U
        R = (self.GV * Kh[:, None, :]) @ VinvU  # alpha_rs M0^-1, columns U (nf, pair, u)
        Q = VU @ self.VB  # M0^-1 alpha_sP, rows U (nf, u, pair)
        p = np.arange(pos.shape[0])[:, None]
        C = MU[:, pos[:, :, None], pos[:, None, :]]  # (nf, pair, m, m)
        a = R[:, p, pos]  # (nf, pair, m)
        b = np.swapaxes(Q, 1, 2)[:, p, pos]  # (nf, pair, m)
        D = (1.0 / np.asarray(k_dev, dtype=complex) - 1.0 / K)[:, None, :] * ok[None]
        m = D.shape[-1]
        A = np.eye(m) + D[..., :, None] * C
        y = np.linalg.solve(A, (D * b)[..., None])[..., 0]
        u = u0 + np.einsum("fpm,fpm->fp", a, y)
        if not gradient:
            return u
        # du/dD_j = [(I + D C)^-T a]_j (b - C y)_j; D_j = 1/k_j - 1/K
        w = np.linalg.solve(np.swapaxes(A, -1, -2), a[..., None])[..., 0]
        du_dD = w * (b - (C @ y[..., None])[..., 0])
        return u, -du_dD * ok[None] / np.asarray(k_dev, dtype=complex)[:, None, :] ** 2
