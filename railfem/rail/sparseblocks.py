"""Sparse block helpers of the wave solver (railfem.rail.waves): the (axial, in-plane) blocks
of a section matrix, one LU per diagonal block of a block upper triangular matrix (orderings
found once, blocks laid out in them), a real sparse matrix times a complex block of columns,
and column norms."""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl


def real_times(A, X: np.ndarray) -> np.ndarray:
    """A @ X for a real sparse A and a real or complex dense X (one vector or columns): a
    complex block of columns is multiplied as its real and imaginary parts side by side
    (2x faster than scipy's complex product; for one vector scipy's own is faster)."""
    if X.ndim == 1 or not np.iscomplexobj(X) or np.iscomplexobj(A.data):
        return A @ X
    X = np.ascontiguousarray(X)
    return np.ascontiguousarray(A @ X.view(float)).view(complex)


def diagonal_blocks(P: sp.csc_matrix, na: int):
    """((positions, pattern) of the aa block, same of the pp block) of a sorted CSC
    pattern: the positions of each block's entries in P.data, in the block's CSC order."""
    pos = sp.csc_matrix((np.arange(1, P.nnz + 1, dtype=float), P.indices, P.indptr),
                        shape=P.shape)
    out = []
    for sl_ in (slice(None, na), slice(na, None)):
        blk = pos[sl_][:, sl_].tocsc()
        blk.sort_indices()
        out.append((blk.data.astype(np.int64) - 1, blk))
    return tuple(out)


# SuperLU options for the diagonal blocks: Z_aa and Z_pp are (complex) symmetric, so a
# diagonal pivot is preferred (threshold pivoting: a diagonal entry of at least 0.1 times the
# largest in its column is taken, otherwise the row is swapped) and the ordering is taken on
# A^T + A; the small relaxed supernodes solve fastest. Same fill as partial pivoting, 20-25 %
# less time per solve and per factorisation (benchmarks/results/results_kofw_speed.txt).
LU_OPTIONS = dict(diag_pivot_thresh=0.1, relax=1, panel_size=4, options=dict(SymmetricMode=True))


def block_solver(Zaa, Zpp, Zap, na: int, orders=None, transposed: bool = False):
    """r -> Z^-1 r for Z = [[Zaa, Zap], [0, Zpp]] from one LU of each diagonal block.

    Each diagonal block is factorised as its transpose and solved with SuperLU's transposed
    solve (trans="T"), which is about 20 % faster for one vector than the plain one;
    ``transposed``: Zaa and Zpp are given as their transposes (CSC), e.g. laid out on a
    transposed pattern by ``permuted_pattern``. ``orders``: (qa, qp) fill-reducing orderings
    of the blocks; the blocks and Zap are then given in that order (Zaa = Z_aa[qa][:, qa],
    Zap = Z_ap[qa][:, qp]), r and the solution are not. Without them each block is ordered by
    minimum degree on A^T + A. solve.orders holds the orderings used."""
    if not transposed:
        Zaa, Zpp = Zaa.T.tocsc(), Zpp.T.tocsc()
    spec = "MMD_AT_PLUS_A" if orders is None else "NATURAL"
    la = spl.splu(Zaa, permc_spec=spec, **LU_OPTIONS)
    lp = spl.splu(Zpp, permc_spec=spec, **LU_OPTIONS)
    qa, qp = (None, None) if orders is None else orders
    dtype = np.result_type(Zaa.dtype, Zpp.dtype)
    # a complex copy of Zap: a real sparse matrix times one complex vector converts the
    # matrix on every product
    Zc = Zap.astype(dtype) if np.issubdtype(dtype, np.complexfloating) else Zap

    def times_ap(xp):
        return Zc @ xp if xp.ndim == 1 else real_times(Zap, xp)

    def solve(r):
        r = np.asarray(r, dtype=np.result_type(dtype, r.dtype))
        if qa is None:
            xp = lp.solve(r[na:], trans="T")
            return np.concatenate([la.solve(r[:na] - times_ap(xp), trans="T"), xp])
        x = np.empty_like(r)
        yp = lp.solve(r[na:][qp], trans="T")
        x[na:][qp] = yp
        x[:na][qa] = la.solve(r[:na][qa] - times_ap(yp), trans="T")
        return x

    solve.dtype = dtype  # complex with a loss factor or a complex foundation stiffness
    solve.orders = (np.argsort(la.perm_c), np.argsort(lp.perm_c)) if qa is None else orders
    solve.factors = (la, lp, Zc)  # for BlockShiftInvert (block coordinates)
    return solve


class BlockShiftInvert(spl.LinearOperator):
    """y -> Z^-1 (B y) in the block coordinates of a ``block_solver(..., orders,
    transposed=True)`` solve (rows and columns of each diagonal block in its order), with B
    given in those coordinates (e.g. -B0 for ARPACK's -Z^-1 B0): one sparse product, two
    triangular solve pairs and the ap product, no gathers or scatters and none of
    LinearOperator's checks per product (ARPACK calls it about 2n times for n waves)."""

    def __init__(self, solve, B, na: int):
        self._la, self._lp, self._Zap = solve.factors
        self._B, self._na = B, na
        super().__init__(np.dtype(solve.dtype), B.shape)

    def matvec(self, x):
        b = self._B @ x  # a fresh vector: the result is written into it
        na = self._na
        yp = self._lp.solve(b[na:], trans="T")
        ba = b[:na]
        ba -= self._Zap @ yp
        b[:na] = self._la.solve(ba, trans="T")
        b[na:] = yp
        return b

    _matvec = matvec


def permuted_pattern(positions: np.ndarray, P: sp.csc_matrix, q: np.ndarray,
                     transpose: bool = False):
    """(positions, pattern) of a block (as from ``diagonal_blocks``) with rows and columns
    taken in the order q (``transpose``: of its transpose): the block's entries in P.data
    order of the new pattern."""
    X = sp.csc_matrix((positions.astype(float) + 1, P.indices, P.indptr), shape=P.shape)
    Xq = X[q][:, q]
    Xq = (Xq.T if transpose else Xq).tocsc()
    Xq.sort_indices()
    return Xq.data.astype(np.int64) - 1, Xq


def ordered_blocks(blocks, Zap, orders):
    """(aa, pp, Zap, orders) for ``block_solver(..., orders, transposed=True)``: the
    (positions, pattern) of each diagonal block's transpose (``blocks`` as from
    ``diagonal_blocks``) and Zap, rows and columns in the orders (qa, qp)."""
    (iaa, Paa), (ipp, Ppp) = blocks
    qa, qp = orders
    return (permuted_pattern(iaa, Paa, qa, transpose=True),
            permuted_pattern(ipp, Ppp, qp, transpose=True), Zap[qa][:, qp].tocsr(), orders)


def column_norms(x: np.ndarray) -> np.ndarray:
    """Euclidean norm of each column of a complex array, without (N, n) temporaries."""
    re, im = x.real, x.imag
    return np.sqrt(np.einsum("ij,ij->j", re, re) + np.einsum("ij,ij->j", im, im))


def block_sum(na: int, *parts) -> sp.csc_matrix:
    """Sum of blocks ("aa", "ap", "pa", "pp": axial = first na DOFs) of sparse matrices."""
    out = None
    for X, block in parts:
        X = X.tocoo()
        rows_a, cols_a = X.row < na, X.col < na
        keep = {"aa": rows_a & cols_a, "ap": rows_a & ~cols_a, "pa": ~rows_a & cols_a,
                "pp": ~rows_a & ~cols_a}[block]
        part = sp.csc_matrix((X.data[keep], (X.row[keep], X.col[keep])), shape=X.shape)
        out = part if out is None else out + part
    return out.tocsc()


def on_pattern(P: sp.csc_matrix, X) -> np.ndarray:
    """X's entries laid out on the sorted CSC pattern P (which must contain X's)."""
    X = sp.csc_matrix(X)
    X.sum_duplicates()
    n = P.shape[0]

    def keys(A):
        return np.repeat(np.arange(A.shape[1], dtype=np.int64), np.diff(A.indptr)) * n + A.indices

    kp, kx = keys(P), keys(X)
    pos = np.searchsorted(kp, kx)
    if np.any(pos >= len(kp)) or np.any(kp[np.minimum(pos, len(kp) - 1)] != kx):
        raise ValueError("sparsity pattern does not contain the matrix")  # internal invariant
    out = np.zeros(P.nnz, dtype=X.dtype)
    out[pos] = X.data
    return out
