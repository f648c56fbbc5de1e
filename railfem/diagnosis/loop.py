"""The search: calibrate the base model, test its residual, refit with every candidate
effect (and the best pairs), score, validate on held-out data, and decide.

    from railfem.diagnosis import diagnose
    d = diagnose(rf.io.read_measurement("site_b/"), model="wfe-discrete")
    d.verdict, d.statement, d.chosen

1. **Base**: railfem.identify.fit on the first record's point mobility and decay rate
   (multi-start, the rail loss factor profiled) gives the start; the base model (kp,
   eta_p, kb, eta_b, eta_r) is then refitted to the fitted part of all records
   (railfem.diagnosis.refit), the rail loss factor profiled over kernels (beam models; a
   WFE model keeps the base fit's value: a kernel per step, against a beam's instant).
2. **Residual** of the base (railfem.diagnosis.residual): noise or structure.
3. **Candidates**: every applicable effect of the library is refitted with the base
   parameters; with a beam model the rail loss factor is then profiled on a lattice of
   kernels shared by all candidates (the base's rail loss absorbed part of any damping
   effect), and a pad length is profiled jointly with it; with a WFE model a support
   effect that beats the base gets a short rail-loss profile. Each is scored by AICc and
   BIC on the fitted data and by its error on the held-out data. With ``workers`` > 1
   the candidates (and the pairs, step 5) run in worker processes, those sharing kernels
   in one, and the serial steps' kernels are built ahead there
   (railfem.diagnosis.parallel): the same results.
4. **Gates** (railfem.diagnosis.gates; all needed to keep a candidate): *plausible*
   (continuous parameters inside their bounds, not within 1 % of the range of one, and not
   unidentifiable);
   *better on held-out data by more than the noise explains*: the mean squared held-out
   residual (scaled) falls by >= MIN_GAIN and a paired one-sided test over held-out
   blocks (band x sensor x position cells) rejects "no improvement" at ALPHA: the t-test
   or the Wilcoxon signed-rank test, whichever rejects more strongly, with a Bonferroni
   factor 2 (the t-test alone loses its power when a few blocks near notches dominate
   the differences; the rank test needs >= 7 blocks to reach 1 %);
   *supported*: BIC below the base's by more than DELTA_BIC.
5. **Pairs** of the (up to three) best kept candidates, kept over the best single by the
   same gates.
6. **Decision**: the best kept model is refitted with the rail loss factor profiled and
   gated again (plausibility, as at screening: its intervals now carry the rail loss
   factor); one that fails is not kept (the verdict says why) and the next kept one is
   refitted in its place; an effect's assumed values (Effect.assumed) are then varied
   over their ranges and the intervals reported are the envelope
   (railfem.diagnosis.envelope). If the chosen model's residual is noise
   (railfem.diagnosis.residual.structure_test) or its structured part is below
   NEGLIGIBLE_DB, the effect *explains* the residual; if structure remains it *partly
   explains* it; with no kept candidate "no candidate explains the residual". When
   the base residual is already noise, nothing is claimed.

A candidate that fails (an exception in its screening, a pair or its final refit) is
logged and listed in ``Diagnosis.failures`` (candidate, stage, error); the run goes on.
The base (railfem.identify.base) is the one ``railfem fit`` starts from.
"""
from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from railfem.diagnosis import effects as library
from railfem.diagnosis import parallel
from railfem.diagnosis import residual as resid
from railfem.diagnosis.data import LATERAL_ONLY, DiagnosisData, prepare
from railfem.diagnosis.envelope import assumed_envelope
from railfem.diagnosis.evaluate import Evaluator, lateral_spec
from railfem.diagnosis.gates import final_gate, held_gate, passes, plausibility
from railfem.diagnosis.problem import BASE, DISCREPANCY, Problem, model_scale, noise_scale
from railfem.diagnosis.rail_loss import (ETA_R_LATTICE, eta_r_interval, joint_profile,
                                         profile_eta_r)
from railfem.diagnosis.refit import REFINE_STEPS, Outcome, refit, rewiden_grid
from railfem.diagnosis.verdict import decide
from railfem.identify.base import ETA_R_RANGE, default_base, describe_base
from railfem.spec import TrackSpec, model_kind

log = logging.getLogger(__name__)

WFE_ETA_R_STEPS = 1
WFE_REFINE_STEPS = 1  # parabolic steps of a geometry / pad-length grid with a WFE model
WFE_PAD_LENGTHS = (0.08, 0.16, 0.24)
COVARIATE_SPREAD = {"temperature_c": 5.0, "static_load_kn": 10.0}


@dataclass
class Diagnosis:
    """What diagnose found (see the module docstring); ``to_dict`` is diagnosis.json."""

    data: DiagnosisData
    model: str
    base: Outcome
    base_fit: object
    structure_before: dict
    residual_before: resid.Residual
    candidates: list
    chosen: Outcome | None
    chosen_row: dict | None
    verdict: str
    statement: str
    structure_after: dict | None = None
    residual_after: resid.Residual | None = None
    seconds: dict = field(default_factory=dict)
    skipped: dict = field(default_factory=dict)
    failures: list = field(default_factory=list)  # {candidate, stage, error}
    base_model: str = ""
    reference: object = None  # railfem.diagnosis.reference.BaseReference, or None
    changed: list = field(default_factory=list)  # base parameters changed against it

    @property
    def ranking(self) -> list[str]:
        return [c["name"] for c in self.candidates]


def applicable(effect, data: DiagnosisData, model: str):
    """(True, '') or (False, reason)."""
    for need in effect.needs:
        if need == "discrete" and model_kind(model).is_continuous:
            return False, f"needs discrete supports (model {model})"
        if need == "deviations" and library.deviation_refusal(model_kind(model)):
            return False, library.deviation_refusal(model_kind(model))
        if need == "wfe" and not model_kind(model).is_wfe:
            return False, (f"changes the rail's cross-section, which the beam model {model} "
                           "does not have: diagnose with a WFE model for this effect")
        if need == "lateral" and not data.lateral:
            return False, LATERAL_ONLY
        if need == "hammer" and "hammer" not in data.kinds:
            return False, "needs hammer FRFs (the data are decay rates only)"
        if need.startswith("covariate:"):
            name = need.split(":", 1)[1]
            if not data.has_covariate(name, COVARIATE_SPREAD.get(name, 0.0)):
                return False, (f"needs several records whose {name} differs by >= "
                               f"{COVARIATE_SPREAD.get(name, 0.0):g}")
    if not any(q in effect.quantities for r in data.records for q in r.fit.use):
        return False, "acts on none of the quantities the data hold"
    return True, ""


def grid_values(effect, data: DiagnosisData, model: str = "") -> dict:
    """Categorical grids restricted to what the data have (sensors); with a WFE model the
    pad-length grid is thinned to three values (each is a WFE kernel)."""
    out = {}
    if effect.name == "pad_length" and model and model_kind(model).is_wfe:
        out[(effect.name, "pad_length")] = WFE_PAD_LENGTHS
    if effect.name == "sensor_resonance":
        outs = sorted({o for r in data.records for o in r.fit.outputs})
        out[(effect.name, "sensor")] = ("all",) + (tuple(outs) if len(outs) > 1 else ())
    return out


def merge_grids(*grids: dict) -> dict:
    """One {(effect, name): values} of several effects' grid values (keys are tuples: not
    keyword arguments, so never ``dict(a, **b)``)."""
    out = {}
    for g in grids:
        out.update(g)
    return out


def pair_grid_values(ea, eb, data: DiagnosisData, model: str = "") -> dict:
    """The grid values of a pair of effects (grid_values of each, merged)."""
    return merge_grids(grid_values(ea, data, model), grid_values(eb, data, model))


def _row(o: Outcome, ref: Outcome, base: Outcome, gate: dict, ok: bool, why: str) -> dict:
    return {"name": o.name, "effects": [e.name for e in o.effects], "k": o.k, "n": o.n,
            "cost": o.cost, "aicc": o.aicc, "bic": o.bic,
            "delta_aicc": o.aicc - base.aicc, "delta_bic": o.bic - base.bic,
            "reference": ref.name, "held_out": gate, "plausible": ok, "implausible_why": why,
            "theta": {e: {k: (v if isinstance(v, str) else float(v)) for k, v in th.items()}
                      for e, th in o.theta().items()},
            "parameters": o.parameters()}


@dataclass
class Search:
    """What the steps of diagnose share: the data, the evaluator, the base spec and its
    refit, the residual scales and the options that shape every refit."""

    data: DiagnosisData
    model: str
    ev: Evaluator
    spec: TrackSpec  # the base spec (the rail loss factor of the base refit)
    scale: dict
    base: Outcome | None = None
    pred_base: dict | None = None
    profile_final: bool = True
    failures: list = field(default_factory=list)
    bounds: dict | None = None  # base bounds {name: (low, high)} (a reference section's)
    workers: int = 1  # processes screening the candidates and pairs (parallel.run)

    def fail(self, candidate: str, stage: str, exc: BaseException) -> None:
        """Record (and log) that ``candidate`` failed at ``stage``: the run goes on."""
        msg = f"{type(exc).__name__}: {exc}"
        self.failures.append({"candidate": candidate, "stage": stage, "error": msg})
        log.warning("diagnosis: %s failed at %s: %s", candidate, stage, msg,
                    exc_info=log.isEnabledFor(logging.DEBUG))

    @property
    def wfe(self) -> bool:
        return model_kind(self.model).is_wfe

    @property
    def x_base(self) -> np.ndarray:
        return self.base.x[:len(BASE)]

    @property
    def refine_steps(self) -> int:
        return WFE_REFINE_STEPS if self.wfe else REFINE_STEPS

    @property
    def eta_r_steps(self) -> int | None:
        return WFE_ETA_R_STEPS if self.wfe else None  # each a kernel: tens of s for WFE

    @property
    def profiles(self) -> bool:
        """Whether the rail loss factor is profiled for the candidates (not for WFE)."""
        return self.profile_final and not self.wfe


def select_effects(data: DiagnosisData, model: str, effects) -> tuple[list, dict]:
    """(the applicable candidate effects, {name: why skipped})."""
    names = library.names() if effects in (None, "all") else tuple(effects)
    for n in names:
        library.get(n)
    cands, skipped = [], {}
    if effects is None:  # the default screen leaves out the effects that ask to be named
        skipped.update({n: "not screened by default (tens of parameters, the costliest "
                           "candidate): name it in effects= / --effects"
                        for n in names if not library.get(n).screened})
        names = tuple(n for n in names if library.get(n).screened)
    for n in names:
        ok, why = applicable(library.get(n), data, model)
        (cands.append(library.get(n)) if ok else skipped.__setitem__(n, why))
    return cands, skipped


def make_evaluator(cands, data: DiagnosisData, cache) -> Evaluator:
    """An Evaluator that knows every geometry shift the candidates will ask for."""
    shifts = {}
    for e in cands:
        if e.kind == "geometry":
            for v in e.grid[e.parameters[0].name]:
                s = e.geometry({e.parameters[0].name: v}, None)
                for r in data.records:
                    shifts.setdefault(r.name, set()).add((float(s[0]), float(s[1])))
    return Evaluator(cache=cache, shifts=shifts)


def fit_base(data: DiagnosisData, model: str, spec0: TrackSpec, ev: Evaluator, *,
             n_starts, workers, cache, seed, profile_final,
             discrepancy=DISCREPANCY, reference=None) -> tuple[Search, object]:
    """Step 1: railfem.identify.fit on the first record's point mobility and decay rate (a
    start, scaled by noise plus the same ``discrepancy`` as ``railfem fit``: a WFE base
    keeps its rail loss factor), then the base refit on all records, its rail loss factor
    profiled (beam models), its residuals scaled by noise plus the model-form ``discrepancy``
    (railfem.diagnosis.problem.noise_scale). Returns the Search and the identify
    FitResult. With a ``reference`` (railfem.diagnosis.reference.BaseReference) the base
    starts at the reference's values and stays inside its bounds (no start fit: the
    FitResult is None)."""
    from railfem.identify import fit as identify_fit

    if reference is not None:
        return base_from_reference(data, model, spec0, ev, reference,
                                   profile_final=profile_final, discrepancy=discrepancy)

    start_target = data.records[0].fit  # point and decay rate (the fitter takes no NaN)
    if "transfer" in start_target.use:
        start_target = replace(start_target, use=tuple(q for q in start_target.use
                                                       if q != "transfer"))
    beam = model_kind(model).is_beam
    fr = identify_fit(start_target, model, parameters=BASE + ("eta_r",), base=spec0,
                      bounds={"eta_r": ETA_R_RANGE}, n_starts=n_starts, workers=workers,
                      cache=cache, profiles=(), seed=seed,
                      slow_nodes=3 if beam else None, slow_refine=2 if beam else None,
                      discrepancy=discrepancy)  # as `railfem fit`: its rail loss is kept
    spec_b = spec0.replace(eta_r=fr.spec.rail.eta)
    x0 = np.array([math.log10(getattr(fr.spec.support, n)) for n in BASE])
    parallel.prefetch(ev, workers, parallel.base_kernels(ev, data, spec_b, x0, discrepancy,
                                                         profile_final))
    scale = noise_scale(Problem(data=data, evaluator=ev, spec=spec_b, scale={}), x0,
                        discrepancy)
    s = Search(data=data, model=model, ev=ev, spec=spec_b, scale=scale,
               profile_final=profile_final)
    base_o = refit(data, ev, spec_b, (), x0, scale)
    if s.profiles:  # beam models; a WFE base keeps the start fit's value (its kernels),
        base_o = profile_eta_r(data, ev, spec_b, (), base_o, scale, max_steps=s.eta_r_steps)
    elif s.wfe and profile_final:  # its interval from two kernels support effects share
        base_o = eta_r_interval(data, ev, spec_b, base_o, scale)
    s.spec = spec_b.replace(eta_r=base_o.eta_r)
    s.base = base_o
    s.pred_base = base_o.problem.predict(base_o.x)
    return s, fr


def base_from_reference(data, model, spec0, ev, reference, *, profile_final,
                        discrepancy) -> tuple[Search, None]:
    """Step 1 against a reference section: the base refitted from the reference's values
    (railfem.diagnosis.reference.BaseReference: spec, bounds) inside its bounds, the rail
    loss factor profiled inside its range (beam models)."""
    bounds = dict(reference.bounds)
    spec_b = spec0.replace(**{n: reference.values[n] for n in BASE + ("eta_r",)})
    x0 = np.array([math.log10(reference.values[n]) for n in BASE])
    scale = noise_scale(Problem(data=data, evaluator=ev, spec=spec_b, scale={},
                                bounds=bounds), x0, discrepancy)
    s = Search(data=data, model=model, ev=ev, spec=spec_b, scale=scale,
               profile_final=profile_final, bounds=bounds)
    base_o = refit(data, ev, spec_b, (), x0, scale, bounds=bounds)
    if s.profiles:
        base_o = profile_eta_r(data, ev, spec_b, (), base_o, scale, max_steps=s.eta_r_steps,
                               bounds=bounds)
    elif s.wfe and profile_final:
        base_o = eta_r_interval(data, ev, spec_b, base_o, scale, bounds=bounds)
    s.spec = spec_b.replace(eta_r=base_o.eta_r)
    s.base = base_o
    s.pred_base = base_o.problem.predict(base_o.x)
    return s, None


def screen_single(s: Search, e) -> Outcome:
    """Step 3 for one effect: refitted with the base parameters; with a beam model the rail
    loss factor profiled (not for random effects: only if chosen), and a kernel grid (pad
    length) profiled jointly with it when the candidate already beats the base; with a WFE
    model a support or section effect that beats the base gets a short rail-loss profile."""
    o = refit(s.data, s.ev, s.spec, (e,), s.x_base, s.scale, bounds=s.bounds,
              grid_values=grid_values(e, s.data, s.model), refine_steps=s.refine_steps)
    if s.profiles and e.prior is None:
        o = profile_eta_r(s.data, s.ev, s.spec, (e,), o, s.scale, max_steps=6, refine=False,
                          bounds=s.bounds)
        if e.kind == "spec" and any(n != "index" for n in e.grid) and o.bic < s.base.bic:
            # a kernel grid (pad length) trades against the rail loss: profile both
            # (tens of kernels: only for a candidate that already beats the base)
            o2 = joint_profile(s.data, s.ev, s.spec, e, o, s.scale,
                               grid_values(e, s.data, s.model), bounds=s.bounds)
            o = o2 if o2.cost < o.cost else o
    elif s.wfe and s.profile_final and library.rail_loss_traded(e) and o.bic < s.base.bic:
        # the base's rail loss factor took up part of any added damping: held there, a
        # damping effect lost to a more flexible one (foot damping to rail_damper); a short
        # profile on a coarse lattice, its kernels (~5 s each) shared by the candidates.
        # A changed section (at its best grid value) as well: near a cut-on the base
        # widens the misplaced peak with rail loss, and held there the geometry's gain
        # failed the held-out test (cross-model foot, 2 of 4 seeds); its kernels are its own
        o = profile_eta_r(s.data, s.ev, s.spec, (e,), o, s.scale, max_steps=3, step=0.1,
                          refine=False, bounds=s.bounds)
    return o


def screen_one(s: Search, e) -> tuple[Outcome, dict]:
    """Step 3 for one effect, scored: (its Outcome, its row; screen_single, the gates)."""
    te = time.perf_counter()
    o = screen_single(s, e)
    gate = held_gate(s.base, o, pred_ref=s.pred_base)
    ok, why = plausibility(o)
    # the row's intervals span an assumed value's range as a chosen model's do (the
    # envelope keeps the estimate, the cost and hence every score and gate): a candidate
    # best by BIC but not kept reports them, and its tangent at the centre missed the
    # truth where the response is curved in the assumed value (roll_restraint)
    row = _row(assumed_envelope(o), s.base, s.base, gate, ok, why)
    row["seconds"] = time.perf_counter() - te
    return o, row


def shared(s: Search) -> dict:
    """What workers' results refer to by reference (railfem.diagnosis.parallel)."""
    return {"ev": s.ev, "data": s.data, "records": s.data.records, "scale": s.scale,
            "spec": s.spec, "base": s.base, "bounds": s.bounds,
            **{f"record {i}": r for i, r in enumerate(s.data.records)}}


def screen_singles(s: Search, cands) -> tuple[dict, list]:
    """Step 3: every candidate refitted, gated and scored against the base
    ({name: Outcome}, rows, in the candidates' order); in ``s.workers`` processes
    (railfem.diagnosis.parallel: each logged as it is done). A candidate that fails is
    recorded in ``s.failures``."""
    done, n0 = {}, len(s.failures)
    for i, ok, value in parallel.run(lambda e: screen_one(s, e), cands, s.workers,
                                     shared(s), groups=parallel.kernel_groups(cands, s.wfe)):
        if not ok:
            s.fail(cands[i].name, "screening", value)
            continue
        o, row = done[i] = value
        gate = row["held_out"]
        log.info("diagnosis: %s: dBIC %.1f, held-out %s %.0f %%, %s (%.1f s)", o.name,
                 row["delta_bic"], "pass" if gate.get("pass") else "fail",
                 100 * (gate.get("reduction") or 0),
                 "plausible" if row["plausible"] else row["implausible_why"], row["seconds"])
    order = {e.name: i for i, e in enumerate(cands)}
    s.failures[n0:] = sorted(s.failures[n0:], key=lambda f: order[f["candidate"]])
    outcomes = {done[i][0].name: done[i][0] for i in sorted(done)}
    return outcomes, [done[i][1] for i in sorted(done)]


def pairable(ea, eb) -> bool:
    """Whether two effects can be screened as a pair: two mechanisms, not one nested in the
    other."""
    if ea.kind == eb.kind == "geometry":
        return False
    if {id(p) for p in ea.parameters} & {id(p) for p in eb.parameters}:
        return False  # the same parameter (two_rail's sleeper is sleeper_flexibility's)
    # both set factors on single supports' stiffness (a voided sleeper is one realisation
    # of random supports): nested, not two mechanisms
    return not ("deviations" in ea.needs and "deviations" in eb.needs)


def screen_pairs(s: Search, outcomes: dict, rows: list, max_pairs: int) -> None:
    """Step 5: pairs of the (up to max_pairs) best kept singles, each gated against the
    better single of the two (in ``s.workers`` processes); outcomes and rows are extended
    in place, in the pairs' order."""
    kept = sorted([r for r in rows if passes(r, s.base.bic)], key=lambda r: r["bic"])
    top = kept[:max_pairs] if len(kept) >= 2 else []
    pairs = [(library.get(top[i]["name"]), library.get(top[j]["name"]))
             for i in range(len(top)) for j in range(i + 1, len(top))]
    pairs = [(ea, eb) for ea, eb in pairs if pairable(ea, eb)]
    done, n0 = {}, len(s.failures)
    for i, ok, value in parallel.run(lambda p: screen_pair(s, outcomes[p[0].name], *p),
                                     pairs, s.workers, dict(shared(s), outcomes=outcomes)):
        if ok:
            done[i] = value
        else:
            s.fail("+".join(e.name for e in pairs[i]), "pairs", value)
    order = {"+".join(e.name for e in p): i for i, p in enumerate(pairs)}
    s.failures[n0:] = sorted(s.failures[n0:], key=lambda f: order[f["candidate"]])
    for i in sorted(done):
        o, row = done[i]
        outcomes[o.name] = o
        rows.append(row)


def screen_pair(s: Search, ref: Outcome, ea, eb) -> tuple[Outcome, dict]:
    """Step 5 for one pair: refitted (the rail loss factor profiled with a beam model),
    gated against ``ref`` (the better single): (its Outcome, its row)."""
    o = refit(s.data, s.ev, s.spec, (ea, eb), s.x_base, s.scale,
              grid_values=pair_grid_values(ea, eb, s.data, s.model),
              refine_steps=s.refine_steps, bounds=s.bounds)
    if s.profiles:
        o = profile_eta_r(s.data, s.ev, s.spec, (ea, eb), o, s.scale,
                          max_steps=6, refine=False, bounds=s.bounds)
    gate = held_gate(ref, o)
    ok, why = plausibility(o)
    return o, _row(o, ref, s.base, gate, ok, why)


def _sort(rows: list) -> None:
    rows.sort(key=lambda r: (not r["kept"], r["bic"]))
    for i, r in enumerate(rows, 1):
        r["rank"] = i


def rank(s: Search, outcomes: dict, rows: list) -> tuple[Outcome | None, dict | None]:
    """Step 6 (first half): every row's gates against its reference, the rows ranked (kept
    first, then by BIC); the best kept model and its row, or (None, None)."""
    for r in rows:
        ref_bic = outcomes[r["reference"]].bic if r["reference"] != "base" else s.base.bic
        r["kept"] = passes(r, ref_bic)
    _sort(rows)
    kept = [r for r in rows if r["kept"]]
    if not kept:
        return None, None
    return outcomes[kept[0]["name"]], kept[0]


def choose(s: Search, outcomes: dict, rows: list) -> tuple[Outcome | None, dict | None]:
    """Step 6: the kept rows in rank order, each refitted (final_refit) and gated again
    (final_gate); the first that passes is chosen. One that fails its final refit or its
    gate is not kept (the row says why: ``final_rejected``, a failure in ``s.failures``)
    and the next is considered. Returns (the final Outcome, its row) or (None, None)."""
    rank(s, outcomes, rows)
    for row in [r for r in rows if r["kept"]]:
        try:
            final = final_refit(s, outcomes[row["name"]])
            ok, why = final_gate(final)
        except Exception as exc:  # noqa: BLE001 - one candidate must not end the run
            s.fail(row["name"], "final refit", exc)
            ok, why = False, f"the final refit failed ({type(exc).__name__}: {exc})"
        if ok:
            _sort(rows)
            return final, row
        row["kept"] = False
        row["final_rejected"] = why
        log.info("diagnosis: %s not kept after its final refit: %s", row["name"], why)
    _sort(rows)
    return None, None


def final_refit(s: Search, chosen: Outcome) -> Outcome:
    """Step 6 (second half): the chosen model refitted with the rail loss factor profiled
    from its own estimate (the profile, at least 3 kernels, redoes the best point's
    analysis with the unfitted scatter: the start's is not kept); its intervals then span
    its effects' assumed values' ranges (railfem.diagnosis.envelope)."""
    if not s.profile_final:
        return assumed_envelope(chosen)
    grid_fix = {k: (v,) for k, v in chosen.grid.items()}
    spec_c = s.spec.replace(eta_r=chosen.eta_r)
    if s.wfe and s.eta_r_steps > 0:  # the profile's first two kernels, ahead
        e0 = math.log10(chosen.eta_r)
        parallel.prefetch(s.ev, s.workers, [parallel.evaluation(
            s.ev, s.data, s.spec.replace(eta_r=10 ** round(e0 + d, 6)), chosen.effects,
            chosen.grid, chosen.x) for d in (-ETA_R_LATTICE, ETA_R_LATTICE)])
    scale = model_scale(chosen.problem, chosen.x)  # the chosen model's own variants
    start = refit(s.data, s.ev, spec_c, chosen.effects, s.x_base, scale,
                  grid_values=grid_fix, refine=False, x_start=chosen.x, unfitted=False,
                  bounds=s.bounds)
    start.grid_profiles = chosen.grid_profiles
    start.grid_profiles = rewiden_grid(start)  # their model-form share from `scale`
    return assumed_envelope(profile_eta_r(s.data, s.ev, s.spec, chosen.effects, start,
                                          scale, max_steps=s.eta_r_steps, bounds=s.bounds))


def base_of(data: DiagnosisData, model: str, base: TrackSpec | None = None) -> TrackSpec:
    """The base spec of a diagnosis: ``base`` or the base model every calibration starts
    from (railfem.identify.base.default_base: the site preset on point supports; a pad of
    finite length is one of the effects the search compares, effects/pad_length.py), with
    ``model`` and the data's sleeper spacing."""
    spec0 = base if base is not None else default_base(model)
    spec = spec0.replace(model=model, spacing=data.spacing)
    return lateral_spec(spec) if data.lateral_only else spec  # lateral rows: lateral supports


def diagnose(data, *, model: str = "wfe-discrete", base: TrackSpec | None = None,
             effects=None, spacing: float | None = None, pairs: bool = True,
             n_starts: int = 4, workers: int = 1, cache=False, seed: int = 0,
             profile_final: bool = True, max_pairs: int = 3,
             data_options=None, discrepancy=DISCREPANCY, reference=None) -> Diagnosis:
    """Diagnose ``data`` (a HammerMeasurement, DecayRateMeasurement/Table, a list of them or
    DiagnosisData) with track model ``model``; ``effects``: names from the library
    (default all but those with ``screened=False``, e.g. random_support; "all": every
    one); ``base``: the spec whose other values are kept (default
    railfem.identify.base.default_base: the site preset on point supports, as ``railfem
    fit``); ``data_options``: to railfem.diagnosis.data.prepare (e.g. f_range=(50, 2000),
    sensors=['head']); ``discrepancy``: the model-form discrepancy the residuals are judged
    with ('ensemble': the base's own discretisation variants, railfem.identify.discrepancy;
    None: noise only; or a Discrepancy); ``reference``: a calibrated reference section
    (railfem.diagnosis.reference.BaseReference; railfem.diagnosis.reference.diagnose
    makes one from data or a fit): the base is held inside its bounds, so the residual
    shows what differs; ``workers``: processes of the base fit and of the screening of
    the candidates and the pairs (railfem.diagnosis.parallel: the same results, each
    candidate logged as it is done). See the module docstring for the steps. A
    candidate that fails
    (an exception in its screening, its pairs or its final refit) is logged and listed in
    ``Diagnosis.failures``; the run goes on without it."""
    t0 = time.perf_counter()
    seconds = {}
    data = prepare(data, spacing=spacing, **(data_options or {}))
    spec0 = base_of(data, model, base)
    cands, skipped = select_effects(data, model, effects)
    ev = make_evaluator(cands, data, cache)

    t = time.perf_counter()  # 1. base and 2. its residual
    s, fr = fit_base(data, model, spec0, ev, n_starts=n_starts, workers=workers, cache=cache,
                     seed=seed, profile_final=profile_final, discrepancy=discrepancy,
                     reference=reference)
    s.workers = workers
    res_before = resid.make_residual(data, s.pred_base, discrepancy=s.scale)
    repeats = resid.repeat_scatter(data)
    st_before = resid.structure_test(res_before, n_parameters=s.base.k, repeats=repeats)
    seconds["base"] = time.perf_counter() - t
    log.info("diagnosis: base %s, residual %s (p = %.3g, structured %.2f dB)", model,
             st_before["verdict"], st_before["p"], st_before["structured_rms_db"])

    t = time.perf_counter()  # 3. single candidates (eta_r at the base value), 4. gates
    outcomes, rows = screen_singles(s, cands)
    seconds["singles"] = time.perf_counter() - t
    t = time.perf_counter()  # 5. pairs of the best kept singles
    if pairs:
        screen_pairs(s, outcomes, rows, max_pairs)
    seconds["pairs"] = time.perf_counter() - t

    t = time.perf_counter()  # 6. ranking, final refit and its gates, decision
    chosen, chosen_row = choose(s, outcomes, rows)
    st_after = res_after = None
    if chosen is not None:
        res_after = resid.make_residual(data, chosen.problem.predict(chosen.x),
                                        discrepancy=s.scale)
        st_after = resid.structure_test(res_after, n_parameters=chosen.k, repeats=repeats)
        chosen_row = dict(chosen_row, final_parameters=chosen.parameters(),
                          final_held_out=held_gate(s.base, chosen, pred_ref=s.pred_base))
    seconds["final"] = time.perf_counter() - t
    verdict, statement = decide(st_before, st_after, chosen, chosen_row, rows, s.failures)
    statement += library.not_tried(skipped)
    seconds["total"] = time.perf_counter() - t0
    log.info("diagnosis: %s (%.1f s)", statement, seconds["total"])
    return Diagnosis(data=data, model=model, base=s.base, base_fit=fr,
                     structure_before=st_before, residual_before=res_before,
                     candidates=rows, chosen=chosen, chosen_row=chosen_row, verdict=verdict,
                     statement=statement, structure_after=st_after, residual_after=res_after,
                     seconds=seconds, skipped=skipped, failures=s.failures,
                     base_model=describe_base(s.spec), reference=reference)
