"""Refit the track with candidate effects: bounded least squares in dB over the base
support parameters and the effects' parameters, on the fitted part of every record.

The vector holds the base parameters (kp, eta_p, kb, eta_b: log10 of SI, bounds of
railfem.identify.fit.FIT_BOUNDS) and each effect's continuous parameters (named
``effect.parameter``). The rail loss factor changes the kernel: it is held at the base
estimate while candidates are screened and profiled over kernels in the final refits
(railfem.diagnosis.rail_loss). Grid parameters (a pad length, a geometry shift, a
support index, which sensor) are profiled: every value is scored by one evaluation at the
start, the best ones are refitted, a numeric grid is refined at the parabola through the
best value and its neighbours (one new kernel), and its 95 % interval is read off the
profile (cost within chi^2_1(95 %) s^2 of the minimum).

Scores (residuals scaled per quantity, railfem.diagnosis.problem):
cost = sum (r / s_q)^2, AICc = cost + 2k + 2k(k+1)/(N-k-1), BIC = cost + k ln N.
"""
from __future__ import annotations

import contextlib
import itertools
import logging
import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import stats

from railfem.diagnosis.problem import BASE, Box, Problem, regrid
from railfem.identify import problem as core
from railfem.identify import uncertainty
from railfem.identify.problem import parabola_step
from railfem.diagnosis.intervals import (discrepancy_terms, distinct_variants, grid_inflation,
                                         grid_shift_variance, interval_from_profile, widen)
from railfem.params import Parameter

log = logging.getLogger(__name__)

REFINE_STEPS = 4  # parabolic steps of a numeric grid parameter (each a new kernel)
MAX_GRID_START = 4  # effect parameters up to which starts are a 3-value grid


@dataclass
class Outcome:
    """One refitted model: effects, grid values, vector, cost, scores, uncertainty."""

    effects: tuple
    grid: dict
    x: np.ndarray
    eta_r: float
    cost: float
    n: int
    k: int
    problem: core.Problem
    analysis: dict
    grid_profiles: dict
    eta_r_profile: dict | None = None
    # the cost at the rail loss factor interpolated between the profiled kernels (the
    # vertex of the parabola through the best and its neighbours; profile_eta_r): the
    # profile's value without the error of its last lattice step
    profile_cost: float | None = None
    # the ends of the effects' assumed values' ranges (railfem.diagnosis.envelope): each
    # {"effect", "name", "value", "parameters": that end's refit's parameters()}; the
    # intervals reported are the union of the ends' and this model's own
    envelope: list = field(default_factory=list)

    @property
    def name(self) -> str:
        return "+".join(e.name for e in self.effects) or "base"

    @property
    def aicc(self) -> float:
        k, n = self.k, self.n
        return self.cost + 2 * k + (2 * k * (k + 1) / (n - k - 1) if n - k - 1 > 0 else np.inf)

    @property
    def bic(self) -> float:
        return self.cost + self.k * math.log(self.n)

    def parameters(self) -> list[dict]:
        """Estimates with 95 % intervals: base, effects, grid (profiled) values. The effect
        parameters also get ``ci95_joint``: simultaneous 95 % intervals over the effects'
        k parameters (Bonferroni: each at 1 - 0.05/k), the statement that all of them lie
        inside at once; ``ci95`` is each one's own (marginal) interval. A factor on
        supports' stiffness (Effect.deviation_of) also gets the stiffness it gives them,
        ``support_value`` = factor x fitted mean (N/m), with ``support_ci95`` and
        ``support_ci95_joint`` from the variance of the sum of the two log10 values: a
        shift of the fitted mean moves the factors the other way, so the supports'
        stiffness is known better than the factors."""
        out = [dict(p, group="base" if "." not in p["name"] else "effect")
               for p in self.analysis["parameters"]]
        for (e, n), prof in self.grid_profiles.items():
            out.append({"name": f"{e}.{n}", "group": "effect", "value": prof["value"],
                        "ci95": prof.get("ci95"), "identifiable": prof.get("identifiable"),
                        "reason": prof.get("reason", "profiled over a grid"),
                        "unit": prof.get("unit", "")})
        if self.eta_r_profile is not None:
            out.append({"name": "eta_r", "group": "base", **self.eta_r_profile})
        self._joint(out)
        self._envelope(out)
        return out + [q for e in self.effects if e.derived is not None for q in e.derived(out)]

    def _joint(self, out: list[dict]) -> None:
        eff = [p for p in out if p["group"] == "effect" and p.get("ci95") is not None]
        if not eff:
            return
        level = 1 - 0.05 / len(eff)
        s2, dof = self.analysis["residual_variance"], self.analysis["dof"]
        t = float(stats.t.ppf(1 - (1 - level) / 2, dof))
        box = {p.name: p for p in self.problem.box.parameters}
        for p in eff:
            key = tuple(p["name"].split(".", 1))
            if key in self.grid_profiles:
                prof = self.grid_profiles[key]
                iv = interval_from_profile(prof, s2 * prof.get("inflation", 1.0),
                                           float(stats.chi2.ppf(level, 1)))
                p["ci95_joint"] = widen(iv["ci95"], prof["value"],
                                        prof.get("discrepancy_var", 0.0),
                                        prof.get("discrepancy_terms", 1),
                                        1 - (1 - level) / 2)
            elif np.isfinite(p.get("std_vector", np.inf)):
                q, v, sd = box[p["name"]], p["vector"], p["std_vector"]
                p["ci95_joint"] = [uncertainty.decode(q, v - t * sd),
                                   uncertainty.decode(q, v + t * sd)]
            else:
                p["ci95_joint"] = list(p["ci95"])
        self._supports(eff, float(self.analysis["t_quantile"]), t)

    def _envelope(self, out: list[dict]) -> None:
        """Each interval the union of this model's own and the envelope's ends' (the
        effects' assumed values at the ends of their ranges, refitted), its own kept as
        ``ci95_centre`` (``ci95_joint_centre``), ``assumed_range`` saying so."""
        if not self.envelope:
            return
        ends = [{p["name"]: p for p in end["parameters"]} for end in self.envelope]
        ranges: dict = {}
        for end in self.envelope:
            ranges.setdefault((end["effect"], end["name"], end["assumed"]),
                              []).append(end["value"])
        words = "; ".join(f"{e}'s assumed {n} from {min(v):.3g} to {max(v):.3g}"
                          f" (at {c:.3g} and at both ends)" for (e, n, c), v in ranges.items())
        for p in out:
            got = [e[p["name"]] for e in ends if p["name"] in e]
            if not got:
                continue
            for key in ("ci95", "ci95_joint", "support_ci95", "support_ci95_joint"):
                ivs = [q[key] for q in got if q.get(key) is not None]
                if p.get(key) is None or not ivs:
                    continue
                p[key + "_centre"] = list(p[key])
                p[key] = [min([p[key][0]] + [iv[0] for iv in ivs]),
                          max([p[key][1]] + [iv[1] for iv in ivs])]
            p["assumed_range"] = (f"the 95 % interval spans {words}: the union of the "
                                  "intervals refitted there")

    def _supports(self, eff: list[dict], t: float, t_joint: float) -> None:
        names = list(self.problem.box.names)
        by_name = {e.name: e for e in self.problem.model.effects}
        n_vec = len(self.analysis["covariance_vector"])
        for p in eff:
            e, n = p["name"].split(".", 1)
            dev = by_name[e].deviation_of if e in by_name else None
            if dev is None or p["name"] not in names:
                continue
            which = dev(n)[1]
            i, j = names.index(p["name"]), names.index(which)
            a = np.zeros(n_vec)
            a[[i, j]] = 1.0
            sd = (uncertainty.combination_std(self.analysis, a)
                  if np.isfinite(p.get("std_vector", np.inf)) else float("inf"))
            v = float(self.x[i] + self.x[j])
            p["support_value"] = 10 ** v
            p["support_ci95"] = [10 ** (v - t * sd), 10 ** (v + t * sd)]
            p["support_ci95_joint"] = [10 ** (v - t_joint * sd), 10 ** (v + t_joint * sd)]

    def theta(self) -> dict:
        return self.problem.model.thetas(self.x)

    def spec(self):
        return self.problem.model.base_spec(self.x)


def _solve(problem: core.Problem, x0, max_nfev=200):
    """(x, cost, Jacobian): the refit's least squares, its Jacobian the closed-form
    tangents where the effects give them."""
    x, cost, res = problem.solve(x0, margin=1e-9, jacobian=problem.analytic, xtol=1e-10,
                                 ftol=1e-10, gtol=1e-10, max_nfev=max_nfev)
    return x, cost, res.jac


def _starts(problem: core.Problem, x_base, n_keep: int):
    """Start vectors: the base estimate with every combination of 3 values per effect
    parameter (20 %, its declared start, 80 % of its range in vector units; a parameter's
    ``scan`` values instead where it has them), the best
    n_keep by cost; with more than MAX_GRID_START effect parameters the declared starts
    alone."""
    eff = problem.box.parameters[len(BASE):]
    if not eff:
        return [np.asarray(x_base, dtype=float)]
    if len(eff) > MAX_GRID_START:  # many parameters (random effects): the declared starts
        declared = [p.parameter().encode(p.start) for e in problem.model.effects
                    for p in e.continuous]
        return [np.concatenate([x_base, declared])]
    lo, hi = problem.box.lower[len(BASE):], problem.box.upper[len(BASE):]
    pars = [p for e in problem.model.effects for p in e.continuous]
    declared = [p.parameter().encode(p.start) for p in pars]
    choices = [tuple(map(p.parameter().encode, p.scan)) or  # a parameter's own scan
               (lo[i] + 0.2 * (hi[i] - lo[i]), declared[i], lo[i] + 0.8 * (hi[i] - lo[i]))
               for i, p in enumerate(pars)]
    cands = []
    for combo in itertools.product(*choices):
        x = np.concatenate([x_base, combo])
        try:
            c = problem.cost(x)
        except (ValueError, np.linalg.LinAlgError):
            continue
        if np.isfinite(c):
            cands.append((c, x))
    cands.sort(key=lambda t: t[0])
    return [x for _, x in cands[:n_keep]]


def _solve_effect_only(problem: core.Problem, x0, max_nfev=60):
    """Least squares over the effect parameters only (the base held at x0)."""
    n = len(BASE)
    if len(x0) == n:
        r = problem.residual(x0)
        return np.asarray(x0, dtype=float), float(r @ r), None
    free = np.arange(len(x0)) >= n
    x, cost, _ = problem.solve(x0, free, margin=1e-9, max_nfev=max_nfev)
    return x, cost, None


def fit_fixed(problem: core.Problem, x_base, n_keep: int = 2):
    """Best least-squares solution from the best start vectors: (x, cost, J)."""
    best = None
    for x0 in _starts(problem, x_base, n_keep):
        x, c, J = _solve(problem, x0)
        if best is None or c < best[1]:
            best = (x, c, J)
    return best


def _screening(evaluator):
    """The evaluator's screening mode (railfem.diagnosis.evaluate.Evaluator.screen: a
    kernel's first evaluation by the coupling solve, its eigen form only when refitted), or
    nothing for an evaluator without one."""
    screen = getattr(evaluator, "screen", None)
    return screen() if screen is not None else contextlib.nullcontext()


def _grid_combos(effects):
    keys, values = [], []
    for e in effects:
        for n, vals in e.grid.items():
            keys.append((e.name, n))
            values.append(tuple(vals))
    return keys, values


def refit(data, evaluator, spec, effects, x_base, scale, *, grid_values=None,
          screen_keep: int = 2, refine: bool = True, bounds=None, x_start=None,
          refine_steps: int = REFINE_STEPS, unfitted: bool = True,
          assumed: dict | None = None) -> Outcome:
    """Fit base + ``effects`` (see the module docstring) starting from the base vector
    x_base (BASE parameters, vector units) with the rail loss factor of ``spec``.
    grid_values: {(effect, name): values} overriding the effects' grids (e.g. only the
    sensors a record has). unfitted=False leaves the effects' unfitted scatter out of the
    analysis (a profile point whose analysis is redone at the best one). assumed:
    {(effect, name): value} of the effects' assumed values, set for an envelope over their
    range (railfem.diagnosis.problem.Problem: their linearised terms left out)."""
    effects = tuple(effects)
    keys, values = _grid_combos(effects)
    values = [tuple((grid_values or {}).get(k, v)) for k, v in zip(keys, values)]

    def problem_for(combo):
        return Problem(data=data, evaluator=evaluator, spec=spec, effects=effects,
                       grid=dict(zip(keys, combo)), scale=scale, bounds=bounds,
                       assumed=assumed)

    results: dict = {}
    if keys and x_start is not None and all(len(v) == 1 for v in values):
        combo = tuple(v[0] for v in values)
        results[combo] = _solve(problem_for(combo), x_start)
    elif keys:
        screened = []
        for combo in itertools.product(*values):
            pb = problem_for(combo)
            try:
                with _screening(evaluator):  # ranks the combinations only
                    starts = _starts(pb, x_base, 1)
                    c = pb.cost(starts[0])
            except (ValueError, np.linalg.LinAlgError) as exc:
                log.info("diagnosis: %s at %s skipped: %s", effects[0].name, combo, exc)
                continue
            screened.append((c, combo))
        screened.sort(key=lambda t: t[0])
        for _, combo in screened[:screen_keep]:
            results[combo] = fit_fixed(problem_for(combo), x_base)
    elif x_start is not None:  # a warm start (e.g. the neighbouring rail loss factor)
        results[()] = _solve(problem_for(()), x_start)
    else:
        results[()] = fit_fixed(problem_for(()), x_base)
    best = min(results, key=lambda c: results[c][1])
    profiles = {}
    if keys:
        best, profiles = _profile_grid(keys, values, best, results, problem_for, x_base,
                                       refine_steps if refine else 0)
    pb = problem_for(best)
    if results[best][2] is None:  # won by a partial refit (a support index): refit all
        results[best] = _solve(pb, results[best][0])
        if keys:
            for k_, prof in profiles.items():
                j = keys.index(k_)
                if best[j] in prof["values"]:
                    prof["cost"][prof["values"].index(best[j])] = results[best][1]
    x, c, J = results[best]
    r = pb.residual(x)
    clusters = pb.clusters()
    analysis = _analyse(pb, pb.box, x, J, r, clusters, unfitted)
    s2 = analysis["residual_variance"]
    for k, prof in profiles.items():
        if not prof["integer"] and len(prof["values"]) > 1:
            j = keys.index(k)
            nb = best[:j] + (_nearest_other(prof["values"], best[j]),) + best[j + 1:]
            r_nb = problem_for(nb).residual(x)
            prof["inflation"] = grid_inflation(J, r, r_nb, nb[j] - best[j], clusters)
            null = _null(effects, k, best, j, problem_for, x)
            secant = (r_nb - r) / (nb[j] - best[j]) if null is None else \
                (null[0] - r) / null[1]
            prof["discrepancy_var"], prof["discrepancy_terms"] = grid_discrepancy(
                pb, J, r, secant)
        prof.update(interval_from_profile(prof, s2 * prof.get("inflation", 1.0)))
        if not prof["integer"]:
            _close_profile(prof, keys.index(k), best, values, results, problem_for,
                           x_base, s2)
            if prof.get("discrepancy_var"):
                prof["ci95_profile"] = prof["ci95"]
                prof["ci95"] = widen(prof["ci95"], prof["value"], prof["discrepancy_var"],
                                     prof["discrepancy_terms"])
    k = len(x) + len(keys) + 1  # + the rail loss factor (fitted with the base)
    return Outcome(effects=effects, grid=dict(zip(keys, best)), x=x,
                   eta_r=float(spec.rail.eta), cost=c, n=len(r) - pb.n_prior(), k=k,
                   problem=pb,
                   analysis=analysis, grid_profiles=profiles)


def _nearest_other(values, v):
    return min((u for u in values if u != v), key=lambda u: abs(u - v))


def _close_profile(prof, j, best, values, results, problem_for, x_base, s2) -> None:
    """Extend the profile of grid parameter j (position in the combination ``best``) by
    the grid's next values beyond a side its interval leaves open, one at a time, until
    the interval closes there or the grid ends (prof updated in place). The profile holds
    the best value's neighbours only; an interval widened by the discrepancy
    (grid_inflation) can reach past them, and an interval cut at the last value profiled
    is not the interval."""
    grid = sorted(values[j])
    for _ in range(len(grid)):
        iv = interval_from_profile(prof, s2 * prof.get("inflation", 1.0))
        lo_open = iv["ci95"][0] <= min(prof["values"]) and prof["value"] > grid[0]
        hi_open = iv["ci95"][1] >= max(prof["values"]) and prof["value"] < grid[-1]
        nxt = ([v for v in grid if v < min(prof["values"])][-1:] if lo_open else []) + \
            ([v for v in grid if v > max(prof["values"])][:1] if hi_open else [])
        if not nxt:
            break
        for v in nxt:
            combo = best[:j] + (v,) + best[j + 1:]
            if combo not in results or results[combo][2] is None:
                results[combo] = fit_fixed(problem_for(combo), x_base)
            prof["values"].append(float(v))
            prof["cost"].append(float(results[combo][1]))
        order = np.argsort(prof["values"])
        prof["values"] = [prof["values"][i] for i in order]
        prof["cost"] = [prof["cost"][i] for i in order]
    prof.update(interval_from_profile(prof, s2 * prof.get("inflation", 1.0)))


def _null(effects, key, best, j, problem_for, x):
    """(residual, distance) at the null value (the parameter's start) of grid parameter
    ``key`` (position j of the combination ``best``), the rest held at x; None where the
    estimate is the null value or the parameter has no numeric start."""
    eff = next((e for e in effects if e.name == key[0]), None)
    par = None if eff is None else {p.name: p for p in eff.parameters}.get(key[1])
    v0 = getattr(par, "start", None)
    if not isinstance(v0, (int, float)) or not isinstance(best[j], (int, float, np.floating)) \
            or v0 == best[j]:
        return None
    try:
        return problem_for(best[:j] + (v0,) + best[j + 1:]).residual(x), v0 - best[j]
    except (ValueError, np.linalg.LinAlgError):
        return None


def grid_discrepancy(pb, J, r, secant) -> tuple[float, int]:
    """(variance, terms): the model-form discrepancy's share of a grid parameter's
    estimate in problem ``pb`` (grid_shift_variance of its discrepancy columns along the
    residual's ``secant`` per unit of the parameter; J, r at the estimate) and how many
    variants it samples (Student's t of its widening)."""
    Nd = pb.discrepancy_columns()
    if Nd is None:
        return 0.0, 0
    return (grid_shift_variance(J, r, secant, Nd),
            distinct_variants(pb, Nd) or int(Nd.shape[1]))


def rewiden_grid(o: Outcome) -> dict:
    """``o``'s grid profiles with their model-form share taken from ``o``'s own problem:
    the discrepancy columns of its scale (a chosen model's: model_scale, its own variants
    at its estimate joined to the base's), projected on the secant from the parameter's
    null value to the estimate (grid_shift_variance), each profile interval widened again
    by it. The screening's profiles, which the final refit inherits (it fixes the grid
    values), carried the base's variants only, and for a pad those sample no pad
    discretisation: on cross-model data of a 0.16 m pad in four spring rows the
    estimator's two rows gave 0.18 m with an interval from 0.162 m, on every seed run.
    New dicts; ``o``'s own are not changed."""
    pb, x = o.problem, o.x
    todo = [k for k, p in o.grid_profiles.items() if not p["integer"] and "ci95_profile" in p]
    if pb.discrepancy_columns() is None or not todo:
        return o.grid_profiles
    r, J = pb.residual(x), _jacobian(pb, x)
    keys, combo = list(o.grid), tuple(o.grid.values())
    out = dict(o.grid_profiles)
    for key in todo:
        null = _null(o.effects, key, combo, keys.index(key),
                     lambda c: regrid(pb, dict(zip(keys, c))), x)
        if null is None:
            continue
        var, n = grid_discrepancy(pb, J, r, (null[0] - r) / null[1])
        prof = out[key]
        out[key] = dict(prof, discrepancy_var=var, discrepancy_terms=n,
                        ci95=widen(prof["ci95_profile"], prof["value"], var, n))
    return out


def profile_inflation(o: Outcome, key, prof: dict) -> float:
    """grid_inflation of the grid parameter ``key`` of a refitted model, its profile
    ``prof`` giving the neighbouring value (one more evaluation there)."""
    pb = o.problem
    vn = _nearest_other(prof["values"], o.grid[key])
    r = pb.residual(o.x)
    r_nb = regrid(pb, {**pb.model.grid, key: vn}).residual(o.x)
    return grid_inflation(_jacobian(pb, o.x), r, r_nb, vn - o.grid[key], pb.clusters())


def _profile_grid(keys, values, best, results, problem_for, x_base, refine_steps):
    """For each numeric grid parameter: refit the neighbours of the best value, then one
    parabolic step (a new value); returns the best combination and the profiles."""
    profiles = {}
    best = tuple(best)
    for j, (key, vals) in enumerate(zip(keys, values)):
        numeric = all(isinstance(v, (int, float, np.integer, np.floating)) for v in vals)
        if not numeric:
            continue
        vals = sorted(vals)
        i = vals.index(best[j])
        is_int = all(float(v).is_integer() for v in vals) and key[1] == "index"
        x_best = results[best][0]
        for nb in range(len(vals)) if is_int else (i - 1, i + 1):
            if 0 <= nb < len(vals):
                combo = best[:j] + (vals[nb],) + best[j + 1:]
                if combo not in results:
                    # a support index: the other indices with the base held (their costs
                    # are upper bounds, so the index set is if anything too narrow)
                    results[combo] = (_solve_effect_only(problem_for(combo), x_best)
                                      if is_int else fit_fixed(problem_for(combo),
                                                               x_best[:len(BASE)]))

        def line():
            return sorted((c[j], results[c][1]) for c in results
                          if c[:j] == best[:j] and c[j + 1:] == best[j + 1:])

        for _ in range(0 if is_int else refine_steps):
            pts = line()
            v = parabola_step(dict(pts), 1e-4 * (vals[-1] - vals[0]))
            if v is None:
                break
            v_best = pts[int(np.argmin([c for _, c in pts]))][0]
            near = results[best[:j] + (v_best,) + best[j + 1:]][0]
            combo = best[:j] + (v,) + best[j + 1:]
            results[combo] = _solve(problem_for(combo), near)
        pts = line()
        new_best = min(pts, key=lambda t: t[1])[0]
        best = best[:j] + (new_best,) + best[j + 1:]
        profiles[key] = {"values": [float(v) for v, _ in pts],
                         "cost": [float(c) for _, c in pts], "value": float(new_best),
                         "integer": is_int}
    return best, profiles


def joint_uncertainty(best: Outcome, done: dict) -> None:
    """Intervals of the other parameters with the rail loss factor free: the Jacobian gets
    a column dr/d(log10 eta_r) by a difference to the nearest other kernel (the other
    parameters held), and the analysis is redone on the extended box."""
    nb = nearest_rail_loss(best.eta_r, done)
    if nb is not None:
        rail_loss_analysis(best, done[nb].problem, nb)


def nearest_rail_loss(eta_r: float, lattice) -> float | None:
    """The value of ``lattice`` (log10 rail loss factors, rounded to 1e-6 as the profile's
    keys are) nearest to log10(eta_r) other than its own, or None. Compared on that
    lattice: an unrounded value once picked its own key as the neighbour (a zero column)."""
    le = math.log10(eta_r)
    others = [v for v in lattice if abs(v - round(le, 6)) > 5e-7]
    return min(others, key=lambda v: abs(v - le)) if others else None


def rail_loss_analysis(best: Outcome, pn: core.Problem, nb: float) -> None:
    """best.analysis redone with the rail loss factor free: the Jacobian gets the column
    dr / d(log10 eta_r) by a difference to ``pn`` (best's problem at the rail loss
    factor 10^nb, the other parameters held at best.x); the rail loss factor's interval
    in best.analysis['eta_r']."""
    le = math.log10(best.eta_r)
    pb = best.problem
    r0 = pb.residual(best.x)
    col = (pn.residual(best.x) - r0) / (nb - le)
    J = _jacobian(pb, best.x)
    J = np.column_stack([J, col])
    box = Box(list(pb.box.parameters) + [Parameter(name="eta_r", unit="-", log=True,
                                                   lower=1e-4, upper=0.5)])
    analysis = _analyse(pb, box, np.append(best.x, le), J, r0, pb.clusters())
    best.analysis = dict(analysis, parameters=analysis["parameters"][:-1],
                         eta_r=analysis["parameters"][-1])


def reanalyse(o: Outcome, nb: float | None = None) -> None:
    """o.analysis redone at o.x on o.problem (e.g. after its model changed): with the rail
    loss factor free against its problem at the rail loss factor 10^nb
    (rail_loss_analysis), or on its own box when ``nb`` is None."""
    pb = o.problem
    if nb is not None:
        m = pb.model
        pn = pb.with_model(replace(m, spec=m.spec.replace(eta_r=10.0 ** nb)))
        rail_loss_analysis(o, pn, nb)
        return
    o.analysis = _analyse(pb, pb.box, o.x, _jacobian(pb, o.x), pb.residual(o.x),
                          pb.clusters())


def _analyse(problem: core.Problem, box, v, J, r, clusters, unfitted: bool = True) -> dict:
    """uncertainty.analyse of ``problem`` at vector ``v`` (its x, possibly extended by
    columns of J beyond the problem's box): noise ``clusters`` as the data share it, and
    (``unfitted``) the scatter of the effects' unfitted support factors
    (Problem.unfitted_jacobian)."""
    N = problem.unfitted_jacobian(v[:len(problem.box.parameters)]) if unfitted else None
    Nd = discrepancy_terms(problem, len(r) - len(v))  # the model-form discrepancy as well
    out = uncertainty.analyse(box, v, J, r, clusters=clusters, nuisance=N, discrepancy=Nd)
    out["unfitted_terms"] = 0 if N is None else int(N.shape[1])
    out["discrepancy_terms"] = 0 if Nd is None else int(Nd.shape[1])
    return out


def _jacobian(problem: core.Problem, x, h: float = 1e-6) -> np.ndarray:
    """The Jacobian of an analysis: the closed-form tangents where the effects give them,
    central differences otherwise."""
    if problem.analytic:
        return problem.jacobian(x)
    return problem.central_jacobian(x, h)
