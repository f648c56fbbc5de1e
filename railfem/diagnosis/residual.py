"""The model-measurement residual as an object, and a test of noise against structure.

``Residual`` holds, per record, part ('fit' or 'held') and quantity, the residual
**measured minus model** in dB on its own axes: frequency (Hz) or band (Hz), sensor
('head'/'foot') and hammer position (m). ``band_table`` gives its RMS per one-third-octave
band; railfem.plotting draws it over frequency, over hammer distance and head against foot.

``structure_test`` decides whether the residual is noise or structure:

* **correlation** (always): white noise has no correlation between neighbouring
  frequencies nor between neighbouring hammer positions; structure (a missing mechanism)
  is smooth in both. The Ljung-Box statistic Q = n (n + 2) sum_k rho_k^2 / (n - k),
  k = 1..h, with rho_k the autocorrelation about zero (a level offset is structure), is
  computed on every sequence over frequency (each quantity, sensor, position) and over
  position (each transfer frequency); under white noise each Q is chi^2(h) and the sums
  over sequences are chi^2(sum h). The two p-values are combined by Bonferroni, so the
  false-alarm rate on white noise is at most ``alpha`` (default 1 %).
* **the measurement's own scatter** (where there is any: records that repeat each other,
  e.g. both rails of one section on one date): per band the repeat scatter s_b from the
  differences between repeats; sum r^2 / s_b^2 against chi^2(N - p).

It also estimates the white part of the residual from first differences over frequency
(sigma_w = 1.4826 MAD(r_i - r_i-1) / sqrt 2: smooth structure cancels in differences of
neighbours and sharp local misfits do not move a median) and
the structured RMS sqrt(max(0, mean (r^2 - v) - sigma_w^2)) in dB (the mean weighted by
1 / (sigma_w^2 + v)^2), v the variance the model itself expects an entry to scatter by
(``Block.variance``, from a measurement effect with a random term: the noise floor's
log-Rayleigh scatter, 5.6 dB under the floor; 0 elsewhere; such entries enter the
correlation test over their expected SD sqrt(sigma_w^2 + v)); where repeats exist the
structured RMS is sqrt(mean max(0, r^2 - s_b^2)) instead: what exceeds the repeat
scatter band by band (the repeats measure the noise directly; band-to-band differences of
a decay rate are not noise).

**Model-form discrepancy** (``Block.discrepancy``: s_d^2 per entry from
railfem.identify.discrepancy, how far the model's own discretisation choices move it): a
smooth residual is expected then, so correlation alone does not make structure. Where the
correlation test rejects white noise, the residual's size is judged against noise plus
discrepancy: per cell c (record, quantity, sensor, band; positions pooled) the mean square
excess e_c = mean(r^2 - v) - sigma_w^2 is compared with the discrepancy variance D_c,
R = sum e_c / sum D_c, and k R against chi^2(k) with k = (sum D_c)^2 / sum D_c^2
(Satterthwaite: each cell's discrepancy one Gaussian draw, the conservative reading of a
discrepancy shared by the positions and frequencies of a band). Not rejected: verdict
'consistent' (noise plus discrepancy); rejected: 'structure'.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from railfem.identify.problem import table, table_scale, used_entries

ALPHA = 0.01
NEGLIGIBLE_DB = 0.5  # structure below this RMS (dB) is not worth a mechanism
# a candidate's change must reach this share of the discrepancy (mean squares, held out):
# an RMS change under about a third of the discrepancy's is what another discretisation
# of the base does (set on the cross-model runs: false candidates on clean data 0.0002 -
# 0.04, a frequency-dependent pad the base had half absorbed 0.12)
BEYOND_RATIO = 0.1
# ... and the candidate must lie outside the 95 % range of the shift the discretisation
# variants make along its own change (along_discrepancy): z^2 above Student's t^2 with as
# many degrees of freedom as variants (the spread is estimated from them; three: 10.1).
# On WFE cross-model data a foot 2.5 mm thicker gives z^2 = 110-340; a foot change that
# only absorbs the other mesh's cut-on offset about 3 (the straight-edge variant alone
# moves the estimate by 0.6 mm)
ALONG_LEVEL = 0.975


def along_threshold(n_variants: int) -> float:
    """z^2 a candidate must exceed along its change: t^2(ALONG_LEVEL, n_variants)."""
    return float(stats.t.ppf(ALONG_LEVEL, max(int(n_variants), 1)) ** 2)


@dataclass(frozen=True, kw_only=True, eq=False)
class Block:
    """One residual array: record, part, quantity, axis ('frequency' or 'band'), x (Hz),
    outputs, positions (m, per last axis), values (n_x, n_out, n_pos) dB, NaN = unused."""

    record: str
    part: str
    quantity: str
    axis: str
    x: np.ndarray
    outputs: tuple
    positions: np.ndarray
    values: np.ndarray
    variance: np.ndarray | None = None  # dB^2 the model expects as extra noise per entry
    discrepancy: np.ndarray | None = None  # dB^2 of model-form discrepancy per entry

    def rms(self) -> float:
        v = self.values[np.isfinite(self.values)]
        return float(np.sqrt(np.mean(v ** 2))) if v.size else float("nan")


def blocks(record, part: str, prediction, discrepancy=None) -> list[Block]:
    """The residual blocks of one record's part ('fit' or 'held') for a model prediction
    (railfem.identify.problem.Prediction); ``discrepancy``: a
    railfem.identify.discrepancy.Discrepancy whose variance each block carries."""
    target = record.fit if part == "fit" else record.held
    if target is None:
        return []
    out = []
    for q, v in table(target, prediction).items():
        meas_minus_model = -np.asarray(v, dtype=float)
        if q in ("point", "phase"):
            vals, pos, axis, x = meas_minus_model[:, :, None], target.positions[:1], \
                "frequency", target.frequency
        elif q == "transfer":
            vals, pos, axis, x = meas_minus_model, target.positions[target.transfer_index], \
                "frequency", target.frequency
        else:
            vals, pos, axis, x = meas_minus_model[:, :, None], np.array([np.nan]), "band", \
                target.bands.nominal
        var = (prediction.variance[:, :, target.transfer_index]
               if q == "transfer" and prediction.variance is not None else None)
        d2 = None
        if discrepancy is not None and q in discrepancy.variance:
            d2 = np.broadcast_to(discrepancy.at(q, np.asarray(x, dtype=float))[:, None, None],
                                 vals.shape).copy()
        out.append(Block(record=record.name, part=part, quantity=q, axis=axis,
                         x=np.asarray(x, dtype=float), outputs=tuple(target.outputs),
                         positions=np.asarray(pos, dtype=float), values=vals, variance=var,
                         discrepancy=d2))
    return out


@dataclass(frozen=True, kw_only=True, eq=False)
class Residual:
    """All residual blocks of a model on some data (see the module docstring)."""

    blocks: tuple

    def select(self, *, part=None, quantity=None, record=None) -> list[Block]:
        return [b for b in self.blocks if (part is None or b.part == part)
                and (quantity is None or b.quantity == quantity)
                and (record is None or b.record == record)]

    def rms(self, *, part="fit") -> dict:
        """RMS (dB) per quantity over the records."""
        out = {}
        for q in sorted({b.quantity for b in self.blocks if b.part == part}):
            v = np.concatenate([b.values[np.isfinite(b.values)]
                                for b in self.select(part=part, quantity=q)])
            out[q] = float(np.sqrt(np.mean(v ** 2))) if v.size else None
        return out

    def band_table(self, bands) -> list[dict]:
        """Rows {record, part, quantity, sensor, band_hz, rms_db, mean_db} per band."""
        rows = []
        for b in self.blocks:
            for o, sensor in enumerate(b.outputs):
                for c, lo, hi in zip(bands.nominal, bands.lower, bands.upper):
                    if b.axis == "band":
                        m = np.isclose(b.x, c, rtol=0.03)
                    else:
                        m = (b.x >= lo) & (b.x < hi)
                    v = b.values[m, o, :]
                    v = v[np.isfinite(v)]
                    if v.size:
                        rows.append({"record": b.record, "part": b.part, "quantity": b.quantity,
                                     "sensor": sensor, "band_hz": float(c),
                                     "rms_db": float(np.sqrt(np.mean(v ** 2))),
                                     "mean_db": float(np.mean(v)), "n": int(v.size)})
        return rows


def make_residual(data, predictions: dict, parts=("fit", "held"), *,
                  discrepancy=None) -> Residual:
    """Residual of the model predictions {record name: Prediction} on ``data``;
    ``discrepancy``: a Discrepancy, or a railfem.identify.problem.Scale that carries one
    (its blocks then carry the model-form variance the structure test allows for)."""
    discrepancy = getattr(discrepancy, "discrepancy", discrepancy)
    out = []
    for r in data.records:
        for part in parts:
            out += blocks(r, part, predictions[r.name], discrepancy)
    return Residual(blocks=tuple(out))


# ---------------------------------------------------------------------- noise or structure


def ljung_box(seq: np.ndarray, h: int) -> float:
    """Q of one sequence (autocorrelation about zero: an offset counts as structure)."""
    r = np.asarray(seq, dtype=float)
    n = len(r)
    den = float(r @ r)
    if den == 0:
        return 0.0
    q = 0.0
    for k in range(1, h + 1):
        rho = float(r[k:] @ r[:-k]) / den
        q += rho ** 2 / (n - k)
    return n * (n + 2) * q


def _runs(values: np.ndarray, axis: int, min_len: int, variance=None):
    """Contiguous finite sequences of ``values`` along ``axis`` (others flattened), each
    with the matching entries of ``variance`` (zeros without)."""
    var = np.zeros_like(values) if variance is None else variance
    v = np.moveaxis(values, axis, 0).reshape(values.shape[axis], -1)
    w = np.moveaxis(var, axis, 0).reshape(values.shape[axis], -1)
    for j in range(v.shape[1]):
        col = v[:, j]
        ok = np.isfinite(col)
        if not ok.any():
            continue
        edges = np.flatnonzero(np.diff(np.concatenate(([0], ok.astype(int), [0]))))
        for a, b in zip(edges[::2], edges[1::2]):
            if b - a >= min_len:
                yield col[a:b], w[a:b, j]


def _standard(seq, var, sigma_w):
    """seq over its expected noise SD where the model expects extra variance (else as is:
    the Ljung-Box statistic does not see a common scale)."""
    if not np.any(var):
        return seq
    return seq / np.sqrt(max(sigma_w, 1e-3) ** 2 + var)


def _structured(excess: np.ndarray, sigma_w: float) -> float:
    """sqrt(max(0, mean(r^2 - v) - sigma_w^2)) from rows (r^2 - v, v); the mean weighted
    by 1 / (sigma_w^2 + v)^2, the inverse variance of r^2 (equal weights where v = 0; an
    entry under a noise floor, 5.6 dB log-Rayleigh scatter, would otherwise swing the
    estimate by dB)."""
    d, v = excess
    w = 1.0 / (max(sigma_w, 1e-3) ** 2 + v) ** 2
    return float(np.sqrt(max(0.0, float(w @ d) / float(w.sum()) - sigma_w ** 2)))


def structure_test(res: Residual, *, part="fit", alpha: float = ALPHA,
                   n_parameters: int = 0, repeats=None) -> dict:
    """Noise or structure (see the module docstring). repeats: {band_hz: scatter_db} from
    repeat_scatter, or None. Returns a JSON-ready dict with 'verdict' ('noise', 'consistent'
    (noise plus the blocks' model-form discrepancy) or 'structure'), p-values, sigma_w and
    the structured RMS (dB)."""
    used = [b for b in res.select(part=part) if b.quantity != "phase"]
    # the white part first: 1.4826 MAD of the differences over frequency (robust: sharp
    # local misfits and the few entries a noise floor scatters do not count)
    d = np.concatenate([np.diff(seq) for b in used for seq, _ in _runs(b.values, 0, 8)]
                       or [np.zeros(0)])
    sigma_w = (float(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(2)) if d.size
               else float("nan"))
    q_f = df_f = q_x = df_x = 0.0
    squares, excess, n_tot = [], [], 0
    for b in used:
        # entries the model expects to scatter more (Block.variance: a noise floor) are
        # standardised by their expected SD before the correlation test, and their extra
        # variance is not counted as structure
        for seq, var in _runs(b.values, 0, 8, b.variance):
            h = max(1, min(5, len(seq) // 5))
            q_f += ljung_box(_standard(seq, var, sigma_w), h)
            df_f += h
            squares.append(seq ** 2)
            excess.append(np.stack([seq ** 2 - var, var]))
            n_tot += len(seq)
        if b.quantity == "transfer" and b.values.shape[2] >= 8:
            order = np.argsort(b.positions)
            var_o = None if b.variance is None else b.variance[:, :, order]
            for seq, var in _runs(b.values[:, :, order], 2, 8, var_o):
                h = max(1, min(3, len(seq) // 5))
                q_x += ljung_box(_standard(seq, var, sigma_w), h)
                df_x += h
    p_f = float(stats.chi2.sf(q_f, df_f)) if df_f else 1.0
    p_x = float(stats.chi2.sf(q_x, df_x)) if df_x else 1.0
    tests = [p for p, d in ((p_f, df_f), (p_x, df_x)) if d]
    p_corr = min(1.0, min(tests) * len(tests)) if tests else 1.0
    s = np.concatenate(squares) if squares else np.zeros(0)
    total = float(np.sqrt(np.mean(s))) if s.size else float("nan")
    structured = _structured(np.concatenate(excess, axis=1), sigma_w) if s.size else 0.0
    out = {"part": part, "alpha": alpha, "n": int(n_tot),
           "ljung_box_frequency": {"Q": q_f, "dof": df_f, "p": p_f},
           "ljung_box_position": {"Q": q_x, "dof": df_x, "p": p_x},
           "p_correlation": p_corr, "rms_db": total, "sigma_white_db": sigma_w,
           "structured_rms_db": structured}
    p_all = p_corr
    if repeats:
        sc = scatter_test(res, repeats, part=part, n_parameters=n_parameters)
        out["scatter"] = sc
        p_all = min(1.0, 2 * min(p_corr, sc["p"]))
        if sc.get("excess") is not None:  # the repeats measure the noise directly
            out["structured_rms_db"] = float(np.sqrt(sc["excess"]))
            out["structured_from"] = "repeat scatter"
    out["p"] = p_all
    out["verdict"] = "structure" if p_all < alpha else "noise"
    disc = discrepancy_test(used, sigma_w)
    if disc is not None:
        out["discrepancy"] = disc
        out["structured_beyond_discrepancy_db"] = disc["beyond_db"]
        if out["verdict"] == "structure" and disc["p"] >= alpha:
            out["verdict"] = "consistent"
    return out


def beyond_discrepancy(data, pred_ref: dict, pred_c: dict, discrepancy, *, part="held",
                       alpha: float = ALPHA, ref=None) -> dict | None:
    """Whether a candidate changes the prediction by more than the model-form discrepancy:
    the discrepancy test (discrepancy_test, no noise) on the change model_c - model_ref
    over ``part`` of every record; 'pass' when the change's mean square reaches a share of
    the discrepancy's (ratio R > BEYOND_RATIO: a change well within the discrepancy is what
    another discretisation of the base could do as well; its p-value is reported, not
    required:
    the discrepancy is known only roughly, and the held-out test already weighs each entry
    by noise plus discrepancy) **and** the change lies beyond the discrepancy along its
    own direction (along_discrepancy: z^2 > along_threshold). The first compares sizes summed
    over every band (a change small everywhere fails it), the second the candidate with
    the variants where it acts: a change the size of the discrepancy of the few bands it
    touches, in the direction the variants move the model (another mesh's cut-on offset
    absorbed by a foot thickness), passes the first and fails the second; a cut-on moved
    far beyond the variants' spread passes both. ``ref``: the reference's refit (an object
    with ``problem`` and ``x``: railfem.diagnosis.refit.Outcome), whose base parameters
    are then held free in the along test (base_tables). None without discrepancy (a
    Discrepancy, or a Scale that carries one)."""
    scale, discrepancy = discrepancy, getattr(discrepancy, "discrepancy", discrepancy)
    if discrepancy is None:
        return None
    before = make_residual(data, pred_ref, (part,), discrepancy=discrepancy)
    cand = make_residual(data, pred_c, (part,), discrepancy=discrepancy)
    change = [Block(**{**a.__dict__, "values": a.values - b.values, "variance": None})
              for a, b in zip(before.blocks, cand.blocks) if a.quantity != "phase"]
    out = discrepancy_test(change, 0.0)
    if out is None:
        return None
    base = None if ref is None else base_tables(ref.problem, ref.x)
    out["along"] = along_discrepancy(data, pred_ref, pred_c, scale, base=base)
    along = out["along"]
    out["pass"] = bool(out["ratio"] > BEYOND_RATIO
                       and (along is None or along["z2"] > along["threshold"]))
    out["significant"] = bool(out["p"] < alpha)  # above the discrepancy at alpha (reported)
    return out


def along_discrepancy(data, pred_ref: dict, pred_c: dict, scale, base=None) -> dict | None:
    """The candidate's change against the discrepancy **along that change**: the
    ensemble's variants (Discrepancy.samples: d_j, each variant minus the base) projected
    on the change c = model_c - model_ref over the fitted part of every record, both
    weighted as the fit weighs them (w = 1 / (noise^2 + s_d^2) per entry, ``scale``: the
    Scale of the fit, or a Discrepancy alone: unit noise). The least-squares estimate of a
    step along c moves by theta_j = (c'w d_j) / (c'w c) under variant j (in units of the
    candidate's own change: theta = 1 is the candidate), so

        z^2 = 1 / (factor mean_j theta_j^2) = (c'w c)^2 / (factor mean_j (c'w d_j)^2)

    is the squared distance of the candidate from the base in SDs of the shift the
    discretisation alone would make along the same direction (Kennedy-O'Hagan: the
    discrepancy confounded with the parameter; a low-rank one, the variants). Near a
    cut-on this is the frequency-warp reading of the discrepancy: the variants' level
    differences there are a shift of the cut-on, and an effect that shifts it (the foot's
    thickness) is judged by its shift against theirs (300 Hz against a spread of about
    50 Hz), not by its level change against the band's level variance, which the same
    shift inflates.

    ``base`` (base_tables: the base parameters' derivatives at the reference): the step
    along c is estimated with the base parameters free, as the refit estimates it, so c
    and each d_j enter by their parts the base cannot fit (c_perp = c - B b, the weighted
    least-squares residual of c on the base columns B; theta_j = c_perp'w d_j /
    c_perp'w c_perp). What the base absorbs of a variant (a spring rule that reads as a
    stiffer pad) then does not count as a shift of the candidate: a pad stiffening with
    frequency changes the prediction the way the node-spring variant does to 0.8 of its
    size when the base is held, to a fraction of that once kp and eta_p may move. {'z2',
    'theta': per variant, 'variants', 'threshold': along_threshold, 'base_free'}; None
    without samples (a Discrepancy given as variances only) or without a change."""
    disc = getattr(scale, "discrepancy", scale)
    samples = getattr(disc, "samples", None)
    if not samples:
        return None
    noise = scale if disc is not scale else {}
    nb = 0 if not base else len(next(iter(base.values())))
    nv = len(disc.variants)
    # Gram matrix of [B, c, D] over the entries (weighted): rows/cols 0..nb-1 the base,
    # nb the change, nb+1.. the variants
    G = np.zeros((nb + 1, nb + 1 + nv))
    for r in data.records:
        ta, tb = table(r.fit, pred_ref[r.name]), table(r.fit, pred_c[r.name])
        for q in ta:
            S = samples.get((r.name, q))
            if S is None or q == "phase":
                continue
            c = np.asarray(tb[q], dtype=float) - np.asarray(ta[q], dtype=float)
            w = 1.0 / np.asarray(table_scale(noise, r.fit, q, c.shape), dtype=float) ** 2
            cols = [np.asarray(d, dtype=float) for d in (base or {}).get((r.name, q), ())]
            if nb and len(cols) != nb:
                continue
            used = used_entries(r.fit, q) & np.isfinite(c)
            for col in cols:
                used &= np.isfinite(col)
            ww = np.where(used, np.broadcast_to(w, c.shape), 0.0)
            left = [np.where(used, v, 0.0) for v in cols + [c]]
            right = left + [np.where(used, d, 0.0) for d in S]
            for i, u in enumerate(left):
                G[i] += [float(np.sum(u * ww * v)) for v in right]
    cc0 = G[nb, nb]
    if nb:  # c and the variants less what the base columns fit of them (Schur complement)
        A_inv = np.linalg.pinv(G[:nb, :nb])
        G = G[nb:, nb:] - G[nb:, :nb] @ A_inv @ G[:nb, nb:]
    cc, cd = G[0, 0], G[0, 1:]
    if not (cc0 > 0 and cc > 1e-9 * cc0):  # no change, or one the base fits entirely
        return None
    theta = cd / cc
    ms = float(disc.factor * np.mean(theta ** 2))
    return {"z2": float("inf") if ms == 0 else 1.0 / ms, "theta": theta.round(4).tolist(),
            "variants": list(disc.variants), "threshold": along_threshold(nv),
            "base_free": bool(nb)}


def base_tables(problem, x, *, n_base: int = 4, step: float = 1e-3) -> dict:
    """{(record, quantity): [d table / d x_i for the first ``n_base`` entries of x]} (dB per
    vector unit) on the axes of the records' fitted tables: forward differences of
    ``problem``'s prediction (railfem.identify.problem.Problem) at ``x``, a step inside
    the box. The reference's base parameters for along_discrepancy; memoised for the last
    few (problem, x): the screening asks for the base's at every candidate."""
    key = (id(problem), np.asarray(x, dtype=float).tobytes(), n_base)
    hit = _BASE_MEMO.get(key)
    if hit is not None and hit[0] is problem:
        return hit[1]
    x = np.asarray(x, dtype=float)
    p0 = problem.predict(x)
    t0 = {r.name: table(r.fit, p0[r.name]) for r in problem.records}
    out: dict = {}
    hi = problem.box.upper
    for i in range(min(n_base, len(x))):
        h = step if x[i] + step <= hi[i] else -step
        xi = x.copy()
        xi[i] += h
        pi = problem.predict(xi)
        for r in problem.records:
            ti = table(r.fit, pi[r.name])
            for q, v in ti.items():
                d = (np.asarray(v, dtype=float) - np.asarray(t0[r.name][q], dtype=float)) / h
                out.setdefault((r.name, q), []).append(d)
    if len(_BASE_MEMO) >= 4:
        _BASE_MEMO.pop(next(iter(_BASE_MEMO)))
    _BASE_MEMO[key] = (problem, out)
    return out


_BASE_MEMO: dict = {}


def discrepancy_test(used, sigma_w: float) -> dict | None:
    """The residual's size against noise plus model-form discrepancy (module docstring):
    {R, k, p, the discrepancy's RMS and what exceeds it (dB)}; None without discrepancy."""
    cells: dict = {}
    for b in used:
        if b.discrepancy is None:
            continue
        var = np.zeros_like(b.values) if b.variance is None else b.variance
        k = np.rint(10 * np.log10(np.maximum(b.x, 1e-12) / 1000.0)).astype(int)
        for o in range(b.values.shape[1]):
            for kb in np.unique(k):
                m = k == kb
                r, v, d2 = b.values[m, o], var[m, o], b.discrepancy[m, o]
                ok = np.isfinite(r)
                if ok.any():
                    key = (b.record, b.quantity, o, int(kb))
                    e, d, n = cells.get(key, (0.0, 0.0, 0))
                    cells[key] = (e + float(np.sum(r[ok] ** 2 - v[ok])),
                                  d + float(np.sum(d2[ok])), n + int(ok.sum()))
    if not cells:
        return None
    e = np.array([c[0] / c[2] for c in cells.values()]) - sigma_w ** 2
    d = np.array([c[1] / c[2] for c in cells.values()])
    n = np.array([c[2] for c in cells.values()], dtype=float)
    if not d.sum() > 0:
        return None
    ratio = float(e.sum() / d.sum())
    k = float(d.sum() ** 2 / (d ** 2).sum())
    p = float(stats.chi2.sf(max(ratio, 0.0) * k, k))
    mean_d = float(n @ d / n.sum())
    beyond = float(np.sqrt(max(0.0, float(n @ (e - d)) / n.sum())))
    return {"ratio": ratio, "k": k, "p": p, "cells": len(cells),
            "discrepancy_rms_db": float(np.sqrt(mean_d)), "beyond_db": beyond}


def repeat_scatter(data, part="fit") -> dict:
    """{band centre: repeat scatter in dB} from records that repeat each other (same
    section and date, e.g. the two rails): pooled s_b^2 = sum (d - mean d)^2 / (n - groups),
    d = 10 lg of the measured decay rate. Empty when there are no repeats."""
    groups: dict = {}
    for r in data.records:
        m = r.metadata
        if r.kind != "tdr" or not (m.section or m.date):
            continue
        groups.setdefault((m.section, m.date, r.fit.outputs), []).append(r)  # per direction
    sums: dict = {}
    for recs in groups.values():
        if len(recs) < 2:
            continue
        t0 = recs[0].fit
        vals = np.stack([10 * np.log10(r.fit.tdr[:, 0]) for r in recs])  # (n_rep, bands)
        dev = vals - np.nanmean(vals, axis=0)
        for k, c in enumerate(t0.bands.nominal):
            ok = np.isfinite(dev[:, k])
            if ok.sum() >= 2:
                s2, dof = sums.get(float(c), (0.0, 0))
                sums[float(c)] = (s2 + float(np.sum(dev[ok, k] ** 2)), dof + int(ok.sum()) - 1)
    return {c: float(np.sqrt(s2 / dof)) for c, (s2, dof) in sums.items() if dof > 0}


def scatter_test(res: Residual, scatter: dict, *, part="fit", n_parameters=0) -> dict:
    """sum r^2 / s_b^2 over the decay-rate residuals against chi^2(N - p)."""
    chi, n, r2, s2, ex = 0.0, 0, 0.0, 0.0, 0.0
    for b in res.select(part=part, quantity="tdr"):
        for k, c in enumerate(b.x):
            s = scatter.get(float(c))
            v = b.values[k].ravel()
            v = v[np.isfinite(v)]
            if s and v.size:
                chi += float(np.sum((v / s) ** 2))
                n += v.size
                r2 += float(np.sum(v ** 2))
                s2 += s ** 2 * v.size
                ex += float(np.sum(np.maximum(v ** 2 - s ** 2, 0.0)))
    dof = max(n - n_parameters, 1)
    return {"chi2": chi, "dof": dof, "p": float(stats.chi2.sf(chi, dof)) if n else 1.0,
            "ratio": chi / dof if n else None, "n": n, "mean_r2": r2 / n if n else None,
            "mean_s2": s2 / n if n else None, "excess": ex / n if n else None}
