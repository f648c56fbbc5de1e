"""Diagnosis against a reference section: "what did the dampers (the new pads, the
tamping) change?"

    from railfem.diagnosis.reference import diagnose
    d = diagnose(damped, reference=undamped, model="timoshenko-discrete")
    d.statement   # 'against the reference section (...): rail_damper explains ...'

The base track (kp, eta_p, kb, eta_b, eta_r) is calibrated on the reference section (the
diagnosis's own base fit, railfem.diagnosis.loop.fit_base, on the reference data), or read
from a calibration of it (a ``railfem fit`` FitResult or its fit.json dict, a Diagnosis of
it, or a BaseReference). DATA is then diagnosed with the base held near the reference:
each base parameter inside the reference's 95 % interval, widened to at least
REFERENCE_TOLERANCE (relative) for what two sections of the same kind differ by anyway; the
rail loss factor's prior range (railfem.identify.base.ETA_R_RANGE) becomes that interval.
What the reference does not have is then left to the effects: added damping cannot hide in
the rail loss factor, and a base parameter that ends on an edge of its interval is named
as changed.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from railfem import validators as v
from railfem.diagnosis import loop
from railfem.diagnosis.data import prepare
from railfem.diagnosis.effects import rail_damper
from railfem.diagnosis.problem import BASE, DISCREPANCY
from railfem.identify.base import BASE_PARAMETERS
from railfem.identify.fit import FIT_BOUNDS
from railfem.spec import TrackSpec, spec_from_dict

log = logging.getLogger(__name__)

REFERENCE_TOLERANCE = 0.1  # relative: two sections of the same kind differ by this anyway
EDGE = 0.02  # share of an interval (log scale) within which a base parameter is "at its edge"


@dataclass(frozen=True, kw_only=True)
class BaseReference:
    """A calibrated base: ``spec`` (its support and rail loss factor the reference's),
    ``values`` {name: SI value} and ``bounds`` {name: (low, high)} SI of BASE_PARAMETERS
    (kp, eta_p, kb, eta_b, eta_r), where DATA's base is held; ``source`` in words."""

    spec: TrackSpec
    values: dict
    bounds: dict
    source: str = "reference"
    intervals: dict = field(default_factory=dict)  # the reference's own 95 % intervals

    def __post_init__(self):
        if not isinstance(self.spec, TrackSpec):
            raise TypeError(f"BaseReference.spec must be a TrackSpec, got "
                            f"{type(self.spec).__name__}")
        for n in BASE_PARAMETERS:
            if n not in self.values or n not in self.bounds:
                raise ValueError(f"BaseReference: {n} has no value or bounds")
            lo, hi = self.bounds[n]
            if not 0 < lo <= self.values[n] <= hi:
                raise ValueError(f"BaseReference: {n} = {self.values[n]:.4g} outside its "
                                 f"bounds ({lo:.4g}, {hi:.4g})")

    def describe(self) -> str:
        """One line: where the reference comes from and its base values."""
        vals = ", ".join(f"{n} {_fmt(n, self.values[n])}" for n in BASE_PARAMETERS)
        return f"{self.source}: {vals}"

    def to_dict(self) -> dict:
        return {"source": self.source, "values": dict(self.values),
                "bounds": {k: list(b) for k, b in self.bounds.items()},
                "intervals": {k: list(b) for k, b in self.intervals.items()}}


def _fmt(name: str, value: float) -> str:
    return f"{value / 1e6:.4g} MN/m" if name in ("kp", "kb") else f"{value:.3g}"


def held_bounds(values: dict, intervals: dict, tolerance: float, box=None) -> dict:
    """{name: (low, high)}: each value's interval ``intervals[name]`` (SI, may be missing
    or infinite), at least value /(1 + tolerance) .. value (1 + tolerance), and never
    outside the plausible search box ``box`` (default FIT_BOUNDS): a parameter the
    reference's data did not fix (an interval of 1e-300..1e300) is held in the box the
    base is searched in anyway, not let loose to unphysical values."""
    box = FIT_BOUNDS if box is None else box
    out = {}
    for n, x in values.items():
        f = 1.0 + tolerance
        lo, hi = intervals.get(n, (x, x))
        if lo is not None and hi is not None and np.isfinite(lo) and np.isfinite(hi) \
                and lo > 0:
            f = max(f, x / lo, hi / x)
        lo, hi = x / f, x * f
        if n in box:
            lo, hi = max(lo, min(box[n][0], x)), min(hi, max(box[n][1], x))
        out[n] = (lo, hi)
    return out


def from_parameters(spec: TrackSpec, params, source: str,
                    tolerance: float = REFERENCE_TOLERANCE) -> BaseReference:
    """A BaseReference from a spec and a list of parameter dicts (name, value, ci95), as a
    fit or a diagnosis reports them; a base parameter missing there takes the spec's
    value."""
    got = {p["name"]: p for p in params if p.get("name") in BASE_PARAMETERS}
    values, intervals = {}, {}
    for n in BASE_PARAMETERS:
        if n in got and got[n].get("value") is not None:
            values[n] = float(got[n]["value"])
            ci = got[n].get("ci95")
            if ci is not None and None not in ci:  # null in JSON: an end not found
                intervals[n] = (float(ci[0]), float(ci[1]))
        else:
            values[n] = float(spec.rail.eta if n == "eta_r" else getattr(spec.support, n))
    spec = spec.replace(**values)
    return BaseReference(spec=spec, values=values, source=source, intervals=intervals,
                         bounds=held_bounds(values, intervals, tolerance))


def from_outcome(o, source: str, tolerance: float = REFERENCE_TOLERANCE) -> BaseReference:
    """A BaseReference from a diagnosis's base Outcome (railfem.diagnosis.refit)."""
    params = [p for p in o.parameters() if p.get("group") == "base"]
    if not any(p["name"] == "eta_r" for p in params):
        params.append({"name": "eta_r", "value": o.eta_r, "ci95": None})
    return from_parameters(o.spec(), params, source, tolerance)


def calibrate(reference, *, model: str = "wfe-discrete", base: TrackSpec | None = None,
              spacing: float | None = None, n_starts: int = 4, workers: int = 1,
              cache=False, seed: int = 0, data_options=None, discrepancy=DISCREPANCY,
              tolerance: float = REFERENCE_TOLERANCE) -> BaseReference:
    """The base of the reference section: ``reference`` is a BaseReference (as is), a
    Diagnosis (its base), a FitResult or a fit.json dict ('spec' and 'parameters'), or data
    of the section (anything railfem.diagnosis.diagnose takes), then calibrated by the
    diagnosis's base fit (railfem.diagnosis.loop.fit_base) with ``model``."""
    v.non_negative("tolerance", tolerance, "-")
    if isinstance(reference, BaseReference):
        return reference
    if isinstance(reference, loop.Diagnosis):
        return from_outcome(reference.base, f"the base of a diagnosis of "
                            f"{reference.data.description}", tolerance)
    if isinstance(reference, dict) and "spec" in reference and "parameters" in reference:
        spec = spec_from_dict(reference["spec"])
        return from_parameters(spec, reference["parameters"], "a fit (fit.json) of the "
                               "reference section", tolerance)
    if hasattr(reference, "spec") and hasattr(reference, "parameters") \
            and isinstance(getattr(reference, "spec"), TrackSpec):
        return from_parameters(reference.spec, reference.parameters,
                               "a fit of the reference section", tolerance)
    data = prepare(reference, spacing=spacing, **(data_options or {}))
    spec0 = loop.base_of(data, model, base)
    cands, _ = loop.select_effects(data, model, ())
    ev = loop.make_evaluator(cands, data, cache)
    s, _ = loop.fit_base(data, model, spec0, ev, n_starts=n_starts, workers=workers,
                         cache=cache, seed=seed, profile_final=True, discrepancy=discrepancy)
    log.info("reference: base calibrated on %s", data.description)
    return from_outcome(s.base, f"the reference section ({data.description})", tolerance)


def changed_base(d, ref: BaseReference) -> list[str]:
    """The base parameters of diagnosis ``d`` (its chosen model's, else its base's) that
    ended within EDGE of an edge of the range they were held in: '{name} {+x %} against
    the reference'."""
    o = d.chosen if d.chosen is not None else d.base
    vals = {p.name: p.decode(x) for p, x in zip(o.problem.box.parameters[:len(BASE)],
                                                 o.x[:len(BASE)])}
    vals["eta_r"] = o.eta_r
    out = []
    for n in BASE_PARAMETERS:
        if moved_to_edge(vals[n], ref.values[n], ref.bounds[n]):
            out.append(f"{n} {100 * (vals[n] / ref.values[n] - 1):+.0f} % against the "
                       "reference (at the edge of the range it was held in)")
    return out


def moved_to_edge(value: float, ref_value: float, bounds) -> bool:
    """``value`` ended within EDGE of an edge of ``bounds`` (log scale) and away from the
    reference's own value: a reference value on the search box's edge (a parameter its
    data pushed there) that DATA leave where it is has not changed."""
    lo, hi = (math.log10(b) for b in bounds)
    x, x0 = math.log10(value), math.log10(ref_value)
    tol = EDGE * (hi - lo)
    return hi - lo > 0 and min(x - lo, hi - x) < tol and abs(x - x0) >= tol


def what_changed(d) -> str:
    """The chosen effect in the words of the field question: for added rail damping, the
    band it acts over."""
    if d.chosen is None:
        return ""
    th = d.chosen.theta()
    if "rail_damper" in th:
        lo, hi = rail_damper.band(th["rail_damper"])
        p = th["rail_damper"]
        return (f"added rail damping over {lo:.0f}-{hi:.0f} Hz (tuned at {p['fa']:.0f} Hz, "
                f"spread {p.get('spread', 1.0):.3g}, {p['mass']:.2g} kg per support, loss "
                f"factor {p['eta_a']:.2g})")
    return f"{d.chosen.name} differs from the reference"


def statement(d, ref: BaseReference) -> str:
    """The diagnosis's statement against the reference."""
    what = what_changed(d)
    changed = changed_base(d, ref)
    head = f"against the reference ({ref.describe()}): "
    tail = (f"; what differs: {what}" if what else "") + \
        ("; base changed: " + "; ".join(changed) if changed else "")
    if d.chosen is None and d.verdict in ("noise", "consistent") and not changed:
        tail += "; no difference from the reference section is claimed"
    return head + d.statement + tail


def diagnose(data, *, reference=None, model: str = "wfe-discrete",
             tolerance: float = REFERENCE_TOLERANCE, **options):
    """railfem.diagnosis.diagnose with a ``reference`` section (see the module docstring):
    without one, the ordinary diagnosis. ``options``: those of
    railfem.diagnosis.loop.diagnose (effects, n_starts, base, spacing, ...); the
    reference's data, if given as data, are read with the same spacing, data options and
    base. The Diagnosis gets ``reference`` (the BaseReference) and ``changed`` (the base
    parameters at an edge of their range) and a statement against the reference."""
    if reference is None:
        return loop.diagnose(data, model=model, **options)
    keep = {k: options[k] for k in ("base", "spacing", "n_starts", "workers", "cache",
                                     "seed", "data_options", "discrepancy") if k in options}
    ref = calibrate(reference, model=model, tolerance=tolerance, **keep)
    d = loop.diagnose(data, model=model, reference=ref, **options)
    d.changed = changed_base(d, ref)
    d.statement = statement(d, ref)
    return d
