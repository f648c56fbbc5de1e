"""The least-squares problem of a diagnosis: the residuals (model - measurement, dB) of a
base track plus candidate effects on the fitted (or held-out) part of every record.

The problem is railfem.identify.problem.Problem (the one the fit uses) with an
EffectModel: the vector holds the base parameters (kp, eta_p, kb, eta_b: log10 of SI,
bounds of railfem.identify.fit.FIT_BOUNDS) and each effect's continuous parameters (named
``effect.parameter``); grid parameters are fixed per model. Residuals are the used entries
of every record (railfem.identify.problem.used_rows), divided by a fixed scale per quantity
(``noise_scale``: the white-noise level of the base fit's residual from the median
absolute deviation of its first differences, at least 0.1 dB), so every model is scored on
the same footing; random effects add their prior rows. The scale carries the model-form
discrepancy of the base at its fitted parameters (railfem.identify.discrepancy.ensemble;
an entry's scale is sqrt(noise^2 + s_d^2) of its band), so bands the model cannot predict
weigh less and the gates judge against noise plus discrepancy. What an effect leaves
unfitted (the support factors outside a random effect's window, the spec values it
assumes) enters the intervals only, as random terms (EffectModel.unfitted_tangents).
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field, replace

import numpy as np

from railfem.identify import discrepancy as model_form
from railfem.identify import problem as core
from railfem.identify.base import ETA_R_RANGE, eta_r_prior
from railfem.identify.fit import FIT_BOUNDS
from railfem.identify.problem import Box, Prediction, table
from railfem.params import Parameter
from railfem.spec import SupportDeviation

log = logging.getLogger(__name__)

BASE = ("kp", "eta_p", "kb", "eta_b")
MIN_SCALE = 0.1  # dB

#: the label's suffix of a variant evaluated on a chosen model (model_scale)
MODEL_VARIANT = " (chosen model)"

#: decades either side of an effect's assumed value: its receptance tangent's central
#: difference. The tangent is linearised in the receptance (Problem.unfitted_jacobian), so
#: it must be local: near a resonance a step of 0.05 decades (a secant across it) put the
#: residual's column 26 % from its derivative (tests/test_unfitted_spec.py), 0.001 puts
#: it 1e-4 from it and stays far above the solvers' round-off
ASSUMED_STEP = 1e-3

#: the model-form discrepancy by default: 'ensemble' (railfem.identify.discrepancy) or None
DISCREPANCY = "ensemble"

__all__ = ["BASE", "Box", "DISCREPANCY", "EffectModel", "MIN_SCALE", "Prediction", "Problem",
           "base_parameters", "model_scale", "noise_scale", "regrid", "table"]


def base_parameters(bounds=None) -> list[Parameter]:
    b = dict(FIT_BOUNDS, **(bounds or {}))
    return [Parameter(name=n, unit="-" if n.startswith("eta") else "N/m", log=True,
                      lower=b[n][0], upper=b[n][1]) for n in BASE]


def Problem(*, data, evaluator, spec, effects=(), grid=None, scale=None,  # noqa: N802
            bounds=None, assumed=None) -> core.Problem:
    """The diagnosis's problem: railfem.identify.problem.Problem of base ``spec`` (its rail
    loss factor used as is) + ``effects`` (grid values ``grid``: {(effect, name): value})
    on the records of ``data``, scaled by ``scale`` (a constructor named as what it
    builds). ``assumed``: {(effect, name): value} of the effects' assumed values
    (Effect.assumed) for an envelope over their range (railfem.diagnosis.envelope): the
    values set, their linearised terms left out of the intervals (None: the declared
    values, their terms in)."""
    model = EffectModel(data=data, evaluator=evaluator, spec=spec, effects=tuple(effects),
                        grid=dict(grid or {}), bounds=bounds, assumed=dict(assumed or {}),
                        assumed_terms=assumed is None)
    return core.Problem(model, data.records, scale={} if scale is None else scale,
                        rows=core.used_rows)


def regrid(problem: core.Problem, grid: dict) -> core.Problem:
    """``problem`` with other grid values of its effects."""
    return problem.with_model(replace(problem.model, grid=grid))


@dataclass
class EffectModel:
    """A base spec + effects (grid values fixed) at the records' geometry: the model of a
    diagnosis's Problem (box, predict, prior, closed-form tangents, unfitted terms)."""

    data: object
    evaluator: object
    spec: object  # the base TrackSpec (its rail loss factor is used as is)
    effects: tuple = ()
    grid: dict = field(default_factory=dict)  # {(effect, name): value}
    bounds: dict | None = None
    #: {(effect, name): value} of assumed values set other than declared (an envelope's)
    assumed: dict = field(default_factory=dict)
    #: whether the assumed values' linearised terms enter the intervals (not where their
    #: envelope carries them: railfem.diagnosis.envelope)
    assumed_terms: bool = True

    def __post_init__(self):
        ps = base_parameters(self.bounds)
        for e in self.effects:
            for p in e.continuous:
                q = p.parameter()
                ps.append(Parameter(name=f"{e.name}.{p.name}", unit=q.unit, log=q.log,
                                    lower=q.lower, upper=q.upper))
        self.box = Box(ps)
        self._thetas = (None, None)  # the last thetas: (x's bytes, values)

    def thetas(self, x) -> dict:
        """{effect: {parameter: value}} of the vector x (the last one's kept: a Jacobian
        column asks for it twice)."""
        key = np.asarray(x, dtype=float).tobytes()
        if self._thetas[0] != key:
            out = {e.name: {} for e in self.effects}
            for p, xi in zip(self.box.parameters[len(BASE):], x[len(BASE):]):
                e, n = p.name.split(".", 1)
                out[e][n] = p.decode(xi)
            for (e, n), v in self.grid.items():
                out[e][n] = v
            for e in self.effects:  # the values an effect sets and does not fit
                for a in e.assumed:
                    out[e.name][a.name] = self.assumed.get((e.name, a.name), a.value)
            self._thetas = (key, out)
        return {e: dict(v) for e, v in self._thetas[1].items()}

    def base_spec(self, x):
        vals = {p.name: p.decode(xi) for p, xi in zip(self.box.parameters, x[:len(BASE)])}
        return self.spec.replace(**vals)

    def predict(self, x) -> dict:
        """{record name: Prediction} as the data would show it."""
        th = self.thetas(x)
        return self._as_measured({r.name: self.evaluator.receptance(*self._where(x, th, r))
                                  for r in self.data.records}, th)

    def as_measured(self, a: dict, x) -> dict:
        """{record name: Prediction} from {record name: receptance} at x (the measurement
        effects applied)."""
        return self._as_measured(a, self.thetas(x))

    def _as_measured(self, a: dict, th) -> dict:
        return {r.name: self._measured(a[r.name], th, r) for r in self.data.records}

    def _where(self, x, th, r):
        """(spec, record, shift) the evaluator is asked for: base, spec and geometry
        effects applied."""
        spec, shift = self.base_spec(x), [0.0, 0.0]
        for e in self.effects:
            if e.kind in ("spec", "campaign"):
                spec = e.apply(spec, th[e.name], r)
            elif e.kind == "geometry":
                ds, dh = e.geometry(th[e.name], r)
                shift[0] += ds
                shift[1] += dh
        return spec, r, tuple(shift)

    def _measured(self, a, th, r) -> Prediction:
        level = power = a
        var = None
        for e in self.effects:
            if e.kind == "measurement":
                if e.variance is not None:  # of the term, on what it is added to
                    v = e.variance(level, th[e.name], r)
                    var = v if var is None else var + v
                level = e.apply_measurement(level, th[e.name], r)
                power = (e.apply_power or e.apply_measurement)(power, th[e.name], r)
        return Prediction(level=level, power=power, variance=var)

    def prior(self, x) -> list:
        """The effects' prior entries (Effect.prior: random effects shrunk towards their
        mean)."""
        th = self.thetas(x)
        return [np.asarray(e.prior(th[e.name]), dtype=float) for e in self.effects
                if e.prior is not None] + [self.eta_r_prior()]

    def eta_r_prior(self) -> np.ndarray:
        """The base rail loss factor's prior entry (railfem.identify.base.eta_r_prior; its
        range ``bounds['eta_r']``, default ETA_R_RANGE): 0 inside the range."""
        return eta_r_prior(self.spec.rail.eta, (self.bounds or {}).get("eta_r", ETA_R_RANGE))

    @property
    def analytic(self) -> bool:
        return any(e.deviation_of is not None for e in self.effects)

    def _tangent_parameters(self) -> dict:
        """{vector index: ((support indices), 'kp' | 'kb')} of the parameters that are the
        log10 of a factor on some supports' stiffness (Effect.deviation_of)."""
        out = {}
        for i, p in enumerate(self.box.parameters[len(BASE):], start=len(BASE)):
            e, n = p.name.split(".", 1)
            eff = next(x for x in self.effects if x.name == e)
            if eff.deviation_of is not None:
                out[i] = eff.deviation_of(n)
        return out

    def tangents(self, x):
        """({record name: receptance}, {vector index: {record name: d receptance / d ln
        factor}}) for the support factors of the random effects (and the base support
        parameters when every effect is such a factor), from the evaluator's closed-form
        derivatives (one Woodbury solve for all of them); None where the evaluator has
        none for the spec."""
        tp = self._tangent_parameters()
        if not tp:
            return None
        th = self.thetas(x)
        got = {r.name: self.evaluator.tangents(*self._where(x, th, r))
               for r in self.data.records}
        if any(v is None for v in got.values()):
            return None
        tan = {i: {n: sum(got[n][1][(j, which)] for j in ids) for n in got}
               for i, (ids, which) in tp.items()}
        if all(e.deviation_of is not None for e in self.effects):
            # the base parameters act through the supports' stiffness alone
            for i, name in enumerate(BASE):
                if all(("base", name) in got[n][1] for n in got):
                    tan[i] = {n: got[n][1][("base", name)] for n in got}
        return {k: v[0] for k, v in got.items()}, tan

    def unfitted_tangents(self, x):
        """The effects' unfitted random terms: the support factors they leave at the mean
        (Effect.unfitted; z the ln factor, 0 in the fit) and the spec values they assume
        (Effect.assumed; z the log10 of the value over the assumed one): ({record name:
        receptance at x}, [(SD, {record name: d receptance / d z})]), the support factors
        first in the order of their keys, then the assumed values; None when there are
        none (an envelope's model, ``assumed_terms`` False, leaves the assumed values
        out). The support factors' tangents are closed-form (when the evaluator has none
        for the spec their scatter is left out, logged); an assumed value's is the central
        difference ASSUMED_STEP decades either side of it, the rest of x held."""
        th = self.thetas(x)
        got = self._support_terms(x, th)
        a0, terms = got if got is not None else (None, [])
        assumed = [(e, a) for e in self.effects for a in e.assumed] \
            if self.assumed_terms else []
        if assumed and a0 is None:
            a0 = {r.name: self.evaluator.receptance(*self._where(x, th, r))
                  for r in self.data.records}
        terms += [(a.sd, self._assumed_tangent(x, th, e.name, a.name)) for e, a in assumed]
        return (a0, terms) if terms else None

    def _assumed_tangent(self, x, th, effect: str, name: str) -> dict:
        """{record name: d receptance / d log10 of the assumed value ``name`` of
        ``effect``} at x: a central difference, ASSUMED_STEP decades either side."""
        out = {}
        for r in self.data.records:
            a = []
            for d in (-ASSUMED_STEP, ASSUMED_STEP):
                t = {k: dict(v) for k, v in th.items()}
                t[effect][name] = th[effect][name] * 10.0 ** d
                a.append(self.evaluator.receptance(*self._where(x, t, r)))
            out[r.name] = (a[1] - a[0]) / (2 * ASSUMED_STEP)
        return out

    def _support_terms(self, x, th):
        """The unfitted support factors (Effect.unfitted): ({record name: receptance},
        [(SD of ln factor, {record name: d receptance / d ln factor})]) in the order of
        their keys, or None."""
        sd = {}
        for e in self.effects:
            if e.unfitted is not None:
                sd.update(e.unfitted(self.base_spec(x)))
        if not sd:
            return None
        ids = sorted({i for i, _ in sd})
        a0, tan = {}, {}
        for r in self.data.records:
            spec, rec, shift = self._where(x, th, r)
            have = {d.index for d in spec.deviations}
            extra = tuple(SupportDeviation(index=i) for i in ids if i not in have)
            got = self.evaluator.tangents(spec.replace(deviations=spec.deviations + extra),
                                          rec, shift)
            if got is None:
                log.warning("diagnosis: no closed-form tangents for %s: the scatter of the "
                            "%d unfitted support factors is left out of the intervals",
                            r.name, len(sd))
                return None
            a0[r.name], tan[r.name] = got
        return a0, [(s, {n: t[key] for n, t in tan.items()}) for key, s in sorted(sd.items())]


def noise_scale(problem: core.Problem, x, discrepancy=None) -> core.Scale:
    """Per quantity, the white-noise level of the residual: 1.4826 MAD of its first
    differences over frequency or band / sqrt 2, at least MIN_SCALE dB; as a
    railfem.identify.problem.Scale carrying ``discrepancy``: None (none), 'ensemble' (the
    base's variants at x, railfem.identify.discrepancy.ensemble) or a Discrepancy."""
    if isinstance(discrepancy, str):
        if discrepancy != "ensemble":
            raise ValueError(f"discrepancy {discrepancy!r}: give 'ensemble', None or a "
                             "railfem.identify.discrepancy.Discrepancy")
        m = problem.model
        discrepancy = ensemble(problem.records, m.evaluator,
                               m.base_spec(np.asarray(x, dtype=float)))
    return core.Scale(_noise(problem, x), discrepancy)


def ensemble(records, evaluator, spec) -> model_form.Discrepancy:
    """The model-form discrepancy of ``spec`` on ``records``
    (railfem.identify.discrepancy.ensemble) by ``evaluator`` (an Evaluator): the base by
    its eigen form, which the refits use after; each variant, evaluated once, by the
    coupling solve of its kernel (Evaluator.receptance_once: no eigen form)."""
    def receptance(s, record):
        return evaluator.receptance(s, record) if s is spec else \
            evaluator.receptance_once(s, record)

    return model_form.ensemble(records, receptance, spec)


def model_scale(problem: core.Problem, x) -> core.Scale:
    """``problem``'s Scale with its discrepancy's samples (the variants' differences,
    from which the intervals take the estimate's shift: Problem.discrepancy_columns)
    joined by those of ``problem``'s own model at x, its effects applied (labels ending
    in MODEL_VARIANT): the variants at both points of the model space, the base at the
    base estimate and the chosen model at its own; the per-band variances (the entries'
    scales, hence every cost and gate) kept. The scale as it is without effects, without
    samples, or (logged) when a variant cannot be evaluated.

    The shift of an estimate under a variant is, linearised at the estimate, the
    least-squares projection of the variant's difference from the model being fitted, at
    its estimate. The base's differences were those of another model at other values:
    on cross-model data of both rails on flexible sleepers (benchmarks/blind, seed 0) the
    base had absorbed the effect (kp 224 MN/m against the chosen model's 430), its
    variants' differences lay at another rail-on-pad resonance, and projected on the
    chosen model they moved kp by 0.018 decades where the chosen model's own variants
    move it by 0.028: its interval missed the truth (400) on every seed. The chosen
    model's own variants alone move its eta_p by 0.005 where the other form moves it by
    0.03 (the base's: 0.03): eta_p's interval then missed. Together, each parameter
    keeps the mean square of both (benchmarks/results/results_base_coverage.md)."""
    m, sc = problem.model, problem.scale
    disc = getattr(sc, "discrepancy", None)
    if not getattr(m, "effects", ()) or disc is None or not disc.samples:
        return sc
    x = np.asarray(x, dtype=float)
    th, samples = m.thetas(x), {}
    try:
        for r in problem.records:
            spec, rec, shift = m._where(x, th, r)
            a0 = m.evaluator.receptance(spec, rec, shift)
            for _, s in model_form.variants(spec, disc.variants):
                a = m.evaluator.receptance_once(s, rec, shift)
                for q, d in model_form.differences(rec.fit, a0, a).items():
                    samples.setdefault((r.name, q), []).append(d)
    except (ValueError, RuntimeError, np.linalg.LinAlgError) as exc:
        log.warning("diagnosis: the discrepancy's variants of %s could not be evaluated "
                    "(%s): the base's differences kept for its intervals",
                    "+".join(e.name for e in m.effects), exc)
        return sc
    if set(samples) != set(disc.samples):
        return sc
    both = {k: np.concatenate([disc.samples[k], np.stack(v)]) for k, v in samples.items()}
    labels = tuple(disc.variants) + tuple(v + MODEL_VARIANT for v in disc.variants)
    return core.Scale(dict(sc), replace(disc, samples=both, variants=labels))


def _noise(problem: core.Problem, x) -> dict:
    diffs: dict = {}
    pred = problem.predict(x)
    for r in problem.records:
        for q, v in table(r.fit, pred[r.name]).items():
            v = np.asarray(v, dtype=float).reshape(v.shape[0], -1)
            d = np.diff(v, axis=0)
            diffs.setdefault(q, []).append(d[np.isfinite(d)])
    out = {}
    for q, ds in diffs.items():
        d = np.concatenate(ds)
        mad = 1.4826 * float(np.median(np.abs(d - np.median(d)))) if d.size else 0.0
        out[q] = max(mad / math.sqrt(2), MIN_SCALE)  # robust to sharp local misfits
    return out
