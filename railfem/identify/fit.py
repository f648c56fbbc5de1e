"""Track parameters from measured data: bounded nonlinear least squares in dB (METHOD.md §7).

    import railfem as rf
    from railfem.identify import fit
    meas = rf.io.read_measurement("site_b/")
    result = fit(meas, model="wfe-discrete", use=("point", "transfer", "tdr"))
    result.parameters          # estimates, 95 % intervals, identifiable yes/no/weak + reason
    result.discrepancy         # the model-form discrepancy used (per-band s_d, dB)

The problem (railfem.identify.problem.Problem, the one the diagnosis uses as well):
minimise sum_i (r_i / s_i)^2 over the parameter vector x of a
railfem.params.ParameterSpace inside its box (scipy.optimize.least_squares, 'trf'), with
r_i the residuals in dB (railfem.identify.data) and s_i their scale: 1 dB for the first
pass, then the final scales, by default those of ``railfem diagnose``:

* **Model-form discrepancy** (``discrepancy='ensemble'``, the default, as
  railfem.diagnosis.diagnose): the base at the first-pass estimate is evaluated in its own
  discretisation variants (railfem.identify.discrepancy.ensemble: straight edges, another
  element size, another spring rule and count; beam models: their section constants from
  another mesh or the catalogue), giving per band and quantity a variance s_d^2. Each
  residual entry is scaled by sqrt(noise^2 + s_d^2), the noise being the white-noise level
  of the first-pass residual per quantity (1.4826 MAD of its first differences over
  frequency / sqrt 2, at least MIN_NOISE dB), so bands the model cannot predict (near the
  cut-on frequencies) weigh less; each variant's difference from the base is a random term
  of the residual (railfem.identify.problem.Problem.discrepancy_columns), so the 95 %
  intervals carry the shift of the estimate under the variants. The residuals are then the
  used entries unweighted (railfem.identify.problem.used_rows, as the diagnosis's): band
  weights other than 0 and 1 need ``discrepancy=None``.
* ``discrepancy=None``: the residuals weighted by the band weights, the final scale of
  each quantity its own residual RMS (``reweight``: point mobility, transfers and decay
  rates count by how well each is fitted, not by how many numbers each has).

Then:

* **Multi-start**: ``n_starts`` points of a scrambled Sobol sequence in the box (vector
  units: log10 for stiffnesses, loss factors and the mass), run in parallel processes
  (``workers``; BLAS pinned to one thread per process with threadpoolctl); the best is kept.
* **Kernels on every core**: a WFE fit with more than one worker keeps ``workers``
  processes for its duration (railfem.identify.profiling.Lanes). Each kernel it needs (the
  profile nodes, each refinement, the discrepancy's variant on the same section) is split
  by frequency over them, each process always taking the same part of the grid, so it
  keeps that part's waves in memory for the next kernel of the same rail; the parts are
  the whole grid's kernel exactly (the near-field tail solved at the grid's lowest
  frequency in each). A variant on another section mesh is computed whole in one process
  (its tail solved once, started while the processes would wait on the multi-start).
* **Kernel parameters** (eta_r, pad_length; railfem.identify.forward.SLOW) change the
  parameter-free kernel, so the fit does not differentiate through them: it profiles
  (railfem.identify.profiling). The support parameters are fitted at ``slow_nodes``
  values spread over the slow parameter's bounds, then the minimum of that profile is
  refined by parabolic steps (each a new kernel) until it moves less than ``slow_tol``
  (vector units) or ``slow_refine`` steps are spent. Under the final scales the profile is
  refitted (warm starts, one more refinement): the estimate is its minimum, every cost of
  the reported profile under the same scales, and its 95 % interval the profile's, widened
  in quadrature by the discrepancy's share (``ci95_linearised``: from the Jacobian, which
  uses a finite-difference column for it).
* **Uncertainty** (railfem.identify.uncertainty): covariance from the Jacobian at the
  optimum scaled by the residual variance (with a discrepancy, as in the diagnosis: the
  larger of it and the cluster-robust one, plus the variants' random terms), 95 %
  intervals, correlations, identifiability; profile likelihoods of the stiffnesses (kp,
  kb): the other parameters refitted on a grid of fixed values (the kernel parameters held
  at their estimate), with finer points around the minimum until at least
  PROFILE_MIN_INSIDE lie within the 95 % threshold.
"""
from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass

import numpy as np
from scipy.stats import qmc

from railfem.identify import data as fdata
from railfem.identify import discrepancy as model_form
from railfem.identify import uncertainty
from railfem.identify.base import BASE_PARAMETERS, default_base, describe_base
from railfem.identify.forward import ForwardModel, Geometry, door_receptance, slow_names
from railfem.identify.problem import Problem, Scale, used_rows, weighted_rows
from railfem.identify.profiling import (
    Lanes, default_workers, fit_with_slow, interval_from_slow_profile,
    profile, reprofile, run_tasks, slow_profile_summary, solve_free, start_task,
)
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
SLOW_STEP = {"timoshenko": 1e-4, "wfe": 0.02}  # finite-difference step of a kernel parameter
#: the model-form discrepancy by default, as railfem.diagnosis.diagnose's: 'ensemble'
#: (railfem.identify.discrepancy), None (noise only) or a Discrepancy
DISCREPANCY = "ensemble"
MIN_NOISE = 0.1  # dB: the least white-noise level of a quantity (as the diagnosis's)


# ------------------------------------------------------------------ the fit


@dataclass(frozen=True, kw_only=True, eq=False)
class FitResult:
    """A fitted track: spec, estimates with 95 % intervals and identifiability, residuals.

    parameters: one dict per parameter (name, unit, value, ci95, identifiable, reason, ...).
    correlation: (p, p). residual_rms: {quantity: RMS dB}; residual_bands: {quantity:
    per-band RMS dB per sensor}. starts: the multi-start runs. profiles: {name: profile}.
    slow_profile: the kernel-parameter profile (values, costs) or None. discrepancy: the
    model-form discrepancy used (railfem.identify.discrepancy.Discrepancy.to_dict: method,
    variants, per-band s_d in dB per quantity; method 'none' without)."""

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
    discrepancy: dict | None = None

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
            "model_form_discrepancy": self.discrepancy or model_form.none().to_dict(),
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
        forward: ForwardModel | None = None, target_options=None,
        discrepancy=DISCREPANCY) -> FitResult:
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
    railfem.identify.data.hammer_target / decay_rate_target. discrepancy: the model-form
    discrepancy the residuals are scaled with ('ensemble', the default, as ``railfem
    diagnose``; None: noise only, each quantity scaled by its residual RMS when
    ``reweight``; or a railfem.identify.discrepancy.Discrepancy). See the module docstring."""
    t_start = time.perf_counter()
    en15461.reset_notes()  # its notes once per fit: the data's, not every model evaluation's
    check_discrepancy(discrepancy)
    forward, target = prepare(data, model, parameters=parameters, base=base, bounds=bounds,
                              use=use, cache=cache, forward=forward,
                              target_options=target_options)
    check_band_weights(target, discrepancy)
    workers = default_workers() if workers is None else int(workers)
    rows = weighted_rows if discrepancy is None else used_rows
    problem = Problem(target=target, forward=forward, rows=rows)
    space = forward.space
    names, lo, hi = space.names, space.lower, space.upper
    slow = slow_names(space)
    if len(slow) > 1:
        raise ValueError(f"fit at most one kernel parameter at a time, got {slow}; fix the "
                         "others in base")
    beam = space.base.is_beam
    slow_nodes = slow_nodes or (7 if beam else 4)
    slow_refine = (8 if beam else 1) if slow_refine is None else slow_refine
    seconds = {}

    free = np.array([n not in slow for n in names])
    u = qmc.Sobol(d=len(names), scramble=True, seed=seed).random(max(int(n_starts), 1))
    starts = lo + (0.02 + 0.96 * u) * (hi - lo)
    x_base = np.clip(space.from_spec(space.base), lo, hi)

    lanes = open_lanes(problem, workers)
    try:
        slow_profile = None
        t = time.perf_counter()
        # the variants' near-field tails (any loss factor) while the lanes would wait
        prefetch = None if lanes is None or discrepancy != "ensemble" else \
            (lambda: lanes.prefetch(model_form.variants(space.base), space.base.rail))
        if not slow:
            forward.engine(forward.spec(x_base))  # built here once, not in every worker process
            if prefetch is not None:
                prefetch()
            runs = run_tasks(problem, start_task, [(s, free) for s in starts], workers, "start")
            x_hat = np.array(min(runs, key=lambda r: r["cost"])["x"])
        else:
            x_hat, runs, slow_profile = fit_with_slow(problem, starts, free, slow[0], slow_nodes,
                                                      slow_refine, slow_tol, workers, x_base,
                                                      after_nodes=prefetch)
        seconds["starts"] = time.perf_counter() - t

        t = time.perf_counter()
        scale = final_scale(problem, x_hat, discrepancy, reweight=reweight, cache=cache,
                            lanes=lanes)
        if scale is not None:
            problem.scale = scale
            if slow_profile is None:
                x_hat, _, _ = solve_free(problem, x_hat, free)
            else:  # the estimate is the profile's minimum under the final scales
                x_hat, slow_profile = reprofile(problem, slow_profile, free, slow_refine,
                                                slow_tol)
        seconds["final_scales"] = time.perf_counter() - t
        t = time.perf_counter()
        J = jacobian(problem, x_hat, slow, beam)
        r = problem.residual(x_hat)
        seconds["jacobian"] = time.perf_counter() - t

        t = time.perf_counter()
        analysis, prof = analyse(problem, x_hat, J, r, slow, slow_profile,
                                 [n for n in profiles if n in names and n not in slow],
                                 profile_points, free, workers)
        seconds["profiles"] = time.perf_counter() - t
    finally:
        if lanes is not None:
            lanes.close()
            forward.builder = None
    seconds["total"] = time.perf_counter() - t_start

    receptance = forward.receptance(x_hat)
    table = fdata.residual_table(target, receptance)
    residual_rms = {q: float(np.sqrt(np.nanmean(v ** 2))) for q, v in table.items()}
    disc = getattr(problem.scale, "discrepancy", None)
    log.info("fit %s: cost %.4g, residual RMS %s dB, %.1f s", model, float(r @ r),
             {q: round(v, 3) for q, v in residual_rms.items()}, seconds["total"])
    return FitResult(model=model, spec=space.to_spec(x_hat), names=names, x=x_hat,
                     cost=float(r @ r), parameters=analysis["parameters"],
                     correlation=np.array(analysis["correlation"]), analysis=analysis,
                     residual_rms=residual_rms, residual_bands=band_rms(target, table),
                     scale=dict(problem.scale), starts=runs, profiles=prof,
                     slow_profile=slow_profile, target=target, receptance=receptance,
                     seconds=seconds,
                     discrepancy=(model_form.none() if disc is None else disc).to_dict())


def prepare(data, model, *, parameters, base, bounds, use, cache, forward, target_options):
    """(forward model, target) of a fit: ``forward`` checked against the data's geometry,
    or a new ForwardModel on the space of ``parameters`` around the base spec."""
    if forward is None:
        spec0 = base_spec(data, model, base)
        names = tuple(parameters)
        b = {n: (bounds or {}).get(n, FIT_BOUNDS[n]) for n in names if n in FIT_BOUNDS}
        b.update({n: v for n, v in (bounds or {}).items() if n not in b})
        space = ParameterSpace(spec0, names, bounds=b)
        target = make_target(data, use=use, spacing=spec0.spacing, **(target_options or {}))
        geometry = Geometry(frequency=target.frequency, outputs=target.outputs,
                            sensor_x=target.sensor_x, force_x=target.force_x)
        return ForwardModel(space, geometry, cache=cache), target
    target = make_target(data, use=use, spacing=forward.space.base.spacing,
                         **(target_options or {}))
    g = forward.geometry
    if (len(g.frequency) != len(target.frequency) or np.any(g.frequency != target.frequency)
            or g.outputs != target.outputs or np.any(g.force_x != target.force_x)):
        raise ValueError("the forward model was prepared for another geometry or "
                         "frequency grid than these data")
    return forward, target


def check_discrepancy(discrepancy) -> None:
    """A ValueError unless ``discrepancy`` is 'ensemble', None or a Discrepancy."""
    if not (discrepancy is None or discrepancy == "ensemble"
            or isinstance(discrepancy, model_form.Discrepancy)):
        raise ValueError(f"discrepancy {discrepancy!r}: give 'ensemble' (the base's own "
                         "discretisation variants), None (noise only) or a "
                         "railfem.identify.discrepancy.Discrepancy")


def check_band_weights(target: fdata.Target, discrepancy) -> None:
    """A model-form discrepancy weighs the bands itself: band weights other than 0 (leave
    out) and 1 need discrepancy=None."""
    if discrepancy is None:
        return
    w = [np.asarray(a, dtype=float) for a in (target.frf_weight, target.band_weight)
         if a is not None]
    if any(np.any((a != 0) & (a != 1)) for a in w):
        raise ValueError("band weights other than 0 and 1 with a model-form discrepancy: "
                         "the discrepancy weighs the bands itself; give discrepancy=None "
                         "(--discrepancy none) to weigh them by hand")


def final_scale(problem: Problem, x, discrepancy, *, reweight: bool = True, cache=None,
                lanes=None):
    """The residual scales of the final fit at the first-pass estimate x: with a
    ``discrepancy`` a Scale of the white-noise level per quantity (``white_noise``) and the
    discrepancy ('ensemble': ``ensemble_at``); without, each quantity's residual RMS
    (``reweight`` and more than one quantity) or None (the first pass's 1 dB stand).
    lanes: railfem.identify.profiling.Lanes the variants are computed in, or None."""
    target = problem.target
    if discrepancy is not None:
        if isinstance(discrepancy, str):
            discrepancy = ensemble_at(problem, x, cache, lanes)
        return Scale(white_noise(target, problem.forward.receptance(x)), discrepancy)
    if not reweight or len(target.use) <= 1:
        return None
    groups = fdata.residuals(target, problem.forward.receptance(x))
    n_tot = sum(len(v) for v in groups.values())
    p = len(problem.box.names)
    rms = {q: float(np.sqrt(np.sum(v ** 2) / max(len(v) * (1 - p / n_tot), 1)))
           for q, v in groups.items()}
    top = max(rms.values())
    return {q: max(s, 1e-6 * top, 1e-12) for q, s in rms.items()}


def white_noise(target: fdata.Target, receptance) -> dict:
    """Per quantity, the white-noise level (dB) of the residual of ``receptance``: 1.4826
    MAD of its first differences over frequency (band for the decay rate) / sqrt 2, at
    least MIN_NOISE (railfem.diagnosis.problem.noise_scale's rule)."""
    out = {}
    for q, v in fdata.residual_table(target, receptance).items():
        d = np.diff(np.asarray(v, dtype=float).reshape(v.shape[0], -1), axis=0)
        d = d[np.isfinite(d)]
        mad = 1.4826 * float(np.median(np.abs(d - np.median(d)))) if d.size else 0.0
        out[q] = max(mad / math.sqrt(2), MIN_NOISE)
    return out


def ensemble_at(problem: Problem, x, cache=None, lanes=None) -> model_form.Discrepancy:
    """The model-form discrepancy of the fit's base at x (railfem.identify.discrepancy
    .ensemble over its variants): the base from the fit's own forward model, each variant
    through the door at the data's geometry (kernel ``cache`` as the fit's), computed in
    ``lanes`` (railfem.identify.profiling.Lanes: every variant on every core) if given."""
    fwd = problem.forward
    spec = fwd.spec(x)
    g = fwd.geometry
    done = {}
    if lanes is not None:
        specs = [s for _, s in model_form.variants(spec)]
        done = dict(zip(map(variant_key, specs),
                        lanes.receptances(specs, cache, rail=spec.rail)))

    def receptance(s, record):
        if s is spec:
            return fwd.receptance(x)
        got = done.get(variant_key(s))
        if isinstance(got, Exception):
            raise got
        if got is not None:
            return got
        return door_receptance(s, g.frequency, g.sensor_x, g.force_x, g.outputs,
                               force=g.force, cache=cache)

    return model_form.ensemble(problem.records, receptance, spec)


def variant_key(spec: TrackSpec) -> str:
    """What tells two specs apart (their dict form)."""
    return str(spec_to_dict(spec))


def open_lanes(problem: Problem, workers: int):
    """railfem.identify.profiling.Lanes of ``workers`` processes for a fit of a uniform
    discrete WFE model (spectral engine), made the forward model's engine builder; None
    otherwise (one worker, beam models, other engines: their kernels as before)."""
    fwd = problem.forward
    if workers <= 1 or fwd.kind != "spectral" or fwd.space.base.is_beam:
        return None
    lanes = Lanes(problem, workers)
    fwd.builder = lanes.builder
    return lanes


def analyse(problem: Problem, x, J, r, slow, slow_profile, todo, profile_points, free,
            workers) -> tuple[dict, dict]:
    """(uncertainty analysis, profiles) at the estimate x: the stiffness profiles of
    ``todo``, the kernel parameter's interval from its profile; with a discrepancy the
    noise clusters and the variants' random terms as in the diagnosis."""
    space = problem.box
    disc = problem.discrepancy_columns()
    extra = {} if disc is None else {"clusters": problem.clusters(), "discrepancy": disc}
    analysis0 = uncertainty.analyse(space, x, J, r, **extra)
    prof = {}
    if todo and profile_points > 1:
        prof = profile(problem, x, analysis0, todo, profile_points, free, workers)
    if slow_profile is not None:  # refitted under the final scales (reprofile)
        prof[slow[0]] = slow_profile_summary(slow_profile, float(r @ r),
                                             analysis0["residual_variance"], space, slow[0])
    analysis = uncertainty.analyse(space, x, J, r, prof, **extra)
    analysis["discrepancy_terms"] = 0 if disc is None else int(disc.shape[1])
    if slow_profile is not None:
        i = space.names.index(slow[0])
        shift = 0.0
        if disc is not None:  # the variants' share of its variance, added in quadrature
            shift = analysis["t_quantile"] * math.sqrt(
                max(uncertainty.nuisance_covariance(J, disc)[i, i], 0.0))
        interval_from_slow_profile(analysis, prof[slow[0]], space, x, extra=shift)
    return analysis, prof


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
