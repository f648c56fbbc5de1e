"""The WFE rail on supports (METHOD.md section 2): continuous, discrete and periodic.

Vertical loading on the rail's mirror plane excites only the symmetric wave family, and the
rail-foot springs come in mirror pairs carrying equal forces, so every model here works on
that family with one unknown per spring pair (half the unknowns and half the eigen-solve).

Sign convention: F are the forces the rail puts on the springs (compression positive when
the rail moves down), K the spring dynamic stiffness, alpha free-rail receptances. Then

    (I + K alpha_ss) F = K alpha_sP P,     u_r = alpha_rP P - alpha_rs F

which is METHOD.md's (Y_rf + Y_s) F = Y_P P multiplied by K and written for receptance
(mobility = i omega receptance throughout). Multiplying by K keeps an absent (K = 0) or
rigid spring well-posed.

The discrete and periodic models are split into a parameter-free kernel (free-rail Green's
functions, ``discrete_kernel`` / ``periodic_kernel``, computed here) and a cheap coupling
solve with the supports' K(omega) (railfem.coupling); the ``*_receptance`` functions do both.

* ``discrete_receptance``: a finite set of supports (default 131) centred on the load;
  alpha_ss depends only on the separation, so it is built from one residue sum per distinct
  separation (the block-Toeplitz structure) and solved densely.
* ``periodic_receptance``: infinitely many identical supports. With F_n the forces at
  support n, F_n = (1/2pi) int F(theta) exp(i n theta) dtheta turns the infinite system into
  one small system per Floquet angle theta, whose lattice sums over the supports are
  geometric series of the waves, summed in closed form; the theta integral is a periodic
  trapezoid rule (spectrally convergent; its error is checked in the tests). Lattice sums
  are kept at distinct residuals of the separations modulo the spacing, and the integer
  shifts become one FFT over theta.
* ``continuous_receptance``: a foundation of dynamic stiffness K_s/d per metre spread over
  the rail-foot underside, added to the section stiffness before the wave solve.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .coupling import (DiscreteKernel, PeriodicKernel, couple_discrete, couple_periodic,
                       theta_mean, unique_separations)
from .mobility import FamilyResponse, Location, _kernels, combine, residue_sum, wave_sum
from .supports import SupportLayout, dynamic_stiffness, foot_spring_weights
from .waveguide import Waveguide
from .waves import FamilyOperators, frozen_tail, join, waves_at

log = logging.getLogger(__name__)

FAMILY = "symmetric"
DEFAULT_N_FOOT_SPRINGS = 8  # METHOD.md section 2
DEFAULT_N_THETA = 512  # Floquet angles; see tests/test_track.py for the convergence check


@dataclass(frozen=True, kw_only=True)
class FootSprings:
    """Spring pairs across the rail-foot underside.

    pairs: one Location per mirror pair (weights 1/2 on each node's vertical DOF, so the
    pair's generalised force is the pair's total force and its displacement the nodes'
    mean). weight: (n_pairs,) share of the support carried by each pair (sums to 1).
    y: (n_pairs,) |y| of the pair's nodes (m).
    """

    pairs: tuple[Location, ...]
    weight: np.ndarray
    y: np.ndarray


def foot_springs(guide: Waveguide, n_f: int = DEFAULT_N_FOOT_SPRINGS) -> FootSprings:
    """n_f springs at foot-underside nodes nearest to equal strips of the foot width,
    weighted by tributary width (supports.foot_spring_weights), grouped in mirror pairs."""
    under = guide.node_sets.get("foot_underside", np.array([], dtype=int))
    if len(under) < 2:
        raise ValueError(
            f"the mesh has {len(under)} rail-foot underside node(s); supports need the foot "
            "underside (the lowest straight edge of the profile): check the profile outline "
            "and that the mesh was built by railfem.meshing")
    if int(n_f) != n_f or n_f < 1:
        raise ValueError(f"n_f = {n_f!r}: the number of foot springs must be an integer >= 1")
    y = guide.nodes[under, 0]
    width = y.max() - y.min()
    targets = y.min() + (np.arange(n_f) + 0.5) / n_f * width
    chosen = under[[int(np.argmin(np.abs(y - t))) for t in targets]]
    if len(set(chosen.tolist())) < n_f:
        raise ValueError(f"the foot underside has too few nodes for n_f = {n_f} springs "
                         f"({len(under)} nodes): refine the mesh or use fewer springs")
    yc = guide.nodes[chosen, 0]
    w = foot_spring_weights(yc - (y.max() + y.min()) / 2, width)
    pairs, weights, ys = [], [], []
    for i in range(n_f // 2 + n_f % 2):
        a, b = i, n_f - 1 - i
        wv = np.zeros(guide.n_dofs)
        wv[guide.dof(int(chosen[a]), "z")] += 0.5
        wv[guide.dof(int(chosen[b]), "z")] += 0.5
        pairs.append(Location(label=f"foot_spring_{i}", weights=wv))
        weights.append(w[a] + (w[b] if b != a else 0.0))
        ys.append(abs(yc[a]))
    return FootSprings(pairs=tuple(pairs), weight=np.array(weights), y=np.array(ys))


def _check_symmetric(guide: Waveguide, locs) -> None:
    if set(guide.families) != {"symmetric", "antisymmetric"}:
        raise ValueError(f"the supported-track models need a mirror-symmetric section mesh; "
                         f"{guide.mesh.name} is not (one wave family {list(guide.families)})")
    T = guide.families["antisymmetric"].T
    for loc in locs:
        if np.abs(T.T @ loc.weights).max() > 1e-12 * np.abs(loc.weights).max():
            raise ValueError(f"load {loc.label!r} is not symmetric about the web axis; the "
                             "supported-track models take vertical loads on the mirror plane")


@dataclass(frozen=True, kw_only=True)
class TrackResponse:
    """Receptance of a supported track.

    frequency: (nf,) Hz. receptance: (nf, n_out, n_resp_x, n_force_x) in m/N.
    outputs: labels of the response locations. response_x, force_x: positions (m).
    """

    frequency: np.ndarray
    receptance: np.ndarray
    outputs: tuple[str, ...]
    response_x: np.ndarray
    force_x: np.ndarray

    @property
    def mobility(self) -> np.ndarray:
        """Mobility (m/s/N), exp(+i omega t): i omega times the receptance."""
        return 1j * 2 * np.pi * self.frequency[:, None, None, None] * self.receptance


def _axes(frequency, force_x, response_x):
    from .mobility import _check_frequency

    f = _check_frequency(frequency)
    fx = np.atleast_1d(np.asarray(force_x, dtype=float))
    rx = np.atleast_1d(np.asarray(response_x, dtype=float))
    for name, v in (("force_x", fx), ("response_x", rx)):
        if v.ndim != 1 or not np.all(np.isfinite(v)):
            raise ValueError(f"{name} must be a 1-D array of finite positions (m), got {v!r:.80}")
    return f, fx, rx


# ------------------------------------------------------------------ Green's functions
# All locations of a problem (springs, load, outputs) are weight vectors stacked as the
# columns of W. Per family and frequency the waves are projected on them once:
# X = phi^T W_r and Xm = phi^T (T_a W_r) (T_a flips the axial DOFs), and the Green's function
# between any two column groups is a residue sum over those projections. Families on which
# no location has a component are skipped (for vertical loads and spring pairs on the mirror
# plane: the antisymmetric one).


def _projection_sweep(guide: Waveguide, W: np.ndarray, f: np.ndarray, n_waves: int,
                      tail: bool, forces: np.ndarray):
    """Per frequency, a list over the active families of (k, X, Xm, denom); the frozen
    near-field tail (waves.frozen_tail) is projected once and appended at each frequency.
    A family is active when a force column (springs or loads, ``forces``) has a component
    on it: a family no force excites adds nothing (e.g. the antisymmetric part of an
    off-centre vertical sensor under vertical loads and spring pairs)."""
    fams = []
    for fam in guide.families:
        Wr = np.asarray(guide.families[fam].T.T @ W)
        if not np.any(Wr[:, forces] != 0):
            continue
        comp = guide.families[fam].component
        Wm = np.where(comp == 0, -1.0, 1.0)[:, None] * Wr
        ops = FamilyOperators(guide, fam)
        t = frozen_tail(ops, 2 * np.pi * f.min(), n_waves) if tail else None
        tp = None if t is None else (t.k, t.phi.T @ Wr, t.phi.T @ Wm, t.denom)
        fams.append((ops, Wr, Wm, tp))
    for fi in f:
        sets = []
        for ops, Wr, Wm, tp in fams:
            w = waves_at(ops, 2 * np.pi * fi, method="shift-invert", n_waves=n_waves)
            p = (w.k, w.phi.T @ Wr, w.phi.T @ Wm, w.denom)
            if tp is not None:
                p = tuple(np.concatenate([u, v]) for u, v in zip(p, tp))
            sets.append(p)
        yield sets


def _terms(p, o, i):
    """wave_terms of the response columns o and force columns i of one projected set."""
    _, X, Xm, d = p
    return X[:, o].T, Xm[:, i] / d[:, None], Xm[:, o].T, X[:, i] / d[:, None]


def _green(sets, o, i, x, Lf, Lr) -> np.ndarray:
    """Receptance (n_o, nx, n_i) at separations x (response minus load position, m), summed
    over the families."""
    return sum(residue_sum(_terms(p, o, i), p[0], x, Lf, Lr) for p in sets)


def _columns(springs: FootSprings, load: Location, outputs: list[Location]):
    W = np.column_stack([p.weights for p in springs.pairs] + [load.weights]
                        + [o.weights for o in outputs])
    n_p = len(springs.pairs)
    return W, np.arange(n_p), np.array([n_p]), n_p + 1 + np.arange(len(outputs))


# ------------------------------------------------------------------ discrete supports


def discrete_kernel(guide: Waveguide, springs: FootSprings, spring_x, frequency, *,
                    load: Location, outputs: list[Location], force_x, response_x,
                    spring_length: float = 0.0, load_length: float = 0.02,
                    response_length: float = 0.0, n_waves: int = 40, tail: bool = True,
                    progress=None) -> DiscreteKernel:
    """The parameter-free part of the discrete-support model (railfem.coupling): free-rail
    receptances between the spring sets at ``spring_x`` (m; one set of foot springs per
    support or row), the load at ``force_x`` and the outputs at ``response_x``.

    spring_length: length along the rail over which each set spreads its force (m);
    load_length / response_length: the same for the load and the outputs."""
    f, fx, rx = _axes(frequency, force_x, response_x)
    xs = np.atleast_1d(np.asarray(spring_x, dtype=float))
    _check_symmetric(guide, [load])
    W, S, P, R = _columns(springs, load, outputs)
    u_ss, i_ss = unique_separations(xs[:, None] - xs[None, :])
    u_sP, i_sP = unique_separations(xs[:, None] - fx[None, :])
    u_rs, i_rs = unique_separations(rx[:, None] - xs[None, :])
    u_rP, i_rP = unique_separations(rx[:, None] - fx[None, :])
    n_p, n_o, nf = len(S), len(R), len(f)
    ss = np.empty((nf, len(u_ss), n_p, n_p), dtype=complex)
    sP = np.empty((nf, len(u_sP), n_p), dtype=complex)
    rs = np.empty((nf, len(u_rs), n_o, n_p), dtype=complex)
    rP = np.empty((nf, len(u_rP), n_o), dtype=complex)
    Ls = spring_length
    for i, sets in enumerate(_projection_sweep(guide, W, f, n_waves, tail,
                                                   np.concatenate([S, P]))):
        ss[i] = _green(sets, S, S, u_ss, Ls, Ls).transpose(1, 0, 2)
        sP[i] = _green(sets, S, P, u_sP, load_length, Ls)[..., 0].T
        rs[i] = _green(sets, R, S, u_rs, Ls, response_length).transpose(1, 0, 2)
        rP[i] = _green(sets, R, P, u_rP, load_length, response_length)[..., 0].T
        if progress:
            progress(i + 1, nf)
    return DiscreteKernel(frequency=f, spring_weight=np.asarray(springs.weight, dtype=float),
                          spring_x=xs, ss=ss, ss_sep=u_ss, ss_index=i_ss, sP=sP,
                          sP_index=i_sP, rs=rs, rs_index=i_rs,
                          rP=rP, rP_index=i_rP)


def discrete_receptance(guide: Waveguide, layout: SupportLayout, frequency, *, load: Location,
                        outputs: list[Location], force_x, response_x,
                        n_f: int = DEFAULT_N_FOOT_SPRINGS, load_length: float = 0.02,
                        response_length: float = 0.0, n_waves: int = 40, tail: bool = True,
                        progress=None) -> TrackResponse:
    """WFE rail on the discrete supports of ``layout`` (each support may differ):
    ``discrete_kernel`` then ``coupling.couple_discrete``.

    The load is spread over load_length along the rail, outputs are averaged over
    response_length (equal lengths make the result reciprocal in load and output). The
    supports are taken exactly as laid out: keep loads and responses well inside them
    (``railfem.models`` re-centres a uniform layout on each load-response pair)."""
    kernel = discrete_kernel(guide, foot_springs(guide, n_f), layout.springs().x, frequency,
                             load=load, outputs=outputs, force_x=force_x,
                             response_x=response_x, spring_length=layout.row_length,
                             load_length=load_length, response_length=response_length,
                             n_waves=n_waves, tail=tail, progress=progress)
    f = kernel.frequency
    out = couple_discrete(kernel, layout.spring_stiffness(2 * np.pi * f))
    _, fx, rx = _axes(f, force_x, response_x)
    return TrackResponse(frequency=f, receptance=out, outputs=tuple(o.label for o in outputs),
                         response_x=rx, force_x=fx)


# ------------------------------------------------------------------ periodic supports


def _reduce(delta: np.ndarray, d: float):
    """delta = m d + r with r in [-d/2, d/2): returns (m, r)."""
    m = np.floor(delta / d + 0.5)
    return m, delta - m * d


def _lattice(sets, o, i, delta, d, theta, Lf, Lr, n_explicit: int = 2) -> np.ndarray:
    """L(delta, theta) = sum_j G(delta + j d) exp(-i j theta), (n_theta, n_o, n_delta, n_i).

    Terms |j| <= n_explicit are summed directly (they contain the smoothing of loads and
    springs); beyond, every wave term is e^{-ik|x|} times a constant, so each wave's tail is
    a geometric series in q = exp(-i k d) exp(-+i theta), summed in closed form.
    """
    m = n_explicit + 1
    if (Lf + Lr) / 2 + d / 2 >= m * d - 1e-12:
        raise ValueError("load/pad lengths exceed the lattice's explicit range")
    js = np.arange(-n_explicit, n_explicit + 1)
    x = (delta[None, :] + js[:, None] * d).ravel()
    phase = np.exp(-1j * np.outer(theta, js))
    out = 0.0
    for p in sets:
        k, terms = p[0], _terms(p, o, i)
        G = residue_sum(terms, k, x, Lf, Lr).reshape(len(o), len(js), len(delta), len(i))
        L = np.einsum("tj,ojdi->todi", phase, G)
        alive = np.abs(np.exp(-1j * k * (m - 0.5) * d)) > 1e-14
        if alive.any():
            ka = k[alive]
            ta = (terms[0][:, alive], terms[1][alive], terms[2][:, alive], terms[3][alive])
            fwd, _ = _kernels(ka, delta + m * d, Lf, Lr)
            _, bwd = _kernels(ka, delta - m * d, Lf, Lr)
            q = np.exp(-1j * ka * d)[:, None]
            gf = np.exp(-1j * m * theta)[None, :] / (1 - q * np.exp(-1j * theta)[None, :])
            gb = np.exp(1j * m * theta)[None, :] / (1 - q * np.exp(1j * theta)[None, :])
            tl = combine(ta, fwd[:, :, None] * gf[:, None, :], bwd[:, :, None] * gb[:, None, :])
            L = L + tl.transpose(2, 0, 1, 3)
        out = out + L
    return out


def _residuals(delta: np.ndarray, d: float):
    """Distinct residuals of delta = m d + r: (r_unique, index of each delta, m)."""
    m, r = _reduce(delta, d)
    u, inv = unique_separations(r)
    return u, inv, m.astype(int)


def periodic_kernel(guide: Waveguide, springs: FootSprings, row_offsets, spacing: float,
                    frequency, *, load: Location, outputs: list[Location], force_x,
                    response_x, spring_length: float = 0.0, load_length: float = 0.02,
                    n_theta: int = DEFAULT_N_THETA, n_waves: int = 40, tail: bool = True,
                    progress=None) -> PeriodicKernel:
    """The parameter-free part of the periodic-support model (railfem.coupling): Floquet
    lattice sums of the free rail between the spring rows of one cell (offsets
    ``row_offsets`` from the support centre, supports at x = n * spacing), the load at
    ``force_x`` and the outputs at ``response_x``, at ``n_theta`` angles."""
    f, fx, rx = _axes(frequency, force_x, response_x)
    if int(n_theta) != n_theta or n_theta < 16:
        raise ValueError(f"n_theta = {n_theta!r}: use an integer >= 16 Floquet angles")
    _check_symmetric(guide, [load])
    o = np.atleast_1d(np.asarray(row_offsets, dtype=float))
    d = float(spacing)
    W, S, P, R = _columns(springs, load, outputs)
    n_r, n_p, n_o, nf = len(o), len(S), len(R), len(f)
    theta = -np.pi + 2 * np.pi * np.arange(n_theta) / n_theta
    dss = (o[:, None] - o[None, :]).ravel()
    u_sP, i_sP, m_sP = _residuals(o[:, None] - fx[None, :], d)
    u_rs, i_rs, m_rs = _residuals(rx[:, None] - o[None, :], d)
    u_rP, i_rP, m_rP = _residuals(rx[:, None] - fx[None, :], d)
    need, inv = np.unique(m_rP, return_inverse=True)
    inv = inv.reshape(m_rP.shape)
    n = n_r * n_p
    ss = np.empty((nf, n_theta, n, n), dtype=complex)
    sP = np.empty((nf, n_theta, len(u_sP), n_p), dtype=complex)
    rs = np.empty((nf, n_theta, len(u_rs), n_o, n_p), dtype=complex)
    direct = np.empty((nf, n_o, len(rx), len(fx)), dtype=complex)
    Ls = spring_length
    m_ss, r_ss = _reduce(dss, d)
    for i, sets in enumerate(_projection_sweep(guide, W, f, n_waves, tail,
                                                   np.concatenate([S, P]))):
        L = _lattice(sets, S, S, r_ss, d, theta, Ls, Ls)
        L = L * np.exp(1j * np.outer(theta, m_ss))[:, None, :, None]  # (t, p, r r', p')
        ss[i] = L.reshape(n_theta, n_p, n_r, n_r, n_p).transpose(0, 2, 1, 3, 4).reshape(
            n_theta, n, n)
        sP[i] = _lattice(sets, S, P, u_sP, d, theta, load_length, Ls)[..., 0].transpose(0, 2, 1)
        rs[i] = _lattice(sets, R, S, u_rs, d, theta, Ls, 0.0).transpose(0, 2, 1, 3)
        LrP = _lattice(sets, R, P, u_rP, d, theta, load_length, 0.0)[..., 0]  # (t, o, u)
        Lm = theta_mean(LrP, theta, need)  # (n_need, o, u)
        direct[i] = Lm[inv, :, i_rP].transpose(2, 0, 1)
        if progress:
            progress(i + 1, nf)
    return PeriodicKernel(frequency=f, theta=theta,
                          spring_weight=np.asarray(springs.weight, dtype=float), ss=ss,
                          sP=sP, sP_u=i_sP, sP_m=m_sP, rs=rs, rs_u=i_rs, rs_m=m_rs,
                          direct=direct)


def periodic_receptance(guide: Waveguide, params, spacing: float, frequency, *, load: Location,
                        outputs: list[Location], force_x, response_x, pad_length: float = 0.0,
                        n_rows: int = 1, n_f: int = DEFAULT_N_FOOT_SPRINGS,
                        load_length: float = 0.02, n_theta: int = DEFAULT_N_THETA,
                        n_waves: int = 40, tail: bool = True, progress=None) -> TrackResponse:
    """WFE rail on infinitely many identical supports at x = n * spacing (Floquet):
    ``periodic_kernel`` then ``coupling.couple_periodic``."""
    from .supports import uniform_layout

    cell = uniform_layout(params, spacing, n=1, pad_length=pad_length, n_rows=n_rows)
    kernel = periodic_kernel(guide, foot_springs(guide, n_f), cell.springs().x, spacing,
                             frequency, load=load, outputs=outputs, force_x=force_x,
                             response_x=response_x, spring_length=cell.row_length,
                             load_length=load_length, n_theta=n_theta, n_waves=n_waves,
                             tail=tail, progress=progress)
    f = kernel.frequency
    out = couple_periodic(kernel, cell.spring_stiffness(2 * np.pi * f))
    _, fx, rx = _axes(f, force_x, response_x)
    return TrackResponse(frequency=f, receptance=out, outputs=tuple(o.label for o in outputs),
                         response_x=rx, force_x=fx)


def foot_bed(guide: Waveguide) -> sp.csr_matrix:
    """Diagonal (row-sum lumped) distribution of a unit vertical foundation stiffness over the
    rail-foot underside: consistent P2 edge weights by lateral width, summing to 1."""
    from .mobility import _boundary_edges

    under = guide.node_sets.get("foot_underside", np.array([], dtype=int))
    ed = _boundary_edges(guide)
    ed = ed[np.isin(ed[:, 0], under) & np.isin(ed[:, 1], under)]
    if len(ed) == 0:
        raise ValueError("the mesh has no rail-foot underside edges to carry a continuous "
                         "support: check the profile's foot (lowest straight edge)")
    width = np.abs(guide.nodes[ed[:, 0], 0] - guide.nodes[ed[:, 1], 0])
    diag = np.zeros(guide.n_dofs)
    for nodes, share in zip(ed, width):
        diag[guide.node_dofs[nodes, 2]] += share * np.array([1 / 6, 1 / 6, 2 / 3])
    return sp.diags(diag / diag.sum()).tocsr()


def supported_operators(guide: Waveguide, params, spacing: float) -> FamilyOperators:
    """Symmetric-family operators of the rail on the continuous foundation: its waves are
    the free waves of the continuously supported track."""
    ops = FamilyOperators(guide, FAMILY)
    T = guide.families[FAMILY].T
    bed = (T.T @ foot_bed(guide) @ T).tocsr()[ops.order][:, ops.order]
    ops.extra = lambda omega: (dynamic_stiffness(params, omega).item() / spacing) * bed
    return ops


def _wave_sets(ops, f, n_waves, tail):
    """Waves of the family at each frequency, with the frozen near-field tail."""
    t = frozen_tail(ops, 2 * np.pi * f.min(), n_waves) if tail else None
    for fi in f:
        w = waves_at(ops, 2 * np.pi * fi, method="shift-invert", n_waves=n_waves)
        yield w if t is None else join(w, t)


def continuous_receptance(guide: Waveguide, params, spacing: float, frequency, *,
                          load: Location, outputs: list[Location], x,
                          load_length: float = 0.02, n_waves: int = 40, tail: bool = True,
                          progress=None) -> TrackResponse:
    """WFE rail on a continuous foundation K_s(omega)/spacing per metre (METHOD.md section 2),
    spread over the rail-foot underside. x: response positions relative to the load (m)."""
    f, _, rx = _axes(frequency, [0.0], x)
    if not np.isfinite(spacing) or spacing <= 0:
        raise ValueError(f"spacing = {spacing!r} m: use the sleeper spacing > 0 m")
    _check_symmetric(guide, [load])
    ops = supported_operators(guide, params, spacing)
    R = np.column_stack([o.weights for o in outputs])
    fr = FamilyResponse(guide, FAMILY, load.weights[:, None], R)
    out = np.empty((len(f), len(outputs), len(rx), 1), dtype=complex)
    for i, w in enumerate(_wave_sets(ops, f, n_waves, tail)):
        out[i] = wave_sum(fr, w, rx, load_length, 0.0)
        if progress:
            progress(i + 1, len(f))
    return TrackResponse(frequency=f, receptance=out, outputs=tuple(o.label for o in outputs),
                         response_x=rx, force_x=np.zeros(1))
