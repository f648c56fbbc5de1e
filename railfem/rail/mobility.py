"""Free-rail forced response by the residue theorem (METHOD.md section 1).

For a force distribution F (N DOFs) acting at x = 0 the response at x >= 0 is

    u(x) = -i sum_n phi_n (psi_n^T F) exp(-i k_n x) / (psi_n^T A'(k_n) phi_n)

over the positive-going waves; x < 0 follows from the mirror x -> -x of the rail, which
flips the axial DOFs: u(-x; F) = T_a u(x; T_a F). A load spread along the rail over a box
of length L (centred on x = 0) convolves each wave term with the box, which is integrated in
closed form, so responses inside and outside the loaded length are exact for the waves kept.
This module projects the waves of the section on loads and responses (``FamilyResponse``,
``wave_terms``); the residue sums themselves are railfem.rail.greens.

Locations (loads and responses) are weight vectors over the DOFs: a single DOF for a point,
or a patch of consistent nodal loads over a stretch of boundary. A force on one node of a
continuum is singular (the local flexibility grows without bound under mesh refinement);
spreading it over a patch across the surface and a length along the rail makes point
mobilities converge. Responses are read at single nodes or as patch averages.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from .greens import residue_sum
from .waveguide import Waveguide, check_resolution
from .waves import FamilyOperators, frozen_tail, join, waves_at

log = logging.getLogger(__name__)

#: Default length (m) over which a force is spread along the rail: a load on a single
#: cross-section of a continuum is singular (its point mobility grows under mesh refinement);
#: spread over 20 mm (a wheel contact or hammer tip is 10-20 mm long) the head point mobility
#: converges with the mesh (tests/test_mobility.py). The CLI uses the same default.
DEFAULT_LOAD_LENGTH = 0.02


@dataclass(frozen=True, kw_only=True)
class Location:
    """A load or response location on the section: weights (N,) over the DOFs summing to 1
    in the loaded direction, and a label."""

    label: str
    weights: np.ndarray


def point(guide: Waveguide, node: int | str, direction: str = "z",
          label: str | None = None) -> Location:
    """Unit weight on one DOF: node index or single-node set name ('head_top', 'foot_sensor')."""
    w = np.zeros(guide.n_dofs)
    w[guide.dof(node, direction)] = 1.0
    name = node if isinstance(node, str) else f"node{node}"
    return Location(label=label or f"{name}_{direction}", weights=w)


def boundary_edges(guide: Waveguide) -> np.ndarray:
    """(ne, 3) boundary edges of the section's P2 mesh as (end, end, mid) node indices: the
    element edges whose mid-side node lies on the boundary (surface patches, foot beds)."""
    e = guide.elements
    edges = np.vstack([e[:, [0, 1, 3]], e[:, [1, 2, 4]], e[:, [2, 0, 5]]])
    return edges[np.isin(edges[:, 2], guide.node_sets["boundary"])]


_GAUSS2 = (0.5 - 0.5 / np.sqrt(3.0), 0.5 + 0.5 / np.sqrt(3.0))


def _p2_shapes(t) -> np.ndarray:
    """P2 edge shape functions (N_a, N_b, N_m) at t in [0, 1]: (1-t)(1-2t), t(2t-1), 4t(1-t)."""
    t = np.asarray(t, dtype=float)
    return np.stack([(1 - t) * (1 - 2 * t), t * (2 * t - 1), 4 * t * (1 - t)], axis=-1)


def _edge_patch_loads(y: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """int N_i(t) |y'(t)| dt over the part of a P2 edge whose y lies in [lo, hi]: the
    consistent nodal loads (N_a, N_b, N_m) of a unit traction per unit lateral width.

    y = (y_a, y_b, y_m) are the edge's node coordinates; y(t) = sum y_i N_i(t) is quadratic
    on a curved edge. The edge is cut where y(t) crosses lo or hi and where y'(t) = 0, so
    |y'| is linear on each piece and 2-point Gauss integrates N_i |y'| (cubic) exactly."""
    ya, yb, ym = y
    c1, c2 = -3 * ya - yb + 4 * ym, 2 * ya + 2 * yb - 4 * ym
    cuts = [0.0, 1.0]
    if c2 != 0:
        cuts.append(-c1 / (2 * c2))
    for level in (lo, hi):
        roots = np.roots([c2, c1, ya - level]) if c2 != 0 else (
            [(level - ya) / c1] if c1 != 0 else [])
        cuts += [r.real for r in np.atleast_1d(roots) if abs(np.imag(r)) < 1e-12]
    t = np.unique(np.clip(cuts, 0.0, 1.0))
    out = np.zeros(3)
    for s0, s1 in zip(t[:-1], t[1:]):
        mid = 0.5 * (s0 + s1)
        if not lo <= ya + c1 * mid + c2 * mid * mid <= hi:
            continue
        for g in _GAUSS2:
            tg = s0 + g * (s1 - s0)
            out += 0.5 * (s1 - s0) * _p2_shapes(tg) * abs(c1 + 2 * c2 * tg)
    return out


def surface_patch(guide: Waveguide, centre: tuple[float, float], width: float,
                  direction: str = "z", label: str | None = None,
                  along: str = "y") -> Location:
    """Uniform traction (per unit lateral width) over the boundary within `width` (m,
    measured along y, or along z with along='z' for a patch on a side face) of `centre`;
    consistent P2 nodal loads, normalised to a unit resultant.

    The boundary edges are the P2 edges of the mesh, curved on a curved mesh: each edge gets
    the exact integrals of its shape functions times |dy/dt| over the part of it whose y is
    covered (lumping an edge's share as if the whole edge were loaded makes the patch, and
    the point mobility, jump with the mesh). width = 0 gives the nearest node."""
    from ..conventions import DIRECTIONS

    if width < 0 or not np.isfinite(width):
        raise ValueError(f"patch width must be >= 0 m, got {width!r}")
    c = DIRECTIONS[direction]
    nodes = guide.nodes
    if width == 0:
        b = guide.node_sets["boundary"]
        n0 = b[np.argmin(np.hypot(nodes[b, 0] - centre[0], nodes[b, 1] - centre[1]))]
        return point(guide, int(n0), direction, label)
    ed = boundary_edges(guide)
    mid = nodes[ed[:, 2]]
    near = np.nonzero(np.hypot(mid[:, 0] - centre[0], mid[:, 1] - centre[1])
                      < max(width, 2 * guide.mesh.h))[0]
    a = {"y": 0, "z": 1}[along]
    lo, hi = centre[a] - width / 2, centre[a] + width / 2
    loads = np.array([_edge_patch_loads(nodes[ed[i], a], lo, hi) for i in near]).reshape(-1, 3)
    keep = loads.sum(axis=1) > 0
    if not keep.any():
        raise ValueError(f"no boundary of the section lies within {width} m of {centre}; "
                         "choose a centre on the surface or a wider patch")
    w = np.zeros(guide.n_dofs)
    np.add.at(w, guide.node_dofs[ed[near[keep]], c].ravel(), loads[keep].ravel())
    return Location(label=label or f"patch{width * 1e3:g}mm_{direction}", weights=w / w.sum())


def head_patch(guide: Waveguide, width: float = 0.02, direction: str = "z") -> Location:
    """Vertical load patch across the head top centre (wheel contact, hammer tip)."""
    top = guide.nodes[guide.node("head_top")]
    return surface_patch(guide, (float(top[0]), float(top[1])), width, direction,
                         label=f"head_{direction}")


class FamilyResponse:
    """Projections of loads and responses on one family, built once per sweep."""

    def __init__(self, guide, family, force_w, resp_w):
        self.ops = FamilyOperators(guide, family)
        T = guide.families[family].T
        comp = guide.families[family].component
        self.flip = np.where(comp == 0, -1.0, 1.0)
        self.F = T.T @ force_w  # (n_r, n_in)
        self.R = (T.T @ resp_w).T  # (n_out, n_r): response = R @ u_r
        self._scale = (np.abs(force_w).max(initial=0.0), np.abs(resp_w).max(initial=0.0))

    @property
    def active(self) -> bool:
        """The family carries load and response: projections above round-off (mirror pairs
        on a curved mesh leave ~1e-15 in the other family, which is no excitation)."""
        f, r = self._scale
        return bool(np.abs(self.F).max(initial=0.0) > 1e-9 * f
                    and np.abs(self.R).max(initial=0.0) > 1e-9 * r)


def free_receptance(guide: Waveguide, frequency, force: list[Location], response: list[Location],
                    x, *, load_length: float = DEFAULT_LOAD_LENGTH, response_length: float = 0.0,
                    method: str = "shift-invert", n_waves: int = 40, tail: bool = True,
                    progress=None) -> np.ndarray:
    """Receptance (m/N) of the free rail: array (nf, n_response, n_x, n_force).

    force and response are Locations; x (m) are response positions relative to the load
    centre (either sign); load_length (m, default DEFAULT_LOAD_LENGTH = 20 mm, the length
    at which the head point mobility has converged with the mesh; 0 only when asked for:
    a load on one cross-section of a continuum) spreads each force uniformly along the rail and
    response_length (m) averages each response over a length centred on its position (the
    work-conjugate of a spread load: a point mobility with both equal converges fastest in
    the number of waves kept).

    method 'dense' keeps every wave; 'shift-invert' keeps the n_waves smallest |k| per family
    and, with tail=True, adds the dropped waves frozen at the lowest frequency
    (waves.frozen_tail), which restores point responses to all waves within 0.2 % up to 5 kHz
    (without it: 10-30 % above 1 kHz); transfers 0.2 m or more from the load need no tail
    (tests/test_mobility.py).

    At x = 0 exactly with load_length = response_length = 0 the forward sum is used: a
    response odd in x (axial response to an in-plane load) should vanish there but comes out
    at 1e-4 (dense) to a few % (shift-invert) of the largest response; use x != 0 or a length.
    """
    f = check_frequency(frequency)
    x = np.atleast_1d(np.asarray(x, dtype=float))
    if not np.all(np.isfinite(x)):
        raise ValueError("response positions x must be finite (m)")
    check_resolution(guide, f.max())
    for name, val in (("load_length", load_length), ("response_length", response_length)):
        if not np.isfinite(val) or val < 0:
            raise ValueError(f"{name} must be a finite length >= 0 m, got {val!r}")
    Fw = np.column_stack([loc.weights for loc in force])
    Rw = np.column_stack([loc.weights for loc in response])
    fams = [fr for fr in (FamilyResponse(guide, fam, Fw, Rw) for fam in guide.families)
            if fr.active]
    out = np.zeros((len(f), len(response), len(x), len(force)), dtype=complex)
    tails = {fr.ops.family: frozen_tail(fr.ops, 2 * np.pi * f.min(), n_waves)
             for fr in fams if tail and method == "shift-invert"}
    for i, fi in enumerate(f):
        for fr in fams:
            w = waves_at(fr.ops, 2 * np.pi * fi, method=method, n_waves=n_waves)
            if fr.ops.family in tails:
                w = join(w, tails[fr.ops.family])
            out[i] += wave_sum(fr, w, x, load_length, response_length)
        if progress:
            progress(i + 1, len(f))
    return out


def wave_terms(fr: FamilyResponse, w):
    """Per-wave factors of the residue sum: response shapes (n_out, nw) read directly and
    through the mirror, and load participations (nw, n_in) for the load and its mirror.
    The mirror's sign flip acts on the small load/response matrices, not on the modes."""
    phi = w.phi
    a = (phi.T @ (fr.flip[:, None] * fr.F)) / w.denom[:, None]  # psi^T F / d
    b = (phi.T @ fr.F) / w.denom[:, None]  # same for the mirrored load T_a F
    return fr.R @ phi, a, (fr.R * fr.flip[None, :]) @ phi, b


def wave_sum(fr: FamilyResponse, w, x, L_force: float = 0.0, L_resp: float = 0.0) -> np.ndarray:
    """Receptance (n_out, nx, n_in) of one family's waves at response positions x."""
    return residue_sum(wave_terms(fr, w), w.k, x, L_force, L_resp)


def check_frequency(frequency) -> np.ndarray:
    """frequency (Hz) as a 1-D float array; ValueError unless every value is positive and
    finite."""
    f = np.atleast_1d(np.asarray(frequency, dtype=float))
    if f.ndim != 1 or not np.all(np.isfinite(f)) or np.any(f <= 0):
        raise ValueError(f"frequency must be a 1-D array of positive finite values in Hz, got "
                         f"{np.asarray(frequency)!r:.80}")
    return f


def free_mobility(guide: Waveguide, frequency, force: Location, response: list[Location], x,
                  **kwargs):
    """Free-rail mobility as an FRF: outputs are (response, x) pairs, input is the force."""
    from ..response import FRF

    f = check_frequency(frequency)
    x = np.atleast_1d(np.asarray(x, dtype=float))
    alpha = free_receptance(guide, f, [force], response, x, **kwargs)
    nf = len(f)
    values = alpha.reshape(nf, len(response) * len(x), 1)
    labels = tuple(f"{r.label}@x={xx:.3f}" for r in response for xx in x)
    frf = FRF(frequency=f, values=values, quantity="receptance", response=labels,
              force=(force.label,), response_x=np.tile(x, len(response)), force_x=np.zeros(1))
    return frf.to("mobility")
