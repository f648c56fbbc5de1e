"""Rail-pad footprints across the rail-foot underside (METHOD.md section 2).

A support acts on the rail through its pad, which covers the foot underside across the whole
foot width W and over the pad length along the rail. Along the rail the models of
``railfem.track.wfe`` spread each row of springs over its slice of the pad length with the
closed-form wave kernels. This module does the width: it places the support's vertical
springs across the foot underside and says how each spring reads and loads the rail.

``rule="midpoint"`` (the distributed bed): n points at the centres of n equal strips of the
foot width. A spring at y_q reads the rail's vertical displacement there, interpolated by
the P2 shape functions of the foot-underside edge that holds y_q, u(y_q) = N(y_q)^T u, and
puts its force on the same edge nodes with the same weights (the consistent nodal load of
a point force). With weights 1/n the springs form the bed

    sum_q (1/n) N(y_q) N(y_q)^T  ->  (1/W) int_foot N(y) N(y)^T dy     (n -> infinity),

the consistent Winkler bed of the pad on the FE foot (``consistent_bed``); the midpoint
rule converges at O(n^-2) (tests/test_footprints.py). The number of springs is then a
quadrature choice, not a physical parameter.

``rule="nodes"`` (the published configuration, METHOD.md section 2): n springs at the
foot-underside nodes nearest to the centres of n equal strips, each carrying its tributary
width (``supports.foot_spring_weights``). A force on one node of a continuum is singular,
so this form does not converge under mesh refinement; it is kept to reproduce earlier
results.

Springs come in mirror pairs (y, -y) that carry equal forces under a vertical load on the
mirror plane: one weight vector per pair, 1/2 on each spring's weights, and the pair's share
of the support. The edge geometry is read from the mesh nodes, mid-side nodes included, so
curved (isoparametric) edges are located correctly; the bed is per unit of lateral (y)
width, the plane of the pad.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..rail.mobility import Location
from .supports import foot_spring_weights
from ..rail.waveguide import Waveguide

RULES = ("midpoint", "nodes")


@dataclass(frozen=True, kw_only=True)
class WidthPoints:
    """Springs of one support across the foot underside, grouped in mirror pairs.

    pairs: one Location per pair (vertical DOF weights; a unit pair force loads them, the
    pair's displacement is weights @ u; each sums to 1). share: (n_pairs,) fraction of the
    support carried by each pair (sums to 1). y: (n_pairs,) |y| of the pair's springs (m).
    rule, n: how they were placed (n springs in all).
    """

    pairs: tuple[Location, ...]
    share: np.ndarray
    y: np.ndarray
    rule: str
    n: int


def underside_edges(guide: Waveguide) -> np.ndarray:
    """(ne, 3) foot-underside edges as (end, end, mid-side) node indices, sorted by y."""
    under = guide.node_sets.get("foot_underside", np.array([], dtype=int))
    e = guide.elements
    edges = np.vstack([e[:, [0, 1, 3]], e[:, [1, 2, 4]], e[:, [2, 0, 5]]])
    edges = edges[np.all(np.isin(edges, under), axis=1)]
    if len(under) < 2 or len(edges) == 0:
        raise ValueError(
            f"the mesh has {len(under)} rail-foot underside node(s) and {len(edges)} underside "
            "edge(s); supports need the foot underside (the lowest straight edge of the "
            "profile): check the profile outline and the mesh's 'foot_underside' node set")
    # both neighbours of an underside edge share it: keep one copy
    key = np.sort(edges[:, :2], axis=1)
    _, first = np.unique(key, axis=0, return_index=True)
    edges = edges[np.sort(first)]
    y = guide.nodes[edges[:, 2], 0]
    return edges[np.argsort(y)]


def shape_functions(t) -> np.ndarray:
    """P2 edge shape functions (N_end0, N_end1, N_mid) at t in [0, 1], shape (..., 3)."""
    t = np.asarray(t, dtype=float)
    return np.stack([(1 - t) * (1 - 2 * t), t * (2 * t - 1), 4 * t * (1 - t)], axis=-1)


def _edge_parameter(yn: np.ndarray, y: float) -> float:
    """t in [0, 1] with sum_i N_i(t) y_i = y on an edge with node y-coordinates yn (end,
    end, mid); Newton from the straight-edge guess (one step when the edge is straight)."""
    t = (y - yn[0]) / (yn[1] - yn[0])
    for _ in range(20):
        dN = np.array([4 * t - 3, 4 * t - 1, 4 - 8 * t])
        step = (shape_functions(t) @ yn - y) / (dN @ yn)
        t -= step
        if abs(step) < 1e-14:
            break
    return float(np.clip(t, 0.0, 1.0))


def point_weights(guide: Waveguide, y: float, edges: np.ndarray | None = None,
                  component: int = 2) -> np.ndarray:
    """(N,) weights over the DOFs of ``component`` (0 = u_x, 1 = u_y, 2 = u_z, the default)
    that read the foot-underside displacement at lateral position y (m): the P2 shape
    functions of the underside edge holding y."""
    edges = underside_edges(guide) if edges is None else edges
    yn = guide.nodes[edges, 0]  # (ne, 3)
    lo, hi = yn[:, :2].min(axis=1), yn[:, :2].max(axis=1)
    tol = 1e-9 * (hi.max() - lo.min())
    inside = np.nonzero((y >= lo - tol) & (y <= hi + tol))[0]
    if len(inside) == 0:
        raise ValueError(f"y = {y!r} m lies outside the foot underside "
                         f"[{lo.min():.6g}, {hi.max():.6g}] m")
    j = inside[0]
    t = _edge_parameter(yn[j], y)
    w = np.zeros(guide.n_dofs)
    w[guide.node_dofs[edges[j], component]] = shape_functions(t)
    return w


def width_points(guide: Waveguide, n: int, rule: str = "midpoint") -> WidthPoints:
    """n springs of one support across the foot underside by ``rule`` (see the module)."""
    reads, ys, share = spring_reads(guide, n, rule)
    pairs, shares, ypair = [], [], []
    for i in range(n // 2 + n % 2):
        a, b = i, n - 1 - i
        pairs.append(Location(label=f"foot_spring_{i}", weights=0.5 * (reads[a] + reads[b])))
        shares.append(share[a] + (share[b] if b != a else 0.0))
        ypair.append(abs(ys[a]))
    return WidthPoints(pairs=tuple(pairs), share=np.array(shares), y=np.array(ypair),
                       rule=rule, n=int(n))


def spring_reads(guide: Waveguide, n: int, rule: str = "midpoint", component: int = 2):
    """(reads, y, share) of the n springs of one support across the foot underside by
    ``rule``, sorted by y: per spring the (N,) weights over the DOFs of ``component``
    (0 = u_x, 1 = u_y, 2 = u_z) that read the rail at the spring (and spread its force),
    its lateral position y (m) and its share of the support (sums to 1)."""
    if rule not in RULES:
        raise ValueError(f"footprint rule {rule!r} is not one of {', '.join(RULES)}")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n = {n!r}: the number of springs across the foot must be an "
                         "integer >= 1")
    edges = underside_edges(guide)
    under = guide.node_sets["foot_underside"]
    y_nodes = guide.nodes[under, 0]
    y0, y1 = y_nodes.min(), y_nodes.max()
    targets = y0 + (np.arange(n) + 0.5) / n * (y1 - y0)
    if rule == "nodes":
        chosen = under[[int(np.argmin(np.abs(y_nodes - t))) for t in targets]]
        if len(set(chosen.tolist())) < n:
            raise ValueError(f"the foot underside has too few nodes for n = {n} springs at "
                             f"nodes ({len(under)} nodes): refine the mesh or use fewer springs")
        ys = guide.nodes[chosen, 0]
        share = foot_spring_weights(ys - (y0 + y1) / 2, y1 - y0)
        reads = []
        for node in chosen:
            w = np.zeros(guide.n_dofs)
            w[guide.node_dofs[node, component]] = 1.0
            reads.append(w)
    else:
        ys = targets
        share = np.full(n, 1.0 / n)
        reads = [point_weights(guide, float(y), edges, component) for y in ys]
    return reads, ys, share


def roll_reads(guide: Waveguide, n: int, rule: str = "midpoint") -> Location:
    """The foot's roll (rotation about the rail axis, rad, positive from +y towards +z) as a
    generalised column over the n vertical springs across the foot underside:

        theta = sum_j w_j y_j u_z,j / sum_j w_j y_j^2

    (the least-squares rotation of the spring points, w_j their shares, y_j from the foot
    centre). Loaded by a moment M it puts M w_j y_j / sum w y^2 on spring j: no net force,
    moment M. The fastening's roll restraint k_roll acts on it
    (railfem.track.supports.SupportParameters)."""
    reads, ys, share = spring_reads(guide, n, rule, 2)
    y = np.asarray(ys) - np.mean([np.min(ys), np.max(ys)])
    den = float(np.sum(share * y ** 2))
    if n < 2 or den <= 0:
        raise ValueError(f"the roll of the foot needs n >= 2 springs across it, got n = {n}")
    w = sum(c * r for c, r in zip(share * y / den, reads))
    return Location(label="foot_roll", weights=np.asarray(w))


def bed_matrix(points: WidthPoints):
    """The width bed the springs make, sum over pairs of share w w^T (sparse, N x N):
    the stiffness matrix of a support of unit stiffness acting through these springs."""
    import scipy.sparse as sp

    W = sp.csr_matrix(np.vstack([p.weights for p in points.pairs]))
    return (W.T @ sp.diags(points.share) @ W).tocsr()


def consistent_bed(guide: Waveguide):
    """(1/W) int N(y) N(y)^T dy over the foot underside (vertical DOFs, sparse N x N): the
    limit of the midpoint springs, exact by 5-point Gauss-Legendre on each edge."""
    import scipy.sparse as sp

    edges = underside_edges(guide)
    g, gw = np.polynomial.legendre.leggauss(5)
    t, gw = (g + 1) / 2, gw / 2
    N = shape_functions(t)  # (5, 3)
    dN = np.stack([4 * t - 3, 4 * t - 1, 4 - 8 * t], axis=-1)
    rows, cols, vals = [], [], []
    width = 0.0
    for e in edges:
        yn = guide.nodes[e, 0]
        jac = np.abs(dN @ yn)  # |dy/dt| at the Gauss points
        local = np.einsum("q,qi,qj->ij", gw * jac, N, N)
        dofs = guide.node_dofs[e, 2]
        rows.append(np.repeat(dofs, 3))
        cols.append(np.tile(dofs, 3))
        vals.append(local.ravel())
        width += float(gw @ jac)
    bed = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                        shape=(guide.n_dofs, guide.n_dofs))
    return bed / width


__all__ = ["RULES", "WidthPoints", "bed_matrix", "consistent_bed", "point_weights",
           "roll_reads",
           "shape_functions", "spring_reads", "underside_edges", "width_points"]
