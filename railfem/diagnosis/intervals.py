"""Intervals of an effect's grid parameters (a kernel parameter profiled over a grid: the
pad length, the foot thickness): the 95 % interval read off a profile of costs, its
inflation for the residual's cluster structure, and its widening by the model-form
discrepancy (how far the discretisation variants alone would move the estimate)."""
from __future__ import annotations

import math

import numpy as np
from scipy import stats

from railfem.diagnosis.problem import MODEL_VARIANT
from railfem.identify import uncertainty
from railfem.identify.profiling import CHI2_95


def grid_inflation(J, r, r_nb, step, clusters) -> float:
    """Variance inflation of a profiled grid parameter: with its column (r_nb - r) / step
    (the residual at the neighbouring grid value, the rest held) added to the Jacobian, the
    cluster-robust over the model-based variance of that parameter, at least 1. The profile
    interval's threshold (chi^2 s^2) is scaled by it, as the continuous parameters take
    the larger of the two variances. The model-form discrepancy is not in it: it shifts
    the estimate rather than flattening the profile (grid_shift_variance, widen)."""
    Jx = np.column_stack([J, (r_nb - r) / step])
    _, C_diag, *_ = uncertainty.covariance(Jx, r)
    C_rob, _ = uncertainty.robust_covariance(Jx, r, clusters)
    ratio = C_rob[-1, -1] / C_diag[-1] if np.isfinite(C_diag[-1]) and C_diag[-1] > 0 else 1.0
    return float(max(1.0, ratio))


def grid_shift_variance(J, r, secant, discrepancy) -> float:
    """The variance (squared units of the grid parameter) of the estimate's shift under
    the model-form discrepancy: N (railfem.identify.problem.Problem.discrepancy_columns,
    one column per variant of the base, scaled by sqrt(factor / n)) projected by least
    squares on ``secant`` (d r / d value) with the columns J held free
    (uncertainty.nuisance_covariance): sum over the variants of their shift squared / n.

    This is the model-form error in the grid parameter's own units: near a cut-on the
    variants' level differences are a shift of the cut-on, and their projection on a
    parameter that moves the cut-on (a foot thickness) is the thickness change that would
    make the same shift. The secant is the one from the parameter's null value (the
    effect's start) to the estimate (_null): the variants' differences are those of the
    base, at the null value, and lie at the base's cut-on; a neighbour's secant at a foot
    3.5 mm thicker moves a cut-on 400 Hz away from them and sees almost none of them."""
    if discrepancy is None or not np.size(discrepancy):
        return 0.0
    Jd = np.column_stack([J, secant])
    return float(uncertainty.nuisance_covariance(Jd, np.asarray(discrepancy))[-1, -1])


def discrepancy_terms(problem, dof: int, level: float = 0.975):
    """The model-form discrepancy as random terms of an analysis
    (railfem.identify.problem.Problem.discrepancy_columns N: one column per variant, N N'
    their mean square), scaled by t(level, n_variants) / t(level, dof) when the columns
    are the variants' (an interval x +- t(level, dof) SD, railfem.identify.uncertainty.
    analyse): the discrepancy's share of each half-width then takes the quantile of a
    variance estimated from the few variants (three: 3.18 instead of 1.96), as a grid
    parameter's (widen) and the held-out gate's along the change (residual.along_threshold)
    do, and the noise's share keeps its own. On clean data of a WFE model of another form
    (benchmarks/blind, form 'cross') the pad loss factor's estimate sat 0.075 decades
    from the truth, 2.6 times the RMS of the variants' shifts (0.029): outside the 1.96
    quantile, inside 3.18 (the shifts of the 15 mm mesh and of the node springs were
    0.036 and 0.034: the other model differs in both at once). None without discrepancy.

    Not taken: the variants' shift variances summed (foreign data differ in every aspect
    at once) with the normal quantile, sqrt(3) x 1.96 = 3.39 RMS instead of 3.18 (3.61 at
    20 degrees of freedom). With three variants both bound the shifts of all three adding
    with one sign (sqrt(3) |d| = 1.73 |d|, |d| their root sum of squares: 1.84 |d| today,
    1.96 |d| summed); the other form's shifts seen so far lie inside both (the grip of
    roll_restraint 1.3 |d|, the pad loss factor 1.5 |d|). On the blind lateral data of
    roll_restraint (10 seeds) it widened the grip's interval by 4-10 % and brought none of
    the three seeds whose interval misses the truth inside (lower ends 0.503-0.517 for
    0.5): what they lack is the bias of the grip's assumed loss factor, to which the grip
    is convex (benchmarks/results/results_roll_restraint.md)."""
    N = problem.discrepancy_columns()
    n_var = distinct_variants(problem, N)
    if n_var is None:  # per-cell columns: as they are
        return N
    k = float(stats.t.ppf(level, n_var) / stats.t.ppf(level, max(int(dof), 1)))
    return N * max(k, 1.0)


def distinct_variants(problem, N) -> int | None:
    """How many discretisation variants the discrepancy columns N of ``problem`` sample
    (Problem.discrepancy_columns: one column per variant label), the variants evaluated
    on a chosen model as well (model_scale, labels ending in MODEL_VARIANT) counted once:
    they are the same variants at another point, and Student's t is over how many
    variants there are. None when N is not one column per variant label."""
    disc = getattr(problem.scale, "discrepancy", None)
    labels = tuple(getattr(disc, "variants", ()) or ())
    if N is None or not labels or N.shape[1] != len(labels):
        return None
    return len({v.removesuffix(MODEL_VARIANT) for v in labels})


def widen(ci, value, var_shift: float, n_variants: int, level: float = 0.975) -> list:
    """A profile interval ``ci`` about ``value`` widened by the discrepancy's shift of the
    estimate: each side's half-width h becomes sqrt(h^2 + t^2 var_shift), t Student's at
    ``level`` with as many degrees of freedom as variants (the shift's variance is
    estimated from them; three: t = 3.18). The two parts add as variances of independent
    errors; the discrepancy's is added outside the profile because it moves the
    estimate: the profile of a cut-on parameter on lines coarser than the peak is far
    from a parabola (a foot 1 mm off puts a dip on a line: cost x 4), so a threshold
    scaled by it would not widen the interval by the shift."""
    if not var_shift > 0:
        return list(ci)
    q = float(stats.t.ppf(level, max(int(n_variants), 1))) ** 2 * var_shift
    return [value - math.sqrt((value - ci[0]) ** 2 + q),
            value + math.sqrt((ci[1] - value) ** 2 + q)]


def interval_from_profile(prof: dict, s2: float, threshold: float = CHI2_95) -> dict:
    """95 % interval of a profiled grid parameter: where the profile stays within
    ``threshold`` s^2 (CHI2_95: 95 %) of its minimum (linear interpolation; open at the
    grid's ends)."""
    v, c = np.array(prof["values"]), np.array(prof["cost"])
    d = (c - c.min()) / max(s2, 1e-300)
    k = int(np.argmin(d))
    if prof.get("integer"):
        inside = v[d < threshold]
        return {"ci95": [float(inside.min()), float(inside.max())],
                "identifiable": "yes" if len(inside) == 1 else "weak",
                "reason": f"indices within the 95 % profile threshold: "
                          f"{[int(x) for x in inside]}"}
    lo = hi = None
    for a in range(k, 0, -1):
        if d[a - 1] >= threshold:
            lo = v[a - 1] + (threshold - d[a - 1]) * (v[a] - v[a - 1]) / (d[a] - d[a - 1])
            break
    for a in range(k, len(v) - 1):
        if d[a + 1] >= threshold:
            hi = v[a] + (threshold - d[a]) * (v[a + 1] - v[a]) / (d[a + 1] - d[a])
            break
    if lo is not None and hi is not None:
        # a finer interval from the parabola fitted (least squares) to every profile point
        # from the bracketing point below to the one above: refinement steps cluster points
        # near the minimum, where a parabola through the best three follows the refits'
        # tolerance instead of the profile
        a_, b_ = np.flatnonzero(v <= lo)[-1], np.flatnonzero(v >= hi)[0]
        xs, cs = v[a_:b_ + 1], c[a_:b_ + 1]
        a, b, _ = np.linalg.lstsq(np.vstack([xs ** 2, xs, np.ones_like(xs)]).T, cs,
                                  rcond=None)[0]
        if a > 0:
            half = math.sqrt(threshold * s2 / a)
            vertex = -b / (2 * a)
            # the interval holds the reported (best) value whatever the parabola says
            lo, hi = min(vertex - half, v[k]), max(vertex + half, v[k])
    open_ = [s for s, x in (("low", lo), ("high", hi)) if x is None]
    return {"ci95": [float(v[0] if lo is None else lo), float(v[-1] if hi is None else hi)],
            "identifiable": "yes" if not open_ else ("weak" if len(open_) == 1 else "no"),
            "reason": "profile over the grid" + (f", open on the {' and '.join(open_)} side"
                                                 if open_ else "")}
