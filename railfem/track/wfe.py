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
solve with the supports' K(omega) (railfem.track.coupling); the ``*_receptance`` functions do both.

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
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from .coupling import (
    DiscreteKernel, PeriodicKernel, couple_discrete, couple_periodic, theta_mean,
    unique_separations,
)
from ..rail.greens import combine, residue_sum, wave_kernels
from ..rail.mobility import FamilyResponse, Location, boundary_edges, check_frequency, wave_sum
from .directions import PAD_ROLL, directional_stiffness, family_direction
from .supports import SupportLayout, dynamic_stiffness
from ..rail.waveguide import Waveguide
from ..rail.waves import FamilyOperators, frozen_tail, join, waves_at

log = logging.getLogger(__name__)

FAMILY = "symmetric"
DEFAULT_N_FOOT_SPRINGS = 8  # METHOD.md section 2
DEFAULT_N_THETA = 512  # Floquet angles; see tests/test_track.py for the convergence check


#: A load excites a family when its projection on it exceeds this fraction of its largest
#: projection; a spring column is kept when its projection on an excited family does.
#: Mirror images computed in floating point leave round-off (1e-17 .. 1e-15) on the other
#: family, which is not an excitation.
FAMILY_TOL = 1e-9
COMPONENT = {"x": 0, "y": 1, "z": 2}
#: direction code of the foot's roll column (the fastening's roll restraint, foot_springs)
ROLL_CODE = 3
#: direction code of the vertical springs' mirror-pair differences: the pad against the
#: foot's roll (railfem.track.directions.PAD_ROLL)
PAD_ROLL_CODE = 4
CODES = {**COMPONENT, "r": ROLL_CODE, PAD_ROLL: PAD_ROLL_CODE}


@dataclass(frozen=True, kw_only=True)
class FootSprings:
    """Springs across the rail-foot underside as generalised columns.

    pairs: one Location per mirror pair of vertical springs, their sum (weights 1/2 on each
    spring's vertical DOFs, so the pair's generalised force is the pair's total force and
    its displacement the springs' mean): what a vertical load on the mirror plane loads.
    weight: (n_pairs,) share of the support carried by each pair (sums to 1).
    y: (n_pairs,) |y| of the pair's springs (m).

    others: further columns, each the sum or the difference (1/2 (w_a - w_b)) of a mirror
    pair in one direction; other_weight their shares, other_direction 'z', 'y' or 'x'.
    Two equal independent springs a, b are exactly the sum and difference columns, each
    with the pair's stiffness (F_a = K u_a, F_b = K u_b gives F_s = 2K u_s, F_d = 2K u_d
    with u_s, u_d the mean and half difference): no coupling between them. Each column lies
    in one symmetry family: vertical and longitudinal sums and the lateral difference in
    the symmetric family, the others in the antisymmetric one.
    """

    pairs: tuple[Location, ...]
    weight: np.ndarray
    y: np.ndarray
    others: tuple[Location, ...] = ()
    other_weight: np.ndarray = field(default_factory=lambda: np.zeros(0))
    other_direction: tuple[str, ...] = ()

    @property
    def directions(self) -> str:
        """The directions the springs act in, canonical order z, y, x (and r: the roll)."""
        return "".join(d for d in "zyxr" if d == "z" or d in self.other_direction)


def foot_springs(guide: Waveguide, n_f: int = DEFAULT_N_FOOT_SPRINGS, *,
                 rule: str = "nodes", directions: str = "z") -> FootSprings:
    """n_f springs of a support across the rail-foot underside, grouped in mirror pairs
    (railfem.track.footprints): ``rule="nodes"`` at the nodes nearest to equal strips, weighted by
    tributary width (METHOD.md section 2, the published configuration); ``"midpoint"`` at
    the strip centres through the P2 edge shape functions (the distributed bed).
    directions: 'z' or with 'y' (lateral) and 'x' (longitudinal): each spring position
    carries one spring per direction, on the same footprint; 'r' adds the foot's roll as
    one generalised column (footprints.roll_reads: the fastening's roll restraint).
    A FootSprings passed as n_f is returned as it is, so the models take any footprint."""
    from .footprints import roll_reads, spring_reads, width_points

    if isinstance(n_f, FootSprings):
        return n_f
    if "z" not in directions or not set(directions) <= set("zyxr"):
        raise ValueError(f"spring directions = {directions!r}: give 'z' with optionally 'y' "
                         "(lateral) and 'x' (longitudinal), e.g. 'zyx'")
    wp = width_points(guide, n_f, rule)
    others, weight, direction = [], [], []
    for d in "zyx":
        if d not in directions:
            continue
        reads, _, share = spring_reads(guide, n_f, rule, COMPONENT[d])
        for i in range(n_f // 2 + n_f % 2):
            a, b = i, n_f - 1 - i
            pair_share = share[a] + (share[b] if b != a else 0.0)
            parts = [("-", 0.5 * (reads[a] - reads[b]))] if b != a else []
            if d != "z":  # the vertical sums are ``pairs``
                parts.insert(0, ("+", 0.5 * (reads[a] + reads[b])))
            for sign, w in parts:
                others.append(Location(label=f"foot_spring_{i}_{d}{sign}", weights=w))
                weight.append(pair_share)
                direction.append(PAD_ROLL if d + sign == PAD_ROLL else d)
    if "r" in directions:  # the roll: a moment on the foot, the whole support's restraint
        others.append(roll_reads(guide, n_f, rule))
        weight.append(1.0)
        direction.append("r")
    return FootSprings(pairs=wp.pairs, weight=wp.share, y=wp.y, others=tuple(others),
                       other_weight=np.array(weight), other_direction=tuple(direction))


def excited_families(guide: Waveguide, loads) -> list[str]:
    """The families of ``guide`` on which any of the loads (Locations) has a component
    (FAMILY_TOL): a vertical load on the mirror plane excites the symmetric family only,
    a lateral or off-centre load both."""
    out = []
    for loc in loads:
        proj = {f: np.abs(guide.families[f].T.T @ loc.weights).max() for f in guide.families}
        top = max(proj.values())
        out += [f for f, v in proj.items() if v > FAMILY_TOL * top and f not in out]
    return [f for f in guide.families if f in out]


def spring_columns(guide: Waveguide, springs: FootSprings, families) -> tuple:
    """(locations, shares, direction codes 0/1/2 = x/y/z) of the spring columns with a
    component on one of ``families``: the vertical sums first, in their order (a vertical
    load on the mirror plane keeps exactly those), then the others."""
    locs = list(springs.pairs) + list(springs.others)
    share = np.concatenate([np.asarray(springs.weight, dtype=float),
                            np.asarray(springs.other_weight, dtype=float)])
    code = np.array([2] * len(springs.pairs)
                    + [CODES[d] for d in springs.other_direction],
                    dtype=np.int64)
    keep = []
    for j, loc in enumerate(locs):
        top = np.abs(loc.weights).max()
        if any(np.abs(guide.families[f].T.T @ loc.weights).max() > FAMILY_TOL * top
               for f in families):
            keep.append(j)
    return [locs[j] for j in keep], share[keep], code[keep]


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
    f = check_frequency(frequency)
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
                      tail: bool, families, tail_frequency: float | None = None):
    """Per frequency, a list over ``families`` (those the loads excite, excited_families)
    of (k, X, Xm, denom); the frozen near-field tail (waves.frozen_tail) is projected once
    and appended at each frequency. A family no load excites adds nothing (the supports
    are mirror-symmetric), e.g. the antisymmetric part of an off-centre vertical sensor
    under a vertical load on the mirror plane. The tail is solved at ``tail_frequency``
    (Hz; default the lowest of f)."""
    f_tail = f.min() if tail_frequency is None else float(tail_frequency)
    fams = []
    for fam in families:
        Wr = np.asarray(guide.families[fam].T.T @ W)
        comp = guide.families[fam].component
        Wm = np.where(comp == 0, -1.0, 1.0)[:, None] * Wr
        ops = FamilyOperators(guide, fam)
        t = frozen_tail(ops, 2 * np.pi * f_tail, n_waves) if tail else None
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


def _columns(guide: Waveguide, springs: FootSprings, load: Location,
             outputs: list[Location]):
    """(W, spring cols, load col, output cols, families, spring shares, spring directions)
    of a problem: the families the load excites and the spring columns on them."""
    families = excited_families(guide, [load])
    cols, share, code = spring_columns(guide, springs, families)
    W = np.column_stack([c.weights for c in cols] + [load.weights]
                        + [o.weights for o in outputs])
    n_p = len(cols)
    return (W, np.arange(n_p), np.array([n_p]), n_p + 1 + np.arange(len(outputs)), families,
            share, code)


def spring_stiffness(layout: SupportLayout, omega, kernel) -> np.ndarray:
    """The coupling's spring-set stiffness for ``kernel``'s springs: (nf, n_sets) vertical
    when all its springs are vertical, else (nf, n_sets, 3) in the directions x, y, z, or
    (nf, n_sets, 4) with the roll restraint (N m/rad) as the fourth, (nf, n_sets, 5) with
    the pad against the foot's roll (directions.PAD_ROLL) as the fifth
    (railfem.track.coupling)."""
    codes = np.asarray(kernel.spring_direction)
    if np.all(codes == 2):
        return layout.spring_stiffness(omega)
    dirs = ["x", "y", "z", "r", PAD_ROLL][:max(3, int(codes.max()) + 1)]
    return np.stack([layout.spring_stiffness(omega, d) for d in dirs], axis=-1)


# ------------------------------------------------------------------ discrete supports


def discrete_kernel(guide: Waveguide, springs: FootSprings, spring_x, frequency, *,
                    load: Location, outputs: list[Location], force_x, response_x,
                    spring_length: float = 0.0, load_length: float = 0.02,
                    response_length: float = 0.0, n_waves: int = 40, tail: bool = True,
                    progress=None, eta_r: float | None = None,
                    tail_frequency: float | None = None) -> DiscreteKernel:
    """The parameter-free part of the discrete-support model (railfem.track.coupling): free-rail
    receptances between the spring sets at ``spring_x`` (m; one set of foot springs per
    support or row), the load at ``force_x`` and the outputs at ``response_x``.

    spring_length: length along the rail over which each set spreads its force (m);
    load_length / response_length: the same for the load and the outputs.
    eta_r: the rail's loss factor, default the guide's; another value re-uses the guide's
    matrices and its undamped near-field tail (waves.frozen_tail): only the retained waves
    are solved again. tail_frequency: where the frozen near-field tail is solved (Hz,
    default the lowest of ``frequency``): a part of a frequency grid computed with its
    grid's lowest frequency gives that grid's kernel at those frequencies exactly."""
    if eta_r is not None and eta_r != guide.loss_factor:
        guide = guide.with_loss_factor(eta_r)
    f, fx, rx = _axes(frequency, force_x, response_x)
    xs = np.atleast_1d(np.asarray(spring_x, dtype=float))
    W, S, P, R, families, share, code = _columns(guide, springs, load, outputs)
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
    for i, sets in enumerate(_projection_sweep(guide, W, f, n_waves, tail, families,
                                               tail_frequency)):
        ss[i] = _green(sets, S, S, u_ss, Ls, Ls).transpose(1, 0, 2)
        sP[i] = _green(sets, S, P, u_sP, load_length, Ls)[..., 0].T
        rs[i] = _green(sets, R, S, u_rs, Ls, response_length).transpose(1, 0, 2)
        rP[i] = _green(sets, R, P, u_rP, load_length, response_length)[..., 0].T
        if progress:
            progress(i + 1, nf)
    return DiscreteKernel(frequency=f, spring_weight=share, spring_direction=code,
                          spring_x=xs, ss=ss, ss_sep=u_ss, ss_index=i_ss, sP=sP,
                          sP_index=i_sP, rs=rs, rs_index=i_rs,
                          rP=rP, rP_index=i_rP)


def discrete_receptance(guide: Waveguide, layout: SupportLayout, frequency, *, load: Location,
                        outputs: list[Location], force_x, response_x,
                        n_f: int = DEFAULT_N_FOOT_SPRINGS, load_length: float = 0.02,
                        response_length: float = 0.0, n_waves: int = 40, tail: bool = True,
                        directions: str = "z", progress=None) -> TrackResponse:
    """WFE rail on the discrete supports of ``layout`` (each support may differ):
    ``discrete_kernel`` then ``coupling.couple_discrete``.

    The load is spread over load_length along the rail, outputs are averaged over
    response_length (equal lengths make the result reciprocal in load and output). The
    supports are taken exactly as laid out: keep loads and responses well inside them
    (``railfem.models`` re-centres a uniform layout on each load-response pair).
    directions: the directions the supports act in ('z', or with 'y' and 'x', see
    foot_springs; a FootSprings given as n_f brings its own)."""
    springs = foot_springs(guide, n_f, directions=directions)
    kernel = discrete_kernel(guide, springs, layout.springs().x, frequency,
                             load=load, outputs=outputs, force_x=force_x,
                             response_x=response_x, spring_length=layout.row_length,
                             load_length=load_length, response_length=response_length,
                             n_waves=n_waves, tail=tail, progress=progress)
    f = kernel.frequency
    out = couple_discrete(kernel, spring_stiffness(layout, 2 * np.pi * f, kernel))
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
            fwd, _ = wave_kernels(ka, delta + m * d, Lf, Lr)
            _, bwd = wave_kernels(ka, delta - m * d, Lf, Lr)
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
    """The parameter-free part of the periodic-support model (railfem.track.coupling): Floquet
    lattice sums of the free rail between the spring rows of one cell (offsets
    ``row_offsets`` from the support centre, supports at x = n * spacing), the load at
    ``force_x`` and the outputs at ``response_x``, at ``n_theta`` angles."""
    f, fx, rx = _axes(frequency, force_x, response_x)
    if int(n_theta) != n_theta or n_theta < 16:
        raise ValueError(f"n_theta = {n_theta!r}: use an integer >= 16 Floquet angles")
    o = np.atleast_1d(np.asarray(row_offsets, dtype=float))
    d = float(spacing)
    W, S, P, R, families, share, code = _columns(guide, springs, load, outputs)
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
    for i, sets in enumerate(_projection_sweep(guide, W, f, n_waves, tail, families)):
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
    return PeriodicKernel(frequency=f, theta=theta, spring_weight=share,
                          spring_direction=code, ss=ss,
                          sP=sP, sP_u=i_sP, sP_m=m_sP, rs=rs, rs_u=i_rs, rs_m=m_rs,
                          direct=direct)


def periodic_receptance(guide: Waveguide, params, spacing: float, frequency, *, load: Location,
                        outputs: list[Location], force_x, response_x, pad_length: float = 0.0,
                        n_rows: int = 1, n_f: int = DEFAULT_N_FOOT_SPRINGS,
                        load_length: float = 0.02, n_theta: int = DEFAULT_N_THETA,
                        n_waves: int = 40, tail: bool = True, directions: str = "z",
                        progress=None) -> TrackResponse:
    """WFE rail on infinitely many identical supports at x = n * spacing (Floquet):
    ``periodic_kernel`` then ``coupling.couple_periodic``."""
    from .supports import uniform_layout

    cell = uniform_layout(params, spacing, n=1, pad_length=pad_length, n_rows=n_rows)
    kernel = periodic_kernel(guide, foot_springs(guide, n_f, directions=directions),
                             cell.springs().x, spacing,
                             frequency, load=load, outputs=outputs, force_x=force_x,
                             response_x=response_x, spring_length=cell.row_length,
                             load_length=load_length, n_theta=n_theta, n_waves=n_waves,
                             tail=tail, progress=progress)
    f = kernel.frequency
    out = couple_periodic(kernel, spring_stiffness(cell, 2 * np.pi * f, kernel))
    _, fx, rx = _axes(f, force_x, response_x)
    return TrackResponse(frequency=f, receptance=out, outputs=tuple(o.label for o in outputs),
                         response_x=rx, force_x=fx)


def foot_bed(guide: Waveguide, component: int = 2) -> sp.csr_matrix:
    """Diagonal (row-sum lumped) distribution of a unit foundation stiffness over the
    rail-foot underside: consistent P2 edge weights by lateral width, summing to 1, on the
    DOFs of ``component`` (2 = u_z, the vertical bed; 1 = u_y lateral, 0 = u_x)."""
    under = guide.node_sets.get("foot_underside", np.array([], dtype=int))
    ed = boundary_edges(guide)
    ed = ed[np.isin(ed[:, 0], under) & np.isin(ed[:, 1], under)]
    if len(ed) == 0:
        raise ValueError("the mesh has no rail-foot underside edges to carry a continuous "
                         "support: check the profile's foot (lowest straight edge)")
    width = np.abs(guide.nodes[ed[:, 0], 0] - guide.nodes[ed[:, 1], 0])
    diag = np.zeros(guide.n_dofs)
    for nodes, share in zip(ed, width):
        diag[guide.node_dofs[nodes, component]] += share * np.array([1 / 6, 1 / 6, 2 / 3])
    return sp.diags(diag / diag.sum()).tocsr()


def roll_bed(guide: Waveguide, n: int = 64):
    """g g^T (sparse) with g the foot's roll reading (footprints.roll_reads, midpoint rule,
    n points): the stiffness matrix of a unit roll restraint (N m/rad) on the foot."""
    from .footprints import roll_reads

    g = sp.csr_matrix(roll_reads(guide, n, "midpoint").weights[None, :])
    return (g.T @ g).tocsr()


def supported_operators(guide: Waveguide, params, spacing: float, family: str = FAMILY,
                        directions: str = "z") -> FamilyOperators:
    """Operators of one family of the rail on the continuous foundation (in the
    ``directions`` z, y, x, each direction's chain K_d(omega)/spacing per metre spread over
    the foot underside; the vertical bed on the antisymmetric family, the foot's roll, with
    the pad against the rail seat, directions.family_direction): its waves are the free
    waves of the continuously supported track."""
    ops = FamilyOperators(guide, family)
    T = guide.families[family].T
    beds = [(family_direction(d, family),
             (T.T @ (roll_bed(guide) if d == "r" else foot_bed(guide, COMPONENT[d]))
              @ T).tocsr()[ops.order][:, ops.order])
            for d in "zyxr" if d in directions]
    if len(beds) == 1 and beds[0][0] == "z":
        bed = beds[0][1]
        ops.extra = lambda omega: (dynamic_stiffness(params, omega).item() / spacing) * bed
    else:
        ops.extra = lambda omega: sum(
            (directional_stiffness(params, omega, d).item() / spacing) * b for d, b in beds)
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
                          directions: str = "z", progress=None) -> TrackResponse:
    """WFE rail on a continuous foundation K_s(omega)/spacing per metre (METHOD.md section 2),
    spread over the rail-foot underside, acting in ``directions`` ('z', or with 'y' and
    'x'). x: response positions relative to the load (m). The families the load excites
    are solved and superposed."""
    f, _, rx = _axes(frequency, [0.0], x)
    if not np.isfinite(spacing) or spacing <= 0:
        raise ValueError(f"spacing = {spacing!r} m: use the sleeper spacing > 0 m")
    foot_bed(guide)  # the foot underside must exist
    R = np.column_stack([o.weights for o in outputs])
    parts = []
    for fam in excited_families(guide, [load]):
        ops = supported_operators(guide, params, spacing, fam, directions)
        fr = FamilyResponse(guide, fam, load.weights[:, None], R)
        parts.append((fr, _wave_sets(ops, f, n_waves, tail)))
    out = np.zeros((len(f), len(outputs), len(rx), 1), dtype=complex)
    for i in range(len(f)):
        for fr, sets in parts:
            out[i] += wave_sum(fr, next(sets), rx, load_length, 0.0)
        if progress:
            progress(i + 1, len(f))
    return TrackResponse(frequency=f, receptance=out, outputs=tuple(o.label for o in outputs),
                         response_x=rx, force_x=np.zeros(1))
