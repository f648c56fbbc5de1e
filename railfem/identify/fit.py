"""Track parameters from measured data: bounded nonlinear least squares in dB (METHOD.md §7).

    import railfem as rf
    from railfem.identify import fit
    meas = rf.io.read_measurement("site_b/")
    result = fit(meas, model="wfe-discrete", use=("point", "transfer", "tdr"))
    result.parameters          # estimates, 95 % intervals, identifiable yes/no/weak + reason

The problem (railfem.identify.problem.Problem, the one the diagnosis uses as well):
minimise sum_g sum_i (r_gi / s_g)^2 over the parameter vector x of a
railfem.params.ParameterSpace inside its box (scipy.optimize.least_squares, 'trf'), with
r_g the residuals in dB of quantity g (railfem.identify.data) and s_g its residual scale:
1 dB for the first pass, then each quantity's own residual RMS (so point mobility, transfers
and decay rates count by how well each is fitted, not by how many numbers each has).

* **Multi-start**: ``n_starts`` points of a scrambled Sobol sequence in the box (vector
  units: log10 for stiffnesses, loss factors and the mass), run in parallel processes
  (``workers``; BLAS pinned to one thread per process with threadpoolctl); the best is kept.
* **Kernel parameters** (eta_r, pad_length; railfem.identify.forward.SLOW) change the
  parameter-free kernel, so the fit does not differentiate through them: it profiles. The
  support parameters are fitted at ``slow_nodes`` values spread over the slow parameter's
  bounds, then the minimum of that profile is refined by parabolic steps (each a new
  kernel) until it moves less than ``slow_tol`` (vector units) or ``slow_refine`` steps are
  spent. After the residual scales are re-weighted the profile is refitted under the final
  scales (warm starts, one more refinement): the estimate is its minimum and its 95 %
  interval the profile's (``ci95_linearised``: from the Jacobian, which uses a
  finite-difference column for it).
* **Uncertainty** (railfem.identify.uncertainty): covariance from the Jacobian at the
  optimum scaled by the residual variance, 95 % intervals, correlations, identifiability;
  profile likelihoods of the stiffnesses (kp, kb): the other parameters refitted on a grid
  of fixed values (the kernel parameters held at their estimate), with finer points around
  the minimum until at least PROFILE_MIN_INSIDE lie within the 95 % threshold.
"""
from __future__ import annotations

import logging
import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np
from scipy.stats import qmc

from railfem.identify import data as fdata
from railfem.identify import uncertainty
from railfem.identify.base import BASE_PARAMETERS, default_base, describe_base
from railfem.identify.forward import ForwardModel, Geometry, slow_names
from railfem.identify.problem import Problem, SlowProfile
from railfem.measurement import DecayRateMeasurement, HammerMeasurement
from railfem.params import ParameterSpace
from railfem.spec import TrackSpec, spec_to_dict
from railfem.standards import en15461, iec61260

log = logging.getLogger(__name__)

DEFAULT_PARAMETERS = BASE_PARAMETERS  # the one base model (railfem.identify.base)
#: Search box of a fit (SI); wider than any track of METHOD.md Table 1.
FIT_BOUNDS = {
    "kp": (1e7, 1e10), "eta_p": (0.01, 2.0), "kb": (5e6, 2e9), "eta_b": (0.02, 5.0),
    "eta_r": (1e-3, 0.3), "ms": (30.0, 600.0), "pad_length": (0.0, 0.3),
}
PROFILED = ("kp", "kb")
CHI2_95 = 3.841  # chi-square(1) 95 % quantile: the profile-likelihood threshold
PROFILE_MIN_INSIDE = 5  # profile points within the 95 % threshold a profile refines to
PROFILE_ROUNDS = 3  # rounds of finer profile points at most
SLOW_STEP = {"timoshenko": 1e-4, "wfe": 0.02}  # finite-difference step of a kernel parameter


def _solve(problem: Problem, x0, free, *, max_nfev=None):
    """least_squares over the entries ``free`` of x (the others held at x0):
    (x, cost, number of evaluations)."""
    free = np.asarray(free, dtype=bool)
    x, cost, res = problem.solve(x0, free, x_scale=1.0, xtol=1e-12, ftol=1e-12, gtol=1e-12,
                                 max_nfev=max_nfev or 100 * (int(free.sum()) + 1))
    return x, cost, int(res.nfev)


# ------------------------------------------------------------------ parallel processes

_WORKER: dict = {}


def _init_worker(problem):
    from threadpoolctl import threadpool_limits

    _WORKER["problem"] = problem
    _WORKER["limits"] = threadpool_limits(1)  # kept alive for the worker's lifetime


def _run(task):
    fn, args = task
    return fn(_WORKER["problem"], *args)


def _start(problem, x0, free):
    t = time.perf_counter()
    x, cost, nfev = _solve(problem, x0, free)
    return {"x0": np.asarray(x0).tolist(), "x": x.tolist(), "cost": cost, "nfev": nfev,
            "seconds": time.perf_counter() - t}


def _profile_point(problem, x_hat, i, value, free):
    x0 = np.array(x_hat, dtype=float)
    x0[i] = value
    f = np.array(free, dtype=bool)
    f[i] = False
    x, cost, _ = _solve(problem, x0, f)
    return {"value": float(value), "cost": cost, "x": x.tolist()}


def default_workers() -> int:
    return max(1, min(os.cpu_count() or 1, 8))


def run_tasks(problem: Problem, fn, arglist, workers: int, what: str):
    """fn(problem, *args) for every args, in ``workers`` processes (1: here), logged."""
    out = [None] * len(arglist)
    t0 = time.perf_counter()
    if workers <= 1 or len(arglist) <= 1:
        for k, args in enumerate(arglist):
            out[k] = fn(problem, *args)
            log.info("fit: %s %d/%d done (%.1f s)", what, k + 1, len(arglist),
                     time.perf_counter() - t0)
        return out
    from concurrent.futures import as_completed

    with ProcessPoolExecutor(max_workers=min(workers, len(arglist)), initializer=_init_worker,
                             initargs=(problem,)) as pool:
        futs = {pool.submit(_run, (fn, args)): k for k, args in enumerate(arglist)}
        for n, fut in enumerate(as_completed(futs), 1):
            out[futs[fut]] = fut.result()
            log.info("fit: %s %d/%d done (%.1f s)", what, n, len(arglist),
                     time.perf_counter() - t0)
    return out


# ------------------------------------------------------------------ the fit


@dataclass(frozen=True, kw_only=True, eq=False)
class FitResult:
    """A fitted track: spec, estimates with 95 % intervals and identifiability, residuals.

    parameters: one dict per parameter (name, unit, value, ci95, identifiable, reason, ...).
    correlation: (p, p). residual_rms: {quantity: RMS dB}; residual_bands: {quantity:
    per-band RMS dB per sensor}. starts: the multi-start runs. profiles: {name: profile}.
    slow_profile: the kernel-parameter profile (values, costs) or None."""

    model: str
    spec: TrackSpec
    names: tuple[str, ...]
    x: np.ndarray
    cost: float
    parameters: list
    correlation: np.ndarray
    analysis: dict
    residual_rms: dict
    residual_bands: dict
    scale: dict
    starts: list
    profiles: dict
    slow_profile: dict | None
    target: fdata.Target
    receptance: np.ndarray
    seconds: dict

    def parameter(self, name: str) -> dict:
        for p in self.parameters:
            if p["name"] == name:
                return p
        raise KeyError(f"no fitted parameter {name!r}; fitted: {self.names}")

    def identifiable(self) -> dict:
        return {p["name"]: p["identifiable"] for p in self.parameters}

    def to_dict(self) -> dict:
        """JSON-ready summary (what fit.json holds)."""
        from railfem import __version__

        return {
            "railfem_version": __version__, "model": self.model, "names": list(self.names),
            "base_model": describe_base(self.spec, self.names),
            "parameters": self.parameters, "correlation": self.correlation.tolist(),
            "singular_values": self.analysis["singular_values"],
            "residual_variance": self.analysis["residual_variance"],
            "dof": self.analysis["dof"], "residual_rms_db": self.residual_rms,
            "residual_rms_per_band_db": self.residual_bands, "residual_scale_db": self.scale,
            "data": {"description": self.target.description, "use": list(self.target.use),
                     "sensors": list(self.target.outputs),
                     "frequency_hz": [float(self.target.frequency[0]),
                                      float(self.target.frequency[-1])],
                     "n_frequencies": int(len(self.target.frequency)),
                     "positions_m": self.target.positions.tolist(),
                     "transfer_positions_m":
                         self.target.positions[self.target.transfer_index].tolist()},
            "spec": spec_to_dict(self.spec), "cost": self.cost,
            "starts": self.starts, "profiles": self.profiles,
            "slow_profile": self.slow_profile, "seconds": self.seconds,
            "identifiability_rules": uncertainty.__doc__.split("Identifiability")[1].strip(),
        }


def base_spec(data, model: str, base: TrackSpec | None = None) -> TrackSpec:
    """The spec the fit starts from: ``base`` or the base model of every calibration
    (railfem.identify.base.default_base: the site preset on point supports), with the model
    and the measurement's sleeper spacing."""
    spec = base if base is not None else default_base(model)
    spacing = getattr(data, "sleeper_spacing", None)
    changes = {"model": model}
    if spacing is not None and abs(spacing - spec.spacing) > 1e-12:
        changes["spacing"] = float(spacing)
    return spec.replace(**changes)


def make_target(data, *, use=None, spacing: float | None = None, **options) -> fdata.Target:
    """A Target from a HammerMeasurement, a DecayRateMeasurement or a Target."""
    if isinstance(data, fdata.Target):
        return data
    if isinstance(data, HammerMeasurement):
        return fdata.hammer_target(data, use=tuple(use or ("point", "transfer", "tdr")),
                                   **options)
    if isinstance(data, DecayRateMeasurement):
        if use is not None and tuple(use) != ("tdr",):
            raise ValueError(f"a decay-rate measurement holds only 'tdr', use = {use!r}")
        if spacing is None:
            raise ValueError("fitting a decay rate needs the sleeper spacing (m)")
        return fdata.decay_rate_target(data, spacing, **options)
    raise TypeError(f"cannot fit {type(data).__name__}: give a HammerMeasurement, a "
                    "DecayRateMeasurement or a railfem.identify.data.Target")


def fit(data, model: str = "wfe-discrete", *, parameters=DEFAULT_PARAMETERS, base=None,
        bounds=None, use=None, n_starts: int = 8, seed: int = 0, workers: int | None = None,
        cache=None, profiles=PROFILED, profile_points: int = 11, slow_nodes: int | None = None,
        slow_refine: int | None = None, slow_tol: float = 1e-5, reweight: bool = True,
        forward: ForwardModel | None = None, target_options=None) -> FitResult:
    """Fit the track parameters ``parameters`` of ``model`` to ``data``.

    data: HammerMeasurement, DecayRateMeasurement (needs base or the default spacing) or
    Target. base: the TrackSpec whose other values are kept (default the base model of
    railfem.identify.base: site preset, point supports, the measurement's spacing).
    bounds: {name: (low, high)} SI, overriding FIT_BOUNDS.
    use: quantities (railfem.identify.data.QUANTITIES). workers: processes (default all
    cores, 1 = serial). cache: kernel cache (railfem.models). profiles: parameters to
    profile. slow_nodes / slow_refine: kernel-parameter profile (defaults: 7 / 8 for the
    beam models, 4 / 1 for the WFE models). forward: a prepared ForwardModel (reused across
    fits of the same geometry, e.g. a campaign). target_options: passed to
    railfem.identify.data.hammer_target / decay_rate_target."""
    t_start = time.perf_counter()
    en15461.reset_notes()  # its notes once per fit: the data's, not every model evaluation's
    spec0 = base_spec(data, model, base)
    if forward is None:
        names = tuple(parameters)
        b = {n: (bounds or {}).get(n, FIT_BOUNDS[n]) for n in names if n in FIT_BOUNDS}
        b.update({n: v for n, v in (bounds or {}).items() if n not in b})
        space = ParameterSpace(spec0, names, bounds=b)
        target = make_target(data, use=use, spacing=spec0.spacing, **(target_options or {}))
        geometry = Geometry(frequency=target.frequency, outputs=target.outputs,
                            sensor_x=target.sensor_x, force_x=target.force_x)
        forward = ForwardModel(space, geometry, cache=cache)
    else:
        space = forward.space
        target = make_target(data, use=use, spacing=space.base.spacing,
                             **(target_options or {}))
        g = forward.geometry
        if (len(g.frequency) != len(target.frequency)
                or np.any(g.frequency != target.frequency)
                or g.outputs != target.outputs or np.any(g.force_x != target.force_x)):
            raise ValueError("the forward model was prepared for another geometry or "
                             "frequency grid than these data")
    workers = default_workers() if workers is None else int(workers)
    problem = Problem(target=target, forward=forward)
    names = space.names
    lo, hi = space.lower, space.upper
    slow = slow_names(space)
    if len(slow) > 1:
        raise ValueError(f"fit at most one kernel parameter at a time, got {slow}; fix the "
                         "others in base")
    beam = space.base.is_beam
    slow_nodes = slow_nodes or (7 if beam else 4)
    slow_refine = (8 if beam else 1) if slow_refine is None else slow_refine
    seconds = {}

    free = np.array([n not in slow for n in names])
    sobol = qmc.Sobol(d=len(names), scramble=True, seed=seed)
    u = sobol.random(max(int(n_starts), 1))
    starts = lo + (0.02 + 0.96 * u) * (hi - lo)
    x_base = np.clip(space.from_spec(space.base), lo, hi)

    slow_profile = None
    t = time.perf_counter()
    if not slow:
        runs = run_tasks(problem, _start, [(s, free) for s in starts], workers, "start")
        best = min(runs, key=lambda r: r["cost"])
        x_hat = np.array(best["x"])
    else:
        x_hat, runs, slow_profile = _fit_with_slow(problem, starts, free, slow[0], slow_nodes,
                                                   slow_refine, slow_tol, workers, x_base)
    seconds["starts"] = time.perf_counter() - t

    if reweight and len(target.use) > 1:
        groups = fdata.residuals(target, forward.receptance(x_hat))
        n_tot = sum(len(v) for v in groups.values())
        rms = {q: float(np.sqrt(np.sum(v ** 2) / max(len(v) * (1 - len(names) / n_tot), 1)))
               for q, v in groups.items()}
        top = max(rms.values())
        problem.scale = {q: max(s, 1e-6 * top, 1e-12) for q, s in rms.items()}
        if slow_profile is None:
            x_hat, _, _ = _solve(problem, x_hat, free)
        else:  # the estimate is the profile's minimum under the final scales
            x_hat, slow_profile = reprofile(problem, slow_profile, free, slow_refine,
                                            slow_tol)
    t = time.perf_counter()
    J = jacobian(problem, x_hat, slow, beam)
    r = problem.residual(x_hat)
    seconds["jacobian"] = time.perf_counter() - t

    t = time.perf_counter()
    analysis0 = uncertainty.analyse(space, x_hat, J, r)
    prof = {}
    todo = [n for n in profiles if n in names and n not in slow]
    if todo and profile_points > 1:
        prof = profile(problem, x_hat, analysis0, todo, profile_points, free, workers)
    if slow_profile is not None:  # refitted under the final scales (reprofile)
        prof[slow[0]] = _slow_profile_summary(slow_profile, float(r @ r),
                                              analysis0["residual_variance"], space, slow[0])
    analysis = uncertainty.analyse(space, x_hat, J, r, prof)
    if slow_profile is not None:
        interval_from_slow_profile(analysis, prof[slow[0]])
    seconds["profiles"] = time.perf_counter() - t
    seconds["total"] = time.perf_counter() - t_start

    receptance = forward.receptance(x_hat)
    table = fdata.residual_table(target, receptance)
    residual_rms = {q: float(np.sqrt(np.nanmean(v ** 2))) for q, v in table.items()}
    residual_bands = band_rms(target, table)
    log.info("fit %s: cost %.4g, residual RMS %s dB, %.1f s", model, float(r @ r),
             {q: round(v, 3) for q, v in residual_rms.items()}, seconds["total"])
    return FitResult(model=model, spec=space.to_spec(x_hat), names=names, x=x_hat,
                     cost=float(r @ r), parameters=analysis["parameters"],
                     correlation=np.array(analysis["correlation"]), analysis=analysis,
                     residual_rms=residual_rms, residual_bands=residual_bands,
                     scale=dict(problem.scale), starts=runs, profiles=prof,
                     slow_profile=slow_profile, target=target, receptance=receptance,
                     seconds=seconds)


def jacobian(problem: Problem, x: np.ndarray, slow=(), beam: bool = True) -> np.ndarray:
    """dr/dx at x: central differences (step 1e-6 in vector units, Problem.central_jacobian)
    for the support parameters; a forward difference of SLOW_STEP for a kernel parameter
    (each step is a new kernel)."""
    names = problem.box.names
    r0 = problem.residual(x)
    J = np.empty((len(r0), len(x)))
    fast = [i for i, n in enumerate(names) if n not in slow]
    if fast:
        J[:, fast] = problem.central_jacobian(x, 1e-6, fast)
    for i in (i for i, n in enumerate(names) if n in slow):
        J[:, i] = _slow_column(problem, x, i, r0, beam)
    return J


def _slow_column(problem: Problem, x, i, r0, beam: bool) -> np.ndarray:
    """dr/dx_i of a kernel parameter: a forward difference of SLOW_STEP (backward on the
    upper bound); a WFE fit steps to a built kernel node within 0.35 decades instead."""
    h = SLOW_STEP["timoshenko" if beam else "wfe"]
    step = h if x[i] + h <= problem.box.upper[i] else -h
    if not beam:  # reuse a built kernel node within 0.35 decades (one-sided)
        near = [v for v in problem.forward.slow_values(i) if 0 < abs(v - x[i]) <= 0.35]
        if near:
            step = min(near, key=lambda v: abs(v - x[i])) - x[i]
    xp = x.copy()
    xp[i] += step
    return (problem.residual(xp) - r0) / step


def _fit_with_slow(problem, starts, free, name, n_nodes, n_refine, tol, workers, x_base):
    """Profile over the kernel parameter ``name`` (SlowProfile): multi-start at the middle
    node, warm starts outward, then parabolic refinement of the profile minimum (from the
    points at the box's edge as well; a concave bracket steps to its better edge)."""
    space = problem.box
    i = space.names.index(name)
    lo, hi = space.lower[i], space.upper[i]
    nodes = np.linspace(lo, hi, n_nodes + 2)[1:-1] if n_nodes > 1 else np.array([x_base[i]])
    prebuild_nodes(problem, nodes, i, x_base, workers)
    mid = len(nodes) // 2
    order = [mid] + [k for d in range(1, len(nodes)) for k in (mid - d, mid + d)
                     if 0 <= k < len(nodes)]

    def evaluate(s):  # warm-started from the nearest refitted value
        x0 = prof.nearest(s)[1].copy()
        x0[i] = s
        x, cost, _ = _solve(problem, x0, free)
        log.info("fit: %s = %.6g: cost %.6g", name, space.parameters[i].decode(s), cost)
        return cost, x

    prof = SlowProfile(evaluate)
    s = nodes[mid]
    xs = np.array(starts)
    xs[:, i] = s
    runs = run_tasks(problem, _start, [(x0, free) for x0 in xs], workers,
                     f"start ({name} = {space.parameters[i].decode(s):.4g})")
    best = min(runs, key=lambda r: r["cost"])
    prof.points[prof.key(s)] = (best["cost"], np.array(best["x"]))
    for k in order[1:]:
        prof.at(nodes[k])
    prof.refine(n_refine, tol, at_edge=True, lo=lo, hi=hi)
    x_best, profile_ = _profile_dict(prof.points, space, i, name)
    return x_best, runs, profile_


def reprofile(problem, slow_profile: dict, free, n_refine, tol):
    """The kernel-parameter profile refitted under the problem's (final) residual scales:
    each point warm-started from its first-pass refit, then parabolic refinement of the
    minimum; returns (x at the profile's minimum, the profile dict)."""
    space = problem.box
    name = slow_profile["name"]
    i = space.names.index(name)
    old = {float(v): np.array(x) for v, x in zip(slow_profile["vector"], slow_profile["x"])}

    def evaluate(s):
        x0 = (old.get(s) if s in old else prof.nearest(s)[1]).copy()
        x0[i] = s
        x, cost, _ = _solve(problem, x0, free)
        log.debug("fit: %s = %.6g: cost %.6g (final scales)", name,
                  space.parameters[i].decode(s), cost)
        return cost, x

    prof = SlowProfile(evaluate)
    for v in sorted(old):
        prof.at(v)
    prof.refine(n_refine, tol, at_edge=True, lo=space.lower[i], hi=space.upper[i])
    return _profile_dict(prof.points, space, i, name)


def _profile_dict(done: dict, space, i, name):
    """(x at the minimum, profile dict) of SlowProfile points {vector: (cost, x)}."""
    s_best = min(done, key=lambda v: done[v][0])
    vals = sorted(done)
    return done[s_best][1], {
        "name": name, "vector": [float(v) for v in vals],
        "value": [space.parameters[i].decode(v) for v in vals],
        "cost": [done[v][0] for v in vals], "x": [done[v][1].tolist() for v in vals]}


def interval_from_slow_profile(analysis: dict, summary: dict) -> None:
    """The kernel parameter's 95 % interval is its profile's (the refits at fixed values):
    a forward-difference Jacobian column only approximates it; the linearised one is kept
    as ``ci95_linearised``."""
    for p in analysis["parameters"]:
        if p["name"] == summary["name"]:
            p["ci95_linearised"] = p["ci95"]
            p["ci95"] = list(summary["ci95"])
            p["interval"] = "profile"


def prebuild_nodes(problem, nodes, i, x_base, workers):
    """Build the engines of the kernel-parameter nodes (in parallel processes)."""
    fwd = problem.forward
    if fwd.kind != "spectral":
        return
    xs = []
    for s in nodes:
        x = x_base.copy()
        x[i] = s
        xs.append(x)
    if workers <= 1:
        for x in xs:
            fwd.engine(fwd.spec(x))
        return
    engines = run_tasks(problem, _engine_task, [(x,) for x in xs], workers, "kernel")
    for e in engines:
        fwd.add_engine(e)


def _engine_task(problem, x):
    fwd = problem.forward
    return fwd.engine(fwd.spec(x))


def profile(problem, x_hat, analysis, names, n_points, free, workers) -> dict:
    """Profile likelihoods: for each name, the others refitted on a grid of fixed values
    around the estimate (+- max(2.5 x the 95 % half-width, 0.3 decades), inside the box)."""
    space = problem.forward.space
    c0 = problem.cost(x_hat)
    s2 = analysis["residual_variance"]
    tasks, where = [], []
    for n in names:
        i = space.names.index(n)
        p = analysis["parameters"][i]
        half = analysis["t_quantile"] * p["std_vector"]
        span = max(2.5 * half if np.isfinite(half) else 0.0, 0.3)
        grid = np.linspace(max(x_hat[i] - span, space.lower[i]),
                           min(x_hat[i] + span, space.upper[i]), n_points)
        tasks += [(x_hat, i, v, free) for v in grid]
        where += [n] * len(grid)
    out = list(zip(where, run_tasks(problem, _profile_point, tasks, workers, "profile point")))

    def curve(n):  # (values, costs, delta chi^2) of the points of n so far, sorted
        pts = sorted((o["value"], o["cost"]) for w, o in out if w == n)
        vec, cost = np.array([v for v, _ in pts]), np.array([c for _, c in pts])
        return vec, cost, (cost - min(c0, cost.min())) / max(s2, 1e-300)

    for _ in range(PROFILE_ROUNDS):  # finer points until the interval spans several
        tasks, where = [], []
        for n in names:
            new = refine_points(*curve(n)[::2])
            tasks += [(x_hat, space.names.index(n), v, free) for v in new]
            where += [n] * len(new)
        if not tasks:
            break
        out += zip(where, run_tasks(problem, _profile_point, tasks, workers, "profile point"))
    return {n: _profile_summary(space, space.names.index(n), *curve(n)) for n in names}


def refine_points(vec, dchi, min_inside: int = PROFILE_MIN_INSIDE, n_new: int = 6) -> list:
    """New profile values when fewer than ``min_inside`` points lie within the 95 %
    threshold: ``n_new`` evenly between the points that bracket the minimum (the last at
    or above the threshold on each side, or the grid's end); [] when enough lie inside."""
    inside = dchi < CHI2_95
    if inside.sum() >= min_inside or len(vec) < 2:
        return []
    k = int(np.argmin(dchi))
    below = np.flatnonzero(~inside[:k])
    above = np.flatnonzero(~inside[k + 1:])
    a = int(below[-1]) if below.size else 0
    b = k + 1 + int(above[0]) if above.size else len(vec) - 1
    if vec[b] <= vec[a]:
        return []
    new = np.linspace(vec[a], vec[b], n_new + 2)[1:-1]
    tol = 1e-9 * max(1.0, float(np.abs(vec).max()))
    return [float(v) for v in new if np.min(np.abs(vec - v)) > tol]


def _profile_summary(space, i, vec, cost, dchi, widen: bool = False) -> dict:
    p = space.parameters[i]
    lo, hi, open_ = profile_interval(vec, dchi, widen=widen)
    return {"name": p.name, "vector": vec.tolist(), "value": [p.decode(v) for v in vec],
            "cost": cost.tolist(), "delta_chi2": dchi.tolist(),
            "ci95": [p.decode(lo), p.decode(hi)], "open": open_}


def profile_interval(vec, dchi, *, widen: bool = False) -> tuple[float, float, str | None]:
    """(low, high, open side) of the 95 % interval of a profile (values ``vec`` sorted,
    ``dchi`` its delta chi^2): where it crosses CHI2_95, linearly interpolated, or the end
    of the profile where it stays below ('low', 'high', 'both'). ``widen``: a coarse
    profile (a kernel parameter: each point a kernel), each end moved out to where the
    parabola through the minimum and its neighbours crosses, but not beyond the
    bracketing point: on a convex profile the straight line from a point below the
    threshold to one far above crosses too early."""
    vec, dchi = np.asarray(vec, dtype=float), np.asarray(dchi, dtype=float)
    k = int(np.argmin(dchi))
    low_open, high_open = dchi[0] < CHI2_95, dchi[-1] < CHI2_95
    lo = vec[0] if low_open else _crossing(vec[:k + 1][::-1], dchi[:k + 1][::-1])
    hi = vec[-1] if high_open else _crossing(vec[k:], dchi[k:])
    if widen and 0 < k < len(vec) - 1:
        A = np.vstack([vec[k - 1:k + 2] ** 2, vec[k - 1:k + 2], np.ones(3)]).T
        a, b, c = np.linalg.solve(A, dchi[k - 1:k + 2])
        disc = b * b - 4 * a * (c - CHI2_95)
        if a > 0 and disc > 0:
            r1, r2 = (-b - np.sqrt(disc)) / (2 * a), (-b + np.sqrt(disc)) / (2 * a)
            out_lo = [j for j in range(k) if dchi[j] >= CHI2_95]
            out_hi = [j for j in range(k + 1, len(vec)) if dchi[j] >= CHI2_95]
            if out_lo:
                lo = max(min(lo, r1), vec[out_lo[-1]])
            if out_hi:
                hi = min(max(hi, r2), vec[out_hi[0]])
    open_ = "both" if low_open and high_open else "low" if low_open else \
        "high" if high_open else None
    return float(lo), float(hi), open_


def _slow_profile_summary(sp, c_best, s2, space, name) -> dict:
    i = space.names.index(name)
    vec = np.array(sp["vector"])
    cost = np.array(sp["cost"])
    return _profile_summary(space, i, vec, cost,
                            (cost - min(c_best, cost.min())) / max(s2, 1e-300), widen=True)


def _crossing(x, y) -> float:
    """First x where y (starting below CHI2_95) reaches CHI2_95, linearly interpolated."""
    for j in range(1, len(x)):
        if y[j] >= CHI2_95:
            if y[j - 1] >= CHI2_95 or y[j] == y[j - 1]:
                return float(x[j - 1])
            return float(x[j - 1] + (CHI2_95 - y[j - 1]) * (x[j] - x[j - 1]) / (y[j] - y[j - 1]))
    return float(x[-1])


def band_rms(target: fdata.Target, table: dict) -> dict:
    """Per quantity and sensor, the RMS residual (dB) in each one-third-octave band."""
    out = {}
    centres = target.bands.nominal
    member = iec61260.band_index(target.frequency, target.bands)
    for q, v in table.items():
        rows = {}
        for o, sensor in enumerate(target.outputs):
            vals = []
            for k in range(len(target.bands.nominal)):
                if q == "tdr":
                    x = v[k, o]
                    vals.append(None if not np.isfinite(x) else float(abs(x)))
                    continue
                m = member == k
                sel = v[m, o].ravel()
                sel = sel[np.isfinite(sel)]
                vals.append(float(np.sqrt(np.mean(sel ** 2))) if sel.size else None)
            rows[sensor] = vals
        out[q] = {"band_hz": centres.tolist(), **rows}
    return out
