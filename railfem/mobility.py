"""Free-rail forced response by the residue theorem (METHOD.md section 1).

For a force distribution F (N DOFs) acting at x = 0 the response at x >= 0 is

    u(x) = -i sum_n phi_n (psi_n^T F) exp(-i k_n x) / (psi_n^T A'(k_n) phi_n)

over the positive-going waves; x < 0 follows from the mirror x -> -x of the rail, which
flips the axial DOFs: u(-x; F) = T_a u(x; T_a F). A load spread along the rail over a box
of length L (centred on x = 0) convolves each wave term with the box, which is integrated in
closed form, so responses inside and outside the loaded length are exact for the waves kept.

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

from .waveguide import FAMILIES, Waveguide
from .waves import FamilyOperators, waves_at

log = logging.getLogger(__name__)


@dataclass(frozen=True, kw_only=True)
class Location:
    """A load or response location on the section: weights (N,) over the DOFs summing to 1
    in the loaded direction, and a label."""

    label: str
    weights: np.ndarray


def point(guide: Waveguide, node: int | str, direction: str = "z", label: str | None = None) -> Location:
    """Unit weight on one DOF: node index or single-node set name ('head_top', 'foot_sensor')."""
    w = np.zeros(guide.n_dofs)
    w[guide.dof(node, direction)] = 1.0
    name = node if isinstance(node, str) else f"node{node}"
    return Location(label=label or f"{name}_{direction}", weights=w)


def _boundary_edges(guide: Waveguide) -> np.ndarray:
    """(ne, 3) boundary edges of the P2 mesh as (end, end, mid) node indices."""
    e = guide.elements
    edges = np.vstack([e[:, [0, 1, 3]], e[:, [1, 2, 4]], e[:, [2, 0, 5]]])
    return edges[np.isin(edges[:, 2], guide.node_sets["boundary"])]


def surface_patch(guide: Waveguide, centre: tuple[float, float], width: float,
                  direction: str = "z", label: str | None = None) -> Location:
    """Uniform traction over the boundary within `width` (m, measured along y) of `centre`
    on the surface facing the loaded direction; consistent P2 nodal loads (1/6, 1/6, 2/3 of
    each edge's share), normalised to a unit resultant. width = 0 gives the nearest node."""
    from .conventions import DIRECTIONS

    if width < 0 or not np.isfinite(width):
        raise ValueError(f"patch width must be >= 0 m, got {width!r}")
    c = DIRECTIONS[direction]
    nodes = guide.nodes
    if width == 0:
        b = guide.node_sets["boundary"]
        n0 = b[np.argmin(np.hypot(nodes[b, 0] - centre[0], nodes[b, 1] - centre[1]))]
        return point(guide, int(n0), direction, label)
    ed = _boundary_edges(guide)
    p0, p1 = nodes[ed[:, 0]], nodes[ed[:, 1]]
    mid = nodes[ed[:, 2]]
    near = np.hypot(mid[:, 0] - centre[0], mid[:, 1] - centre[1]) < max(width, 2 * guide.mesh.h)
    # overlap of each edge's lateral extent with the patch [yc - w/2, yc + w/2]
    lo = np.maximum(np.minimum(p0[:, 0], p1[:, 0]), centre[0] - width / 2)
    hi = np.minimum(np.maximum(p0[:, 0], p1[:, 0]), centre[0] + width / 2)
    share = np.where(near, np.clip(hi - lo, 0, None), 0.0)
    if share.sum() <= 0:
        raise ValueError(f"no boundary of the section lies within {width} m of {centre}; "
                         "choose a centre on the surface or a wider patch")
    w = np.zeros(guide.n_dofs)
    for (a, b, m), s in zip(ed, share):
        if s > 0:
            w[guide.node_dofs[[a, b, m], c]] += s * np.array([1 / 6, 1 / 6, 2 / 3])
    return Location(label=label or f"patch{width * 1e3:g}mm_{direction}", weights=w / w.sum())


def head_patch(guide: Waveguide, width: float = 0.02, direction: str = "z") -> Location:
    """Vertical load patch across the head top centre (wheel contact, hammer tip)."""
    top = guide.nodes[guide.node("head_top")]
    return surface_patch(guide, (float(top[0]), float(top[1])), width, direction,
                         label=f"head_{direction}")


def _box_kernels(k: np.ndarray, x: np.ndarray, L: float):
    """Forward (s >= 0) and backward (s < 0) wave kernels averaged over a load box of
    length L centred on 0, evaluated at response positions x: arrays (nw, nx)."""
    k = k[:, None]
    if L == 0:
        fwd = np.where(x >= 0, np.exp(-1j * k * np.abs(x)), 0.0)
        bwd = np.where(x < 0, np.exp(-1j * k * np.abs(x)), 0.0)
        return fwd, bwd
    lo, hi = np.maximum(x - L / 2, 0), np.maximum(x + L / 2, 0)
    fwd = (np.exp(-1j * k * lo) - np.exp(-1j * k * hi)) / (1j * k * L)
    lo2, hi2 = np.minimum(x - L / 2, 0), np.minimum(x + L / 2, 0)
    bwd = (np.exp(1j * k * hi2) - np.exp(1j * k * lo2)) / (1j * k * L)
    return fwd, bwd


class _FamilyResponse:
    """Projections of loads and responses on one family, built once per sweep."""

    def __init__(self, guide, family, force_w, resp_w):
        self.ops = FamilyOperators(guide, family)
        T = guide.families[family].T
        comp = guide.families[family].component
        self.flip = np.where(comp == 0, -1.0, 1.0)
        self.F = T.T @ force_w  # (n_r, n_in)
        self.R = (T.T @ resp_w).T  # (n_out, n_r): response = R @ u_r

    @property
    def active(self) -> bool:
        return bool(np.any(self.F != 0) and np.any(self.R != 0))


def free_receptance(guide: Waveguide, frequency, force: list[Location], response: list[Location],
                    x, *, load_length: float = 0.0, method: str = "shift-invert",
                    n_waves: int = 40, progress=None) -> np.ndarray:
    """Receptance (m/N) of the free rail: array (nf, n_response, n_x, n_force).

    force and response are Locations; x (m) are response positions relative to the load
    centre (either sign); load_length (m) spreads each force uniformly along the rail.
    """
    f = _check_frequency(frequency)
    x = np.atleast_1d(np.asarray(x, dtype=float))
    if not np.all(np.isfinite(x)):
        raise ValueError("response positions x must be finite (m)")
    if load_length < 0 or not np.isfinite(load_length):
        raise ValueError(f"load_length must be >= 0 m, got {load_length!r}")
    Fw = np.column_stack([loc.weights for loc in force])
    Rw = np.column_stack([loc.weights for loc in response])
    fams = [fr for fr in (_FamilyResponse(guide, fam, Fw, Rw) for fam in FAMILIES) if fr.active]
    out = np.zeros((len(f), len(response), len(x), len(force)), dtype=complex)
    for i, fi in enumerate(f):
        for fr in fams:
            w = waves_at(fr.ops, 2 * np.pi * fi, method=method, n_waves=n_waves)
            out[i] += _wave_sum(fr, w, x, load_length)
        if progress:
            progress(i + 1, len(f))
    return out


def _wave_sum(fr: _FamilyResponse, w, x, L) -> np.ndarray:
    phi = w.phi
    a = ((fr.flip[:, None] * phi).T @ fr.F) / w.denom[:, None]  # (nw, n_in): psi^T F / d
    b = (phi.T @ fr.F) / w.denom[:, None]  # same for the mirrored load T_a F
    fwd, bwd = _box_kernels(w.k, x, L)  # (nw, nx)
    Rphi = fr.R @ phi  # (n_out, nw)
    Rphi_m = fr.R @ (fr.flip[:, None] * phi)  # responses read through the mirror
    u = np.einsum("on,nx,ni->oxi", Rphi, fwd, a) + np.einsum("on,nx,ni->oxi", Rphi_m, bwd, b)
    return -1j * u


def _check_frequency(frequency) -> np.ndarray:
    f = np.atleast_1d(np.asarray(frequency, dtype=float))
    if f.ndim != 1 or not np.all(np.isfinite(f)) or np.any(f <= 0):
        raise ValueError(f"frequency must be a 1-D array of positive finite values in Hz, got "
                         f"{np.asarray(frequency)!r:.80}")
    return f


def free_mobility(guide: Waveguide, frequency, force: Location, response: list[Location], x,
                  **kwargs):
    """Free-rail mobility as an FRF: outputs are (response, x) pairs, input is the force."""
    from .frf import FRF

    f = _check_frequency(frequency)
    x = np.atleast_1d(np.asarray(x, dtype=float))
    alpha = free_receptance(guide, f, [force], response, x, **kwargs)
    nf = len(f)
    values = alpha.reshape(nf, len(response) * len(x), 1)
    labels = tuple(f"{r.label}@x={xx:.3f}" for r in response for xx in x)
    frf = FRF(frequency=f, values=values, quantity="receptance", response=labels,
              force=(force.label,), response_x=np.tile(x, len(response)), force_x=np.zeros(1))
    return frf.to("mobility")
