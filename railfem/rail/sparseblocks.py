"""Sparse block helpers of the wave solver (railfem.rail.waves): the (axial, in-plane) blocks
of a section matrix, one LU per diagonal block of a block upper triangular matrix, and a real
sparse matrix times a complex block of columns."""
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


def block_solver(Zaa, Zpp, Zap, na: int):
    """r -> Z^-1 r for Z = [[Zaa, Zap], [0, Zpp]] from one LU of each diagonal block."""
    la = spl.splu(Zaa, permc_spec="MMD_AT_PLUS_A")
    lp = spl.splu(Zpp, permc_spec="MMD_AT_PLUS_A")
    dtype = np.result_type(Zaa.dtype, Zpp.dtype)

    def solve(r):
        r = np.asarray(r, dtype=np.result_type(dtype, r.dtype))
        xp = lp.solve(r[na:])
        xa = la.solve(r[:na] - real_times(Zap, xp))
        return np.concatenate([xa, xp])

    solve.dtype = dtype  # complex with a loss factor or a complex foundation stiffness
    return solve


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
