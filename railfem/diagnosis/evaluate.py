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
"""
from __future__ import annotations

import logging
import math

import numpy as np

from railfem import models
from railfem.identify.spectral import SpectralCoupling, check, spectral_coupling
from railfem.supports import SupportParameters, dynamic_stiffness

log = logging.getLogger(__name__)

UNIFORM = ("wfe-discrete", "timoshenko-discrete")
MARGIN = 20.0  # m of supports beyond the outermost position of a track with deviations
SPECTRAL_TOLERANCE = 1e-8


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
        if spec.model in UNIFORM and spec.uniform:
            shifts = self.shifts.get(record.name, [(0.0, 0.0)])
            if shift not in shifts:  # an unregistered shift: a kernel of its own
                shifts = [(0.0, 0.0), shift]
            sc = self._bank(spec, record, tuple(shifts))[shift]
            a = sc.receptance(dynamic_stiffness(spec.support, 2 * np.pi * sc.frequency))
            n_out = len(record.fit.outputs)
            return np.repeat(a, n_out, axis=1) if a.shape[1] != n_out else a
        t = record.fit
        sx, fx = shifted(record, shift)
        if spec.deviations:
            need = int(2 * math.ceil((max(np.abs(fx).max(), abs(sx)) + MARGIN)
                                     / spec.spacing) + 1)
            if spec.n_supports < need:
                spec = spec.replace(n_supports=need)
        a = models.receptance(spec, t.frequency, fx, [sx], outputs=t.outputs,
                              cache=self.cache)
        return a[:, :, 0, :]

    def _bank(self, spec, record, shifts) -> dict:
        key = (record.geometry_key, shifts, spec.model, float(spec.rail.eta), float(spec.pad_length),
               spec.spacing, spec.n_rows, spec.n_supports, spec.rail.profile, spec.rail.h,
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
        pattern = canon.layout().springs().weight
        pairs_r, pairs_f, sel = [], [], {}
        for s, (sx, f_) in zip(shifts, geo):
            r = int(np.searchsorted(rx, round(sx, 10)))
            c = np.searchsorted(fx, np.round(f_, 10))
            sel[s] = np.arange(len(pairs_r), len(pairs_r) + len(c))
            pairs_r += [jr[r, ci] for ci in c]
            pairs_f += [jf[r, ci] for ci in c]
        sc = spectral_coupling(kernel, pattern, np.array(pairs_r), np.array(pairs_f))
        omega = 2 * np.pi * t.frequency
        err = check(sc, kernel, pattern, np.array(pairs_r), np.array(pairs_f),
                    dynamic_stiffness(canon.support, omega))
        if err > SPECTRAL_TOLERANCE:
            raise RuntimeError(f"the eigen form of the coupling differs from the direct "
                               f"solve by {err:.1e} for {spec.model}")
        bank = {s: SpectralCoupling(frequency=sc.frequency, lam=sc.lam,
                                    residue=sc.residue[..., idx], direct=sc.direct[..., idx])
                for s, idx in sel.items()}
        self._banks[key] = bank
        return bank
