"""The model at a record's geometry, for any spec an effect produces, cheaply.

* uniform discrete tracks (wfe-discrete, timoshenko-discrete): one parameter-free kernel
  per (rail loss factor, pad length) and record, covering at once every geometry shift the
  candidate effects ask for (sensor and hammer position errors), in the eigen form of the
  coupling (railfem.identify.spectral): a support change, a pad law or a rail absorber then
  costs a short sum per frequency (milliseconds);
* deviating supports on a discrete track (beam or WFE rail): the record's own kernel in a
  Woodbury form (railfem.track.woodbury.SupportUpdate): the uniform coupling's eigen form
  plus a low-rank update of rank (springs of the deviating supports), with closed-form
  derivatives; each pair on its re-centred supports as for the uniform track;
* anything else (a shifted geometry with deviations, lateral springs, the periodic and
  continuous models): the door (railfem.models.receptance), whose kernels are cached by
  content, so a deviation change costs the coupling solve. Deviating supports need
  positions well inside the supported stretch: n_supports is raised so that 20 m of
  supports lie beyond every position.

A lateral record (a lateral decay rate, channel 'head_lateral': railfem.diagnosis.data)
goes through the door with the lateral hammer (``lateral_receptance``), on supports acting
vertically and laterally whose lateral chain follows the base's vertical one by the
presets' rule (``lateral_spec``). The periodic WFE track (wfe-periodic) is the model for
it: one kernel (about 7 s on the shipped 10 mm mesh, 54 frequencies) and then about 0.05 s
per evaluation, where the discrete WFE track's lateral kernel takes about a minute and the
continuous WFE track about 11 s per evaluation (benchmarks/results/results_sbb_lateral.md).

It is the fit's forward model (railfem.identify.forward) with the diagnosis's options: the
record's own geometry uses the fit's SpectralEngine (same kernels, same content keys),
shifted geometries one checked eigen form (checked_coupling) over all of them, the door
its door_receptance; the eigen form is summed as a batched product, and a track with
deviating supports gets a Woodbury update (SupportUpdate) with closed-form derivatives.
"""
from __future__ import annotations

import logging
import math
from collections import OrderedDict
from contextlib import contextmanager
from dataclasses import replace

import numpy as np

from railfem import models
from railfem.diagnosis.data import is_lateral
from railfem.identify.forward import (Geometry, SpectralEngine, checked_coupling,
                                      door_receptance, spectral_key)
from railfem.identify.spectral import SpectralCoupling
from railfem.track import kernelcache
from railfem.track.coupling import couple_discrete
from railfem.track.woodbury import SupportUpdate
from railfem.track.sleeper import CASES as LOAD_CASES
from railfem.track.supports import SupportParameters, dynamic_stiffness, horizontal_support

log = logging.getLogger(__name__)

MARGIN = 20.0  # m of supports beyond the outermost position of a track with deviations
DOOR_MEMO = 8  # door evaluations kept by Evaluator._door (records x specs)
MAX_UPDATE_BYTES = 1e9  # Woodbury forms kept (records x rail loss factors): (springs)^2 each


def plain_support(p: SupportParameters) -> SupportParameters:
    """The support without the diagnosis hooks (pad laws, absorber: what a kernel's check
    uses); every other option (horizontal chains, sleeper, ballast mass) is kept."""
    return replace(p, pad_laws=(), absorber=None)


def shifted(record, shift) -> tuple[float, np.ndarray]:
    """(sensor x, force x) of ``record`` with the sensor moved by shift[0] and the hammer
    positions (not the point) by shift[1] (m)."""
    t = record.fit
    ds, dh = float(shift[0]), float(shift[1])
    sx = float(t.sensor_x) + ds
    pos = np.asarray(t.positions, dtype=float) + np.where(np.arange(len(t.positions)) > 0,
                                                          dh, 0.0)
    return sx, sx + pos


def lateral_spec(spec):
    """The track a lateral record is evaluated on: ``spec`` with supports acting vertically
    and laterally (support_directions with 'y') and its lateral chain following the
    vertical one by the presets' rule (railfem.track.supports.horizontal_support: lateral
    pad kp / 7 with the pad's loss factor, the sleeper's lateral ballast support kb / 2
    with the ballast's, the sleeper mass moving with the rail), so the base's pad and
    ballast parameters calibrate the lateral chain on lateral data. The fastening's grip
    (k_roll, k_clip) and the vertical options are kept."""
    sup = spec.support
    dirs = spec.support_directions if "y" in spec.support_directions else \
        spec.support_directions + "y"
    return spec.replace(support_directions="".join(d for d in "zyx" if d in dirs),
                        **horizontal_support(sup.kp, sup.eta_p, sup.kb, sup.eta_b, sup.ms))


def lateral_receptance(spec, record, shift=(0.0, 0.0), cache=False) -> np.ndarray:
    """(nf, 1, n_pos) lateral receptance (m/N) of ``record``'s EN 15461 test on the track
    ``lateral_spec(spec)``: lateral hammer and sensor on the side of the head, through the
    door (its kernels are cached by content: a support change costs the coupling). A track
    with deviating supports gets supports well beyond every position (MARGIN)."""
    spec = lateral_spec(spec)
    t = record.fit
    sx, fx = shifted(record, shift)
    if spec.deviations:
        spec = with_margin(spec, sx, fx)
    return door_receptance(spec, t.frequency, sx, fx, t.outputs, force="head_lateral",
                           cache=cache)


def with_margin(spec, sx, fx):
    """``spec`` with at least MARGIN m of supports beyond the sensor ``sx`` and the forces
    ``fx`` (m)."""
    need = int(2 * math.ceil((max(np.abs(fx).max(), abs(sx)) + MARGIN) / spec.spacing) + 1)
    return spec.replace(n_supports=need) if spec.n_supports < need else spec


def base_tangents(spec, w, da, daK, h: float = 1e-6) -> dict:
    """{('base', name): d receptance / d ln name} of the support parameters kp, eta_p, kb,
    eta_b of a track with deviating supports, from SupportUpdate's d/dK of the uniform
    supports (daK) and d/dk of each deviating one (da): each parameter moves both."""
    uni = spec.replace(deviations=())

    def stiffness(name, f):
        s = replace(uni.support, **{name: getattr(uni.support, name) * f})
        return dynamic_stiffness(s, w), np.column_stack(
            [dynamic_stiffness(d.apply(s), w) for d in spec.deviations])

    out = {}
    for name in ("kp", "eta_p", "kb", "eta_b"):
        (Kp, kp), (Km, km) = stiffness(name, math.exp(h)), stiffness(name, math.exp(-h))
        out[("base", name)] = (daK * ((Kp - Km) / (2 * h))[:, None, None]
                               + np.einsum("fopj,fj->fop", da, (kp - km) / (2 * h)))
    return out


class Evaluator:
    """receptance(spec, record, shift) -> (nf, n_out, n_pos) m/N at the record's geometry.

    shifts: {record name: [(sensor shift, hammer shift), ...]} the geometry effects will
    ask for (one kernel serves them all); cache: the door's kernel cache."""

    def __init__(self, *, cache=False, shifts=None):
        self.cache = cache
        self.shifts = {k: sorted({(0.0, 0.0), *map(tuple, v)}) for k, v in
                       (shifts or {}).items()}
        self._banks: dict = {}
        self._updates: OrderedDict = OrderedDict()
        self.n_kernels = 0
        self.screening = False  # see screen()
        self._held: dict = {}  # kernels evaluated by the coupling solve while screening
        self._door_memo: OrderedDict = OrderedDict()  # see _door()

    @contextmanager
    def screen(self):
        """Within: a record's own kernel that has no eigen form yet is evaluated by the
        coupling solve and kept (a grid value a refit screens once and does not refit never
        costs the eigen form: about a second per WFE kernel); its next evaluation builds
        the eigen form from it, as without screening. The two agree to the eigen form's
        check (railfem.identify.forward.SPECTRAL_TOLERANCE, round-off in practice)."""
        before, self.screening = self.screening, True
        try:
            yield
        finally:
            self.screening = before

    def receptance(self, spec, record, shift=(0.0, 0.0)) -> np.ndarray:
        shift = (float(shift[0]), float(shift[1]))
        if spec.rails == 2:  # two rails: the mean of the in- and anti-phase tracks
            a_s, a_a = (self.receptance(spec.load_case(c), record, shift) for c in LOAD_CASES)
            return (a_s + a_a) / 2
        if is_lateral(record):
            return self._door(spec, record, shift,
                              lambda: lateral_receptance(spec, record, shift, self.cache))
        if spec.kind.is_discrete and spec.uniform:
            a = self._screened(spec, record) if self.screening and shift == (0.0, 0.0) \
                else None
            if a is None:
                sc = self._coupling(spec, record, shift)
                a = sc.receptance(dynamic_stiffness(spec.support, 2 * np.pi * sc.frequency),
                                  batched=True)
            n_out = len(record.fit.outputs)
            return np.repeat(a, n_out, axis=1) if a.shape[1] != n_out else a
        t = record.fit
        sx, fx = shifted(record, shift)
        if self._woodbury(spec, shift):
            return self._deviations(spec, record, shift)
        if spec.deviations:
            need = int(2 * math.ceil((max(np.abs(fx).max(), abs(sx)) + MARGIN)
                                     / spec.spacing) + 1)
            if spec.n_supports < need:
                spec = spec.replace(n_supports=need)
        return self._door(spec, record, shift, lambda: door_receptance(
            spec, t.frequency, sx, fx, t.outputs, cache=self.cache))

    def _door(self, spec, record, shift, compute) -> np.ndarray:
        """compute() (the door: a coupling solve each call) once per spec and geometry:
        records of one geometry (the two rails of a section, repeats) at the same spec get
        the same values, a copy each (the last DOOR_MEMO evaluations kept)."""
        t = record.fit
        key = (spec, shift, is_lateral(record), float(t.sensor_x), tuple(t.outputs),
               np.asarray(t.frequency, dtype=float).tobytes(),
               np.asarray(t.positions, dtype=float).tobytes())
        try:
            a = self._door_memo.get(key)
        except TypeError:  # a spec with an unhashable field: evaluated each time
            return compute()
        if a is None:
            a = self._door_memo[key] = compute()
            while len(self._door_memo) > DOOR_MEMO:
                self._door_memo.popitem(last=False)
        else:
            self._door_memo.move_to_end(key)
        return a.copy()

    def receptance_once(self, spec, record, shift=(0.0, 0.0)) -> np.ndarray:
        """receptance(spec, record, shift) for a spec evaluated once (a discrepancy
        variant, railfem.identify.discrepancy.ensemble): a uniform discrete track's kernel
        without an eigen form is evaluated by the coupling solve (as while screening,
        screen()) and not kept, so the eigen form (about a second per WFE kernel) is built
        only for specs evaluated again. The two agree to round-off (2e-14 relative on the
        WFE variants)."""
        before = set(self._held)
        with self.screen():
            a = self.receptance(spec, record, shift)
        for key in set(self._held) - before:
            del self._held[key]
        return a

    def tangents(self, spec, record, shift=(0.0, 0.0)):
        """(receptance, {(support index, 'kp' | 'kb'): d receptance / d ln factor}) of a
        discrete track with deviating supports (the Woodbury path, exact derivatives), or
        None where that path does not serve the spec (lateral springs, two rails)."""
        shift = (float(shift[0]), float(shift[1]))
        if is_lateral(record) or not self._woodbury(spec, shift):
            return None
        return self._deviations(spec, record, shift, gradient=True)

    @staticmethod
    def _woodbury(spec, shift) -> bool:
        """The Woodbury path serves a single-rail discrete track (beam or WFE rail, point
        supports or pads in rows) with deviations and vertical springs, at any registered
        geometry shift, every deviating support keeping some stiffness (1/k enters the
        update)."""
        return (spec.kind.is_discrete and bool(spec.deviations) and spec.rails == 1
                and spec.support_directions == "z"
                and all(min(d.kp, d.kb) > 0 for d in spec.deviations))

    def _update(self, spec, record, shift):
        """(the Woodbury form of the uniform track of ``spec``, the pairs of ``shift``):
        the record's own kernel (the one the base fit computed) unshifted, else the
        kernel of every shift registered for the record (the one _bank uses)."""
        shifts = ((0.0, 0.0),) if shift == (0.0, 0.0) else \
            tuple(self.shifts.get(record.name, [(0.0, 0.0)]))
        if shift not in shifts:  # an unregistered shift: a kernel of its own
            shifts = ((0.0, 0.0), shift)
        key = (record.geometry_key, shifts, "deviations", spec.model, float(spec.rail.eta),
               float(spec.pad_length), spec.n_rows, spec.spacing, spec.n_supports,
               spec.rail, spec.numerics)
        if key in self._updates:
            self._updates.move_to_end(key)
            su, sel = self._updates[key]
            return su, sel[shift]
        t = record.fit
        canon = spec.replace(deviations=(), support=plain_support(spec.support))
        log.info("diagnosis: Woodbury form of the %s track for deviating supports (%s, "
                 "eta_r %.4g, %d geometries)", spec.model, record.name, spec.rail.eta,
                 len(shifts))
        geo = [shifted(record, s) for s in shifts]
        rx = np.unique(np.round([g[0] for g in geo], 10))
        fx = np.unique(np.round(np.concatenate([g[1] for g in geo]), 10))
        if len(shifts) == 1:  # the record's own geometry: the base fit's kernel
            rx, fx = [t.sensor_x], t.force_x
        kernel, jr, jf = models.discrete_kernel(canon, t.frequency, fx, rx,
                                                outputs=t.outputs, cache=self.cache)
        pr, pf, sel, centre = [], [], {}, []
        for s, (sx, f_) in zip(shifts, geo):
            r = 0 if len(shifts) == 1 else int(np.searchsorted(rx, round(sx, 10)))
            c = np.arange(len(f_)) if len(shifts) == 1 else \
                np.searchsorted(fx, np.round(f_, 10))
            sel[s] = np.arange(len(pr), len(pr) + len(c))
            pr += [jr[r, ci] for ci in c]
            pf += [jf[r, ci] for ci in c]
            centre += list(np.round((sx + np.asarray(f_)) / (2 * spec.spacing)).astype(int))
        su = SupportUpdate(kernel, canon.layout().springs().weight, np.array(pr),
                           np.array(pf), np.array(centre), n_rows=spec.n_rows)
        self._updates[key] = (su, sel)
        self.n_kernels += 1
        while (len(self._updates) > 1  # each holds (springs)^2 per frequency
               and sum(u.nbytes for u, _ in self._updates.values()) > MAX_UPDATE_BYTES):
            self._updates.popitem(last=False)
        return su, sel[shift]

    def _deviations(self, spec, record, shift, gradient: bool = False):
        """A discrete track with deviating supports: the uniform track's eigen form plus
        a low-rank (Woodbury) update (railfem.track.woodbury.SupportUpdate); exact."""
        su, pairs = self._update(spec, record, shift)
        uni = spec.replace(deviations=())
        w = 2 * np.pi * record.fit.frequency
        K = dynamic_stiffness(uni.support, w)
        k_dev = np.column_stack([dynamic_stiffness(d.apply(uni.support), w)
                                 for d in spec.deviations])
        n_out = len(record.fit.outputs)
        idx = [d.index for d in spec.deviations]

        def fit(a):
            return np.repeat(a, n_out, axis=1) if a.shape[1] != n_out else a

        if not gradient:
            return fit(su.receptance(K, k_dev, idx, pairs=pairs))
        a, da, daK = su.receptance(K, k_dev, idx, gradient=True, pairs=pairs, uniform=True)
        h = 1e-7
        tangent = {}
        for j, d in enumerate(spec.deviations):
            for which in ("kp", "kb"):
                dk = (dynamic_stiffness(replace(d, **{which: getattr(d, which) * math.exp(h)})
                                        .apply(uni.support), w) - k_dev[:, j]) / h
                tangent[(d.index, which)] = fit(da[..., j] * dk[:, None, None])
        tangent.update({k: fit(v) for k, v in base_tangents(spec, w, da, daK).items()})
        return fit(a), tangent

    def _coupling(self, spec, record, shift) -> SpectralCoupling:
        """The eigen form of a uniform discrete track at the record's geometry shifted by
        ``shift``."""
        if shift == (0.0, 0.0):
            return self._plain(spec, record)
        shifts = self.shifts.get(record.name, [(0.0, 0.0)])
        if shift not in shifts:  # an unregistered shift: a kernel of its own
            shifts = [(0.0, 0.0), shift]
        return self._bank(spec, record, tuple(shifts))[shift]

    @staticmethod
    def _plain_key(spec, record) -> tuple:
        return (record.geometry_key, "plain", spec.model, float(spec.rail.eta),
                float(spec.pad_length), spec.spacing, spec.n_rows, spec.n_supports,
                spec.rail, spec.numerics)

    @staticmethod
    def _geometry(record) -> Geometry:
        t = record.fit
        return Geometry(frequency=t.frequency, outputs=t.outputs, sensor_x=t.sensor_x,
                        force_x=t.force_x)

    def _screened(self, spec, record):
        """The record's own geometry while screening (screen()): the receptance by the
        coupling solve of its kernel (kept for the eigen form), or None where the eigen
        form is at hand or this kernel was screened before (the eigen form then pays)."""
        key = self._plain_key(spec, record)
        if key in self._banks or key in self._held or spec.support_directions != "z":
            return None
        canon = spec.replace(support=plain_support(spec.support))
        geo = self._geometry(record)
        if kernelcache.resolve(self.cache).get(spectral_key(canon, geo)) is not None:
            return None
        log.info("diagnosis: kernel of %s for %s (eta_r %.4g, pad length %.3g m), screened "
                 "by the coupling solve", spec.model, record.name, spec.rail.eta,
                 spec.pad_length)
        held = models.discrete_kernel(canon, geo.frequency, geo.force_x, [geo.sensor_x],
                                      outputs=geo.outputs, cache=self.cache)
        self._held[key] = held
        self.n_kernels += 1
        kernel, jr, jf = held
        K = dynamic_stiffness(spec.support, 2 * np.pi * geo.frequency)
        pattern = canon.layout().springs().weight
        return couple_discrete(kernel, K[:, None] * pattern[None, :])[:, :, jr[0], jf[0]]

    def _plain(self, spec, record) -> SpectralCoupling:
        """The record's own geometry: railfem.identify's engine, so the kernel and its
        eigen form computed by the base fit are reused (same content keys)."""
        key = self._plain_key(spec, record)
        if key not in self._banks:
            held = self._held.pop(key, None)
            if held is None:
                log.info("diagnosis: kernel of %s for %s (eta_r %.4g, pad length %.3g m)",
                         spec.model, record.name, spec.rail.eta, spec.pad_length)
                self.n_kernels += 1
            canon = spec.replace(support=plain_support(spec.support))
            self._banks[key] = SpectralEngine(canon, self._geometry(record),
                                              cache=self.cache, kernel=held).coupling
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
