"""Free-rail Green's functions by the residue theorem (METHOD.md section 1).

For a force distribution F acting at x = 0 the response of the free rail at x >= 0 is

    u(x) = -i sum_n phi_n (psi_n^T F) exp(-i k_n x) / (psi_n^T A'(k_n) phi_n)

over the positive-going waves k_n (Im k_n < 0); x < 0 follows from the mirror x -> -x of
the rail (the mirrored load and response shapes). A load spread along the rail over a box of
length L_force and a response averaged over L_resp convolve each wave with the trapezoid of
the two boxes, integrated in closed form, so responses inside and outside the smoothing
window are exact for the waves kept.

The functions here take a wave set already projected on the loads and responses (its
``terms``, railfem.rail.mobility.wave_terms) and know nothing of the mesh: they serve the WFE
rail (railfem.rail.mobility, railfem.track.wfe) and the beams (railfem.track.beams) alike.

* ``wave_kernels``: the propagation factor of each wave to each response position;
* ``residue_sum``: the receptance of a wave set at response positions;
* ``combine``: the residue sum with kernels given by the caller (lattice sums).
"""
from __future__ import annotations

import numpy as np

__all__ = ["wave_kernels", "residue_sum", "combine"]


def _smoothing_pieces(L_force: float, L_resp: float):
    """The convolution of the force box (length L_force) with the response box (L_resp):
    a trapezoid, as linear pieces (tau0, tau1, w0, w1) of unit area; [] for two points."""
    a, b = max(L_force, L_resp), min(L_force, L_resp)
    if a == 0:
        return []
    top = 1.0 / a
    if b == 0:
        return [(-a / 2, a / 2, top, top)]
    pieces = [(-(a + b) / 2, -(a - b) / 2, 0.0, top), ((a - b) / 2, (a + b) / 2, top, 0.0)]
    if a > b:
        pieces.insert(1, (-(a - b) / 2, (a - b) / 2, top, top))
    return pieces


def _forward_kernel(k: np.ndarray, x: np.ndarray, pieces) -> np.ndarray:
    """int w(tau) exp(-i k (x + tau)) over x + tau >= 0 for piecewise-linear w: (nw, nx).

    Closed form with the primitives of exp(-iks) and s exp(-iks), so that strongly
    evanescent waves (|k| L >> 1) are integrated exactly."""
    k = k[:, None]
    if not pieces:
        return np.where(x >= 0, np.exp(-1j * k * np.abs(x)), 0.0)
    out = np.zeros((k.shape[0], x.size), dtype=complex)
    for t0, t1, w0, w1 in pieces:
        slope = (w1 - w0) / (t1 - t0)
        lo, hi = np.maximum(x + t0, 0.0), np.maximum(x + t1, 0.0)
        # w as a function of s = x + tau: w = w0 + slope (s - x - t0)
        c0 = w0 - slope * (x + t0)
        e_lo, e_hi = np.exp(-1j * k * lo), np.exp(-1j * k * hi)
        i0 = 1j / k * (e_hi - e_lo)
        i1 = e_hi * (1j * hi / k + 1 / k**2) - e_lo * (1j * lo / k + 1 / k**2)
        out += np.where(hi > lo, c0 * i0 + slope * i1, 0.0)
    return out


def wave_kernels(k: np.ndarray, x: np.ndarray, L_force: float, L_resp: float):
    """Forward and backward wave kernels (fwd, bwd), each (nw, nx): the propagation factor
    exp(-i k_n |x|) of each wave k_n (Im k_n < 0, positive-going) from the load to the
    response positions x (1-D, m, response minus load centre), for a force spread uniformly
    over L_force and a response averaged over L_resp (both centred, m; 0 is a point).

    fwd carries the waves the load sends towards +x (nonzero where the response lies ahead
    of the load, x >= 0 for two points), bwd those towards -x (mirrored load and response,
    x < 0). Inside the smoothing window (|x| < (L_force + L_resp)/2) both are the exact
    convolution of the wave with the trapezoid of the two boxes, in closed form."""
    pieces = _smoothing_pieces(L_force, L_resp)
    if not pieces:
        e = np.exp(-1j * k[:, None] * np.abs(x))
        return e * (x >= 0), e * (x < 0)
    # outside the smoothing window the kernel is a plain wave times a constant per wave
    half = (L_force + L_resp) / 2
    at_edge = _forward_kernel(k, np.array([half]), pieces)
    near = np.abs(x) < half
    plain = at_edge * np.exp(-1j * k[:, None] * np.clip(np.abs(x) - half, 0.0, None))
    fwd, bwd = plain * (x >= half), plain * (x <= -half)
    if near.any():
        fwd[:, near] = _forward_kernel(k, x[near], pieces)
        bwd[:, near] = _forward_kernel(k, -x[near], pieces)
    return fwd, bwd


def _pair_products(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    """C[(o, i), n] = R[o, n] p[n, i]: the per-wave weight of each output-input pair."""
    return (R[:, None, :] * p.T[None, :, :]).reshape(R.shape[0] * p.shape[1], -1)


def combine(terms, fwd: np.ndarray, bwd: np.ndarray) -> np.ndarray:
    """The residue sum -i sum_n over waves n of a wave set's ``terms`` (mobility.wave_terms:
    response shapes and load participations, direct and mirrored) weighted by given
    forward / backward kernels fwd, bwd (nw, ...), e.g. ``wave_kernels`` times lattice
    factors: receptance (n_out, ..., n_in) in m/N."""
    Rphi, a, Rphi_m, b = terms
    n_o, n_i = Rphi.shape[0], a.shape[1]
    s = (_pair_products(Rphi, a) @ fwd.reshape(fwd.shape[0], -1)
         + _pair_products(Rphi_m, b) @ bwd.reshape(bwd.shape[0], -1))
    return -1j * np.moveaxis(s.reshape(n_o, n_i, *fwd.shape[1:]), 1, -1)


def residue_sum(terms, k: np.ndarray, x, L_force: float = 0.0,
                L_resp: float = 0.0) -> np.ndarray:
    """The free-rail Green's function by residues: receptance (n_out, nx, n_in) in m/N of a
    wave set given its ``terms`` (railfem.rail.mobility.wave_terms: response shapes and load
    participations divided by psi^T A'(k) phi, direct and through the mirror) and its
    wavenumbers k (Im k < 0), at response positions x (1-D, m) relative to the load centre,
    for a force spread over L_force and a response averaged over L_resp (m, 0 is a point):
    u(x) = -i sum_n R phi_n (psi_n^T F / d_n) K_n(x), K_n the wave kernel (wave_kernels).

    Outside the smoothing window only one direction contributes (forward for x >= the
    half window, backward for x <= minus it), each a plain wave times a constant per wave.
    A wave is summed only up to its reach (35 / |Im k| beyond the window, where it is below
    e^-35 of its amplitude): with the waves ranked by reach and the separations sorted, the
    terms kept form a staircase, summed by ``_staircase`` in a few matrix products whose
    cost is within twice the staircase's (the near-field tail, hundreds of waves of reach
    below a few cm, then costs little more than the propagating waves)."""
    x = np.asarray(x, dtype=float)
    Rphi, a, Rphi_m, b = terms
    n_o, n_i = Rphi.shape[0], a.shape[1]
    Cf, Cb = _pair_products(Rphi, a), _pair_products(Rphi_m, b)
    pieces = _smoothing_pieces(L_force, L_resp)
    half = (L_force + L_resp) / 2
    edge = _forward_kernel(k, np.array([half]), pieces)[:, 0] if pieces else np.ones(len(k))
    span = 35.0 / np.maximum(-k.imag, 1e-300)  # reach beyond the smoothing window
    rank = np.argsort(-span, kind="stable")
    k_r, span_r = k[rank], span[rank]
    out = np.zeros((n_o * n_i, x.size), dtype=complex)
    pos = x >= half
    neg = (x <= -half) if pieces else ~pos
    for side, C in ((pos, Cf), (neg, Cb)):
        if side.any():
            idx = np.flatnonzero(side)
            out[:, idx] = _staircase((C * edge)[:, rank], k_r, span_r, np.abs(x[idx]) - half)
    near = ~(pos | neg)
    if near.any():
        fwd, bwd = wave_kernels(k, x[near], L_force, L_resp)
        out[:, near] = Cf @ fwd + Cb @ bwd
    return -1j * out.reshape(n_o, n_i, x.size).transpose(0, 2, 1)


def _staircase(C: np.ndarray, k: np.ndarray, span: np.ndarray, s: np.ndarray) -> np.ndarray:
    """sum_n C[:, n] exp(-i k_n s_j) over the waves n with span_n >= s_j: (n_c, ns).

    The waves come ranked by span, decreasing, so those of separation s_j are a prefix of
    length cnt_j; the separations are taken in increasing order in blocks over which that
    prefix at most halves, each block one product with the block's longest prefix (the
    waves it adds beyond their span are below e^-35 there)."""
    order = np.argsort(s, kind="stable")
    ss = s[order]
    cnt = np.searchsorted(-span, -ss, side="right")  # waves with span >= s
    out = np.zeros((C.shape[0], len(s)), dtype=complex)
    j = 0
    while j < len(ss) and cnt[j] > 0:
        c = cnt[j]
        j2 = max(j + 1, int(np.searchsorted(-cnt, -(c // 2), side="right")))
        cols = order[j:j2]
        out[:, cols] = C[:, :c] @ np.exp(-1j * np.outer(k[:c], ss[j:j2]))
        j = j2
    return out
