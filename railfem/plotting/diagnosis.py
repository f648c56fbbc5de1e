"""Diagnosis figures: residual over frequency and hammer distance, residual RMS before
and after the chosen effect, scores of the candidate effects."""

from __future__ import annotations

import numpy as np

from .base import (MARKERS, axes_or_new, columns, curve_labels, legend, nominal_band_label,
                   pyplot, readable_log_ticks, vector)


# ------------------------------------------------------------------ diagnosis (residuals)
def plot_residual_map(frequency, positions, values, *, ax=None, title: str | None = None,
                      limit_db: float | None = None):
    """Residual (measured - model, dB) over frequency (axis 0) and hammer distance (axis 1)
    as a colour map; NaN cells (not compared) stay blank. Returns the Axes."""
    f = vector(frequency, "frequency")
    x = vector(positions, "positions")
    v = np.asarray(values, dtype=float)
    if v.shape != (len(f), len(x)):
        raise ValueError(f"values has shape {v.shape}, expected (n_frequency, n_positions) "
                         f"= ({len(f)}, {len(x)})")
    ax = axes_or_new(ax)
    lim = limit_db if limit_db is not None else max(float(np.nanmax(np.abs(v))) if
                                                    np.isfinite(v).any() else 1.0, 0.1)
    order = np.argsort(x)
    mesh = ax.pcolormesh(np.arange(len(x) + 1) - 0.5, f if len(f) < 2 else
                         np.concatenate([[f[0] ** 1.5 / f[1] ** 0.5],
                                         np.sqrt(f[1:] * f[:-1]),
                                         [f[-1] ** 1.5 / f[-2] ** 0.5]]),
                         v[:, order], cmap="RdBu_r", vmin=-lim, vmax=lim, shading="flat")
    ax.set_yscale("log")
    ax.set_xticks(np.arange(len(x)))
    ax.set_xticklabels([f"{p:g}" for p in x[order]], rotation=90, fontsize=7)
    ax.set_xlabel("Hammer distance from the sensor (m)")
    ax.set_ylabel("Frequency (Hz)")
    ax.figure.colorbar(mesh, ax=ax, label="Measured - model (dB)")
    if title:
        ax.set_title(title)
    return ax


def plot_residual_spectrum(frequency, values, labels=None, *, ax=None,
                           ylabel: str = "Measured - model (dB)"):
    """Residual curves over frequency (values: (n_frequency, n_curves), e.g. head and foot
    point mobility); a zero line for reference. Returns the Axes."""
    f = vector(frequency, "frequency")
    v = columns(values, len(f), "values", "frequency")
    ax = axes_or_new(ax)
    for j, lab in enumerate(curve_labels(labels, v.shape[1])):
        ax.semilogx(f, v[:, j], marker=MARKERS[j % len(MARKERS)], markersize=3, label=lab)
    ax.axhline(0.0, color="0.4", lw=0.8)
    ax.set_xlabel("Frequency (Hz)")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    legend(ax)
    return ax


def plot_residual_distance(positions, values, labels=None, *, ax=None,
                           ylabel: str = "Measured - model (dB)"):
    """Residual over hammer distance (values: (n_positions, n_curves), e.g. one curve per
    one-third-octave band). The distance axis is logarithmic when every distance is
    positive; symmetric-logarithmic (linear within 0.6 m of the sensor) when one is zero,
    from 0, or negative. Returns the Axes."""
    x = vector(positions, "positions")
    v = columns(values, len(x), "values", "positions")
    ax = axes_or_new(ax)
    order = np.argsort(x)
    for j, lab in enumerate(curve_labels(labels, v.shape[1])):
        ax.plot(x[order], v[order, j], marker=MARKERS[j % len(MARKERS)], markersize=3,
                label=lab)
    ax.axhline(0.0, color="0.4", lw=0.8)
    if x.min() > 0:
        ax.set_xscale("log")
        readable_log_ticks(ax.xaxis)
    else:
        ax.set_xscale("symlog", linthresh=0.6)
        if x.min() == 0:  # no empty negative half
            ax.set_xlim(left=0.0)
    ax.set_xlabel("Hammer distance from the sensor (m)")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    legend(ax)
    return ax


def plot_error_before_after(centres, before, after, *, ax=None, label: str = "",
                            ylabel: str = "Residual RMS (dB)"):
    """Residual RMS per one-third-octave band before (base model) and after (with the
    chosen effect): two bar series. NaN bands are left empty. Returns the Axes."""
    c = vector(centres, "centres")
    b = vector(before, "before")
    a = vector(after, "after")
    if not len(b) == len(a) == len(c):
        raise ValueError("centres, before and after must have the same length")
    ax = axes_or_new(ax)
    i = np.arange(len(c))
    ax.bar(i - 0.2, b, width=0.4, label=f"before {label}".strip())
    ax.bar(i + 0.2, a, width=0.4, label=f"after {label}".strip())
    ax.set_xticks(i)
    ax.set_xticklabels([nominal_band_label(x) for x in c], rotation=90, fontsize=8)
    ax.set_xlabel("One-third-octave band centre frequency (Hz)")
    ax.set_ylabel(ylabel)
    ax.grid(True, axis="y", alpha=0.3)
    legend(ax)
    return ax


def plot_error_before_after_parts(quantity: str, parts: dict, *, axes=None):
    """:func:`plot_error_before_after` of one quantity, one panel per data part (stacked):
    parts maps a part ('fit', 'held') to (centres, before, after). Returns the list of
    Axes."""
    if not parts:
        raise ValueError("parts is empty: nothing to plot")
    if axes is None:
        fig, grid = pyplot().subplots(len(parts), 1, figsize=(7, 3.2 * len(parts)),
                                      squeeze=False)
        axes = list(grid[:, 0])
    axes = list(np.ravel(axes))
    if len(axes) != len(parts):
        raise ValueError(f"got {len(axes)} axes for {len(parts)} parts")
    for ax, (part, (centres, before, after)) in zip(axes, parts.items()):
        plot_error_before_after(centres, before, after, ax=ax, label=f"({part})")
        ax.set_title(f"{quantity}: residual RMS per band, {part} data")
    axes[0].figure.tight_layout()
    return axes


def plot_candidate_scores(names, delta_bic, held_reduction, kept=None, *, gate=None,
                          ax=None):
    """Candidates of a diagnosis: BIC change against the base (bars, left axis, clipped
    symlog) and held-out error reduction in % (markers, right axis); kept candidates
    hatched. ``gate``: the least held-out reduction a candidate must reach (a fraction, e.g.
    railfem.diagnosis.gates.MIN_GAIN), drawn as a labelled dashed line on the right axis.
    Returns the (left) Axes."""
    n = len(names)
    d = vector(delta_bic, "delta_bic")
    r = vector(held_reduction, "held_reduction")
    if not len(d) == len(r) == n:
        raise ValueError("names, delta_bic and held_reduction must have the same length")
    kept = [False] * n if kept is None else list(kept)
    ax = axes_or_new(ax, figsize=(7.0, 4.8))
    i = np.arange(n)
    bars = ax.bar(i, d, color=["tab:green" if k else "tab:gray" for k in kept])
    for b_, k in zip(bars, kept):
        if k:
            b_.set_hatch("//")
    ax.set_yscale("symlog", linthresh=10)
    ax.axhline(0.0, color="0.3", lw=0.8)
    ax.set_ylabel("BIC - BIC(base)")
    ax.set_xticks(i)
    ax.set_xticklabels(list(names), rotation=60, ha="right", fontsize=8)
    ax2 = ax.twinx()
    ax2.plot(i, 100 * r, "o", color="tab:red", label="held-out error reduction")
    ax2.set_ylabel("Held-out error reduction (%)", color="tab:red")
    ax2.axhline(0.0, color="tab:red", lw=0.5, ls=":")
    if gate is not None:
        ax2.axhline(100 * float(gate), color="tab:red", lw=1.0, ls="--", gid="gate",
                    label=f"held-out gate: at least {100 * float(gate):g} % reduction")
        ax2.legend(fontsize="small", loc="upper right")
    return ax
