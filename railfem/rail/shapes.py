"""Full cross-section shapes of the waves at one frequency (for renders and inspection)."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import waves
from .branches import MAX_ATTENUATION, propagating_mask
from .labels import label_waves
from .waveguide import Waveguide

__all__ = ["WaveShape", "wave_shapes"]


@dataclass(frozen=True, kw_only=True)
class WaveShape:
    """One wave at one frequency with its full cross-section shape.

    shape: (n_nodes, 3) complex (u_x, u_y, u_z) per P2 node of ``guide.nodes``, scaled to
    unit norm and phased so that the in-plane part is real (the axial part of a
    propagating wave is then imaginary).
    """

    family: str
    frequency: float
    k: complex
    label: str
    propagating: bool
    shape: np.ndarray


def wave_shapes(guide: Waveguide, frequency_hz: float, *, method: str = "shift-invert",
                n_waves: int = 40, propagating_only: bool = True,
                max_attenuation: float | None = None) -> list[WaveShape]:
    """Waves of both families at one frequency with per-node shapes (T @ phi mapped through
    ``guide.node_dofs``), sorted by family then by decreasing Re k."""
    max_att = MAX_ATTENUATION if max_attenuation is None else max_attenuation
    out = []
    for fam in guide.families:
        ops = waves.FamilyOperators(guide, fam)
        w = waves.waves_at(ops, 2 * np.pi * frequency_hz, method=method, n_waves=n_waves)
        labels = label_waves(guide, ops, w)
        prop = propagating_mask(w.k, max_att)
        order = np.argsort(-w.k.real)
        for j in order:
            if propagating_only and not prop[j]:
                continue
            full = ops.T @ w.phi[:, j]
            u = full[guide.node_dofs]  # (n, 3)
            inplane = u[:, 1:].ravel()
            big = inplane[np.argmax(np.abs(inplane))] if np.any(inplane) else 1.0
            u = u * np.exp(-1j * np.angle(big))
            u = u / np.linalg.norm(u)
            out.append(WaveShape(family=fam, frequency=float(frequency_hz), k=complex(w.k[j]),
                                 label=str(labels[j]), propagating=bool(prop[j]), shape=u))
    return out
