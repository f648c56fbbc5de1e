"""The least-squares problem of a diagnosis: the residuals (model - measurement, dB) of a
base track plus candidate effects on the fitted (or held-out) part of every record.

The vector holds the base parameters (kp, eta_p, kb, eta_b: log10 of SI, bounds of
railfem.identify.fit.FIT_BOUNDS) and each effect's continuous parameters (named
``effect.parameter``); grid parameters are fixed per Problem. Residuals are divided by a
fixed scale per quantity (``noise_scale``: the white-noise level of the base fit's
residual from the median absolute deviation of its first differences, at least 0.1 dB),
so every model is scored on the same footing; random effects add their prior rows.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from railfem.identify import data as fdata
from railfem.identify.fit import FIT_BOUNDS
from railfem.params import Parameter
from railfem.spec import SupportDeviation
from railfem.standards import iec61260

log = logging.getLogger(__name__)

BASE = ("kp", "eta_p", "kb", "eta_b")
MIN_SCALE = 0.1  # dB
FAR = 60.0  # dB: the residual of a model entry that is not finite


@dataclass(frozen=True)
class Prediction:
    """A model prediction of one record: the receptance (nf, n_out, n_pos) whose level in
    dB the FRFs are compared with, and the one whose band power the decay rate sums (they
    differ only under a random additive measurement term: the noise floor), with the
    variance (dB^2) such a term adds to each level (None: none)."""

    level: np.ndarray
    power: np.ndarray
    variance: np.ndarray | None = None  # dB^2 a random term adds to each level entry


def table(target, prediction: Prediction) -> dict:
    """railfem.identify.data.residual_table of a Prediction."""
    power = None if prediction.power is prediction.level else prediction.power
    return fdata.residual_table(target, prediction.level, power=power)


class Box:
    """The parameter box of a refit (what railfem.identify.uncertainty.analyse reads)."""

    def __init__(self, parameters):
        self.parameters = tuple(parameters)

    @property
    def names(self):
        return tuple(p.name for p in self.parameters)

    @property
    def lower(self):
        return np.array([p.encode(p.lower) for p in self.parameters])

    @property
    def upper(self):
        return np.array([p.encode(p.upper) for p in self.parameters])


def base_parameters(bounds=None) -> list[Parameter]:
    b = dict(FIT_BOUNDS, **(bounds or {}))
    return [Parameter(name=n, unit="-" if n.startswith("eta") else "N/m", log=True,
                      lower=b[n][0], upper=b[n][1]) for n in BASE]


@dataclass
class Problem:
    """Residuals of base spec + effects (grid values fixed) on the data's fitted parts."""

    data: object
    evaluator: object
    spec: object  # the base TrackSpec (its rail loss factor is used as is)
    effects: tuple = ()
    grid: dict = field(default_factory=dict)  # {(effect, name): value}
    scale: dict = field(default_factory=dict)
    bounds: dict | None = None

    def __post_init__(self):
        ps = base_parameters(self.bounds)
        for e in self.effects:
            for p in e.continuous:
                q = p.parameter()
                ps.append(Parameter(name=f"{e.name}.{p.name}", unit=q.unit, log=q.log,
                                    lower=q.lower, upper=q.upper))
        self.box = Box(ps)

    def thetas(self, x) -> dict:
        out = {e.name: {} for e in self.effects}
        for p, xi in zip(self.box.parameters[len(BASE):], x[len(BASE):]):
            e, n = p.name.split(".", 1)
            out[e][n] = p.decode(xi)
        for (e, n), v in self.grid.items():
            out[e][n] = v
        return out

    def base_spec(self, x):
        vals = {p.name: p.decode(xi) for p, xi in zip(self.box.parameters, x[:len(BASE)])}
        return self.spec.replace(**vals)

    def predict(self, x) -> dict:
        """{record name: Prediction} as the data would show it."""
        th = self.thetas(x)
        return self._as_measured({r.name: self.evaluator.receptance(*self._where(x, th, r))
                                  for r in self.data.records}, th)

    def _as_measured(self, a: dict, th) -> dict:
        """{record name: Prediction} from {record name: receptance} (measurement effects)."""
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

    def jacobian(self, x, h: float = 1e-7) -> np.ndarray:
        """d residual / dx: forward differences, except for the support factors of a
        random effect, whose receptance derivative the evaluator gives in closed form
        (one Woodbury solve for all of them; the residual is then differenced along it)."""
        x = np.asarray(x, dtype=float)
        hi = self.box.upper
        th = self.thetas(x)
        tp = self._tangent_parameters()
        got = {r.name: self.evaluator.tangents(*self._where(x, th, r))
               for r in self.data.records} if tp else {}
        if any(v is None for v in got.values()):
            tp, got = {}, {}
        a0 = ({k: v[0] for k, v in got.items()} if got else
              {r.name: self.evaluator.receptance(*self._where(x, th, r))
               for r in self.data.records})
        r0 = self.residual(x, prediction=self._as_measured(a0, th))
        J = np.empty((len(r0), len(x)))
        for i in range(len(x)):
            step = h * max(1.0, abs(x[i]))
            step = step if x[i] + step <= hi[i] else -step
            xi = x.copy()
            xi[i] += step
            if i in tp:  # along the closed-form tangent (log10 -> ln: a factor ln 10)
                thi = self.thetas(xi)
                ids, which = tp[i]
                pred = self._as_measured({n: a + step * math.log(10) * sum(
                    got[n][1][(j, which)] for j in ids) for n, a in a0.items()}, thi)
                J[:, i] = (self.residual(xi, prediction=pred) - r0) / step
            else:
                J[:, i] = (self.residual(xi) - r0) / step
        return J

    def unfitted_jacobian(self, x, h: float = 1e-6) -> np.ndarray | None:
        """N = d residual / d z times SD, one column per unfitted support factor of the
        effects (Effect.unfitted; z its ln factor, left at 0 in the fit), from the
        evaluator's closed-form tangents; None when no effect has any, or (logged) when
        the evaluator has no tangents for the spec (their scatter is then left out)."""
        th = self.thetas(x)
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
        r0 = self.residual(x, prediction=self._as_measured(a0, th))
        N = np.empty((len(r0), len(sd)))
        for c, (key, s) in enumerate(sorted(sd.items())):
            pred = self._as_measured({n: a + h * tan[n][key] for n, a in a0.items()}, th)
            N[:, c] = s * (self.residual(x, prediction=pred) - r0) / h
        return N

    @property
    def analytic(self) -> bool:
        return any(e.deviation_of is not None for e in self.effects)

    def groups(self, x, part="fit", prediction=None) -> list:
        """[(record, quantity, residual array)] unscaled, model - measurement (dB)."""
        pred = self.predict(x) if prediction is None else prediction
        out = []
        for r in self.data.records:
            t = r.fit if part == "fit" else r.held
            if t is None:
                continue
            for q, v in residuals(t, pred[r.name]).items():
                out.append((r.name, q, v))
        return out

    def residual(self, x, part="fit", prediction=None) -> np.ndarray:
        """Scaled residuals of ``part``; on the fitted part followed by the effects' prior
        entries (Effect.prior: random effects shrunk towards their mean)."""
        r = [v / self.scale.get(q, 1.0) for _, q, v in self.groups(x, part, prediction)]
        if part == "fit":
            r += self.prior(x)
        return np.concatenate(r)

    def clusters(self) -> np.ndarray:
        """A label per entry of ``residual(x)`` (fitted part): entries whose noise may be
        shared. The EN 15461 decay rate in a band is computed from the same measured FRFs
        as the point and transfer entries of that band and sensor, so (record, sensor,
        band) is one cluster; each prior entry is its own."""
        labels = []
        for r in self.data.records:
            for lab in cluster_labels(r.fit).values():
                labels += [f"{r.name}|{v}" for v in lab]
        labels += [f"prior|{i}" for i in range(self.n_prior())]
        return np.unique(np.array(labels, dtype=object), return_inverse=True)[1]

    def prior(self, x) -> list:
        th = self.thetas(x)
        return [np.asarray(e.prior(th[e.name]), dtype=float) for e in self.effects
                if e.prior is not None]

    def n_prior(self) -> int:
        x = np.zeros(len(self.box.parameters))
        return sum(len(p) for p in self.prior(x))

    def cost(self, x) -> float:
        r = self.residual(x)
        return float(r @ r)


def residuals(target, prediction: Prediction) -> dict:
    """Model - measurement (dB) per quantity, flattened over the entries the target uses
    (weight > 0, data present: masked transfers are NaN in the data); a model entry that
    is not finite (a band without a model decay rate) counts as FAR dB."""
    return {q: np.where(np.isfinite(v), v, FAR)[used_entries(target, q)]
            for q, v in table(target, prediction).items()}


def used_entries(target, q: str) -> np.ndarray:
    """The boolean mask of the entries of quantity q a fit uses (on residual_table's axes)."""
    if q == "tdr":
        return np.isfinite(target.tdr) & (target.band_weight[:, None] > 0)
    if q == "transfer":
        return (target.frf_weight[:, None, None] > 0) & np.isfinite(target.transfer)
    return (target.frf_weight[:, None] > 0) & np.isfinite(target.point)


def cluster_labels(target) -> dict:
    """Per quantity, in the order of ``residuals``, the label 'sensor|band' of each used
    entry (the band of the decay rate; of the frequency for FRF entries)."""
    n_out = len(target.outputs)
    band = -1 - np.arange(len(target.frequency))  # a frequency outside every band: its own
    if target.bands is not None:
        k = iec61260.band_index(target.frequency, target.bands)
        band = np.where(k >= 0, k, band)
    out = {}
    for q in (q for q in fdata.QUANTITIES if q in target.use):  # residual_table's order
        used = used_entries(target, q)
        lab = np.arange(used.shape[0]) if q == "tdr" else band
        lab = np.broadcast_to(lab.reshape((-1,) + (1,) * (used.ndim - 1)), used.shape)
        o = np.broadcast_to(np.arange(n_out).reshape((1, -1) + (1,) * (used.ndim - 2)),
                            used.shape)
        out[q] = [f"{oi}|{bi}" for oi, bi in zip(o[used], lab[used])]
    return out


def noise_scale(problem: Problem, x) -> dict:
    """Per quantity, the white-noise level of the residual: 1.4826 MAD of its first
    differences over frequency or band / sqrt 2, at least MIN_SCALE dB."""
    diffs: dict = {}
    pred = problem.predict(x)
    for r in problem.data.records:
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
