"""The rail loss factor of a diagnosis's models: a WFE kernel holds one rail loss factor, so
the refits (railfem.diagnosis.refit) keep it fixed and it is profiled over kernels instead.

``profile_eta_r`` walks a lattice of log10(eta_r) (``ETA_R_LATTICE`` decades apart, rounded
to 1e-6 so that every candidate shares the kernels) until the minimum is bracketed, with
parabolic steps; ``eta_r_interval`` gives a base's rail loss factor its 95 % interval from
the two kernels either side, the estimate kept; ``attach_eta_r_profile`` turns the refits
at several rail loss factors into the profile and the Jacobian interval (the rail loss
factor free, the discrepancy's terms included as for every other parameter);
``joint_profile`` profiles a numeric kernel grid parameter (a pad length) with the rail
loss factor free at every value."""
from __future__ import annotations

import logging
import math

import numpy as np

from railfem.diagnosis.intervals import interval_from_profile
from railfem.diagnosis.problem import BASE
from railfem.diagnosis.refit import (MAX_GRID_START, REFINE_STEPS, Outcome, joint_uncertainty,
                                     profile_inflation, refit)
from railfem.identify.problem import SlowProfile, parabola_vertex

log = logging.getLogger(__name__)

ETA_R_LATTICE = 0.05  # decades between the rail-loss kernels of a profile


def profile_eta_r(data, evaluator, spec, effects, outcome: Outcome, scale, *,
                  max_steps: int | None = None, step: float = ETA_R_LATTICE,
                  refine: bool = True, tol: float = 0.001, bounds=None) -> Outcome:
    """Refit ``outcome``'s model at other rail loss factors (each a new kernel, shared by
    every candidate: the values lie on a lattice ``step`` decades apart around the base
    value), warm-started from the nearest refitted one, walking downhill until the minimum
    is bracketed; with ``refine``, parabolic steps (new kernels) until they move less than
    ``tol`` decades. Returns the best Outcome with the eta_r profile and its 95 % interval
    (the Jacobian gets a finite-difference rail-loss column)."""
    grid = {k: (v,) for k, v in outcome.grid.items()}
    max_steps = 8 if max_steps is None else max_steps

    def evaluate(le):
        near = prof.nearest(le)
        s_ = spec.replace(eta_r=10 ** le)
        # the unfitted scatter enters the best point's analysis (joint_uncertainty)
        o = refit(data, evaluator, s_, effects, near.x[:len(BASE)], scale, grid_values=grid,
                  refine=False, bounds=bounds, x_start=near.x, unfitted=False)
        if len(o.x) - len(BASE) <= MAX_GRID_START:  # multi-start as well (not for
            fresh = refit(data, evaluator, s_, effects, near.x[:len(BASE)], scale,  # random
                          grid_values=grid, refine=False, bounds=bounds,  # effects)
                          unfitted=False)
            o = fresh if fresh.cost < o.cost else o
        o.grid_profiles = outcome.grid_profiles
        return o

    # the kernels lie on a lattice of log10(eta_r) rounded to 1e-6
    prof = SlowProfile(evaluate, cost=lambda o: o.cost, key=lambda v: round(float(v), 6))
    prof.points[prof.key(math.log10(outcome.eta_r))] = outcome
    e0 = math.log10(outcome.eta_r)
    if max_steps > 0:
        prof.at(e0 - step)
        prof.at(e0 + step)
    prof.walk(step, max_steps)  # until the minimum is bracketed
    prof.refine(max_steps if refine else 0, tol)
    done = prof.points
    v = np.array(sorted(done))
    c = np.array([done[x].cost for x in v])
    best = done[v[int(np.argmin(c))]]
    vx = parabola_vertex({x: done[x].cost for x in done})
    best.profile_cost = best.cost if vx is None else vx[1]
    if len(v) < 2:
        return best
    attach_eta_r_profile(best, done)
    return best


def attach_eta_r_profile(best: Outcome, done: dict) -> None:
    """best.eta_r_profile from the refits ``done`` ({log10 eta_r on the 1e-6 lattice:
    Outcome}, best among them): the profile, its 95 % interval, and the Jacobian interval
    with a finite-difference rail-loss column (joint_uncertainty: best.analysis redone
    with the rail loss factor free, the discrepancy's terms included as for every other
    parameter), which is the reported one."""
    v = np.array(sorted(done))
    c = np.array([done[x].cost for x in v])
    iv = interval_from_profile({"values": list(v), "cost": list(c)},
                               best.analysis["residual_variance"])
    joint_uncertainty(best, done)
    joint = best.analysis.get("eta_r")
    best.eta_r_profile = {"values": [float(10 ** x) for x in v], "cost": c.tolist(),
                          "value": float(best.eta_r), "unit": "-",
                          "ci95": joint["ci95"] if joint else
                          [float(10 ** x) for x in iv["ci95"]],
                          "profile_ci95": [float(10 ** x) for x in iv["ci95"]],
                          "identifiable": joint["identifiable"] if joint else
                          iv["identifiable"],
                          "reason": "profiled over rail-loss kernels; interval from the "
                                    "Jacobian with a finite-difference rail-loss column"}


def eta_r_interval(data, evaluator, spec, outcome: Outcome, scale, *, step: float = 0.1,
                   bounds=None) -> Outcome:
    """``outcome`` (refitted at the rail loss factor of ``spec``, no effects: a WFE base)
    with a 95 % interval of its rail loss factor, the estimate kept: the model refitted at
    the two kernels ``step`` decades either side (warm-started), the interval from the
    Jacobian with the rail-loss column these give (attach_eta_r_profile). The kernels lie
    on the lattice of a support effect's short rail-loss profile (0.1 decades about the
    same value, railfem.diagnosis.loop.screen_single): shared with it.

    The estimate (the start fit's, on the first record's point mobility and decay rate)
    need not be the minimum over every record: the interval is also moved by the shift
    from it to the vertex of the parabola through the three costs (``profile_value``),
    so that it is the interval about the profile's minimum as well as about the value in
    use (clean data of another model, 29 positions to 5 kHz: estimate 0.0183, vertex
    0.019, Jacobian interval 0.0170-0.0197 beside a truth of 0.02)."""
    e0 = math.log10(outcome.eta_r)
    done = {round(e0, 6): outcome}
    for le in (round(e0 - step, 6), round(e0 + step, 6)):
        done[le] = refit(data, evaluator, spec.replace(eta_r=10 ** le), outcome.effects,
                         outcome.x[:len(BASE)], scale, refine=False, bounds=bounds,
                         x_start=outcome.x, unfitted=False)
    attach_eta_r_profile(outcome, done)
    vx = parabola_vertex({x: o.cost for x, o in done.items()}, at_edge=True)
    prof = outcome.eta_r_profile
    if vx is not None and prof is not None:
        shift = 10 ** (vx[0] - e0)
        lo, hi = prof["ci95"]
        prof.update(ci95_estimate=[lo, hi], profile_value=float(10 ** vx[0]),
                    ci95=[min(lo, lo * shift), max(hi, hi * shift)],
                    reason=prof["reason"] + ", moved to hold the same interval about the "
                                            "profile's minimum (profile_value)")
    return outcome


def joint_profile(data, ev, spec_b, effect, start: Outcome, scale, gv, *,
                  bounds=None) -> Outcome:
    """A numeric kernel grid parameter (one) profiled with the rail loss factor free at
    every value (a lattice profile each), then one parabolic step in the grid parameter;
    its profile and 95 % interval come from these costs. ``bounds``: the base's (refit)."""
    (key,) = [(effect.name, n) for n in effect.grid]
    values = sorted(gv.get(key, effect.grid[key[1]]))

    def evaluate(v):
        near = prof.nearest(v) if prof.points else start
        o = refit(data, ev, spec_b.replace(eta_r=near.eta_r), (effect,), near.x[:len(BASE)],
                  scale, grid_values={key: (v,)}, refine=False, x_start=near.x,
                  bounds=bounds)
        o = profile_eta_r(data, ev, spec_b, (effect,), o, scale, max_steps=6,
                          refine=True, bounds=bounds)  # a smooth profile for the steps below
        log.info("diagnosis: %s %s = %.5g: cost %.3f at the best rail-loss kernel, "
                 "%.3f interpolated", effect.name, key[1], v, o.cost, o.profile_cost)
        return o

    # a profile point's cost is its rail-loss profile's interpolated minimum: after
    # parabolic steps of 0.001 decades the best kernel's cost still sat up to ~1 cost unit
    # (s^2 ~ 1) above it in the blind study (the cost's curvature in log10 eta_r is ~3e6
    # on a 29-position test), a jitter of the order of the 95 % threshold (3.84 s^2)
    def point_cost(o):
        return o.profile_cost if o.profile_cost is not None else o.cost

    prof = SlowProfile(evaluate, cost=point_cost)
    for v in values:
        prof.at(v)
    prof.refine(REFINE_STEPS, 1e-4 * (values[-1] - values[0]))
    done = prof.points

    def cost(u):
        return point_cost(done[u])

    v = sorted(done)
    best = done[min(v, key=cost)]
    prof = {"values": [float(u) for u in v], "cost": [float(cost(u)) for u in v],
            "value": float(best.grid[key]), "integer": False,
            "note": "rail loss factor refitted at every value"}
    prof["inflation"] = profile_inflation(best, key, prof)
    prof.update(interval_from_profile(prof, best.analysis["residual_variance"]
                                      * prof["inflation"]))
    best.grid_profiles = {key: prof}
    return best
