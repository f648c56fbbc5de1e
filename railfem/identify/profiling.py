"""Profiles of a fit (railfem.identify.fit) and the parallel processes they run in.

* **Kernel parameter** (eta_r or pad_length: each value a new kernel): ``fit_with_slow``
  fits the support parameters at ``n_nodes`` values spread over its bounds (multi-start at
  the middle one, warm starts outward), then refines the profile's minimum by parabolic
  steps (railfem.identify.problem.SlowProfile); ``reprofile`` refits that profile under
  the final residual scales (the estimate is its minimum, every cost under one set of
  scales); ``interval_from_slow_profile`` makes its 95 % interval the profile's.
* **Stiffness profiles** (``profile``): the other parameters refitted on a grid of fixed
  values around the estimate, with finer points around the minimum until at least
  PROFILE_MIN_INSIDE lie within the 95 % threshold (``refine_points``);
  ``profile_interval`` reads the interval where the profile crosses CHI2_95.
* ``run_tasks``: a function of the problem over argument lists in ``workers`` processes
  (BLAS pinned to one thread each with threadpoolctl).
* ``Lanes``: worker processes kept for a whole fit, each computing its own part of the
  frequency grid of every WFE kernel (``Lanes.builder``: the fit's engines;
  ``Lanes.receptances``: the door at other specs, e.g. the model-form variants), so a
  single kernel uses every core and each lane keeps the waves of its part in memory.
"""
from __future__ import annotations

import logging
import os
import time
from concurrent.futures import BrokenExecutor, ProcessPoolExecutor

import numpy as np

from railfem.identify.forward import (
    door_receptance, log_building, part, spectral_arrays, spectral_key,
)
from railfem.identify.problem import Problem, SlowProfile
from railfem.track import kernelcache

log = logging.getLogger(__name__)

CHI2_95 = 3.841  # chi-square(1) 95 % quantile: the profile-likelihood threshold
PROFILE_MIN_INSIDE = 5  # profile points within the 95 % threshold a profile refines to
PROFILE_ROUNDS = 3  # rounds of finer profile points at most


def solve_free(problem: Problem, x0, free, *, max_nfev=None):
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
    problem.forward.builder = None  # the parent's lanes are not this process's
    _WORKER["limits"] = threadpool_limits(1)  # kept alive for the worker's lifetime


def _run(task):
    fn, args = task
    return fn(_WORKER["problem"], *args)


#: the wave cache of a lane (MB, railfem.rail.waves): the waves of its part of every
#: kernel of a fit (about 60 MB each on the default 60E1 mesh), unless the variable is set
LANE_WAVE_CACHE_MB = 1024


def _init_lane(problem):
    from railfem.rail import waves

    os.environ.setdefault(waves.CACHE_VARIABLE, str(LANE_WAVE_CACHE_MB))
    _init_worker(problem)


class Lanes:
    """``n`` worker processes kept for a fit (a context manager), one single-process pool
    each: every WFE kernel's frequency grid is split in n contiguous parts, part j always
    computed in lane j (its near-field tail solved at the grid's lowest frequency, so the
    parts are the whole grid's kernel: railfem.track.wfe.discrete_kernel), so a kernel
    uses n cores and each lane keeps the waves of its part (railfem.rail.waves' cache)
    for the next kernel of the same rail at the same loss factor."""

    def __init__(self, problem: Problem, n: int):
        self.problem, self.n = problem, int(n)
        self.built: set = set()  # spectral keys the builder has put into the store
        self.prefetched: list = []
        self.computed = 0  # kernels the builder computed (not found in the store)
        self.pools = [ProcessPoolExecutor(max_workers=1, initializer=_init_lane,
                                          initargs=(problem,)) for _ in range(self.n)]

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self) -> None:
        for pool in self.pools:
            pool.shutdown(cancel_futures=True)

    def parts(self) -> list:
        """The frequency rows of each lane."""
        nf = len(self.problem.forward.geometry.frequency)
        return [rows for rows in np.array_split(np.arange(nf), self.n) if rows.size]

    def submit(self, fn, *args, lane: int | None = None) -> list:
        """fn(problem, rows, *args) in every lane on its rows, or in ``lane`` on every
        row: the futures."""
        if lane is not None:
            rows = np.concatenate(self.parts())
            return [self.pools[lane % self.n].submit(_run, (fn, (rows,) + args))]
        return [self.pools[j].submit(_run, (fn, (rows,) + args))
                for j, rows in enumerate(self.parts())]

    def builder(self, specs) -> None:
        """The SpectralEngine arrays of ``specs`` computed in the lanes, put into the
        forward model's kernel store (under spectral_key) unless already there
        (railfem.identify.forward.ForwardModel.builder)."""
        fwd = self.problem.forward
        store = kernelcache.resolve(fwd.cache)
        todo = {}
        for s in specs:
            key = spectral_key(s, fwd.geometry)
            if key in self.built:
                continue
            self.built.add(key)
            log_building(s)
            if store.get(key) is None:
                todo[key] = self.submit(_spectral_part, s)
                self.computed += 1
        t0 = time.perf_counter()
        for n, (key, futs) in enumerate(todo.items(), 1):
            got = [f.result() for f in futs]
            store.put(key, {k: np.concatenate([g[k] for g in got]) for k in got[0]})
            if len(todo) > 1:
                log.info("fit: kernel %d/%d done (%.1f s)", n, len(todo),
                         time.perf_counter() - t0)

    def receptances(self, specs, cache, rail=None) -> list:
        """door_receptance of each spec at the forward model's geometry, computed in the
        lanes (kernel ``cache`` as the door's): per spec the array, or the exception it
        raised. A spec on ``rail`` (a RailSpec: the lanes hold the waves of their parts)
        is split over the lanes, each other one computed whole in one lane in turn (its
        near-field tail solved once)."""
        if isinstance(cache, kernelcache.KernelStore):  # its folder, not its memory
            cache = cache.directory or False
        whole = [k for k, s in enumerate(specs) if rail is None or s.rail != rail]
        futs = [self.submit(_door_part, s, cache,
                            lane=whole.index(k) if k in whole else None)
                for k, s in enumerate(specs)]
        self.prefetched.clear()
        out = []
        for fs in futs:
            try:
                out.append(np.concatenate([f.result() for f in fs]))
            except BrokenExecutor:  # a lane died: not the variant's failure
                raise
            except Exception as exc:  # noqa: BLE001 -- handed to the caller, as the door's
                out.append(exc)
        return out

    def prefetch(self, labelled, rail) -> None:
        """Start the near-field tails (railfem.rail.waves.frozen_tail: solved without the
        loss factor, shared by every loss factor) of the ``labelled`` specs [(label,
        spec)] not on ``rail`` in the lanes ``receptances(specs, cache, rail)`` computes
        them in (whole, in turn), without waiting: the model-form variants' tails while the
        lanes would otherwise wait on the multi-start. Nothing when the builder found
        every kernel in the store (a warm cache holds the variants' kernels as well)."""
        if not self.computed:
            return
        specs = [s for _, s in labelled if s.rail != rail]
        self.prefetched = [self.submit(_tail_part, s, lane=k)[0] for k, s in enumerate(specs)]


def _tail_part(problem, rows, spec) -> None:
    """The near-field tail of spec's rail at the grid's lowest frequency, by the door at
    that frequency alone (the result is dropped: the tail stays in the wave cache)."""
    g = problem.forward.geometry
    f0 = float(g.frequency.min())
    door_receptance(spec, np.array([f0]), g.sensor_x, g.force_x, g.outputs, force=g.force,
                    cache=False)


def _spectral_part(problem, rows, spec):
    g = problem.forward.geometry
    return spectral_arrays(spec, part(g, rows), tail_frequency=float(g.frequency.min()))


def _door_part(problem, rows, spec, cache):
    g = problem.forward.geometry
    return door_receptance(spec, g.frequency[rows], g.sensor_x, g.force_x, g.outputs,
                           force=g.force, cache=cache,
                           tail_frequency=float(g.frequency.min()))


def start_task(problem, x0, free):
    t = time.perf_counter()
    x, cost, nfev = solve_free(problem, x0, free)
    return {"x0": np.asarray(x0).tolist(), "x": x.tolist(), "cost": cost, "nfev": nfev,
            "seconds": time.perf_counter() - t}


def _profile_point(problem, x_hat, i, value, free):
    x0 = np.array(x_hat, dtype=float)
    x0[i] = value
    f = np.array(free, dtype=bool)
    f[i] = False
    x, cost, _ = solve_free(problem, x0, f)
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



def fit_with_slow(problem, starts, free, name, n_nodes, n_refine, tol, workers, x_base, *,
                  after_nodes=None):
    """Profile over the kernel parameter ``name`` (SlowProfile): multi-start at the middle
    node, warm starts outward, then parabolic refinement of the profile minimum (from the
    points at the box's edge as well; a concave bracket steps to its better edge).
    after_nodes: called once the nodes' kernels are built (e.g. Lanes.prefetch)."""
    space = problem.box
    i = space.names.index(name)
    lo, hi = space.lower[i], space.upper[i]
    nodes = np.linspace(lo, hi, n_nodes + 2)[1:-1] if n_nodes > 1 else np.array([x_base[i]])
    prebuild_nodes(problem, nodes, i, x_base, workers)
    if after_nodes is not None:
        after_nodes()
    mid = len(nodes) // 2
    order = [mid] + [k for d in range(1, len(nodes)) for k in (mid - d, mid + d)
                     if 0 <= k < len(nodes)]

    def evaluate(s):  # warm-started from the nearest refitted value
        x0 = prof.nearest(s)[1].copy()
        x0[i] = s
        x, cost, _ = solve_free(problem, x0, free)
        log.info("fit: %s = %.6g: cost %.6g", name, space.parameters[i].decode(s), cost)
        return cost, x

    prof = SlowProfile(evaluate)
    s = nodes[mid]
    xs = np.array(starts)
    xs[:, i] = s
    runs = run_tasks(problem, start_task, [(x0, free) for x0 in xs], workers,
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
        x, cost, _ = solve_free(problem, x0, free)
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


def interval_from_slow_profile(analysis: dict, summary: dict, space=None, x=None, *,
                               extra: float = 0.0) -> None:
    """The kernel parameter's 95 % interval is its profile's (the refits at fixed values):
    a forward-difference Jacobian column only approximates it; the linearised one is kept
    as ``ci95_linearised``. ``extra`` (vector units, with ``space`` and the estimate ``x``):
    a half-width added in quadrature to each side (the model-form discrepancy's share,
    which refits under one set of scales do not show)."""
    for p in analysis["parameters"]:
        if p["name"] == summary["name"]:
            p["ci95_linearised"] = p["ci95"]
            p["ci95"] = list(summary["ci95"])
            p["interval"] = "profile"
            if extra > 0 and space is not None:
                i = space.names.index(p["name"])
                par = space.parameters[i]
                lo, hi = (par.encode(v) for v in p["ci95"])
                lo = x[i] - float(np.hypot(x[i] - lo, extra))
                hi = x[i] + float(np.hypot(hi - x[i], extra))
                p["ci95"] = [par.decode(lo), par.decode(hi)]
                p["interval"] = "profile, widened by the model-form discrepancy"


def prebuild_nodes(problem, nodes, i, x_base, workers):
    """Build the engines of the kernel-parameter nodes (in parallel processes)."""
    fwd = problem.forward
    if fwd.kind not in ("spectral", "eigen"):
        return
    xs = []
    for s in nodes:
        x = x_base.copy()
        x[i] = s
        xs.append(x)
    if fwd.builder is not None:  # each kernel on every lane
        fwd.builder([fwd.spec(x) for x in xs])
        for x in xs:
            fwd.engine(fwd.spec(x))
        return
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


def slow_profile_summary(sp, c_best, s2, space, name) -> dict:
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
