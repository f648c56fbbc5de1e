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

Two strategies: ``"dense"`` returns all N waves (LAPACK eig of A^-1 B); ``"shift-invert"``
returns the ``n_waves`` waves of smallest |k| by ARPACK on the sparse factorisation of the
left-hand matrix divided by c (block upper triangular: one LU of each diagonal block, see
railfem.rail.sparseblocks; the right-hand matrix B0 stays real for any loss factor) -
near-field waves with large |Im k| decay within millimetres and are filtered out by any load
spread over a patch. An undamped rail (eta = 0) is solved in real
arithmetic. ``frozen_tail`` supplies the dropped near-field waves once per sweep.

Solver calls run with BLAS limited to RAILFEM_BLAS_THREADS threads (default 1, see
``blas_threads``). Wave sets are cached in memory per (operators' content, omega, method,
n_waves), bounded by RAILFEM_WAVE_CACHE_MB (default 512 MB; 0 disables it;
railfem.rail.wavecache), so that
repeated calls (a fitter changing support parameters) do not re-solve; ``clear_cache``
empties it.
"""
from __future__ import annotations

import hashlib
import logging
import warnings
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sl
import scipy.sparse as sp
import scipy.sparse.linalg as spl

from .sparseblocks import (BlockShiftInvert, block_solver, block_sum, column_norms,
                           diagonal_blocks, on_pattern, ordered_blocks, real_times)
from .wavecache import (CACHE_VARIABLE, THREADS_VARIABLE,  # noqa: F401 (public names)
                        blas_threads, cache_info, cached, clear_cache)
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
    """Reduced, loss-scaled matrices of one family, built once and reused per frequency.

    The frequency-dependent matrix Z(omega) = c K0' - omega^2 M (K0' is K0 with its
    axial/in-plane block replaced by K1's, see the module docstring) is assembled by one
    vector operation on a sparsity pattern fixed here: no sparse-format conversion per
    frequency."""

    def __init__(self, guide: Waveguide, family: str):
        self.family = family
        self.T = guide.families[family].T
        comp = guide.families[family].component
        self.a = np.nonzero(comp == 0)[0]
        self.p = np.nonzero(comp != 0)[0]
        self.order = np.concatenate([self.a, self.p])
        self.reduced_rows = np.argsort(self.order)  # ordered -> reduced DOFs
        self.na = len(self.a)
        c = 1 + 1j * guide.loss_factor
        K0, K1, K2, M = (X[self.order][:, self.order] for X in reduced(guide, family))
        self.c, self.K0, self.K1, self.K2, self.M = c, K0, K1, K2, M
        sign = np.ones(len(self.order))
        sign[: self.na] = -1.0
        self.flip = sign  # T_a in the (a, p) ordering
        self.B0 = block_sum(self.na, (K2, "aa"), (K2, "pp"), (-K1, "pa"))  # real
        self.B = (c * self.B0).tocsc()
        k0 = block_sum(self.na, (K0, "aa"), (K0, "pp"), (K1, "ap"))
        self.pattern = (abs(k0) + abs(M)).tocsc()  # union sparsity, sorted indices
        self.pattern.sort_indices()
        self.k0_data = on_pattern(self.pattern, k0)
        self.m_data = on_pattern(self.pattern, M)
        self.extra = None  # optional omega -> sparse stiffness (ordered DOFs), e.g. a foundation
        self._key = self._lossless = None
        self.blocks = diagonal_blocks(self.pattern, self.na)
        self.Z_ap = block_sum(self.na, (K1, "ap")).tocsr()[: self.na, self.na:]  # no M in it
        self.B0r = self.B0.tocsr()
        self._B0c = self._ordered = None
        self._B0q, self._perm = {}, None  # shift_invert_operator's -B0 and coordinates

    def constant_matrix(self, omega: float, c: complex | None = None):
        """Z(omega) = c K0' - omega^2 M (+ extra(omega)), CSC; c defaults to 1 + i eta."""
        c = self.c if c is None else c
        if c.imag == 0:
            c = c.real  # real arithmetic for an undamped rail
        P = self.pattern
        Z = sp.csc_matrix((c * self.k0_data - omega**2 * self.m_data, P.indices, P.indptr),
                          shape=P.shape)
        return Z if self.extra is None else (Z + self.extra(omega)).tocsc()

    def factorised(self, omega, c: complex | None = None):
        """solve(r) = Z^-1 r for Z = K0' - (omega^2 / c) M (+ extra(omega) / c): the
        frequency matrix divided by c, so that its pencil partner is the real B0 for any loss
        factor (c B0 / c). Z is block upper triangular in the (axial, in-plane) ordering (M
        has no axial/in-plane coupling, K0' keeps K1's ap block only), so it is solved by one
        LU of each diagonal block and a product with the constant ap block: less fill, and
        faster, than one LU of the whole matrix. A foundation coupling the blocks falls back
        to one LU. r may be one vector or a block of columns; solve.dtype is Z's."""
        c = self.c if c is None else c
        s = omega**2 / c if complex(c).imag else omega**2 / complex(c).real
        data = self.k0_data - s * self.m_data
        if self.extra is None:
            return self._block_solve(data)
        P = self.pattern
        Z = (sp.csc_matrix((data, P.indices, P.indptr), shape=P.shape)
             + self.extra(omega) / (c if complex(c).imag else complex(c).real)).tocsc()
        na = self.na
        if Z[na:, :na].count_nonzero() == 0:
            return block_solver(Z[:na, :na].tocsc(), Z[na:, na:].tocsc(),
                                 Z[:na, na:].tocsr(), na)
        lu = spl.splu(Z.T.tocsc(), permc_spec="MMD_AT_PLUS_A")  # the transposed solve is faster

        def solve(r):
            return lu.solve(np.asarray(r, dtype=np.result_type(Z.dtype, r.dtype)), trans="T")

        solve.dtype = Z.dtype
        return solve

    def _block_solve(self, data):
        """The blockwise solver of the matrix with entries ``data`` on the pattern. The
        blocks' minimum-degree orderings depend on the pattern only: found once by a real
        factorisation of K0' + M (regular), then used for every solve (the blocks'
        transposes, which block_solver factorises, laid out in that order directly), so that
        a result does not depend on what was solved before."""
        def block(positions, P, values=data):
            return sp.csc_matrix((values[positions], P.indices, P.indptr), shape=P.shape)

        if self._ordered is None:
            (iaa, Paa), (ipp, Ppp) = self.blocks
            regular = self.k0_data + self.m_data
            first = block_solver(block(iaa, Paa, regular), block(ipp, Ppp, regular),
                                 self.Z_ap, self.na)
            self._ordered = ordered_blocks(self.blocks, self.Z_ap, first.orders)
            self._perm = np.concatenate([first.orders[0], self.na + first.orders[1]])
        aa, pp, Zap, orders = self._ordered
        return block_solver(block(*aa), block(*pp), Zap, self.na, orders, transposed=True)

    def shift_invert_operator(self, omega, c: complex | None = None):
        """(op, perm): op y = -Z^-1 B0 y in the block coordinates y = x[perm] (axial DOFs
        in the axial block's fill-reducing order, then the in-plane ones in theirs), Z as in
        ``factorised``; (None, None) with an ``extra`` stiffness. A similarity transform of
        -Z^-1 B0 by a permutation: the same eigenvalues, eigenvectors permuted."""
        if self.extra is not None:
            return None, None
        solve = self.factorised(omega, c)
        dtype, p = np.dtype(solve.dtype), self._perm
        if dtype not in self._B0q:  # -B0 in block coordinates, entries of the solve's dtype
            self._B0q[dtype] = (-self.B0r[p][:, p]).astype(dtype).tocsr()
        return BlockShiftInvert(solve, self._B0q[dtype], self.na), p

    def B0_as(self, dtype):
        """B0 (CSR) with entries of dtype: complex for products with complex vectors (a real
        sparse matrix times a complex vector converts the matrix on every product)."""
        if not np.issubdtype(dtype, np.complexfloating):
            return self.B0r
        if self._B0c is None:
            self._B0c = self.B0r.astype(complex)
        return self._B0c

    @property
    def key(self) -> bytes:
        """Digest of everything the waves depend on (matrices, loss factor, DOF order)."""
        if self._key is None:
            h = hashlib.blake2b(digest_size=20)
            h.update(self.lossless_key)
            h.update(np.array([self.c.real, self.c.imag]).tobytes())
            self._key = h.digest()
        return self._key

    @property
    def lossless_key(self) -> bytes:
        """Digest of the matrices and DOF order without the loss factor: what an undamped
        (real-arithmetic) solve depends on, shared by operators of any loss factor."""
        if self._lossless is None:
            h = hashlib.blake2b(digest_size=20)
            h.update(self.family.encode())
            for arr in (self.order, self.T.indices, self.T.indptr, self.T.data,
                        self.pattern.indptr, self.pattern.indices, self.k0_data, self.m_data,
                        self.B0.indptr, self.B0.indices, self.B0.data):
                h.update(np.ascontiguousarray(arr).tobytes())
            self._lossless = h.digest()
        return self._lossless

    def dA(self, k: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """psi_n^T A'(k_n) phi_n for every column, A' = c (2 k K2 + i K1).

        With u_a = i k w and K1 skew, psi^T A' phi = 2 c y^T B0 x for x = (-i u_a, k u_p)
        and y = (-i k u_a, u_p): one product with B0 (fewer entries than K2 and K1) and no
        division by k."""
        na = self.na
        x = phi.copy()
        x[:na] *= -1j
        x[na:] *= k
        Y = real_times(self.B0r, x)
        return 2 * self.c * (np.einsum("ij,ij->j", phi[na:], Y[na:])
                             - 1j * k * np.einsum("ij,ij->j", phi[:na], Y[:na]))

    def group_velocity(self, omega: float, k: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """Undamped group velocity d omega / d k by Hellmann-Feynman (real k)."""
        num = np.einsum("ij,ij->j", phi.conj(),
                        2 * k * real_times(self.K2, phi) + 1j * real_times(self.K1, phi))
        den = 2 * omega * np.einsum("ij,ij->j", phi.conj(), real_times(self.M, phi))
        return (num / den).real

    def to_reduced(self, phi_ordered: np.ndarray) -> np.ndarray:
        out = np.empty_like(phi_ordered)
        out[self.order] = phi_ordered
        return out


# ----------------------------------------------------------------------------- cache
def _cached(ops: FamilyOperators, what: tuple, solve, lossless: bool = False):
    """solve() memoised per (operators' content, what) in the wave cache
    (railfem.rail.wavecache); with ``lossless`` the content leaves out the loss factor (an
    undamped solve). Operators with an ``extra`` stiffness (a callable, e.g. a foundation of
    given parameters) are not cached: the callable's content cannot be keyed."""
    if ops.extra is not None:
        return solve()
    return cached((ops.lossless_key if lossless else ops.key, what), solve)


# ------------------------------------------------------------------------ eigensolvers
def _lambdas_dense(ops: FamilyOperators, omega: float, c: complex, inverted: bool = True):
    """All N pairs (lambda = k^2, vector) of A x + lambda B x = 0, from the eigenvalues
    nu = 1/lambda of -A^-1 B: eig is accurate relative to the largest eigenvalue, which in this
    inverted form belongs to the waves of smallest |k| that carry the far field (in the form
    -B^-1 A the small k^2 of the bending and longitudinal waves lose accuracy at low
    frequency: 0.3 % error in the receptance at 30 Hz on 60E1 h = 20 mm, see
    tests/test_mobility.py). A singular A (no damping, exactly at a cut-on) uses -B^-1 A.
    ``inverted=False`` takes -B^-1 A directly, accurate for the waves of largest |k| (the
    near-field tail). Real arithmetic when c and the matrices are real."""
    def dense_B():
        return (c * ops.B0).toarray() if c.imag else ops.B0.toarray()

    if not inverted:
        A = ops.constant_matrix(omega, c)
        C = spl.splu(ops.B0.astype(A.dtype).tocsc()).solve(A.toarray())
        C *= -1.0 / c if c.imag else -1.0
        return sl.eig(C, check_finite=False, overwrite_a=True)

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sl.LinAlgWarning)
        lu, piv = sl.lu_factor(ops.constant_matrix(omega, c).toarray(), overwrite_a=True,
                               check_finite=False)
    if np.all(np.diag(lu) != 0):
        C = sl.lu_solve((lu, piv), dense_B(), check_finite=False, overwrite_b=True)
        del lu  # frees N^2 before the eig
        C *= -1.0
        nu, x = sl.eig(C, check_finite=False, overwrite_a=True)
        if np.all(np.isfinite(nu)) and np.all(nu != 0):  # B is regular: K2 > 0
            return 1.0 / nu, x
    C = sl.solve(-dense_B(), ops.constant_matrix(omega, c).toarray(), check_finite=False)
    return sl.eig(C, check_finite=False, overwrite_a=True)


def _lambdas_shift_invert(ops: FamilyOperators, omega: float, n: int, c: complex):
    """The n pairs of smallest |lambda| by ARPACK on -Z^-1 B0, Z = K0' - (omega^2 / c) M
    (the pencil divided by c: B0 stays real, and undamped operators stay real)."""
    N = ops.B0.shape[0]
    n = min(n, N - 2)
    # a fixed start vector: ARPACK's own is drawn from a generator that carries over between
    # calls, which would make a result depend (at round-off level) on what ran before
    v0 = np.random.default_rng(0).standard_normal(N)
    op, perm = ops.shift_invert_operator(omega, c)  # in the blocks' orders: no gathers
    if op is None:  # a foundation stiffness: the solve in the operators' own order
        solve = ops.factorised(omega, c)
        B = ops.B0_as(solve.dtype)
        op = spl.LinearOperator(B.shape, dtype=solve.dtype, matvec=lambda x: -solve(B @ x))
    else:
        v0 = v0[perm]
    v0 = v0.astype(op.dtype)
    # about 2n Krylov vectors are needed whatever ncv; beyond 60 waves a basis of 1.5 n
    # restarts once at no more products and less orthogonalisation (benchmarks)
    ncv = min(N - 1, 2 * n + 1 if n <= 60 else n + n // 2)
    nu, vec = spl.eigs(op, k=n, which="LM", tol=1e-10, v0=v0, ncv=ncv)
    if perm is not None:
        vec = vec[np.argsort(perm)]  # the operators' order, rows contiguous
    return 1.0 / nu, vec


def waves_at(ops: FamilyOperators, omega: float, *, method: str = "dense",
             n_waves: int = 60) -> Waves:
    """Positive-going waves of one family at angular frequency omega (rad/s).

    omega may be complex: with one hysteretic loss factor on the whole section the waves of
    a rail of loss factor eta at omega are those of the same rail without loss at the
    complex frequency omega / sqrt(1 + i eta) (``loss_frequency``), with denominators
    divided by 1 + i eta.

    Results are cached in memory per (operators' content, omega, method, n_waves); the
    returned arrays are read-only."""
    if method not in ("dense", "shift-invert"):
        raise ValueError(f"wave solver method must be 'dense' or 'shift-invert', got {method!r}")
    om = complex(omega) if np.iscomplexobj(omega) else float(omega)
    what = ("waves", om, method, int(n_waves) if method == "shift-invert" else None)
    return _cached(ops, what, lambda: _solve_waves(ops, omega, method, n_waves, ops.c))


def loss_frequency(omega, eta: float) -> complex:
    """The complex frequency omega / sqrt(1 + i eta) at which a rail without loss has the
    waves of the rail of loss factor eta at omega: (1 + i eta) K(k) - omega^2 M is
    (1 + i eta) [K(k) - omega^2 / (1 + i eta) M]."""
    return omega / np.sqrt(1 + 1j * eta)


def _solve_waves(ops, omega, method, n_waves, c, keep=slice(None), inverted=True) -> Waves:
    """The waves of A = c K(k) - omega^2 M, sorted by |k|, those of rank ``keep``.

    Solved with c (1 for a real-arithmetic solve), returned for the operators' own loss
    factor: when c differs from ops.c, each wavenumber is moved to first order to the
    damped problem, which is the undamped one at omega^2 / (1 + i eta) (dk = d(omega^2)
    psi^T M phi / psi^T A'(k) phi), before the ranking; otherwise the members of an undamped
    pair (k, -conj k) of equal |k| would be ranked by round-off, not as the damped waves."""
    with blas_threads():
        k, x = _eigen_pairs(ops, omega, method, n_waves, c, inverted)
        return _ranked(ops, omega, c, k, x, keep)


def _eigen_pairs(ops, omega, method, n_waves, c, inverted=True):
    """(k, x): the positive-going wavenumbers of A = c K(k) - omega^2 M and their shapes
    (ordered DOFs, unit columns), unsorted. omega may be complex (a complex frequency)."""
    if method == "dense":
        lam, x = _lambdas_dense(ops, omega, c, inverted)
    else:
        try:
            lam, x = _lambdas_shift_invert(ops, omega, n_waves, c)
        except (spl.ArpackNoConvergence, RuntimeError) as exc:
            log.warning("shift-invert wave solve failed at %.1f Hz (%s); using dense",
                        abs(omega) / (2 * np.pi), exc)
            lam, x = _lambdas_dense(ops, omega, c)
    k = np.sqrt(lam.astype(complex))
    k = np.where(k.imag > 0, -k, k)
    # rows contiguous for the sparse products with the shapes (a copy of the n_waves columns;
    # the dense solve's N columns stay as they are)
    x = np.asarray(x, dtype=complex) if method == "dense" else \
        np.ascontiguousarray(x, dtype=complex)
    x[: ops.na] *= 1j * k  # back-substitute u_a = i k w
    undamped = np.abs(k.imag) <= 1e-6 * np.abs(k)  # eig round-off is ~1e-8
    if undamped.any():
        kr = k[undamped].real
        forward = ops.group_velocity(np.real(omega), kr, x[:, undamped]) >= 0
        k[undamped] = np.where(forward, kr, -kr)
        x[: ops.na, undamped] *= np.where(forward, 1.0, -1.0)  # u_a = i k w, k -> -k
    for j in _chunks(len(k)):  # column blocks: whole-matrix temporaries cost N^2 each
        x[:, j] /= column_norms(x[:, j])
    return k, x


def _ranked(ops, omega, c, k, x, keep=slice(None)) -> Waves:
    """Waves of rank ``keep`` by |k| from eigenpairs solved with c, moved to ops.c (see
    _solve_waves); x is only read."""
    if c != ops.c:
        k = k + _loss_shift(ops, omega, c, k, x)
    idx = np.argsort(np.abs(k))[keep]
    k = k[idx]
    denom = np.empty(len(idx), dtype=complex)
    for j in _chunks(len(idx)):
        denom[j] = ops.dA(k[j], x[:, idx[j]])
    # sorted columns, rows as reduced DOFs (two takes: half the time of one 2-D fancy index)
    phi = x.take(idx, axis=1).take(ops.reduced_rows, axis=0)
    return Waves(family=ops.family, omega=omega, k=k, phi=phi, denom=denom)


def _chunks(n: int, size: int = 256):
    return [slice(j, min(j + size, n)) for j in range(0, n, size)]


def _loss_shift(ops, omega, c, k, x) -> np.ndarray:
    """First-order change of k from the problem solved with c to the one with ops.c:
    c P(k) - omega^2 M = c [P(k) - (omega^2 / c) M], and dk/ds = psi^T M phi / psi^T P' phi
    for P(k) - s M (psi = T_a phi; ops.dA is c psi^T P' phi)."""
    ds = omega**2 * (1 / ops.c - 1 / c)
    out = np.empty_like(k)
    for j in _chunks(len(k)):
        xs = x[:, j]
        out[j] = ds * ops.c * np.einsum("ij,ij->j", ops.flip[:, None] * xs, ops.M @ xs) \
            / ops.dA(k[j], xs)
    return out


def frozen_tail(ops: FamilyOperators, omega0: float, n_waves: int, *,
                damped: bool = False) -> Waves:
    """The waves beyond the ``n_waves`` smallest |k| at omega0, from the full (dense) set.

    They are near-field waves with |Im k| of hundreds of rad/m whose wavenumbers and shapes
    hardly change with frequency (their decay length is far below a bending wavelength), so
    computed once they stand for the waves a shift-invert solve drops at every other
    frequency: a quasi-static correction of point and near-point responses.

    The eigenproblem is solved in the direct form -B^-1 A, accurate for the largest |k|
    (the inverted form of ``waves_at(method="dense")`` carries round-off of up to 1e-4 on
    them, 1e-3 in point receptances), and by default without the rail's loss factor, in real
    arithmetic: the damped problem at omega0 is the undamped one at omega0^2 / (1 + i eta),
    so each wavenumber is moved there to first order and the denominators are those of the
    damped operator. Against the tail solved with the loss factor (``damped=True``, complex
    arithmetic) point receptances differ by < 1e-9 (tests/test_waves_speed.py); the
    real solve takes a third of the time and a quarter of the memory
    (benchmarks/bench_waveguide.py). Cached like waves_at; the undamped eigen-solve is
    cached without the loss factor, so operators of another loss factor on the same
    matrices (a kernel at another eta_r, Waveguide.with_loss_factor) only redo the
    first-order move.
    """
    if damped:
        return _cached(ops, ("tail", float(omega0), int(n_waves), True), lambda: _solve_waves(
            ops, omega0, "dense", 0, ops.c, keep=slice(n_waves, None), inverted=False))

    def solve():
        return _ranked(ops, omega0, 1.0 + 0j, *undamped_pairs(), keep=slice(n_waves, None))

    def undamped_pairs():  # the loss-free eigen-solve, shared by every loss factor
        def eig():
            with blas_threads():
                k, x = _eigen_pairs(ops, omega0, "dense", 0, 1.0 + 0j, inverted=False)
            return Waves(family=ops.family, omega=omega0, k=k, phi=x, denom=np.empty(0))

        w = _cached(ops, ("undamped pairs", float(omega0)), eig, lossless=True)
        return w.k, w.phi

    return _cached(ops, ("tail", float(omega0), int(n_waves), False), solve)


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


@blas_threads()
def solve(guide: Waveguide, frequency, *, families=None, method: str = "shift-invert",
          n_waves: int = 40, progress=None, labels: bool = True) -> Dispersion:
    """k(omega) of the requested families (default: all of the guide's) at each frequency
    (Hz), with wave-type labels (``labels=False``: empty labels, for callers that only
    want the wavenumbers: it skips the shape projections of railfem.rail.labels)."""
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
            labs += label_waves(guide, op, w) if labels else [""] * len(w.k)
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
    K1s = block_sum(ops.na, (ops.K1, "ap"), (-ops.K1, "pa"))
    K = (k * k * ops.K2 + k * K1s + ops.K0).tocsc()
    return K, ops.M.tocsc(), ops


@blas_threads()
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


@blas_threads()
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
