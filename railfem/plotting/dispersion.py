"""Dispersion diagrams: k(omega) points, omega(k) curves, branches with one colour per
wave type."""

from __future__ import annotations

import logging

import numpy as np

from ..rail.branches import MAX_ATTENUATION, propagating_mask
from .base import MARKERS, axes_or_new, columns, curve_labels, legend, vector

log = logging.getLogger(__name__)


def _wave_labels(labels, shape) -> np.ndarray:
    """Broadcast wave-type labels to ``shape`` (nf, nw); '' marks unlabelled."""
    if labels is None:
        return np.full(shape, "", dtype=object)
    array = np.asarray(labels, dtype=object)
    try:
        array = np.broadcast_to(array, shape)
    except ValueError:
        raise ValueError(
            f"labels must have shape {shape} (one wave type per frequency and wave) "
            f"or ({shape[1]},) (one per column), got {np.shape(labels)}"
        ) from None
    return np.where(array == None, "", array).astype(str)  # noqa: E711


def plot_dispersion(frequency, wavenumber, labels=None, *, ax=None,
                    max_attenuation: float = MAX_ATTENUATION):
    """Dispersion diagram of the propagating waves: x = Re k (rad/m), y = frequency (Hz).

    Parameters
    ----------
    frequency : (nf,) array, Hz.
    wavenumber : (nf, nw) complex array, rad/m, positive-going waves (Im k < 0);
        NaN marks an absent wave.
    labels : (nf, nw) or (nw,) array of str, optional
        Wave type of each entry; one marker style and legend entry per type.
    max_attenuation : float
        A wave is drawn when |Im k| <= max_attenuation * |Re k|.
    """
    frequency = vector(frequency, "frequency")
    k = columns(wavenumber, frequency.size, "wavenumber", "frequency", dtype=complex)
    types = _wave_labels(labels, k.shape)
    mask = propagating_mask(k, max_attenuation)
    freq = np.broadcast_to(frequency[:, None], k.shape)
    ax = axes_or_new(ax)
    names = sorted(set(types[mask])) if mask.any() else []
    if not names:
        log.warning("plot_dispersion: no propagating wave (|Im k| <= %g |Re k|)",
                    max_attenuation)
    for i, name in enumerate(names):
        sel = mask & (types == name)
        ax.scatter(k.real[sel], freq[sel], s=10, marker=MARKERS[i % len(MARKERS)],
                   color=f"C{i % 10}", label=name or None)
    ax.set_xlabel("Wavenumber Re k (rad/m)")
    ax.set_ylabel("Frequency (Hz)")
    if mask.any() and np.all(k.real[mask] >= 0):
        ax.set_xlim(left=0)
    ax.set_ylim(bottom=min(0.0, float(frequency.min())))
    ax.grid(True, alpha=0.3)
    legend(ax)
    return ax


def plot_dispersion_k(k_real, frequencies, labels=None, ax=None):
    """omega(k) curves: k (nk,) real rad/m, frequencies (nk, nmodes) Hz.

    ``labels`` gives one name per mode; modes sharing a name share a colour and
    one legend entry.
    """
    k_real = vector(k_real, "k_real")
    freqs = columns(frequencies, k_real.size, "frequencies", "k_real")
    names = curve_labels(labels, freqs.shape[1])
    ax = axes_or_new(ax)
    colours: dict[str, str] = {}
    for j, name in enumerate(names):
        key = name if name is not None else f"mode {j}"
        first = key not in colours
        colours.setdefault(key, f"C{len(colours) % 10}")
        ax.plot(k_real, freqs[:, j], color=colours[key],
                label=name if (name is not None and first) else None)
    ax.set_xlabel("Wavenumber k (rad/m)")
    ax.set_ylabel("Frequency (Hz)")
    ax.grid(True, alpha=0.3)
    legend(ax)
    return ax


#: Colour of each wave type in dispersion plots, the same in every figure.
TYPE_COLOURS = {"vertical bending": "C0", "lateral bending": "C1", "torsion": "C2",
                "longitudinal": "C3", "foot flapping": "C4", "web bending": "C5"}
# the rest of the tab10 cycle, then the light and dark tab20/tab20b shades: all distinct
_SPARE_COLOURS = ("C6", "C8", "C9", "C7", "#aec7e8", "#ffbb78", "#98df8a", "#ff9896",
                  "#c5b0d5", "#c49c94", "#f7b6d2", "#dbdb8d", "#9edae5", "#393b79",
                  "#637939", "#8c6d31", "#843c39", "#7b4173", "#5254a3", "#e7ba52")
#: Line style of each symmetry family in dispersion plots.
FAMILY_LINESTYLES = {"symmetric": "-", "antisymmetric": "--"}


def branch_colours(labels) -> list[str]:
    """One colour per branch: the wave type's colour (TYPE_COLOURS) for the first branch of
    each type, a spare colour for the other branches and for other types (repeating only
    when more than 30 branches need colours)."""
    used: set[str] = set()
    out = []
    for i, lab in enumerate(labels):
        colour = TYPE_COLOURS.get(str(lab))
        if colour is None or colour in used:
            free = [c for c in _SPARE_COLOURS if c not in used]
            colour = free[0] if free else _SPARE_COLOURS[i % len(_SPARE_COLOURS)]
        used.add(colour)
        out.append(colour)
    return out


def plot_branches(branches, *, ax=None, markers: bool | None = None):
    """Dispersion branches (railfem.rail.branches.Branches): x = Re k (rad/m), y = frequency (Hz).

    One line per branch, one colour per branch (TYPE_COLOURS for the wave types), solid for
    the symmetric and dashed for the antisymmetric family, and one legend entry per branch
    (``branches.name``, in words). Branches come from k(omega) or omega(k) sweeps alike.
    ``markers`` (default: for k(omega) sweeps) marks the computed points.
    """
    ax = axes_or_new(ax, figsize=(9.6, 5.6) if branches.n_branches > 8 else (6.4, 4.8))
    present = branches.present()
    if markers is None:
        markers = branches.sweep == "frequency"
    colours = branch_colours(branches.label)
    for b in range(branches.n_branches):
        if not present[:, b].any():
            continue
        ax.plot(branches.k[:, b].real, branches.frequency[:, b], color=colours[b],
                linestyle=FAMILY_LINESTYLES.get(str(branches.family[b]), "-."),
                marker="o" if markers else None, markersize=2.5, linewidth=1.4,
                label=str(branches.name[b]))
    if not present.any():
        log.warning("plot_branches: no branch to draw")
    ax.set_xlabel("Wavenumber Re k (rad/m)")
    ax.set_ylabel("Frequency (Hz)")
    if present.any() and np.nanmin(branches.k.real[present]) >= 0:
        ax.set_xlim(left=0)
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    if present.any():
        title = "solid: symmetric, dashed: antisymmetric"
        if branches.n_branches > 8:
            ax.legend(fontsize="x-small", title=title, title_fontsize="x-small",
                      loc="upper left", bbox_to_anchor=(1.01, 1.0))
        else:
            ax.legend(fontsize="small", title=title, title_fontsize="small")
    return ax
