"""The chosen model's intervals over its effects' assumed values: an envelope, not a tangent.

An effect may set a spec value the data cannot fix, with the standard deviation of its
log10 (railfem.diagnosis.effects.AssumedValue; roll_restraint's grip loss factor). A
screening refit's own analysis (which its plausibility gate reads) carries it as a
linearised unfitted term (the residual's change per decade at the assumed value times its
SD: railfem.diagnosis.problem.EffectModel.unfitted_tangents). Where the estimates are not
linear in the value this term is too small on one side (the grip of roll_restraint on
blind lateral data moves 0.029 per decade below its assumed loss factor and 0.069 above).
The intervals a user reads (a screening row's, railfem.diagnosis.loop.screen_one, and the
chosen model's final ones) therefore take the envelope instead: the model is
refitted with the value at each end of its range, centre x 10^(+-ENVELOPE_SD x SD),
starting from the centre's estimate (the rail loss factor and any grid value held at the
centre's), each end's intervals are computed as the centre's (the rail loss factor free
when it was profiled), and each parameter's reported 95 % interval is the union of the
centre's and the ends'; the reported value stays the centre's. The linearised term is
left out of all three (the envelope carries its share; counted once). Each value is
varied on its own, the others at their centres."""
from __future__ import annotations

import logging
import math
from dataclasses import replace

import numpy as np

from railfem.diagnosis.problem import BASE
from railfem.diagnosis.refit import Outcome, nearest_rail_loss, reanalyse, refit

log = logging.getLogger(__name__)

#: the ends of an assumed value's range, in its SDs either side (95 %: 2 SD)
ENVELOPE_SD = 2.0


def ends(effects) -> list[tuple[str, str, float, float]]:
    """[(effect, name, assumed value, end's value)] of the ends of every assumed value's
    range, low end first."""
    return [(e.name, a.name, a.value, a.value * 10.0 ** (k * ENVELOPE_SD * a.sd))
            for e in effects for a in e.assumed for k in (-1, 1)]


def rail_loss_neighbour(o: Outcome) -> float | None:
    """log10 of the rail loss factor profiled next to ``o``'s (the kernel its rail-loss
    column is taken against, railfem.diagnosis.refit.joint_uncertainty), or None when it
    was not profiled."""
    prof = o.eta_r_profile
    if not prof or len(prof.get("values", ())) < 2:
        return None
    return nearest_rail_loss(o.eta_r, [round(math.log10(v), 6) for v in prof["values"]])


def assumed_envelope(o: Outcome) -> Outcome:
    """``o`` (a chosen model's final refit) with its intervals the envelope over its
    effects' assumed values (see the module docstring): a new Outcome, its analysis
    redone without the assumed values' linearised terms, ``envelope`` holding each end's
    value and parameters; ``o`` itself (its linearised terms) when no effect assumes a
    value or (logged) when an end cannot be refitted."""
    if not ends(o.effects):
        return o
    try:
        return _envelope(o)
    except (ValueError, RuntimeError, np.linalg.LinAlgError) as exc:
        log.warning("diagnosis: %s could not be refitted at the ends of its assumed "
                    "values' ranges (%s): its intervals keep their linearised terms",
                    o.name, exc)
        return o


def _envelope(o: Outcome) -> Outcome:
    todo = ends(o.effects)
    pb, nb = o.problem, rail_loss_neighbour(o)
    m = pb.model
    grid = {k: (v,) for k, v in o.grid.items()}
    out = []
    for effect, name, centre, value in todo:
        end = refit(m.data, m.evaluator, m.spec, o.effects, o.x[:len(BASE)], pb.scale,
                    grid_values=grid, refine=False, x_start=o.x, bounds=m.bounds,
                    assumed={(effect, name): value}, unfitted=False)  # analysed below
        end.grid_profiles = o.grid_profiles
        end.eta_r_profile = o.eta_r_profile
        _analyse_as_centre(end, nb)
        out.append({"effect": effect, "name": name, "assumed": centre, "value": value,
                    "cost": end.cost,
                    "x": [float(v) for v in end.x], "parameters": end.parameters()})
        log.info("diagnosis: %s refitted with %s's %s = %.3g: cost %.3f (centre %.3f)",
                 o.name, effect, name, value, end.cost, o.cost)
    centre = replace(o, problem=pb.with_model(replace(m, assumed_terms=False)),
                     analysis=dict(o.analysis), envelope=out)
    _analyse_as_centre(centre, nb)
    return centre


def _analyse_as_centre(o: Outcome, nb: float | None) -> None:
    """o.analysis at o.x on its own problem, the rail loss factor free against the kernel
    10^nb when it was profiled (its interval then o.eta_r_profile['ci95'])."""
    reanalyse(o, nb)
    joint = o.analysis.get("eta_r")
    if joint is not None and o.eta_r_profile is not None:
        o.eta_r_profile = dict(o.eta_r_profile, ci95=joint["ci95"],
                               identifiable=joint["identifiable"])
