"""Free waves of the waveguide: omega(k) for real k and k(omega) at given frequencies.

k(omega) solves A(k, omega) phi = 0 with A = k^2 K2 + i k K1 + K0 - omega^2 M per symmetry
family. For isotropic material K1 couples only axial (a) with in-plane (p) DOFs, so the
substitution u_a = i k w turns the quadratic problem into a linear one in lambda = k^2 of
size N (instead of the 2N linearisation)::

    [Z_aa  c K1_ap] [w  ]          [c K2_aa     0    ] [w  ]
    [0     Z_pp   ] [u_p]  + k^2   [-c K1_pa  c K2_pp] [u_p]  = 0,   Z = c K0 - omega^2 M

with c = 1 + i eta. Each lambda gives the pair +-k; the positive-going root (Im k < 0, or with
no damping the one with positive group velocity) is kept. The left eigenvector of k_n is
psi_n = T_a phi_n (T_a flips the sign of the axial DOFs), see METHOD.md section 1.

Two strategies: ``"dense"`` returns all N waves (LAPACK eig of B^-1 A); ``"shift-invert"``
returns the ``n_waves`` waves of smallest |k| by ARPACK on the sparse factorisation of the
left-hand matrix - near-field waves with large |Im k| decay within millimetres and are
filtered out by any load spread over a patch.
"""
from __future__ import annotations

import logging
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sl
import scipy.sparse as sp
import scipy.sparse.linalg as spl

from .waveguide import Waveguide, reduced

log = logging.getLogger(__name__)


@dataclass(frozen=True, kw_only=True)
class Waves:
    """Positive-going waves of one symmetry family at one angular frequency.

    omega: rad/s. k: (nw,) complex wavenumbers (rad/m), Im k <= 0, sorted by |k|.
    phi: (n_r, nw) right mode shapes in the family's reduced DOFs (full: T @ phi).
    denom: (nw,) psi^T A'(k) phi with psi = T_a phi.
    """

    family: str
    omega: float
    k: np.ndarray
    phi: np.ndarray
    denom: np.ndarray


class FamilyOperators:
    """Reduced, loss-scaled matrices of one family, built once and reused per frequency."""

    def __init__(self, guide: Waveguide, family: str):
        self.family = family
        self.T = guide.families[family].T
        comp = guide.families[family].component
        self.a = np.nonzero(comp == 0)[0]
        self.p = np.nonzero(comp != 0)[0]
        self.order = np.concatenate([self.a, self.p])
        self.na = len(self.a)
        c = 1 + 1j * guide.loss_factor
        K0, K1, K2, M = (X[self.order][:, self.order] for X in reduced(guide, family))
        self.c, self.K0, self.K1, self.K2, self.M = c, K0, K1, K2, M
        sign = np.ones(len(self.order))
        sign[: self.na] = -1.0
        self.flip = sign  # T_a in the (a, p) ordering
        self.B = self._lambda_matrix().tocsc()
        self.extra = None  # optional omega -> sparse stiffness (ordered DOFs), e.g. a foundation

    def _lambda_matrix(self):
        na = self.na
        K2, K1 = self.K2.tolil(), self.K1
        B = sp.lil_matrix(K2.shape, dtype=complex)
        B[:na, :na] = K2[:na, :na]
        B[na:, na:] = K2[na:, na:]
        B[na:, :na] = -K1[na:, :na]
        return self.c * B.tocsr()

    def constant_matrix(self, omega: float):
        na = self.na
        Z = (self.c * self.K0 - omega**2 * self.M).tolil()
        Z[:na, na:] = self.c * self.K1[:na, na:]
        Z = Z.tocsc()
        return Z if self.extra is None else (Z + self.extra(omega)).tocsc()

    def dA(self, k: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """psi_n^T A'(k_n) phi_n for every column, A' = c (2 k K2 + i K1)."""
        K2phi, K1phi = self.K2 @ phi, self.K1 @ phi
        Ap = self.c * (2 * k * K2phi + 1j * K1phi)
        return np.einsum("ij,ij->j", self.flip[:, None] * phi, Ap)

    def group_velocity(self, omega: float, k: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """Undamped group velocity d omega / d k by Hellmann-Feynman (real k)."""
        num = np.einsum("ij,ij->j", phi.conj(), (2 * k * (self.K2 @ phi) + 1j * (self.K1 @ phi)))
        den = 2 * omega * np.einsum("ij,ij->j", phi.conj(), self.M @ phi)
        return (num / den).real

    def to_reduced(self, phi_ordered: np.ndarray) -> np.ndarray:
        out = np.empty_like(phi_ordered)
        out[self.order] = phi_ordered
        return out


def _lambdas_dense(ops: FamilyOperators, omega: float):
    """All N pairs (lambda = k^2, vector) of A x + lambda B x = 0, from the eigenvalues
    nu = 1/lambda of -A^-1 B: eig is accurate relative to the largest eigenvalue, which in this
    inverted form belongs to the waves of smallest |k| that carry the far field (in the form
    -B^-1 A the small k^2 of the bending and longitudinal waves lose accuracy at low
    frequency: 0.3 % error in the receptance at 30 Hz on 60E1 h = 20 mm, see
    tests/test_mobility.py). A singular A (no damping, exactly at a cut-on) uses -B^-1 A."""
    A = ops.constant_matrix(omega).toarray()
    B = ops.B.toarray()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sl.LinAlgWarning)
        lu, piv = sl.lu_factor(A, check_finite=False)
    if np.all(np.diag(lu) != 0):
        nu, x = sl.eig(sl.lu_solve((lu, piv), -B, check_finite=False), check_finite=False,
                       overwrite_a=True)
        if np.all(np.isfinite(nu)) and np.all(nu != 0):  # B is regular: K2 > 0
            return 1.0 / nu, x
    C = sl.solve(-B, A, check_finite=False)
    return sl.eig(C, check_finite=False, overwrite_a=True)


def _lambdas_shift_invert(ops: FamilyOperators, omega: float, n: int):
    n = min(n, ops.B.shape[0] - 2)
    lu = spl.splu(ops.constant_matrix(omega))
    op = spl.LinearOperator(ops.B.shape, dtype=complex, matvec=lambda x: lu.solve(-(ops.B @ x)))
    nu, vec = spl.eigs(op, k=n, which="LM", tol=1e-10)
    return 1.0 / nu, vec


def waves_at(ops: FamilyOperators, omega: float, *, method: str = "dense",
             n_waves: int = 60) -> Waves:
    """Positive-going waves of one family at angular frequency omega (rad/s)."""
    if method == "dense":
        lam, x = _lambdas_dense(ops, omega)
    elif method == "shift-invert":
        try:
            lam, x = _lambdas_shift_invert(ops, omega, n_waves)
        except (spl.ArpackNoConvergence, RuntimeError) as exc:
            log.warning("shift-invert wave solve failed at %.1f Hz (%s); using dense",
                        omega / (2 * np.pi), exc)
            lam, x = _lambdas_dense(ops, omega)
    else:
        raise ValueError(f"wave solver method must be 'dense' or 'shift-invert', got {method!r}")
    k = np.sqrt(lam.astype(complex))
    k = np.where(k.imag > 0, -k, k)
    x = x.astype(complex)
    x[: ops.na] *= 1j * k  # back-substitute u_a = i k w
    undamped = np.abs(k.imag) <= 1e-6 * np.abs(k)  # eig round-off is ~1e-8
    if undamped.any():
        kr = k[undamped].real
        cg = ops.group_velocity(omega, kr, x[:, undamped])
        k[undamped] = np.where(cg >= 0, kr, -kr)
        x[: ops.na, undamped] *= np.where(cg >= 0, 1.0, -1.0)  # u_a = i k w with k -> -k
    idx = np.argsort(np.abs(k))
    k, x = k[idx], x[:, idx]
    x /= np.linalg.norm(x, axis=0)
    return Waves(family=ops.family, omega=omega, k=k, phi=ops.to_reduced(x),
                 denom=_denominators(ops, k, x))


def _denominators(ops, k, x_ordered):
    return ops.dA(k, x_ordered)


def frozen_tail(ops: FamilyOperators, omega0: float, n_waves: int) -> Waves:
    """The waves beyond the ``n_waves`` smallest |k| at omega0, from the full (dense) set.

    They are near-field waves with |Im k| of hundreds of rad/m whose wavenumbers and shapes
    hardly change with frequency (their decay length is far below a bending wavelength), so
    computed once they stand for the waves a shift-invert solve drops at every other
    frequency: a quasi-static correction of point and near-point responses.
    """
    w = waves_at(ops, omega0, method="dense")
    keep = slice(n_waves, None)
    return Waves(family=w.family, omega=omega0, k=w.k[keep], phi=w.phi[:, keep],
                 denom=w.denom[keep])


def join(*waves: Waves) -> Waves:
    """One wave set from several of the same family (e.g. retained waves + frozen tail)."""
    return Waves(family=waves[0].family, omega=waves[0].omega,
                 k=np.concatenate([w.k for w in waves]),
                 phi=np.concatenate([w.phi for w in waves], axis=1),
                 denom=np.concatenate([w.denom for w in waves]))


@dataclass(frozen=True, kw_only=True)
class Dispersion:
    """k(omega) for a set of frequencies. frequency: (nf,) Hz; k: (nf, nw) complex rad/m,
    padded with NaN; family: (nf, nw) str; label: (nf, nw) wave-type labels."""

    frequency: np.ndarray
    k: np.ndarray
    family: np.ndarray
    label: np.ndarray


def solve(guide: Waveguide, frequency, *, families=None, method: str = "shift-invert",
          n_waves: int = 40, progress=None) -> Dispersion:
    """k(omega) of the requested families (default: all of the guide's) at each frequency
    (Hz), with wave-type labels."""
    from .labels import label_waves

    f = np.atleast_1d(np.asarray(frequency, dtype=float))
    if np.any(~np.isfinite(f)) or np.any(f <= 0):
        raise ValueError(f"frequencies must be positive and finite (Hz), got {f[~(f > 0)][:3]}")
    ops = [FamilyOperators(guide, fam) for fam in (families or guide.families)]
    rows = []
    for i, fi in enumerate(f):
        ks, fams, labs = [], [], []
        for op in ops:
            w = waves_at(op, 2 * np.pi * fi, method=method, n_waves=n_waves)
            ks.append(w.k)
            fams += [op.family] * len(w.k)
            labs += label_waves(guide, op, w)
        rows.append((np.concatenate(ks), np.array(fams), np.array(labs, dtype=object)))
        if progress:
            progress(i + 1, len(f))
    nw = max(len(r[0]) for r in rows)
    k = np.full((len(f), nw), np.nan + 0j)
    fam = np.full((len(f), nw), "", dtype=object)
    lab = np.full((len(f), nw), "", dtype=object)
    for i, (kk, ff, ll) in enumerate(rows):
        o = np.argsort(np.abs(kk))
        k[i, : len(kk)], fam[i, : len(kk)], lab[i, : len(kk)] = kk[o], ff[o], ll[o]
    return Dispersion(frequency=f, k=k, family=fam, label=lab)


def real_k_mode_matrices(guide: Waveguide, family: str, k: float):
    """Undamped real symmetric K(k) = k^2 K2 + k K1s + K0 and M for real k, from scaling
    the axial DOFs by i (METHOD.md section 1)."""
    ops = FamilyOperators(guide, family)
    na = ops.na
    K1s = ops.K1.tolil()
    K1s[na:, :na] = -K1s[na:, :na]
    K = (k * k * ops.K2 + k * K1s.tocsr() + ops.K0).tocsc()
    return K, ops.M.tocsc(), ops


def omega_of_k(guide: Waveguide, k, *, n_modes: int = 10, families=None):
    """Undamped natural frequencies (Hz) of each family at each real wavenumber k (rad/m).

    Returns a dict family -> (nk, n_modes) array, ascending, and the (nk, n_modes) labels.
    """
    from .labels import label_shapes

    k = np.atleast_1d(np.asarray(k, dtype=float))
    out = {}
    for fam in families or guide.families:
        freqs = np.empty((len(k), n_modes))
        labels = np.empty((len(k), n_modes), dtype=object)
        for i, kk in enumerate(k):
            K, M, ops = real_k_mode_matrices(guide, fam, kk)
            w2, vec = spl.eigsh(K, k=n_modes, M=M, sigma=-(2 * np.pi * 100.0) ** 2, which="LM")
            o = np.argsort(w2)
            freqs[i] = np.sqrt(np.clip(w2[o], 0, None)) / (2 * np.pi)
            phi = vec[:, o].astype(complex)
            phi[: ops.na] *= 1j  # undo the i-scaling of axial DOFs
            labels[i] = label_shapes(guide, ops, ops.to_reduced(phi))
        out[fam] = (freqs, labels)
    return out


def cut_on_frequencies(guide: Waveguide, n: int = 6, family: str | None = None) -> np.ndarray:
    """Cut-on frequencies (Hz) of cross-section modes: the non-zero eigenfrequencies at k = 0.

    At k = 0 the problem is K0 phi = omega^2 M phi (in-plane and axial DOFs uncoupled);
    the zero-frequency rigid motions (translations, rotation) are dropped. Families: all of
    the guide's, or the one named.
    """
    fams = tuple(guide.families) if family is None else (family,)
    vals = []
    for fam in fams:
        K, _, _, M = (X.tocsc() for X in reduced(guide, fam))
        w2 = spl.eigsh(K, k=n + 4, M=M, sigma=-(2 * np.pi * 100.0) ** 2, which="LM",
                       return_eigenvectors=False)
        f = np.sqrt(np.clip(np.sort(w2), 0, None)) / (2 * np.pi)
        vals.append(f[f > 1.0])  # rigid motions sit at 0 Hz up to round-off
    return np.sort(np.concatenate(vals))[:n]
