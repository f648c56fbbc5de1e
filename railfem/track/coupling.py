"""Kernels and coupling solves of a rail on discrete supports (METHOD.md section 2).

A supported track is solved in two steps:

* the **kernel**: free-rail Green's functions (receptances) between the support springs, the
  loads and the responses, per frequency. It depends on the rail, the positions and the
  frequency grid, never on the support parameters, so it is computed once (railfem.track.wfe
  for the WFE rail, railfem.track.beams for the Timoshenko beam) and cached
  (railfem.track.kernelcache);
* the **coupling**: with K the springs' dynamic stiffness (F the forces the rail puts on
  the springs, alpha the kernel's receptances)

      (I + K alpha_ss) F = K alpha_sP P,       u_r = alpha_rP P - alpha_rs F

  one dense solve per frequency (discrete supports) or per Floquet angle (periodic
  supports). This is all a parameter change costs.

Rows whose spring is stiff against the rail (|K alpha_ss(0)| > 1, or rigid, K = inf) are
divided by K alpha_ss(0): they read (1/K + alpha_ss) F = alpha_sP P up to that factor, so an
absent (K = 0) and a rigid spring are both well-posed and all rows stay of order one.

Kernel arrays store each Green's function once per distinct separation along the rail with
an index array that gathers it into the full matrix (block-Toeplitz for equal spacing).
The kernels are plain dataclasses of arrays (``to_arrays``/``from_arrays`` for the cache).
"""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from .semiseparable import chain_plan, chain_solve


def unique_separations(sep: np.ndarray, decimals: int = 12):
    """Distinct values of ``sep`` and the index of each entry. Values are rounded to 1e-12 m,
    which merges round-off duplicates (0.7 - 0.6 and 0.1) and moves a wave's phase by less
    than 1e-9 even for the near-field waves."""
    u, inv = np.unique(np.round(sep, decimals), return_inverse=True)
    return u, inv.reshape(sep.shape)


class KernelArrays:
    """What both kernel kinds share: vertical springs unless told otherwise, and the
    conversion to and from the named arrays the kernel cache stores."""

    def __post_init__(self):
        # spring_direction: (n_p,) direction of each spring of a set, 0/1/2 = x/y/z;
        # kernels without it (vertical models, cached before it existed) are vertical
        d = self.spring_direction
        d = np.full(len(self.spring_weight), 2) if d is None else np.asarray(d)
        object.__setattr__(self, "spring_direction", d.astype(np.int64))

    def to_arrays(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_arrays(cls, arrays: dict):
        return cls(**{f.name: np.asarray(arrays[f.name]) for f in fields(cls)
                      if f.name in arrays})


@dataclass(frozen=True, kw_only=True, eq=False)
class DiscreteKernel(KernelArrays):
    """Free-rail receptances of a rail with ``n_s`` spring sets of ``n_p`` springs each.

    frequency: (nf,) Hz. spring_weight: (n_p,) share of a support carried by each spring of
    a set (sums to 1). spring_x: (n_s,) positions of the sets (m, increasing).
    ss: (nf, n_u, n_p, n_p) spring <- spring at the distinct separations ss_sep (m),
    ss_index (n_s, n_s). sP: (nf, n_u, n_p) spring <- load, sP_index (n_s, n_fx).
    rs: (nf, n_u, n_out, n_p) response <- spring, rs_index (n_rx, n_s). rP: (nf, n_u, n_out)
    response <- load, rP_index (n_rx, n_fx). All receptances in m/N.
    """

    frequency: np.ndarray
    spring_weight: np.ndarray
    spring_x: np.ndarray
    ss: np.ndarray
    ss_sep: np.ndarray
    ss_index: np.ndarray
    sP: np.ndarray
    sP_index: np.ndarray
    rs: np.ndarray
    rs_index: np.ndarray
    rP: np.ndarray
    rP_index: np.ndarray
    spring_direction: np.ndarray | None = None


    @property
    def shape(self) -> tuple[int, int, int, int]:
        """(n_s, n_p, n_rx, n_fx)."""
        return (self.ss_index.shape[0], len(self.spring_weight), self.rP_index.shape[0],
                self.rP_index.shape[1])


def _row_scaling(K: np.ndarray, alpha0: np.ndarray):
    """Per-row factors (a, b): row j of the coupling system reads
    (a_j + b_j alpha_ss) F = b_j alpha_sP P. Soft rows (|K alpha0| <= 1) keep
    a = 1, b = K; stiff and rigid rows are divided by K alpha0 (a = 1 / (K alpha0),
    b = 1 / alpha0), so that every row is of order one and partial pivoting stays
    accurate (a plain division by K leaves rows of order alpha0 next to rows of order one)."""
    finite = np.isfinite(K)
    k_fin = np.where(finite, K, 0.0)
    soft = finite & (np.abs(k_fin * alpha0) <= 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv_k = np.where(soft | ~finite, 0.0, 1.0 / np.where(soft | ~finite, 1.0, k_fin))
        a = np.where(soft, 1.0, inv_k / alpha0)
        b = np.where(soft, k_fin, 1.0 / alpha0)
    return a.astype(complex), b.astype(complex)


def _check_stiffness(K: np.ndarray, n_f: int, n: int, direction=None) -> np.ndarray:
    """(n_f, n) vertical set stiffness, or (n_f, n, 3) per direction x, y, z, (n_f, n, 4)
    with the foot's roll (code 3, N m/rad), (n_f, n, 5) with the vertical springs' pair
    differences (code 4, the pad against the foot's roll, railfem.track.directions.PAD_ROLL);
    a kernel with springs other than vertical sums needs one of the last forms, as long
    as its largest code."""
    K = np.asarray(K, dtype=complex)
    if K.shape not in ((n_f, n), (n_f, n, 3), (n_f, n, 4), (n_f, n, 5)):
        raise ValueError(f"spring stiffness has shape {K.shape}, expected (n_freq, n_springs) "
                         f"= ({n_f}, {n}) or (n_freq, n_springs, 3) per direction x, y, z")
    if K.ndim == 2 and direction is not None and np.any(np.asarray(direction) != 2):
        raise ValueError("the kernel has lateral or longitudinal springs: give the spring "
                         "stiffness per direction, shape (n_freq, n_springs, 3) for x, y, z")
    if K.ndim == 3 and direction is not None and np.max(direction) >= K.shape[2]:
        raise ValueError(f"the kernel has springs of direction code {np.max(direction)}: "
                         f"give the spring stiffness with {np.max(direction) + 1} directions "
                         "(railfem.track.wfe.spring_stiffness)")
    if np.any(np.isnan(K)):
        raise ValueError("spring stiffness contains NaN")
    return K


def _spring_stiffness(K_sets: np.ndarray, weight: np.ndarray, direction=None) -> np.ndarray:
    """Stiffness of every spring, set-major: a rigid set stays rigid (inf * w is not NaN).
    K_sets: (n_sets,) vertical, or (n_sets, 3) per direction, picked by ``direction``."""
    if K_sets.ndim == 2:
        K_sets = K_sets[:, direction]  # (n_sets, n_p)
        with np.errstate(invalid="ignore"):
            K = K_sets * weight[None, :]
        return np.where(np.isinf(K_sets), complex(np.inf), K).ravel()
    with np.errstate(invalid="ignore"):
        K = K_sets[:, None] * weight[None, :]
    return np.where(np.isinf(K_sets)[:, None], complex(np.inf), K).ravel()


def mirror_parts(n_s: int, codes) -> list:
    """The even and odd parts of n_s spring sets mirrored about x = 0 (set q <-> n_s-1-q),
    each set's springs of direction ``codes`` (x = 0 flips with the mirror): [(R, JR, sg,
    m)] with R the representative springs (set-major flat indices), JR their mirror
    images, sg the sign relating a part's value at JR to that at R, m 0 for a centre
    set's spring (its own image) else 1."""
    n_p = len(codes)
    sign = np.where(np.asarray(codes) == 0, -1.0, 1.0)
    n_h = n_s // 2
    out = []
    for sigma in (1.0, -1.0):
        reps = [(q, p) for q in range(n_h) for p in range(n_p)]
        if n_s % 2:  # the centre set keeps the components its mirror leaves unchanged
            reps += [(n_h, p) for p in range(n_p) if sigma * sign[p] > 0]
        if reps:
            q, p = np.array(reps).T
            out.append((q * n_p + p, (n_s - 1 - q) * n_p + p, sigma * sign[p],
                        (q != n_s - 1 - q).astype(float)))
    return out


def mirror_plan(kernel: DiscreteKernel, K_sets: np.ndarray, ss_flat: np.ndarray):
    """Index arrays for solving the even and odd parts separately when the problem is
    symmetric under x -> -x (springs at -x_s, equal K, alpha_ss(-x) = s_p s_q alpha_ss(x)
    with s = -1 for longitudinal springs, whose displacement flips with the mirror, +1 for
    vertical and lateral ones), else None: two systems of half the size, four times less
    work. In part sigma (+1 even, -1 odd) F(mirror set, p) = sigma s_p F(set, p)."""
    xs = kernel.spring_x
    n_s = len(xs)
    if n_s < 2 or not np.array_equal(np.round(xs, 12), -np.round(xs[::-1], 12)):
        return None
    if not np.array_equal(K_sets, K_sets[:, ::-1]):
        return None
    u = np.round(kernel.ss_sep, 12)
    j = np.searchsorted(u, -u)
    if np.any(j >= len(u)) or not np.array_equal(u[np.minimum(j, len(u) - 1)], -u):
        return None
    sign = np.where(np.asarray(kernel.spring_direction) == 0, -1.0, 1.0)  # (n_p,)
    scale = np.abs(kernel.ss).max(axis=(1, 2, 3), keepdims=True)
    mirrored = kernel.ss[:, j] * (sign[:, None] * sign[None, :])[None, None]
    if np.any(np.abs(kernel.ss - mirrored) > 1e-12 * scale):  # round-off only
        return None
    parts = []
    for R, JR, sg, m in mirror_parts(n_s, kernel.spring_direction):
        parts.append(dict(R=R, JR=JR, sg=sg, m=m, rr=ss_flat[np.ix_(R, R)],
                          rj=ss_flat[np.ix_(R, JR)]))
    return parts


def _solve_mirrored(plan, ssr, a, b, rhs):
    """F of (diag(a) + b alpha_ss) F = rhs from its even and odd parts."""
    F = np.zeros(rhs.shape, dtype=complex)
    for part in plan:
        R, JR, sg, m = part["R"], part["JR"], part["sg"], part["m"]
        M = b[R, None] * (ssr[part["rr"]] + (m * sg)[None, :] * ssr[part["rj"]])
        M[np.diag_indices(len(R))] += a[R]
        Fp = np.linalg.solve(M, (rhs[R] + sg[:, None] * rhs[JR]) / 2)
        F[R] += Fp
        F[JR] += (m * sg)[:, None] * Fp
    return F


def _solve_dense(plan, ss_flat, ssr, a, b, rhs):
    """F of (diag(a) + b alpha_ss) F = rhs: by mirror halves when ``plan``, else whole."""
    if plan is not None:
        return _solve_mirrored(plan, ssr, a, b, rhs)
    M = b[:, None] * ssr[ss_flat]
    M[np.diag_indices(len(a))] += a
    return np.linalg.solve(M, rhs)


def spring_families(ss: np.ndarray, tol: float = 1e-12) -> list[np.ndarray]:
    """The springs of a set (indices into n_p) grouped by the symmetry family of the rail
    they act on: the free-rail receptance between springs of different families (e.g. a
    lateral sum and a vertical sum of a mirror pair) vanishes but for round-off, so the
    coupling splits into one independent system per group. ss: (nf, n_u, n_p, n_p); two
    springs are linked when their receptance exceeds ``tol`` times the largest."""
    n_p = ss.shape[-1]
    if n_p < 2:
        return [np.arange(n_p)]
    link = np.abs(ss).max(axis=(0, 1)) > tol * np.abs(ss).max()
    link = link | link.T
    group = np.full(n_p, -1)
    for start in range(n_p):
        if group[start] >= 0:
            continue
        group[start], stack = start, [start]
        while stack:
            q = stack.pop()
            for r in np.flatnonzero(link[q] & (group < 0)):
                group[r] = start
                stack.append(r)
    return [np.flatnonzero(group == g) for g in np.unique(group)]


def _family_kernel(kernel: DiscreteKernel, cols: np.ndarray) -> DiscreteKernel:
    """``kernel`` restricted to the springs ``cols`` of each set."""
    return DiscreteKernel(frequency=kernel.frequency, spring_weight=kernel.spring_weight[cols],
                          spring_direction=kernel.spring_direction[cols],
                          spring_x=kernel.spring_x, ss=kernel.ss[:, :, cols][:, :, :, cols],
                          ss_sep=kernel.ss_sep, ss_index=kernel.ss_index,
                          sP=kernel.sP[:, :, cols], sP_index=kernel.sP_index,
                          rs=kernel.rs[..., cols], rs_index=kernel.rs_index, rP=kernel.rP,
                          rP_index=kernel.rP_index)


#: springs (n_s n_p) from which a long uniform layout is solved as a chain of waves
#: (railfem.track.semiseparable) rather than densely: below, the dense mirrored solve is
#: as fast and keeps results bit for bit; a kernel with springs in several directions
#: (often without the mirror split) from CHAIN_MIN_SPRINGS_3D (5x faster at 786 springs)
CHAIN_MIN_SPRINGS = 1200
CHAIN_MIN_SPRINGS_3D = 400


def couple_discrete(kernel: DiscreteKernel, stiffness, method: str = "auto") -> np.ndarray:
    """Receptance (nf, n_out, n_rx, n_fx) of the supported rail (m/N).

    stiffness: (nf, n_s) dynamic stiffness of each spring set (N/m, complex; one support or
    one row of a spread support), shared by its n_p springs by ``kernel.spring_weight``;
    (nf, n_s, 3) per direction x, y, z when the springs act in several
    (``kernel.spring_direction``).
    A layout symmetric about x = 0 with symmetric stiffness (any uniform track) is solved
    as its even and odd parts; springs on different symmetry families of the rail
    (``spring_families``: a lateral load loads both) as separate systems.
    method: 'dense', 'chain' (identical equally spaced supports as a sparse chain of
    waves, railfem.track.semiseparable; equal to the dense solve to round-off, other
    layouts and frequencies whose waves' realisation misses its tolerance solved densely)
    or 'auto' (the chain from CHAIN_MIN_SPRINGS springs, CHAIN_MIN_SPRINGS_3D with springs
    in several directions).
    """
    if method not in ("auto", "dense", "chain"):
        raise ValueError(f"method = {method!r}: give 'auto', 'dense' or 'chain'")
    n_s, n_p, n_rx, n_fx = kernel.shape
    nf = len(kernel.frequency)
    K_sets = _check_stiffness(stiffness, nf, n_s, kernel.spring_direction)
    groups = spring_families(kernel.ss)
    if len(groups) > 1:
        n_out = kernel.rs.shape[2]
        direct = kernel.rP[:, kernel.rP_index].transpose(0, 3, 1, 2)  # (nf, o, rx, fx)
        return direct - sum(direct - couple_discrete(_family_kernel(kernel, g), K_sets,
                                                     method)
                            for g in groups)
    n = n_s * n_p
    chain = None
    several = np.any(kernel.spring_direction != 2)
    if method == "chain" or (method == "auto" and n >= (CHAIN_MIN_SPRINGS_3D if several
                                                          else CHAIN_MIN_SPRINGS)):
        chain = chain_plan(kernel.spring_x, kernel.ss_index, n_p)
    # flat gather indices into (n_u * n_p * n_p) etc., built once per call
    pp = np.arange(n_p)
    ss_diag = ((np.diag(kernel.ss_index)[:, None] * n_p + pp) * n_p + pp).ravel()
    dense = {}  # the dense solve's gather and mirror plan, built when first needed
    sP_flat = (kernel.sP_index[:, None, :] * n_p + pp[None, :, None]).reshape(n, n_fx)
    n_out = kernel.rs.shape[2]
    oo = np.arange(n_out)
    rs_flat = ((kernel.rs_index[None, :, :, None] * n_out + oo[:, None, None, None]) * n_p
               + pp[None, None, None, :]).reshape(n_out * n_rx, n)
    rP_flat = kernel.rP_index[None, :, :] * n_out + oo[:, None, None]
    out = np.empty((nf, n_out, n_rx, n_fx), dtype=complex)
    step = 1 if chain is None else max(1, min(16, int(2e6 / (n * max(n_fx, 1)))))
    for i0 in range(0, nf, step):
        fs = range(i0, min(nf, i0 + step))
        rows = [_scaled_rows(kernel, K_sets[i], ss_diag, sP_flat, i) for i in fs]
        a, b, rhs = (np.stack(x) for x in zip(*rows))
        Fs = ([None] * len(fs) if chain is None
              else chain_solve(chain, kernel.ss[fs.start:fs.stop], a, b, rhs))
        for j, i in enumerate(fs):
            out[i] = _respond(kernel, i, Fs[j], a[j], b[j], rhs[j], dense, K_sets, pp,
                              rs_flat, rP_flat)
    return out


def _scaled_rows(kernel, K_set, ss_diag, sP_flat, i):
    """(a, b, rhs) of the coupling rows at frequency i (_row_scaling)."""
    K = _spring_stiffness(K_set, kernel.spring_weight, kernel.spring_direction)
    a, b = _row_scaling(K, kernel.ss[i].ravel()[ss_diag])
    return a, b, b[:, None] * kernel.sP[i].ravel()[sP_flat]


def _respond(kernel, i, F, a, b, rhs, dense, K_sets, pp, rs_flat, rP_flat):
    """(n_out, n_rx, n_fx) response at frequency i from the spring forces F, solved
    densely first when F is None (``dense`` keeps the gather and mirror plan)."""
    n_s, n_p, n_rx, n_fx = kernel.shape
    n = n_s * n_p
    ssr = kernel.ss[i].ravel()
    if F is None:
        if not dense:
            dense["ss"] = ((kernel.ss_index[:, None, :, None] * n_p
                            + pp[None, :, None, None]) * n_p
                           + pp[None, None, None, :]).reshape(n, n)
            dense["plan"] = mirror_plan(kernel, K_sets, dense["ss"])
        F = _solve_dense(dense["plan"], dense["ss"], ssr, a, b, rhs)
    G = kernel.rs[i].ravel()[rs_flat]
    return kernel.rP[i].ravel()[rP_flat] - (G @ F).reshape(-1, n_rx, n_fx)


@dataclass(frozen=True, kw_only=True, eq=False)
class PeriodicKernel(KernelArrays):
    """Floquet lattice sums of a rail on infinitely many identical supports at n * spacing.

    Each support has n_r rows (offsets o_a within the cell) of n_p springs. With
    theta the Floquet angles (n_t), the lattice sum L(delta, theta) = sum_j alpha(delta + j d)
    exp(-i j theta) obeys L(r + m d) = exp(i m theta) L(r), so it is stored at distinct
    residuals r in [-d/2, d/2) with the integer shift m:

    frequency (nf,) Hz; theta (n_t,); spring_weight (n_p,);
    ss: (nf, n_t, n_r n_p, n_r n_p) spring <- spring;
    sP: (nf, n_t, n_u, n_p) spring <- load at residual u; sP_u, sP_m: (n_r, n_fx);
    rs: (nf, n_t, n_u, n_out, n_p) response <- spring; rs_u, rs_m: (n_rx, n_r);
    direct: (nf, n_out, n_rx, n_fx) the theta-mean of the response <- load lattice
    (the free rail, aliased like the rest of the theta quadrature).
    """

    frequency: np.ndarray
    theta: np.ndarray
    spring_weight: np.ndarray
    ss: np.ndarray
    sP: np.ndarray
    sP_u: np.ndarray
    sP_m: np.ndarray
    rs: np.ndarray
    rs_u: np.ndarray
    rs_m: np.ndarray
    direct: np.ndarray
    spring_direction: np.ndarray | None = None



def theta_mean(values: np.ndarray, theta: np.ndarray, m: np.ndarray) -> np.ndarray:
    """mean_t exp(i m theta_t) values[t, ...] for every integer m, by one FFT over axis 0;
    theta must be the grid -pi + 2 pi t / n_t. Returns (len(m),) + values.shape[1:]."""
    n = len(theta)
    spec = np.fft.ifft(values, axis=0)  # (1/n) sum_t exp(+2 pi i t q / n) values[t]
    m = np.asarray(m, dtype=int)
    sign = np.where(m % 2 == 0, 1.0, -1.0)  # exp(i m theta_0) = exp(-i m pi)
    return sign.reshape((-1,) + (1,) * (values.ndim - 1)) * spec[m % n]


def couple_periodic(kernel: PeriodicKernel, stiffness) -> np.ndarray:
    """Receptance (nf, n_out, n_rx, n_fx) of the rail on identical periodic supports (m/N).

    stiffness: (nf, n_r) dynamic stiffness of each spring row of one support (N/m), or
    (nf, n_r, 3) per direction x, y, z.
    Per Floquet angle (I + K L_ss) Z = K L_sP is solved for a unit load at each distinct
    residual and row; the reacted response sum_t exp(i n theta) L_rs Z is then one FFT over
    theta, gathered at the shifts n = m_rs + m_sP of each response-load pair.
    """
    nf, n_t = kernel.ss.shape[:2]
    n_r = kernel.sP_u.shape[0]
    n_p = len(kernel.spring_weight)
    n = n_r * n_p
    n_u = kernel.sP.shape[2]
    n_out = kernel.rs.shape[3]
    K_rows = _check_stiffness(stiffness, nf, n_r, kernel.spring_direction)
    n_rx, n_fx = kernel.direct.shape[2:]
    diag = np.arange(n)
    rows = np.arange(n_r)
    out = np.empty((nf, n_out, n_rx, n_fx), dtype=complex)
    shifts = kernel.rs_m[:, :, None, None] + kernel.sP_m.T[None, None, :, :]  # (rx, a, fx, b)
    need, inv = np.unique(shifts, return_inverse=True)
    inv = inv.reshape(shifts.shape)
    ia = rows[None, :, None, None]
    ib = rows[None, None, None, :]
    iu_rs = kernel.rs_u[:, :, None, None]
    iu_sP = kernel.sP_u.T[None, None, :, :]
    for i in range(nf):
        K = _spring_stiffness(K_rows[i], kernel.spring_weight, kernel.spring_direction)
        Lss = kernel.ss[i]
        a, b = _row_scaling(K, np.abs(Lss[:, diag, diag]).mean(axis=0))
        M = b[None, :, None] * Lss
        M[:, diag, diag] += a
        # right-hand sides: row b of the cell loaded through its springs by residual u
        rhs = np.zeros((n_t, n_r, n_p, n_r, n_u), dtype=complex)
        sP = kernel.sP[i].transpose(0, 2, 1)  # (t, p, u)
        for r in range(n_r):
            rhs[:, r, :, r, :] = sP
        rhs = rhs.reshape(n_t, n, n_r * n_u) * b[None, :, None]
        Z = np.linalg.solve(M, rhs).reshape(n_t, n_r, n_p, n_r, n_u)
        # H[t, u', o, a, b, u] = sum_p L_rs[t, u', o, p] Z[t, a, p, b, u]
        H = np.einsum("tvop,tapbu->tvoabu", kernel.rs[i], Z, optimize=True)
        Hm = theta_mean(H, kernel.theta, need)  # (n_need, u', o, a, b, u)
        reacted = Hm[inv, iu_rs, :, ia, ib, iu_sP]  # (rx, a, fx, b, o)
        out[i] = kernel.direct[i] - reacted.sum(axis=(1, 3)).transpose(2, 0, 1)
    return out
