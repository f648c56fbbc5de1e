"""Model-form discrepancy: how far the model's own discretisation choices move its
prediction, per one-third-octave band and quantity.

A model that is right in its physics still differs from data simulated (or measured) by
another implementation: the section mesh (element size, straight or curved edges), how the
supports hold the foot (spring rule and count) and the pad's discretisation along the rail
all move the prediction, most near the cut-on frequencies of the cross-section waves. The
residual of a correct model on foreign data is therefore not white noise, and judging it
against noise alone calls that difference "structure".

``ensemble`` estimates the difference from the model itself: the base spec is evaluated in
a few variants around its own configuration (``variants``: another element size, straight
edges, the published node springs in another count, another pad discretisation; beam
models: their section constants from another mesh or the catalogue), at the same
parameters, and per band b and quantity q

    s_d^2(q, b) = mean over variants and over the band's entries of (L_variant - L_base)^2

with L the level in dB of the quantity (point mobility, transfer mobilities, decay rate)
as the data are compared with it. The mean is about the base, not about the ensemble's
mean: the base is the configuration the estimator uses. It is zero when every variant is
the base configuration and grows with the spread of the variants.

``Discrepancy.at(q, x)`` reads s_d^2 at frequencies (or band centres) x. The fit and the
diagnosis add it to the noise variance of every residual entry
(railfem.identify.problem.Scale): an entry's scale is sqrt(noise^2 + s_d^2), so bands the
model cannot predict (near cut-ons) weigh less, the parameter intervals carry the
discrepancy, and the residual tests (railfem.diagnosis.residual) judge against noise plus
discrepancy.

**Where an effect acts in the bands of the discrepancy.** Near a cut-on the variants'
differences are a shift of the cut-on frequency (on 60E1 the foot-flapping cut-on, about
5.1 kHz: straight edges +75 Hz, a 15 mm mesh +15 Hz), seen on the data's lines as level
differences of several dB. s_d^2 keeps only their size per band, so an effect that moves
the same cut-on (a foot thicker by 1 mm: +120 Hz) cannot be told from the discretisation
by its level change: a shift of 300 Hz and one of 50 Hz both change those bands by about
their s_d, the peak being narrower than the lines' spacing. What tells them apart is the
direction: ``samples`` keeps each variant's differences entry by entry, and their
least-squares projection on a candidate's change is the shift the variant would make in
the candidate's own parameter (a foot 3.5 mm thicker: 0.5 mm from the straight-edge
variant, under 0.1 mm from the others), the frequency-warp reading of the discrepancy
without a warp model. The diagnosis judges the candidate by it
(railfem.diagnosis.residual.along_discrepancy) and widens a profiled parameter's interval
by it (railfem.diagnosis.intervals.widen); continuous parameters take it through
Problem.discrepancy_columns. Two alternatives were weighed and not taken: a band-by-band
gate (a change over its band's s_d^2) lets any change pass in bands the variants barely
move (s_d^2 of 0.001 dB^2 at 100 Hz) and does not separate the two shifts above; a
discrepancy variance estimated from the data (REML, Kennedy-O'Hagan) is confounded with
exactly the effects that act where the discrepancy is large: the cut-on misfit of a
thicker foot would be taken as discrepancy and the effect absorbed. The ensemble is
information from outside the data, and three variants are few: in the gate and in a
profiled (grid) parameter's interval the quantile is Student's over their number.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, replace

import numpy as np

from railfem import validators as v

log = logging.getLogger(__name__)

#: variants of a WFE model (label, what changes): each one kernel at the base parameters
WFE_VARIANTS = ("straight edges", "mesh 15 mm", "node springs 8")
#: variants of a beam model: its section constants from another mesh or the catalogue
BEAM_VARIANTS = ("constants: catalogue", "constants: mesh 15 mm",
                 "constants: straight 7.5 mm mesh")
#: a pad of finite length is discretised into spring rows; each variant also gives it this
#: many more rows (a refinement, as a finer mesh: the other form of a pad). Alternating
#: with one row, the variants at a chosen pad of two rows moved its length by +-0.2 m
#: (one row is no discretisation of a 0.18 m pad); one more row moved it 0.006 m, and
#: the pad length of cross-model data of a pad in four rows (0.18 m for 0.16 m) was
#: then inside its interval (benchmarks/results/results_blind_cross.md)
PAD_ROWS_REFINED = 1


@dataclass(frozen=True, kw_only=True, eq=False)
class Discrepancy:
    """Per one-third-octave band (``index``: the IEC 61260 band numbers x, f_m = 1000
    10^(x/10) Hz) and quantity, the discrepancy variance s_d^2 (dB^2): {quantity:
    (n_bands,)}; ``variants``: the labels of the configurations it was estimated from;
    ``factor``: the variance is multiplied by it (1: as estimated); ``samples``: {(record
    name, quantity): (n_variants, ...) dB} the variants' differences from the base on the
    axes of railfem.identify.data.residual_table of the record's fitted part (NaN where not
    used), from which the parameter intervals take the estimate's shift under each variant
    (railfem.identify.problem.Problem.discrepancy_columns)."""

    index: np.ndarray
    variance: dict
    variants: tuple = ()
    factor: float = 1.0
    method: str = "ensemble"
    samples: dict | None = None

    def __post_init__(self):
        v.non_negative("Discrepancy.factor", self.factor, "(-)", "1 for the estimate as is")
        idx = np.asarray(self.index, dtype=int)
        object.__setattr__(self, "index", idx)
        var = {}
        for q, s2 in self.variance.items():
            s2 = np.asarray(s2, dtype=float)
            if s2.shape != idx.shape or not np.all(np.isfinite(s2)) or np.any(s2 < 0):
                raise ValueError(f"Discrepancy.variance[{q!r}]: give {len(idx)} finite "
                                 "variances >= 0 (dB^2), one per band")
            var[q] = s2
        object.__setattr__(self, "variance", var)

    @property
    def nominal(self) -> np.ndarray:
        """Exact mid-band frequencies (Hz) of the bands."""
        return 1000.0 * 10 ** (self.index / 10.0)

    def scaled(self, factor: float) -> Discrepancy:
        """The same estimate with its variance multiplied by ``factor``."""
        return replace(self, factor=float(factor))

    def at(self, quantity: str, x) -> np.ndarray:
        """s_d^2 (dB^2) of ``quantity`` at frequencies (or band centres) x (Hz): the value
        of the band holding x; 0 for a quantity without an estimate, the nearest band's
        value outside the bands estimated."""
        x = np.asarray(x, dtype=float)
        if quantity not in self.variance or not self.index.size:
            return np.zeros(x.shape)
        k = np.rint(10 * np.log10(np.maximum(x, 1e-12) / 1000.0)).astype(int)
        j = np.clip(np.searchsorted(self.index, k), 0, len(self.index) - 1)
        # searchsorted gives the first band >= k: take the nearer one of it and the previous
        prev = np.clip(j - 1, 0, len(self.index) - 1)
        j = np.where(np.abs(self.index[prev] - k) < np.abs(self.index[j] - k), prev, j)
        return self.factor * self.variance[quantity][j]

    def rms_db(self) -> dict:
        """{quantity: RMS over the bands of s_d (dB)}."""
        return {q: float(np.sqrt(self.factor * np.mean(s2))) if s2.size else 0.0
                for q, s2 in self.variance.items()}

    def to_dict(self) -> dict:
        """JSON-ready: per band the discrepancy SD (dB) per quantity."""
        return {"method": self.method, "variants": list(self.variants),
                "factor": self.factor,
                "bands_hz": [float(round(f, 1)) for f in self.nominal],
                "sd_db": {q: np.sqrt(self.factor * s2).round(3).tolist()
                          for q, s2 in self.variance.items()}}


def none() -> Discrepancy:
    """No discrepancy (every variance 0)."""
    return Discrepancy(index=np.zeros(0, dtype=int), variance={}, method="none")


def variants(spec, labels=None) -> list[tuple[str, object]]:
    """[(label, spec)]: ``spec`` in the variants of its model kind (WFE_VARIANTS or
    BEAM_VARIANTS, or ``labels`` from them); a pad of finite length also changes its rows
    (PAD_ROWS_REFINED more rows)."""
    labels = (WFE_VARIANTS if spec.kind.is_wfe else BEAM_VARIANTS) if labels is None \
        else tuple(labels)
    out = []
    for lab in labels:
        s = _variant(spec, lab)
        if spec.pad_length > 0 and spec.kind.is_discrete:
            s = s.replace(n_rows=spec.n_rows + PAD_ROWS_REFINED)
        out.append((lab, s))
    return out


def _variant(spec, label: str):
    rail, num = spec.rail, spec.numerics
    if label == "same":
        return spec
    if label == "straight edges":
        return spec.replace(rail=replace(rail, mesh_file=straight_mesh_file(rail.h)))
    if label.startswith("mesh "):
        return spec.replace(rail=replace(rail, h=float(label.split()[1]) / 1e3))
    if label.startswith("node springs "):
        return spec.replace(numerics=replace(num, foot_rule="nodes",
                                             n_foot_springs=int(label.split()[2])))
    if label.startswith("midpoint springs "):
        return spec.replace(numerics=replace(num, foot_rule="midpoint",
                                             n_foot_springs=int(label.split()[2])))
    if label == "constants: catalogue":
        return spec.replace(rail=replace(rail, beam_constants="catalogue"))
    if label.startswith("constants: straight "):
        h = float(label.split()[2].removesuffix("mm")) / 1e3
        return spec.replace(rail=replace(rail, mesh_file=straight_mesh_file(h),
                                         beam_constants="mesh"))
    if label.startswith("constants: mesh "):
        return spec.replace(rail=replace(rail, h=float(label.split()[2]) / 1e3,
                                         beam_constants="mesh"))
    raise ValueError(f"discrepancy variant {label!r}: give one of {WFE_VARIANTS + BEAM_VARIANTS}"
                     " or 'same', 'mesh H', 'node springs N', 'midpoint springs N', "
                     "'constants: mesh H', 'constants: straight Hmm mesh'")


def straight_mesh_file(h: float) -> str:
    """The straight-sided twin of the section mesh of element size h (m), written once to a
    temporary folder of its own (a spec names a mesh by file)."""
    import tempfile
    from pathlib import Path

    from railfem.rail import meshing

    path = Path(tempfile.gettempdir()) / "railfem-meshes" / f"60E1_h{h * 1e3:g}mm_straight.npz"
    if not path.exists():
        path.parent.mkdir(parents=True, exist_ok=True)
        meshing.save_mesh(meshing.get_mesh("60E1", h, curved=False), path)
    return str(path)


def band_variance(diffs) -> tuple[np.ndarray, dict]:
    """(band index, {quantity: (n_bands,) mean square}) of model-minus-model differences
    ``diffs``: [(quantity, x in Hz (per entry), difference in dB (per entry))]."""
    sums: dict = {}
    for q, x, d in diffs:
        ok = np.isfinite(d)
        k = np.rint(10 * np.log10(np.asarray(x, dtype=float)[ok] / 1000.0)).astype(int)
        for kb in np.unique(k):
            s, n = sums.setdefault(q, {}).get(kb, (0.0, 0))
            dd = np.asarray(d, dtype=float)[ok][k == kb]
            sums[q][kb] = (s + float(dd @ dd), n + dd.size)
    index = np.array(sorted({kb for per in sums.values() for kb in per}), dtype=int)
    var = {q: np.array([per[kb][0] / per[kb][1] if kb in per and per[kb][1] else 0.0
                        for kb in index]) for q, per in sums.items()}
    return index, var


def differences(target, base: np.ndarray, other: np.ndarray) -> dict:
    """{quantity: L_other - L_base (dB)} on the axes of railfem.identify.data.residual_table
    of ``target`` (NaN where the target does not use an entry), from two receptances."""
    from railfem.identify.problem import Prediction, table

    ta = table(target, Prediction(level=base, power=base))
    tb = table(target, Prediction(level=other, power=other))
    return {q: np.asarray(tb[q], dtype=float) - np.asarray(ta[q], dtype=float) for q in ta}


def entries(target, diff: dict) -> list:
    """[(quantity, x in Hz, difference in dB)] of the entries ``target`` uses
    (railfem.identify.problem.used_entries) of a ``differences`` table."""
    from railfem.identify.problem import used_entries

    out = []
    for q, d in diff.items():
        used = used_entries(target, q)
        axis = target.bands.nominal if q == "tdr" else target.frequency
        x = np.broadcast_to(np.asarray(axis, dtype=float).reshape((-1,) + (1,) * (used.ndim - 1)),
                            used.shape)
        out.append((q, x[used], d[used]))
    return out


def ensemble(records, receptance, spec, labels=None, *, factor: float = 1.0) -> Discrepancy:
    """The discrepancy of ``spec`` on ``records`` (objects with ``name`` and ``fit``, a
    railfem.identify.data.Target) from its variants (``variants``; ``labels``: which),
    ``receptance(spec, record)`` -> (nf, n_out, n_pos) the model at the record's geometry
    (railfem.diagnosis.evaluate.Evaluator.receptance). See the module docstring."""
    base = {r.name: receptance(spec, r) for r in records}
    diffs, used, samples = [], [], {}
    for lab, s in variants(spec, labels):
        try:
            tabs = {r.name: differences(r.fit, base[r.name], receptance(s, r)) for r in records}
        except (ValueError, RuntimeError, np.linalg.LinAlgError) as exc:
            log.warning("discrepancy: variant %r left out: %s", lab, exc)
            continue
        for r in records:
            diffs += entries(r.fit, tabs[r.name])
            for q, d in tabs[r.name].items():
                samples.setdefault((r.name, q), []).append(d)
        used.append(lab)
    if not used:
        return none()
    index, var = band_variance(diffs)
    d = Discrepancy(index=index, variance=var, variants=tuple(used), factor=factor,
                    samples={k: np.stack(v) for k, v in samples.items()})
    log.info("discrepancy over %s: RMS %s dB", ", ".join(used),
             {q: round(x, 2) for q, x in d.rms_db().items()})
    return d
