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

* ``discrete_receptance``: a finite set of supports (default 131) centred on the load;
  alpha_ss depends only on the separation, so it is built from one residue sum per distinct
  separation (the block-Toeplitz structure) and solved densely.
* ``periodic_receptance``: infinitely many identical supports. With F_n the forces at
  support n, F_n = (1/2pi) int F(theta) exp(i n theta) dtheta turns the infinite system into
  one small system per Floquet angle theta, whose lattice sums over the supports are
  geometric series of the waves, summed in closed form; the theta integral is a periodic
  trapezoid rule (spectrally convergent; its error is checked in the tests).
* ``continuous_receptance``: a foundation of dynamic stiffness K_s/d per metre spread over
  the rail-foot underside, added to the section stiffness before the wave solve.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .mobility import FamilyResponse, Location, _kernels, combine, wave_sum, wave_terms
from .supports import SupportLayout, dynamic_stiffness
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


def foot_springs(guide: Waveguide, n_f: int = DEFAULT_N_FOOT_SPRINGS, *,
                 rule: str = "nodes") -> FootSprings:
    """n_f springs of a support across the rail-foot underside, grouped in mirror pairs
    (railfem.footprints): ``rule="nodes"`` at the nodes nearest to equal strips, weighted by
    tributary width (METHOD.md section 2, the published configuration); ``"midpoint"`` at
    the strip centres through the P2 edge shape functions (the distributed bed).
    A FootSprings passed as n_f is returned as it is, so the models take any footprint."""
    from .footprints import width_points

    if isinstance(n_f, FootSprings):
        return n_f
    wp = width_points(guide, n_f, rule)
    return FootSprings(pairs=wp.pairs, weight=wp.share, y=wp.y)


def _check_symmetric(guide: Waveguide, locs) -> None:
    T = guide.families["antisymmetric"].T
    for loc in locs:
        if np.abs(T.T @ loc.weights).max() > 1e-12 * np.abs(loc.weights).max():
            raise ValueError(f"load {loc.label!r} is not symmetric about the web axis; the "
                             "supported-track models take vertical loads on the mirror plane")


@dataclass(frozen=True)
class _Setup:
    """Projections on the symmetric family of the load, the outputs and the springs."""

    sP: FamilyResponse  # springs <- load
    rP: FamilyResponse  # outputs <- load
    ss: FamilyResponse  # springs <- springs
    rs: FamilyResponse  # outputs <- springs
    spring_weight: np.ndarray


def _setup(guide, load, outputs, springs):
    _check_symmetric(guide, [load])
    S = np.column_stack([p.weights for p in springs.pairs])
    P = load.weights[:, None]
    R = np.column_stack([o.weights for o in outputs])
    fr = lambda Fw, Rw: FamilyResponse(guide, FAMILY, Fw, Rw)  # noqa: E731
    return _Setup(fr(P, S), fr(P, R), fr(S, S), fr(S, R), springs.weight)


def _wave_sets(ops, f, n_waves, tail):
    """Waves of the family at each frequency, with the frozen near-field tail."""
    t = frozen_tail(ops, 2 * np.pi * f.min(), n_waves) if tail else None
    for fi in f:
        w = waves_at(ops, 2 * np.pi * fi, method="shift-invert", n_waves=n_waves)
        yield w if t is None else join(w, t)


def _unique_sum(fr, w, sep, Lf, Lr):
    """wave_sum evaluated once per distinct separation, gathered back to sep's shape."""
    u, inv = np.unique(np.round(sep, 9), return_inverse=True)
    g = wave_sum(fr, w, u, Lf, Lr)  # (n_out, nu, n_in)
    return g[:, inv.reshape(sep.shape), :]  # (n_out, *sep.shape, n_in)


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


def _spring_length(layout: SupportLayout) -> float:
    """Each spring row spreads its force over its slice of the pad length."""
    return layout.pad_length / layout.n_rows if layout.pad_length > 0 else 0.0


def discrete_receptance(guide: Waveguide, layout: SupportLayout, frequency, *, load: Location,
                        outputs: list[Location], force_x, response_x,
                        n_f: int = DEFAULT_N_FOOT_SPRINGS, load_length: float = 0.02,
                        response_length: float = 0.0, n_waves: int = 40, tail: bool = True,
                        progress=None) -> TrackResponse:
    """WFE rail on the discrete supports of ``layout`` (each support may differ).

    The load is spread over load_length along the rail, outputs are averaged over
    response_length (equal lengths make the result reciprocal in load and output). The
    supports are taken exactly as laid out: keep loads and responses well inside them
    (``trackjob.track_receptance`` re-centres a uniform layout on each load-response pair)."""
    f, fx, rx = _axes(frequency, force_x, response_x)
    springs = foot_springs(guide, n_f)
    st = _setup(guide, load, outputs, springs)
    xs = layout.springs().x
    Ls = _spring_length(layout)
    ops = FamilyOperators(guide, FAMILY)
    n_s, n_p = len(xs), len(springs.pairs)
    K_rows = layout.spring_stiffness(2 * np.pi * f)  # (nf, n_s)
    out = np.empty((len(f), len(outputs), len(rx), len(fx)), dtype=complex)
    for i, w in enumerate(_wave_sets(ops, f, n_waves, tail)):
        A = _unique_sum(st.ss, w, xs[:, None] - xs[None, :], Ls, Ls)  # (p, s, s', p')
        A = A.transpose(1, 0, 2, 3).reshape(n_s * n_p, n_s * n_p)
        B = _unique_sum(st.sP, w, xs[:, None] - fx[None, :], load_length, Ls)  # (p, s, P, 1)
        B = B[..., 0].transpose(1, 0, 2).reshape(n_s * n_p, len(fx))
        K = (K_rows[i][:, None] * st.spring_weight[None, :]).ravel()
        F = np.linalg.solve(np.eye(n_s * n_p) + K[:, None] * A, K[:, None] * B)
        direct = _unique_sum(st.rP, w, rx[:, None] - fx[None, :], load_length,
                             response_length)[..., 0]
        G = _unique_sum(st.rs, w, rx[:, None] - xs[None, :], Ls, response_length)  # o,r,s,p
        out[i] = direct - np.einsum("orsp,spP->orP", G, F.reshape(n_s, n_p, len(fx)))
        if progress:
            progress(i + 1, len(f))
    return TrackResponse(frequency=f, receptance=out, outputs=tuple(o.label for o in outputs),
                         response_x=rx, force_x=fx)


def _axes(frequency, force_x, response_x):
    from .mobility import _check_frequency

    f = _check_frequency(frequency)
    fx = np.atleast_1d(np.asarray(force_x, dtype=float))
    rx = np.atleast_1d(np.asarray(response_x, dtype=float))
    for name, v in (("force_x", fx), ("response_x", rx)):
        if v.ndim != 1 or not np.all(np.isfinite(v)):
            raise ValueError(f"{name} must be a 1-D array of finite positions (m), got {v!r:.80}")
    return f, fx, rx


def _reduce(delta: np.ndarray, d: float):
    """delta = m d + r with r in [-d/2, d/2): returns (m, r)."""
    m = np.floor(delta / d + 0.5)
    return m, delta - m * d


def _lattice(fr, w, delta, d, theta, Lf, Lr, n_explicit: int = 2) -> np.ndarray:
    """L(delta, theta) = sum_j G(delta + j d) exp(-i j theta), (n_theta, n_out, n_delta, n_in).

    Terms |j| <= n_explicit are summed directly (they contain the smoothing of loads and
    springs); beyond, every wave term is e^{-ik|x|} times a constant, so each wave's tail is
    a geometric series in q = exp(-i k d) exp(-+i theta), summed in closed form.
    """
    m = n_explicit + 1
    if (Lf + Lr) / 2 + d / 2 >= m * d - 1e-12:
        raise ValueError("load/pad lengths exceed the lattice's explicit range")
    js = np.arange(-n_explicit, n_explicit + 1)
    x = delta[None, :] + js[:, None] * d
    G = wave_sum(fr, w, x.ravel(), Lf, Lr).reshape(-1, len(js), len(delta), fr.F.shape[1])
    out = np.einsum("tj,ojdi->todi", np.exp(-1j * np.outer(theta, js)), G)
    alive = np.abs(np.exp(-1j * w.k * (m - 0.5) * d)) > 1e-14
    if alive.any():
        k = w.k[alive]
        Rphi, a, Rphi_m, b = wave_terms(fr, w)
        terms = (Rphi[:, alive], a[alive], Rphi_m[:, alive], b[alive])
        fwd, _ = _kernels(k, delta + m * d, Lf, Lr)
        _, bwd = _kernels(k, delta - m * d, Lf, Lr)
        q = np.exp(-1j * k * d)[:, None]
        gf = np.exp(-1j * m * theta)[None, :] / (1 - q * np.exp(-1j * theta)[None, :])
        gb = np.exp(1j * m * theta)[None, :] / (1 - q * np.exp(1j * theta)[None, :])
        tail = combine(terms, fwd[:, :, None] * gf[:, None, :], bwd[:, :, None] * gb[:, None, :])
        out += tail.transpose(2, 0, 1, 3)
    return out


def _shifted_lattice(fr, w, delta, d, theta, Lf, Lr) -> np.ndarray:
    """_lattice for any delta, using L(r + m d) = exp(i m theta) L(r)."""
    m, r = _reduce(np.asarray(delta, dtype=float), d)
    L = _lattice(fr, w, r, d, theta, Lf, Lr)
    return L * np.exp(1j * np.outer(theta, m))[:, None, :, None]


def periodic_receptance(guide: Waveguide, params, spacing: float, frequency, *, load: Location,
                        outputs: list[Location], force_x, response_x, pad_length: float = 0.0,
                        n_rows: int = 1, n_f: int = DEFAULT_N_FOOT_SPRINGS,
                        load_length: float = 0.02, n_theta: int = DEFAULT_N_THETA,
                        n_waves: int = 40, tail: bool = True, progress=None) -> TrackResponse:
    """WFE rail on infinitely many identical supports at x = n * spacing (Floquet)."""
    from .supports import uniform_layout

    f, fx, rx = _axes(frequency, force_x, response_x)
    if int(n_theta) != n_theta or n_theta < 16:
        raise ValueError(f"n_theta = {n_theta!r}: use an integer >= 16 Floquet angles")
    cell = uniform_layout(params, spacing, n=1, pad_length=pad_length, n_rows=n_rows)
    o = cell.springs().x  # row offsets within the cell
    Ls = _spring_length(cell)
    springs = foot_springs(guide, n_f)
    st = _setup(guide, load, outputs, springs)
    n_r, n_p = len(o), len(springs.pairs)
    theta = -np.pi + 2 * np.pi * np.arange(n_theta) / n_theta
    K_rows = cell.spring_stiffness(2 * np.pi * f)  # (nf, n_r)
    ops = FamilyOperators(guide, FAMILY)
    out = np.empty((len(f), len(outputs), len(rx), len(fx)), dtype=complex)
    eye = np.eye(n_r * n_p)
    for i, w in enumerate(_wave_sets(ops, f, n_waves, tail)):
        dss = (o[:, None] - o[None, :]).ravel()
        Lss = _shifted_lattice(st.ss, w, dss, spacing, theta, Ls, Ls)  # (t, p, r*r', p')
        Lss = Lss.reshape(n_theta, n_p, n_r, n_r, n_p).transpose(0, 2, 1, 3, 4)
        Lss = Lss.reshape(n_theta, n_r * n_p, n_r * n_p)
        dsp = (o[:, None] - fx[None, :]).ravel()
        LsP = _shifted_lattice(st.sP, w, dsp, spacing, theta, load_length, Ls)[..., 0]
        LsP = LsP.reshape(n_theta, n_p, n_r, len(fx)).transpose(0, 2, 1, 3)
        LsP = LsP.reshape(n_theta, n_r * n_p, len(fx))
        K = (K_rows[i][:, None] * st.spring_weight[None, :]).ravel()
        Fh = np.linalg.solve(eye + K[None, :, None] * Lss, K[None, :, None] * LsP)
        drs = (rx[:, None] - o[None, :]).ravel()
        Lrs = _shifted_lattice(st.rs, w, drs, spacing, theta, Ls, 0.0)  # (t, out, rx*r, p)
        Lrs = Lrs.reshape(n_theta, len(outputs), len(rx), n_r, n_p)
        reacted = np.einsum("toxrp,trpP->toxP", Lrs, Fh.reshape(n_theta, n_r, n_p, len(fx)))
        # the free-rail waves' near-poles in theta cancel only inside the whole integrand
        drp = (rx[:, None] - fx[None, :]).ravel()
        LrP = _shifted_lattice(st.rP, w, drp, spacing, theta, load_length, 0.0)[..., 0]
        LrP = LrP.reshape(n_theta, len(outputs), len(rx), len(fx))
        out[i] = (LrP - reacted).mean(axis=0)
        if progress:
            progress(i + 1, len(f))
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
