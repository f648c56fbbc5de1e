"""Dispersion branches: waves followed along frequency (or wavenumber) by their mode shapes.

A k(omega) solve returns at each frequency a set of waves sorted by |k|, and an omega(k)
solve the modes at each k sorted by frequency. Where two branches cross, that order changes,
so a column of such arrays jumps from one branch to another; and the labeller
(:mod:`railfem.rail.labels`), which judges one shape at a time, can name one branch differently
along its length (at a few kHz lateral bending moves the head more than the foot and looks
like torsion to it). Colours and legends drawn from either then swap at crossings.

Here a branch is followed by its shape. Between neighbouring sweep points the waves of one
symmetry family are paired by the modal assurance criterion in the mass metric,

    MAC(a, b) = |a^H M b|^2 / ((a^H M a) (b^H M b)),

choosing the pairing with the largest sum of MACs (Hungarian assignment,
``scipy.optimize.linear_sum_assignment``). A pair whose MAC is below ``min_mac`` is no
pair: the new wave starts a branch (a cut-on, or a wave entering the computed set) and the
old branch ends. Waves of the two mirror-symmetry families are M-orthogonal and never
paired. At a crossing of two branches of one family the shapes stay distinct (MAC near 1
along each branch, near 0 across), so each branch keeps its shape, its name and its colour;
at a veering (an avoided crossing) the shapes turn smoothly along the continuous curves and
the tracking follows those curves.

Each branch gets one wave type: the labeller's name that holds over most of the start of
the branch (:func:`branch_labels`): its first octave in a k(omega) sweep, the first third of
the k range in an omega(k) sweep. ``Branches.name`` turns the
types into unique legend entries in words.
"""
from __future__ import annotations

import logging
from collections import Counter
from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spl
from scipy.optimize import linear_sum_assignment

from . import waves
from .labels import label_shapes
from .waveguide import FAMILIES, Waveguide

log = logging.getLogger(__name__)

#: Default limit on |Im k| / |Re k| for a wave to count as propagating
#: (0.25 is a decay of about 13.6 dB per wavelength).
MAX_ATTENUATION = 0.25
#: Smallest MAC of a pair of shapes at neighbouring sweep points on one branch.
MIN_MAC = 0.5
#: Start of a branch whose labels vote for its type: octaves of a k(omega) sweep and the
#: share of the k range of an omega(k) sweep.
REFERENCE_OCTAVES = 1.0
REFERENCE_K_SHARE = 1 / 3

# Wave types of railfem.rail.labels in words for legends.
_TYPE_WORDS = {
    "cross-section (sym.)": "symmetric cross-section wave",
    "cross-section (antisym.)": "antisymmetric cross-section wave",
    "cross-section": "cross-section wave",
}


@dataclass(frozen=True, kw_only=True)
class Branches:
    """Dispersion branches, axis 0 the sweep, axis 1 the branch.

    sweep: 'frequency' (k(omega): waves at given frequencies) or 'wavenumber' (omega(k):
    modes at given real wavenumbers).
    frequency: (n, nb) Hz; k: (n, nb) complex rad/m (real for omega(k)); NaN where the
    branch does not exist (not yet cut on, no longer propagating, outside the computed modes).
    family: (nb,) symmetry family of each branch.
    label: (nb,) one wave type per branch (railfem.rail.labels names).
    name: (nb,) unique legend entry in words (type, plus the cut-on frequency when two
    branches share a type).
    point_label: (n, nb) the labeller's name at each point ('' where absent).
    mac: (n, nb) MAC of each point with the previous point of its branch (NaN at the start).
    """

    sweep: str
    frequency: np.ndarray
    k: np.ndarray
    family: np.ndarray
    label: np.ndarray
    name: np.ndarray
    point_label: np.ndarray
    mac: np.ndarray

    def __post_init__(self):
        if self.sweep not in ("frequency", "wavenumber"):
            raise ValueError(f"sweep must be 'frequency' or 'wavenumber', got {self.sweep!r}")
        n, nb = np.shape(self.frequency)
        for name in ("k", "point_label", "mac"):
            if np.shape(getattr(self, name)) != (n, nb):
                raise ValueError(f"Branches.{name} must have shape {(n, nb)}, "
                                 f"got {np.shape(getattr(self, name))}")
        for name in ("family", "label", "name"):
            if np.shape(getattr(self, name)) != (nb,):
                raise ValueError(f"Branches.{name} must have shape ({nb},), "
                                 f"got {np.shape(getattr(self, name))}")

    @property
    def n_branches(self) -> int:
        return len(self.label)

    def present(self) -> np.ndarray:
        """(n, nb) True where the branch exists."""
        return np.isfinite(self.frequency) & np.isfinite(self.k)


# ------------------------------------------------------------------------------- core
def propagating_mask(wavenumber, max_attenuation: float = MAX_ATTENUATION) -> np.ndarray:
    """True where a wave propagates: finite, Re k != 0 and |Im k| <= max_attenuation |Re k|."""
    k = np.asarray(wavenumber, dtype=complex)
    with np.errstate(invalid="ignore"):
        return (np.isfinite(k) & (k.real != 0)
                & (np.abs(k.imag) <= max_attenuation * np.abs(k.real)))


def mac(a, b, weight=None) -> np.ndarray:
    """Modal assurance criterion between the columns of ``a`` (n, na) and ``b`` (n, nb).

    MAC_ij = |a_i^H W b_j|^2 / ((a_i^H W a_i) (b_j^H W b_j)) with W = ``weight`` (a
    symmetric positive (semi)definite matrix, e.g. the mass matrix) or the identity.
    1 for parallel shapes, 0 for W-orthogonal ones.
    """
    a = np.asarray(a)
    b = np.asarray(b)
    if a.ndim != 2 or b.ndim != 2 or a.shape[0] != b.shape[0]:
        raise ValueError(f"shapes must be (n, na) and (n, nb) with the same n, got "
                         f"{a.shape} and {b.shape}")
    wb = b if weight is None else weight @ b
    wa = a if weight is None else weight @ a
    cross = a.conj().T @ wb
    na = np.real(np.einsum("ij,ij->j", a.conj(), wa))
    nb = np.real(np.einsum("ij,ij->j", b.conj(), wb))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.abs(cross) ** 2 / np.outer(na, nb)
    return np.nan_to_num(out, nan=0.0)


def track(shapes, *, weight=None, min_mac: float = MIN_MAC, max_gap: int = 1) -> np.ndarray:
    """Follow shapes along a sweep; return the (n_points, n_branches) column index of each
    branch at each point (-1 where the branch is absent).

    shapes: sequence of (n, m_p) arrays, the shapes present at sweep point p (m_p may vary).
    A branch ending at point p may be picked up again up to ``max_gap`` points later (a wave
    that drops out of the computed set for a point). New branches are numbered in order of
    appearance, and at one point in column order.
    """
    if not 0.0 < min_mac <= 1.0:
        raise ValueError(f"min_mac must be in (0, 1], got {min_mac}")
    rows: list[dict[int, int]] = []
    last: dict[int, tuple[int, np.ndarray]] = {}  # branch -> (point, shape)
    n_branches = 0
    for p, s in enumerate(shapes):
        s = np.asarray(s)
        if s.ndim != 2:
            raise ValueError(f"shapes[{p}] must be a 2-D (n, m) array, got shape {s.shape}")
        row: dict[int, int] = {}
        open_ = [b for b, (q, _) in last.items() if p - q <= max_gap + 1]
        free = list(range(s.shape[1]))
        if open_ and free:
            score = mac(np.column_stack([last[b][1] for b in open_]), s, weight)
            for i, j in zip(*linear_sum_assignment(score, maximize=True)):
                if score[i, j] >= min_mac:
                    row[open_[i]] = int(j)
            free = [j for j in free if j not in row.values()]
        for j in free:
            row[n_branches] = j
            n_branches += 1
        for b, j in row.items():
            last[b] = (p, s[:, j])
        rows.append(row)
    index = np.full((len(rows), n_branches), -1, dtype=int)
    for p, row in enumerate(rows):
        for b, j in row.items():
            index[p, b] = j
    return index


def branch_labels(point_label, position, window: float) -> np.ndarray:
    """One wave type per branch: the labeller's name that holds over most of the branch's
    first ``window`` of sweep ``position``.

    point_label: (n, nb) names, '' (or None) where a branch is absent. position: (n,) or
    (n, nb) sweep coordinate, increasing along axis 0 (ln f for k(omega), k for omega(k)).
    Each point weighs the stretch of position half way to its neighbours on the branch (cut
    at the window's end), so the vote does not depend on the grid spacing. Near its start a
    branch is a beam wave (low frequency, small k) or a cross-section mode just cut on: the
    shapes the labeller's rules describe. Further on, branches that veer past each other
    exchange their character and the labeller's names along one branch change with it.
    """
    point_label = np.asarray(point_label, dtype=object)
    position = np.broadcast_to(np.asarray(position, dtype=float)[..., None]
                               if np.ndim(position) == 1 else position, point_label.shape)
    out = np.empty(point_label.shape[1], dtype=object)
    for b in range(point_label.shape[1]):
        ok = np.array([x not in ("", None) for x in point_label[:, b]]) & np.isfinite(
            position[:, b])
        if not ok.any():
            out[b] = ""
            continue
        pos, labs = position[ok, b], [str(x) for x in point_label[ok, b]]
        # each point stands for the stretch half way to its neighbours, cut to the window
        mid = (pos[1:] + pos[:-1]) / 2
        lo = np.concatenate([[pos[0]], mid])
        hi = np.minimum(np.concatenate([mid, [pos[-1]]]), pos[0] + window)
        weight = np.clip(hi - lo, 0.0, None)
        if not weight.any():  # a single point
            weight = np.ones(len(labs))
        votes: dict[str, float] = {}
        for lab, w in zip(labs, weight):
            votes[lab] = votes.get(lab, 0.0) + w
        out[b] = max(votes, key=votes.get)  # ties: the first seen
    return out


def type_in_words(label: str) -> str:
    """A railfem.rail.labels wave type as a legend entry in words."""
    return _TYPE_WORDS.get(str(label), str(label)) or "unnamed wave"


def branch_names(label, start_frequency) -> np.ndarray:
    """Unique legend entries in words: the wave type, and where several branches share a
    type, each with the frequency (Hz) at which it starts ('..., from 4.2 kHz')."""
    label = [type_in_words(x) for x in label]
    counts = Counter(label)
    names = []
    for lab, f0 in zip(label, start_frequency):
        if counts[lab] > 1 and np.isfinite(f0):
            lab = f"{lab}, from {_hz(f0)}"
        names.append(lab)
    seen: Counter = Counter()
    for i, n in enumerate(names):  # still equal (same type and start): number them
        seen[n] += 1
        if list(names).count(n) > 1:
            names[i] = f"{n} ({seen[n]})"
    return np.array(names, dtype=object)


def _hz(f: float) -> str:
    return f"{f / 1000:.3g} kHz" if f >= 1000 else f"{f:.3g} Hz"


def _mass_metric(guide: Waveguide, family: str):
    T = guide.families[family].T
    return (T.T @ guide.M @ T).tocsr()


def _assemble(sweep, x, per_family, position, window) -> Branches:
    """Branches from per-family lists of (index, values, labels, macs)."""
    cols_f, cols_k, fams, plabs, macs = [], [], [], [], []
    for fam, (index, k_pts, f_pts, lab_pts, shapes, weight) in per_family.items():
        for b in range(index.shape[1]):
            f_col = np.full(len(x), np.nan)
            k_col = np.full(len(x), np.nan + 0j)
            l_col = np.full(len(x), "", dtype=object)
            m_col = np.full(len(x), np.nan)
            prev = None
            for p, j in enumerate(index[:, b]):
                if j < 0:
                    continue
                f_col[p], k_col[p], l_col[p] = f_pts[p][j], k_pts[p][j], lab_pts[p][j]
                if prev is not None:
                    m_col[p] = mac(prev[:, None], shapes[p][:, j:j + 1], weight)[0, 0]
                prev = shapes[p][:, j]
            cols_f.append(f_col)
            cols_k.append(k_col)
            plabs.append(l_col)
            macs.append(m_col)
            fams.append(fam)
    n = len(x)
    frequency = np.column_stack(cols_f) if cols_f else np.empty((n, 0))
    k = np.column_stack(cols_k) if cols_k else np.empty((n, 0), dtype=complex)
    point_label = np.column_stack(plabs) if plabs else np.empty((n, 0), dtype=object)
    mac_ = np.column_stack(macs) if macs else np.empty((n, 0))
    # order: by family, then by where the branch starts (low frequency / small k first)
    start = np.array([np.nanmin(c) if np.isfinite(c).any() else np.inf for c in cols_f])
    order = np.lexsort((start, np.array([FAMILIES.index(f) if f in FAMILIES else 99
                                         for f in fams])))
    label = branch_labels(point_label[:, order], position, window)
    return Branches(sweep=sweep, frequency=frequency[:, order], k=k[:, order],
                    family=np.array(fams, dtype=object)[order], label=label,
                    name=branch_names(label, start[order]),
                    point_label=point_label[:, order], mac=mac_[:, order])


# ------------------------------------------------------------------------ on a waveguide
def k_of_omega(guide: Waveguide, frequency, *, families=None, method: str = "shift-invert",
               n_waves: int = 40, max_attenuation: float = MAX_ATTENUATION,
               min_mac: float = MIN_MAC,
               progress=None) -> Branches:
    """Propagating waves at each frequency (Hz), followed into branches by shape continuity.

    Solves the waves of each family with :func:`railfem.rail.waves.waves_at` (as
    :func:`railfem.rail.waves.solve` does) and keeps the propagating ones
    (|Im k| <= ``max_attenuation`` |Re k|). The frequencies must be increasing; the finer
    the grid, the surer the pairing at crossings (50 log-spaced points per decade keep the
    MAC of neighbours on one branch above 0.9 on 60E1).
    """
    f = np.atleast_1d(np.asarray(frequency, dtype=float))
    if f.ndim != 1 or f.size == 0 or np.any(~np.isfinite(f)) or np.any(f <= 0):
        raise ValueError(f"frequency must be a 1-D array of positive finite Hz, got {f[:5]}")
    if np.any(np.diff(f) <= 0):
        raise ValueError("frequency must be strictly increasing to follow branches; "
                         "sort it and drop duplicates")
    families = tuple(guide.families) if families is None else families
    ops = {fam: waves.FamilyOperators(guide, fam) for fam in families}
    data = {fam: ([], [], [], []) for fam in families}  # k, freq, labels, shapes per point
    for i, fi in enumerate(f):
        for fam, op in ops.items():
            w = waves.waves_at(op, 2 * np.pi * fi, method=method, n_waves=n_waves)
            keep = propagating_mask(w.k, max_attenuation)
            phi = w.phi[:, keep]
            ks, fs, ls, ss = data[fam]
            ks.append(w.k[keep])
            fs.append(np.full(keep.sum(), fi))
            ss.append(phi)
            ls.append(label_shapes(guide, op, phi) if phi.shape[1] else [])
        if progress:
            progress(i + 1, len(f))
    per_family = {}
    for fam, (ks, fs, ls, ss) in data.items():
        weight = _mass_metric(guide, fam)
        per_family[fam] = (track(ss, weight=weight, min_mac=min_mac), ks, fs, ls, ss, weight)
    return _assemble("frequency", f, per_family, np.log(f), REFERENCE_OCTAVES * np.log(2))


def omega_of_k(guide: Waveguide, k, *, n_modes: int = 10, families=None,
               min_mac: float = MIN_MAC,
               progress=None) -> Branches:
    """The ``n_modes`` lowest undamped modes of each family at each real k (rad/m, >= 0,
    increasing), followed into branches by shape continuity.

    The modes are those of :func:`railfem.rail.waves.omega_of_k` (real symmetric K(k), M), kept
    with their shapes. At k = 0 the rigid motions of a family share the frequency 0 and
    their computed shapes are arbitrary mixtures: start the sweep at a small k > 0 (e.g.
    0.1 rad/m) to name those branches reliably.
    """
    k = np.atleast_1d(np.asarray(k, dtype=float))
    if k.ndim != 1 or k.size == 0 or np.any(~np.isfinite(k)) or np.any(k < 0):
        raise ValueError(f"k must be a 1-D array of finite wavenumbers >= 0 rad/m, got {k[:5]}")
    if np.any(np.diff(k) <= 0):
        raise ValueError("k must be strictly increasing to follow branches; sort it and "
                         "drop duplicates")
    families = tuple(guide.families) if families is None else families
    data = {fam: ([], [], [], []) for fam in families}
    for i, kk in enumerate(k):
        for fam in families:
            K, M, ops = waves.real_k_mode_matrices(guide, fam, kk)
            w2, vec = spl.eigsh(K, k=n_modes, M=M, sigma=-(2 * np.pi * 100.0) ** 2,
                                which="LM")
            o = np.argsort(w2)
            phi = vec[:, o].astype(complex)
            phi[: ops.na] *= 1j  # undo the i-scaling of the axial DOFs
            phi = ops.to_reduced(phi)
            ks, fs, ls, ss = data[fam]
            ks.append(np.full(n_modes, kk + 0j))
            fs.append(np.sqrt(np.clip(w2[o], 0, None)) / (2 * np.pi))
            ls.append(label_shapes(guide, ops, phi))
            ss.append(phi)
        if progress:
            progress(i + 1, len(k))
    per_family = {}
    for fam, (ks, fs, ls, ss) in data.items():
        weight = _mass_metric(guide, fam)
        per_family[fam] = (track(ss, weight=weight, min_mac=min_mac), ks, fs, ls, ss, weight)
    return _assemble("wavenumber", k, per_family, k,
                     REFERENCE_K_SHARE * max(np.ptp(k), np.finfo(float).tiny))


# ------------------------------------------------------------------------------ cut-ons
@dataclass(frozen=True, kw_only=True)
class CutOn:
    """A cross-section wave of the free rail that starts to propagate at ``frequency`` (Hz).

    family: symmetry family; label: its wave type (railfem.rail.labels, from the k = 0 shape);
    axial: True when the k = 0 shape moves only along the rail (at k = 0 the axial and the
    in-plane motions of the section are uncoupled, so every cut-on shape is one or the other).
    """

    frequency: float
    family: str
    label: str
    axial: bool = False

    @property
    def name(self) -> str:
        """The wave type in words, '(axial)' added for an axial cut-on shape."""
        words = type_in_words(self.label)
        return f"{words} (axial)" if self.axial else words


def cut_ons(guide: Waveguide, f_low: float = 0.0, f_high: float = np.inf, *,
            families=None, n_per_family: int = 12) -> list[CutOn]:
    """The free-rail cut-on frequencies between ``f_low`` and ``f_high`` (Hz), named.

    A cut-on frequency is a non-zero natural frequency of the section at k = 0 (the values
    of :func:`railfem.rail.waves.cut_on_frequencies`); the wave type comes from the labeller
    applied to the k = 0 shape. Sorted by frequency.

    Why they show in track decay rates: just above its cut-on a wave's group velocity is
    near zero, so its spatial decay (about eta omega / (2 c_g) nepers per metre for loss
    factor eta) is very large. It adds to the response at and near the hammer but not far
    from it, so the EN 15461 sum of far-to-point response ratios falls and the decay rate
    rises over a band or two: the 13-15 dB/m spike of the WFE track models at the
    foot-flapping cut-on (about 5.1 kHz on 60E1) is this real effect of the model, not
    noise. Supports stiffen the foot, so on a track the foot-flapping cut-on and its spike
    move somewhat above the free-rail value returned here.
    """
    if not (np.isfinite(f_low) and f_low >= 0 and f_high > f_low):
        raise ValueError(f"need 0 <= f_low < f_high (Hz), got {f_low}, {f_high}")
    out = []
    for fam in (guide.families if families is None else families):
        K, M, ops = waves.real_k_mode_matrices(guide, fam, 0.0)
        n = min(n_per_family + 4, K.shape[0] - 2)
        w2, vec = spl.eigsh(K, k=n, M=M, sigma=-(2 * np.pi * 100.0) ** 2, which="LM")
        f = np.sqrt(np.clip(w2, 0, None)) / (2 * np.pi)
        keep = (f > 1.0) & (f >= f_low) & (f <= f_high)  # rigid motions sit at 0 Hz
        if not keep.any():
            continue
        phi = vec[:, keep].astype(complex)
        axial = np.einsum("ij,ij->j", phi[: ops.na].conj(), M[: ops.na, : ops.na] @ phi[: ops.na])
        axial = np.real(axial) > 0.5 * np.real(np.einsum("ij,ij->j", phi.conj(), M @ phi))
        phi[: ops.na] *= 1j
        labels = label_shapes(guide, ops, ops.to_reduced(phi))
        out += [CutOn(frequency=float(fi), family=fam, label=str(lab), axial=bool(ax))
                for fi, lab, ax in zip(f[keep], labels, axial)]
    return sorted(out, key=lambda c: c.frequency)
