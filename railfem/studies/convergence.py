"""Mesh-convergence study of the free-rail waveguide.

For a list of element sizes the section is meshed, the waveguide assembled, and two kinds
of result are recorded:

* the cut-on frequencies of the cross-section modes (the non-zero eigenfrequencies at
  k = 0, :func:`railfem.rail.waves.cut_on_frequencies`), tracked per symmetry family and rank so
  that two close modes of different families cannot swap between meshes;
* the wavenumbers of the propagating waves at chosen frequencies, per family, ranked by
  decreasing Re k (a wave that cuts on near the chosen frequency on one mesh only then
  appears last and leaves the others in place).

Each quantity's error on each mesh is measured against a reference: the Richardson
extrapolation h -> 0 of the three finest meshes (``reference="richardson"``, the default;
it falls back to the finest mesh when the three values do not converge monotonically) or the
finest mesh itself (``reference="finest"``). The observed rate is the least-squares slope of
log(error) against log(h) over the meshes (all of them for Richardson, all but the finest
for "finest"). P2 elements give eigenvalue (and so frequency) errors of order h^4 when the
geometry is exact (a polygon) or curved isoparametric (the default meshes); straight-sided
6-node elements on a curved outline are limited by the geometry to about h^2
(``curved=False`` keeps them for this comparison).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq

from ..rail import meshing
from ..rail import waveguide
from ..rail import waves
from ..materials import Material
from ..rail.profiles import RailProfile, get_profile

log = logging.getLogger(__name__)

#: Propagating wave: |Im k| <= PROPAGATING_TOL |k| (the study uses an undamped rail).
PROPAGATING_TOL = 1e-6


@dataclass(frozen=True, kw_only=True)
class ConvergenceStudy:
    """Results of :func:`convergence_study`; arrays have the mesh sizes along axis 0.

    profile: profile name. curved: curved 6-node elements (else straight-sided).
    sizes: (ns,) element sizes h in m, as given.
    n_dofs: (ns,) total DOFs; n_dofs_family: dict family -> (ns,) reduced DOFs.
    cut_on: (ns, nc) cut-on frequencies in Hz of the nc lowest cross-section modes of the
    finest mesh; cut_on_family: (nc,) their family; cut_on_rank: (nc,) rank within it.
    frequencies: (nf,) Hz. wavenumbers: (ns, nf, nw) Re k (rad/m) of the propagating waves,
    NaN-padded; wave_family, wave_label: (nf, nw) family and wave type (finest mesh).
    reference: "richardson" or "finest", per quantity kind actually used.
    cut_on_reference: (nc,) reference values; cut_on_error: (ns, nc) relative errors;
    cut_on_rate: (nc,) observed orders (least-squares slope over all meshes);
    cut_on_order: (nc,) Richardson order of the three finest meshes (NaN without one);
    likewise wavenumber_reference / _error / _rate
    with shapes (nf, nw), (ns, nf, nw), (nf, nw).
    """

    profile: str
    curved: bool
    sizes: np.ndarray
    n_dofs: np.ndarray
    n_dofs_family: dict
    cut_on: np.ndarray
    cut_on_family: np.ndarray
    cut_on_rank: np.ndarray
    frequencies: np.ndarray
    wavenumbers: np.ndarray
    wave_family: np.ndarray
    wave_label: np.ndarray
    cut_on_reference: np.ndarray
    cut_on_error: np.ndarray
    cut_on_rate: np.ndarray
    cut_on_order: np.ndarray
    wavenumber_reference: np.ndarray
    wavenumber_error: np.ndarray
    wavenumber_rate: np.ndarray
    reference: dict = field(default_factory=dict)


# ----------------------------------------------------------------------- estimators
def richardson(h, values) -> tuple[float, float]:
    """(extrapolated value at h = 0, order p) from three sizes h (any ratios) and values.

    Fits v(h) = v0 + C h^p exactly through the three points. Raises ValueError when the
    differences do not have one sign (no monotone convergence: the extrapolation is
    meaningless).
    """
    h = np.asarray(h, dtype=float)
    v = np.asarray(values, dtype=float)
    if h.shape != (3,) or v.shape != (3,):
        raise ValueError("richardson needs exactly three sizes and three values")
    o = np.argsort(h)[::-1]  # coarse to fine
    (h1, h2, h3), (v1, v2, v3) = h[o], v[o]
    if not (h1 > h2 > h3 > 0):
        raise ValueError(f"richardson needs three distinct positive sizes, got {h}")
    d1, d2 = v1 - v2, v2 - v3
    if d1 == 0 or d2 == 0 or np.sign(d1) != np.sign(d2) or abs(d2) >= abs(d1):
        raise ValueError("values do not converge monotonically; no Richardson estimate")
    ratio = d1 / d2

    def g(p):
        return (h1**p - h2**p) / (h2**p - h3**p) - ratio

    lo, hi = 1e-3, 30.0
    if g(lo) * g(hi) > 0:
        raise ValueError("no Richardson order in (0, 30) fits the three values")
    p = brentq(g, lo, hi, xtol=1e-12)
    v0 = v3 - d2 * h3**p / (h2**p - h3**p)
    return float(v0), float(p)


def observed_rate(h, errors) -> float:
    """Least-squares slope of log|error| against log h over the positive finite errors."""
    h = np.asarray(h, dtype=float)
    e = np.abs(np.asarray(errors, dtype=float))
    ok = np.isfinite(h) & np.isfinite(e) & (h > 0) & (e > 0)
    if np.count_nonzero(ok) < 2 or np.ptp(h[ok]) == 0:
        return float("nan")
    return float(np.polyfit(np.log(h[ok]), np.log(e[ok]), 1)[0])


def _errors_and_rates(h, values, reference: str):
    """values (ns, ...) -> reference (...), relative errors (ns, ...), rates (...), method."""
    ns = len(h)
    flat = values.reshape(ns, -1)
    ref = np.full(flat.shape[1], np.nan)
    order = np.full(flat.shape[1], np.nan)
    err = np.full(flat.shape, np.nan)
    rate = np.full(flat.shape[1], np.nan)
    finest = int(np.argmin(h))
    methods = set()
    fine3 = np.argsort(h)[:3]
    for j in range(flat.shape[1]):
        col = flat[:, j]
        if not np.all(np.isfinite(col)):
            continue
        used = "finest"
        if reference == "richardson" and ns >= 3:
            try:
                ref[j], order[j] = richardson(h[fine3], col[fine3])
                used = "richardson"
            except ValueError:
                log.info("quantity %d: no monotone convergence, reference = finest mesh", j)
        if used == "finest":
            ref[j] = col[finest]
        err[:, j] = col / ref[j] - 1.0
        keep = np.ones(ns, bool)
        if used == "finest":
            keep[finest] = False
        rate[j] = observed_rate(h[keep], err[keep, j])
        methods.add(used)
    shape = values.shape[1:]
    return (ref.reshape(shape), err.reshape(values.shape), rate.reshape(shape),
            order.reshape(shape), "+".join(sorted(methods)) or "none")


# ---------------------------------------------------------------------------- study
def _propagating(guide, ops_list, frequency_hz, n_waves):
    from ..rail.labels import label_waves

    out = []  # (family, Re k, label) sorted: family order, decreasing Re k
    for ops in ops_list:
        w = waves.waves_at(ops, 2 * np.pi * frequency_hz, method="shift-invert",
                           n_waves=n_waves)
        prop = np.abs(w.k.imag) <= PROPAGATING_TOL * np.abs(w.k)
        labs = np.array(label_waves(guide, ops, w), dtype=object)
        kr, lab = w.k.real[prop], labs[prop]
        o = np.argsort(-kr)
        out += [(ops.family, float(kk), str(ll)) for kk, ll in zip(kr[o], lab[o])]
    return out


def convergence_study(profile: RailProfile | str, sizes, *, frequencies=(), n_cut_on: int = 6,
                      progress=None, reference: str = "richardson",
                      material: Material | None = None, n_waves: int = 40,
                      use_shipped: bool = False, curved: bool = True) -> ConvergenceStudy:
    """Mesh-convergence study over element sizes (m).

    profile: a RailProfile or a name for :func:`railfem.rail.profiles.get_profile`.
    sizes: element sizes h in m (at least two; three for Richardson).
    frequencies: Hz at which the propagating wavenumbers are compared.
    n_cut_on: number of cross-section cut-on frequencies to track.
    progress: optional callable(done, total) called after each mesh.
    reference: "richardson" (default) or "finest".
    material: defaults to undamped steel (a loss factor would make every wave complex).
    use_shipped: take the shipped mesh when there is one for (profile, h); by default every
    mesh is generated afresh so the study does not depend on the files in railfem/data/meshes/.
    curved: curved 6-node elements (default) or the straight-sided twins of the same
    triangulations (mid-side nodes at the chord midpoints).
    """
    prof = get_profile(profile) if isinstance(profile, str) else profile
    h = np.asarray(sizes, dtype=float).ravel()
    if h.size < 2 or not np.all(np.isfinite(h)) or np.any(h <= 0):
        raise ValueError(f"convergence_study needs at least two element sizes > 0 (m), got {h}")
    if len(np.unique(h)) != h.size:
        raise ValueError(f"element sizes must be distinct, got {h}")
    if reference not in ("richardson", "finest"):
        raise ValueError(f"reference must be 'richardson' or 'finest', got {reference!r}")
    if not (isinstance(n_cut_on, (int, np.integer)) and n_cut_on >= 1):
        raise ValueError(f"n_cut_on must be an integer >= 1, got {n_cut_on!r}")
    f = np.atleast_1d(np.asarray(frequencies, dtype=float)).ravel()
    if np.any(~np.isfinite(f)) or np.any(f <= 0):
        raise ValueError(f"frequencies must be positive and finite (Hz), got {f}")
    material = material or Material.steel()
    if material.loss_factor != 0:
        raise ValueError("convergence_study needs an undamped material (loss_factor = 0) to "
                         "tell propagating waves from attenuated ones")

    ns = h.size
    n_dofs = np.zeros(ns, dtype=np.int64)
    n_fam, cut = {}, {}
    per_size_waves = []
    for i, hi in enumerate(h):
        mesh = (meshing.get_mesh(prof, hi, curved=curved) if use_shipped
                else meshing.mesh_profile(prof, hi, curved=curved))
        guide = waveguide.assemble(mesh, material)
        n_dofs[i] = guide.n_dofs
        for fam in guide.families:
            n_fam.setdefault(fam, np.zeros(ns, dtype=np.int64))[i] = \
                guide.families[fam].T.shape[1]
            c = waves.cut_on_frequencies(guide, n_cut_on, family=fam)
            cut.setdefault(fam, np.full((ns, n_cut_on), np.nan))[i, : len(c)] = c
        ops = [waves.FamilyOperators(guide, fam) for fam in guide.families] if f.size else []
        per_size_waves.append([_propagating(guide, ops, fi, n_waves) for fi in f])
        log.info("convergence %s: h = %.4g mm, %d DOFs done (%d/%d)", prof.name, hi * 1e3,
                 guide.n_dofs, i + 1, ns)
        if progress:
            progress(i + 1, ns)

    # cut-on: the n_cut_on lowest of the finest mesh, each tracked by (family, rank)
    finest = int(np.argmin(h))
    cand = [(cut[fam][finest, r], fam, r) for fam in cut
            for r in range(n_cut_on) if np.isfinite(cut[fam][finest, r])]
    cand.sort()
    cand = cand[:n_cut_on]
    cut_on = np.column_stack([cut[fam][:, r] for _, fam, r in cand]) if cand else \
        np.zeros((ns, 0))
    cut_fam = np.array([fam for _, fam, _ in cand], dtype=object)
    cut_rank = np.array([r for _, _, r in cand], dtype=np.int64)

    # wavenumbers: (ns, nf, nw), column j = j-th wave of the finest mesh's list
    nf = f.size
    nw = max([len(per_size_waves[finest][q]) for q in range(nf)] + [0])
    kk = np.full((ns, nf, nw), np.nan)
    wfam = np.full((nf, nw), "", dtype=object)
    wlab = np.full((nf, nw), "", dtype=object)
    for q in range(nf):
        ref_list = per_size_waves[finest][q]
        for j, (fam, _, lab) in enumerate(ref_list):
            wfam[q, j], wlab[q, j] = fam, lab
            rank = sum(1 for fam2, _, _ in ref_list[:j] if fam2 == fam)
            for i in range(ns):
                mine = [k for fam2, k, _ in per_size_waves[i][q] if fam2 == fam]
                if rank < len(mine):
                    kk[i, q, j] = mine[rank]

    c_ref, c_err, c_rate, c_order, c_used = _errors_and_rates(h, cut_on, reference)
    k_ref, k_err, k_rate, _, k_used = _errors_and_rates(h, kk, reference)
    return ConvergenceStudy(
        profile=prof.name, curved=curved, sizes=h, n_dofs=n_dofs, n_dofs_family=n_fam,
        cut_on=cut_on,
        cut_on_family=cut_fam, cut_on_rank=cut_rank, frequencies=f, wavenumbers=kk,
        wave_family=wfam, wave_label=wlab, cut_on_reference=c_ref, cut_on_error=c_err,
        cut_on_rate=c_rate, cut_on_order=c_order, wavenumber_reference=k_ref,
        wavenumber_error=k_err,
        wavenumber_rate=k_rate, reference={"cut_on": c_used, "wavenumbers": k_used})


__all__ = ["ConvergenceStudy", "convergence_study", "observed_rate", "richardson"]
