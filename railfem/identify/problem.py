"""The least-squares problem of a fit: residuals (model - measurement, dB) of a parametrised
model on measured targets, over a box in vector units (log10 for log-scale parameters).

One class serves the fit of railfem.identify.fit (one Target, a ForwardModel) and the
diagnosis (railfem.diagnosis: several records, base track plus candidate effects):

* ``model`` predicts: ``box`` (parameters, names, lower, upper: a
  railfem.params.ParameterSpace or a Box) and ``predict(x)`` -> {record name: Prediction};
  a model may add rows (``prior(x)``: the effects' priors), closed-form receptance
  derivatives (``tangents(x)``: the support factors of random effects, one Woodbury solve)
  and unfitted random terms (``unfitted_tangents(x)``: their scatter in the intervals);
* ``records``: objects with ``name``, ``fit`` and ``held`` (railfem.identify.data.Target or
  None): the fitted and held-out parts;
* ``rows``: how a target's residual arrays are formed: ``weighted_rows`` (the band and
  frequency weights applied, railfem.identify.data.residuals: the fit) or ``used_rows``
  (unweighted, the used entries, a model entry that is not finite counts as FAR dB: the
  diagnosis, whose noise scale is per quantity);
* ``scale``: the residual scale per quantity (dB), 1 where not given; a ``Scale`` also
  carries a model-form discrepancy (railfem.identify.discrepancy): each entry is then
  divided by sqrt(scale^2 + s_d^2(its band)), so bands the model cannot predict weigh less.

The kernel parameter (the rail loss factor) is not differentiated through: it is profiled
(``SlowProfile``: refits at fixed values, parabolic steps through the best point).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy.optimize import least_squares

from railfem.identify import data as fdata
from railfem.standards import iec61260

FAR = 60.0  # dB: the residual of a used model entry that is not finite (used_rows)


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
    """A parameter box (what railfem.identify.uncertainty.analyse reads)."""

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


class Record(NamedTuple):
    """A record of a one-target problem."""

    name: str
    fit: object
    held: object = None


class TargetModel:
    """A ForwardModel as a Problem's model: one record ``name``, the receptance as both
    level and power."""

    def __init__(self, forward, name: str = "data"):
        self.forward, self.name = forward, name

    @property
    def box(self):
        return self.forward.space

    def predict(self, x) -> dict:
        a = self.forward.receptance(x)
        return {self.name: Prediction(level=a, power=a)}


# ------------------------------------------------------------------ residual rows


def weighted_rows(target, prediction: Prediction) -> dict:
    """railfem.identify.data.residuals (band weights applied) in the order of target.use."""
    g = fdata.residuals(target, prediction.level)
    return {q: g[q] for q in target.use}


def used_rows(target, prediction: Prediction) -> dict:
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
    """Per quantity, in the order of ``used_rows``, the label 'sensor|band' of each used
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


def row_axis(target, q: str, rows) -> np.ndarray:
    """The index on the first axis (frequency; band for the decay rate) of every entry of
    ``rows(target, ...)[q]`` (used_rows or weighted_rows)."""
    if rows is used_rows:
        return np.nonzero(used_entries(target, q))[0]
    if q == "tdr":
        return np.nonzero(np.isfinite(target.tdr) & (target.band_weight[:, None] > 0))[0]
    w = target.frf_weight > 0
    shape = target.transfer.shape if q == "transfer" else target.point.shape
    idx = np.broadcast_to(np.arange(shape[0]).reshape((-1,) + (1,) * (len(shape) - 1)), shape)
    return idx[w].ravel()


def row_x(target, q: str, rows) -> np.ndarray:
    """Frequency (Hz; the band centre for the decay rate) of every entry of a row array."""
    axis = target.bands.nominal if q == "tdr" else target.frequency
    return np.asarray(axis, dtype=float)[row_axis(target, q, rows)]


class Scale(dict):
    """Residual scales per quantity (dB: the noise), with an optional model-form
    ``discrepancy`` (railfem.identify.discrepancy.Discrepancy): an entry's scale is then
    sqrt(noise^2 + s_d^2(band of the entry)). A plain dict of scales is a Scale without
    discrepancy."""

    def __init__(self, noise=(), discrepancy=None):
        super().__init__(noise)
        self.discrepancy = discrepancy
        self._entries: dict = {}

    def entries(self, target, q: str, rows):
        """The scale of every entry of ``rows(target, ...)[q]`` (an array), or the
        quantity's scale (a number) without discrepancy."""
        s = self.get(q, 1.0)
        if self.discrepancy is None:
            return s
        key = (id(target), q, rows)
        if key not in self._entries:
            x = row_x(target, q, rows)
            self._entries[key] = (target, np.sqrt(s ** 2 + self.discrepancy.at(q, x)))
        return self._entries[key][1]

    def table(self, target, q: str, shape) -> np.ndarray | float:
        """The scale on the axes of a residual_table array of ``shape`` (first axis
        frequency, or band for the decay rate)."""
        s = self.get(q, 1.0)
        if self.discrepancy is None:
            return s
        axis = target.bands.nominal if q == "tdr" else target.frequency
        d2 = self.discrepancy.at(q, np.asarray(axis, dtype=float))
        return np.sqrt(s ** 2 + d2).reshape((-1,) + (1,) * (len(shape) - 1))


def entry_scale(scale, target, q: str, rows):
    """Per-entry scale of a row array under ``scale`` (a Scale or a plain dict)."""
    if isinstance(scale, Scale):
        return scale.entries(target, q, rows)
    return scale.get(q, 1.0)


def table_scale(scale, target, q: str, shape):
    """The scale on a residual_table array's axes under ``scale`` (a Scale or a dict)."""
    if isinstance(scale, Scale):
        return scale.table(target, q, shape)
    return scale.get(q, 1.0)


# ------------------------------------------------------------------ the problem


class Problem:
    """Residuals of ``model`` on ``records`` (see the module docstring). The shorthand
    Problem(target=..., forward=...) is the fit of one Target with a ForwardModel."""

    def __init__(self, model=None, records=(), *, scale=None, rows=weighted_rows,
                 target=None, forward=None):
        if forward is not None:
            if target is None or model is not None:
                raise ValueError("Problem(target=..., forward=...) takes a target and no model")
            model, records = TargetModel(forward), (Record("data", target),)
        if model is None:
            raise ValueError("a Problem needs a model (or target= and forward=)")
        self.model, self.records = model, tuple(records)
        self.scale = {} if scale is None else scale
        self.rows = rows
        self.target, self.forward = target, forward

    @property
    def box(self):
        return self.model.box

    def with_model(self, model) -> Problem:
        """The same records, scales and rows with another model."""
        return Problem(model, self.records, scale=self.scale, rows=self.rows)

    def predict(self, x) -> dict:
        """{record name: Prediction} as the data would show it."""
        return self.model.predict(x)

    def groups(self, x, part="fit", prediction=None) -> list:
        """[(record, quantity, residual array)] unscaled, model - measurement (dB)."""
        return [(rec.name, q, v) for rec, t, q, v in self.entries(x, part, prediction)]

    def entries(self, x, part="fit", prediction=None):
        """(record, its target of ``part``, quantity, unscaled residual array) in order."""
        pred = self.predict(x) if prediction is None else prediction
        for rec in self.records:
            t = rec.fit if part == "fit" else rec.held
            if t is not None:
                for q, v in self.rows(t, pred[rec.name]).items():
                    yield rec, t, q, v

    def residual(self, x, part="fit", prediction=None) -> np.ndarray:
        """Scaled residuals of ``part`` (each entry over its scale: Scale); on the fitted
        part followed by the model's prior entries (railfem.diagnosis: random effects
        shrunk towards their mean)."""
        r = [v / entry_scale(self.scale, t, q, self.rows)
             for _, t, q, v in self.entries(x, part, prediction)]
        if part == "fit":
            r += self.prior(x)
        return np.concatenate(r)

    def cost(self, x) -> float:
        r = self.residual(x)
        return float(r @ r)

    def prior(self, x) -> list:
        prior = getattr(self.model, "prior", None)
        return [] if prior is None else prior(x)

    def n_prior(self) -> int:
        x = np.zeros(len(self.box.parameters))
        return sum(len(p) for p in self.prior(x))

    def clusters(self) -> np.ndarray:
        """A label per entry of ``residual(x)`` (fitted part, used_rows): entries whose
        noise may be shared. The EN 15461 decay rate in a band is computed from the same
        measured FRFs as the point and transfer entries of that band and sensor, so
        (record, sensor, band) is one cluster; each prior entry is its own."""
        labels = []
        for r in self.records:
            for lab in cluster_labels(r.fit).values():
                labels += [f"{r.name}|{v}" for v in lab]
        labels += [f"prior|{i}" for i in range(self.n_prior())]
        return np.unique(np.array(labels, dtype=object), return_inverse=True)[1]

    # -------------------------------------------------------------- derivatives

    @property
    def analytic(self) -> bool:
        """Whether the model gives closed-form receptance derivatives for some parameters."""
        return bool(getattr(self.model, "analytic", False))

    def jacobian(self, x, h: float = 1e-7) -> np.ndarray:
        """d residual / dx: forward differences (step h max(1, |x_i|), inside the box),
        except for the parameters whose receptance derivative the model gives in closed
        form (``model.tangents``: d receptance / d ln value): the residual is then
        differenced along it (one model evaluation for all of them)."""
        x = np.asarray(x, dtype=float)
        hi = self.box.upper
        lin = self.model.tangents(x) if self.analytic else None
        if lin is None:
            r0 = self.residual(x)
        else:
            a0, tan = lin
            r0 = self.residual(x, prediction=self.model.as_measured(a0, x))
        J = np.empty((len(r0), len(x)))
        for i in range(len(x)):
            step = h * max(1.0, abs(x[i]))
            step = step if x[i] + step <= hi[i] else -step
            xi = x.copy()
            xi[i] += step
            if lin is not None and i in tan:  # log10 -> ln: a factor ln 10
                pred = self.model.as_measured({n: a + step * math.log(10) * tan[i][n]
                                               for n, a in a0.items()}, xi)
                J[:, i] = (self.residual(xi, prediction=pred) - r0) / step
            else:
                J[:, i] = (self.residual(xi) - r0) / step
        return J

    def central_jacobian(self, x, h: float = 1e-6, columns=None) -> np.ndarray:
        """d residual / dx by central differences (step h, kept inside the box: one-sided
        on a bound) for the entries ``columns`` (default all)."""
        x = np.asarray(x, dtype=float)
        lo, hi = self.box.lower, self.box.upper
        columns = range(len(x)) if columns is None else columns
        cols = []
        for i in columns:
            a, b = x.copy(), x.copy()
            a[i], b[i] = max(x[i] - h, lo[i]), min(x[i] + h, hi[i])
            cols.append((self.residual(b) - self.residual(a)) / (b[i] - a[i]))
        return np.column_stack(cols)

    def unfitted_jacobian(self, x, h: float = 1e-6) -> np.ndarray | None:
        """N = d residual / d z times SD, one column per unfitted random term of the model
        (``model.unfitted_tangents``: z the ln factor of a support, left at 0 in the fit),
        from closed-form tangents; None when the model has none."""
        get = getattr(self.model, "unfitted_tangents", None)
        got = None if get is None else get(x)
        return None if got is None else self._unfitted(x, got, h)

    def discrepancy_columns(self) -> np.ndarray | None:
        """The model-form discrepancy (a Scale's, used_rows only) as random terms of the
        fitted residual, zero rows for the prior entries; None without discrepancy. With
        the ensemble's samples (Discrepancy.samples): one column per variant, its
        difference from the base over each entry's scale times sqrt(factor / n): the
        intervals then carry the mean square of the estimate's shift under the variants.
        Without: one column per (record, quantity, sensor, band) cell, s_d of the band on
        the cell's entries (a discrepancy shared by a band's positions and frequencies)."""
        disc = getattr(self.scale, "discrepancy", None)
        if disc is None or self.rows is not used_rows:
            return None
        samples = disc.samples or {}
        if samples and all((r.name, q) in samples for r in self.records for q in r.fit.use):
            cols = []
            for r in self.records:
                for q in cluster_labels(r.fit):  # the order of the residual's entries
                    S = samples[(r.name, q)][:, used_entries(r.fit, q)]
                    cols.append(S / entry_scale(self.scale, r.fit, q, used_rows))
            N = np.concatenate(cols, axis=1).T * math.sqrt(disc.factor / len(disc.variants))
            N = np.vstack([np.nan_to_num(N), np.zeros((self.n_prior(), N.shape[1]))])
            return N if np.any(N != 0) else None
        vals, labels = [], []
        for r in self.records:
            for q, lab in cluster_labels(r.fit).items():
                d2 = disc.at(q, row_x(r.fit, q, used_rows))
                vals.append(np.sqrt(d2) / entry_scale(self.scale, r.fit, q, used_rows))
                labels += [f"{r.name}|{q}|{v}" for v in lab]
        v = np.concatenate(vals)
        cells, inv = np.unique(np.array(labels, dtype=object), return_inverse=True)
        N = np.zeros((len(v) + self.n_prior(), len(cells)))
        N[np.arange(len(v)), inv] = v
        keep = np.any(N != 0, axis=0)
        return N[:, keep] if keep.any() else None

    def _unfitted(self, x, got, h):
        a0, terms = got
        r0 = self.residual(x, prediction=self.model.as_measured(a0, x))
        N = np.empty((len(r0), len(terms)))
        for c, (s, tan) in enumerate(terms):
            pred = self.model.as_measured({n: a + h * tan[n] for n, a in a0.items()}, x)
            N[:, c] = s * (self.residual(x, prediction=pred) - r0) / h
        return N

    # -------------------------------------------------------------- least squares

    def solve(self, x0, free=None, *, margin: float = 0.0, jacobian: bool = False,
              **options):
        """scipy.optimize.least_squares ('trf') over the entries ``free`` of x (default
        all; the others held at x0) inside the box, the start moved ``margin`` (share of
        the range) inside it; ``jacobian``: this problem's (closed-form tangents; all
        entries free); options: least_squares' (tolerances, max_nfev, x_scale).
        Returns (x, cost, least_squares' result)."""
        x0 = np.asarray(x0, dtype=float)
        free = np.ones(len(x0), bool) if free is None else np.asarray(free, dtype=bool)
        lo, hi = self.box.lower[free], self.box.upper[free]
        z0 = np.clip(x0[free], lo + margin * (hi - lo), hi - margin * (hi - lo))
        if free.all():
            fun = self.residual
        else:
            def fun(z):
                x = x0.copy()
                x[free] = z
                return self.residual(x)
        if jacobian:
            options["jac"] = self.jacobian
        res = least_squares(fun, z0, bounds=(lo, hi), method="trf", **options)
        x = x0.copy()
        x[free] = res.x
        return x, float(2 * res.cost), res


# ------------------------------------------------------------------ kernel-parameter profile


def parabola_vertex(costs: dict, *, at_edge: bool = False, lo: float = -np.inf,
                    hi: float = np.inf) -> tuple[float, float] | None:
    """(value, cost) at the vertex of the parabola through the best point of a 1-D profile
    {value: cost} and its two neighbours, the value kept between them and inside [lo, hi]
    (the cost then that of the parabola there, never above the best point's). When the
    best point is at an end or the parabola opens downwards: None, or with ``at_edge``
    the parabola through the three points at that end, and the better edge of the bracket
    when it opens downwards."""
    v = np.array(sorted(costs))
    c = np.array([costs[x] for x in v])
    k = int(np.argmin(c))
    if len(v) < 3:
        return None
    if not 0 < k < len(v) - 1:
        if not at_edge:
            return None
        k = min(max(k, 1), len(v) - 2)
    A = np.vstack([v[k - 1:k + 2] ** 2, v[k - 1:k + 2], np.ones(3)]).T
    a, b, c0 = np.linalg.solve(A, c[k - 1:k + 2])
    if a <= 0:
        if not at_edge:
            return None
        j = k - 1 + int(np.argmin(c[k - 1:k + 2]))
        return float(v[j]), float(c[j])
    x = float(np.clip(-b / (2 * a), max(lo, v[k - 1]), min(hi, v[k + 1])))
    return x, float(min(a * x * x + b * x + c0, c[k]))


def parabola_step(costs: dict, tol: float, **options) -> float | None:
    """The next value of a 1-D profile {value: cost}: parabola_vertex's value (options:
    its keywords); None when there is none or it is within ``tol`` of a known value."""
    vx = parabola_vertex(costs, **options)
    if vx is None:
        return None
    return None if min(abs(vx[0] - np.array(list(costs)))) < tol else vx[0]


class SlowProfile:
    """The profile of a fit over a kernel parameter (the rail loss factor, in vector
    units): {value: point}, each point a refit at that value. ``evaluate(value)`` refits
    (typically warm-started from ``nearest(value)``); ``cost(point)`` reads a point's cost;
    ``key`` maps a value to its key (e.g. a rounding lattice)."""

    def __init__(self, evaluate, *, cost=lambda p: p[0], key=float):
        self.evaluate, self.cost, self.key = evaluate, cost, key
        self.points: dict = {}

    def at(self, value):
        """The point at ``value`` (refitted on first use)."""
        v = self.key(value)
        if v not in self.points:
            self.points[v] = self.evaluate(v)
        return self.points[v]

    def nearest(self, value):
        """The refitted point nearest ``value``."""
        return self.points[min(self.points, key=lambda u: abs(u - value))]

    def costs(self) -> dict:
        return {v: self.cost(p) for v, p in self.points.items()}

    def walk(self, step: float, max_steps: int) -> None:
        """Steps of ``step`` beyond the best end until the minimum is bracketed."""
        for _ in range(max_steps):
            v = sorted(self.points)
            k = int(np.argmin([self.cost(self.points[x]) for x in v]))
            if k == 0:
                self.at(v[0] - step)
            elif k == len(v) - 1:
                self.at(v[-1] + step)
            else:
                break

    def refine(self, steps: int, tol: float, **options) -> None:
        """Up to ``steps`` parabolic steps (parabola_step, options: parabola_vertex's) until
        one lands within ``tol`` of a known value."""
        for _ in range(steps):
            new = parabola_step(self.costs(), tol, **options)
            if new is None:
                break
            self.at(new)
