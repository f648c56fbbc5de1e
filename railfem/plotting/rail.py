"""Along the rail and over the mesh: levels along the rail, pass-by levels against the
train position, mesh convergence."""

from __future__ import annotations

import logging

import numpy as np

from .base import (MARKERS, axes_or_new, columns, curve_labels, legend, plain_log_labels,
                  positive_or_nan, vector)

log = logging.getLogger(__name__)


def along_rail_frequencies(frequency, wanted=(250.0, 500.0, 1000.0, 2000.0)) -> np.ndarray:
    """Indices into the computed ``frequency`` grid (Hz, increasing) for along-rail curves.

    Each wanted frequency inside the computed range is taken at its nearest grid point
    (log distance); wanted frequencies outside it are dropped with a log message; two that
    fall on one grid point count once. If none is left, up to ``len(wanted)`` frequencies
    spread evenly (in log) over the computed range are taken instead. The indices returned
    are distinct and increasing.
    """
    f = vector(frequency, "frequency")
    if np.any(f <= 0) or np.any(np.diff(f) <= 0):
        raise ValueError("frequency must be positive and strictly increasing (Hz)")
    wanted = np.atleast_1d(np.asarray(wanted, dtype=float))
    step = np.log(f[1] / f[0]) / 2 if f.size > 1 else 0.0  # half a grid step of slack
    inside = (np.log(wanted) >= np.log(f[0]) - step) & (np.log(wanted) <= np.log(f[-1]) + step)
    if (~inside).any():
        log.info("along-rail curves: %s Hz outside the computed %.4g-%.4g Hz, dropped",
                 ", ".join(f"{w:g}" for w in wanted[~inside]), f[0], f[-1])
    idx = [int(np.argmin(np.abs(np.log(f / w)))) for w in wanted[inside]]
    if not idx:
        n = min(len(wanted), f.size)
        targets = np.exp(np.linspace(np.log(f[0]), np.log(f[-1]), n + 2)[1:-1]) if n > 1 \
            else np.array([np.sqrt(f[0] * f[-1])])
        idx = [int(np.argmin(np.abs(np.log(f / t)))) for t in targets]
        log.info("along-rail curves: none of the wanted frequencies lies in %.4g-%.4g Hz; "
                 "using %s Hz", f[0], f[-1], ", ".join(f"{f[i]:.4g}" for i in sorted(set(idx))))
    unique = sorted(set(idx))
    if len(unique) < len(idx):
        log.info("along-rail curves: %d wanted frequencies share a grid point; %d curves",
                 len(idx), len(unique))
    return np.array(unique, dtype=int)


def plot_along_rail(x, values, labels=None, *, ax=None, ylabel: str = "Level (dB)",
                    x_force: float | None = None, supports=None):
    """Levels (dB) along the rail; values (nx,) or (nx, nc), x (nx,) positions (m).

    x_force : position of the force (m); the x axis then shows the distance from it
    (x - x_force). supports : positions (m, same origin as x) of the sleepers, marked with
    triangles under the curves.
    """
    x = vector(x, "x")
    v = columns(values, x.size, "values", "x")
    names = curve_labels(labels, v.shape[1])
    x0 = 0.0 if x_force is None else float(x_force)
    ax = axes_or_new(ax)
    for j, name in enumerate(names):
        ax.plot(x - x0, v[:, j], label=name)
    if supports is not None:
        s = np.asarray(supports, dtype=float).ravel() - x0
        s = s[(s >= (x - x0).min()) & (s <= (x - x0).max())]
        if s.size:
            ax.plot(s, np.zeros_like(s), linestyle="none", marker="^", markersize=6,
                    color="0.35", transform=ax.get_xaxis_transform(), clip_on=False,
                    label="sleeper (support)", gid="supports")
    ax.set_xlabel("Distance along rail x (m)" if x_force is None
                  else "Distance from the force (m)")
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    legend(ax)
    return ax


# ------------------------------------------------------------------------ pass-by
def plot_passby_levels(position, levels, labels=None, *, ax=None,
                       ylabel: str = "Band velocity level (dB re 1e-9 m/s)"):
    """Band levels (dB) at the sensor against the train position; position (nx,), levels
    (nx,) or (nx, nc) (one column per band)."""
    x = vector(position, "position")
    v = columns(levels, x.size, "levels", "position")
    names = curve_labels(labels, v.shape[1])
    ax = axes_or_new(ax, figsize=(8.0, 4.8))
    for j, name in enumerate(names):
        ax.plot(x, v[:, j], label=name, linewidth=0.8)
    ax.set_xlabel("Leading-wheel position relative to the sensor (m)")
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    legend(ax)
    return ax


# -------------------------------------------------------------------- convergence
def convergence_slope(h, errors) -> float:
    """Least-squares slope of log(error) against log(h) over positive finite points."""
    h = np.asarray(h, dtype=float)
    errors = np.asarray(errors, dtype=float)
    ok = np.isfinite(h) & np.isfinite(errors) & (h > 0) & (errors > 0)
    if np.count_nonzero(ok) < 2 or np.ptp(h[ok]) == 0:
        return float("nan")
    return float(np.polyfit(np.log(h[ok]), np.log(errors[ok]), 1)[0])


def plot_convergence(h, errors, labels=None, *, ax=None, fit: bool = True,
                     xlabel: str = "Element size h (m)", ylabel: str = "Relative error"):
    """Log-log error against element size; the fitted slope goes in the legend.

    h : (nh,); errors : (nh,) or (nh, nc).
    """
    h = vector(h, "h")
    e = columns(errors, h.size, "errors", "h")
    names = curve_labels(labels, e.shape[1])
    ax = axes_or_new(ax)
    for j, name in enumerate(names):
        label = name
        if fit:
            slope = convergence_slope(h, e[:, j])
            rate = f"slope {slope:.2f}" if np.isfinite(slope) else "slope n/a"
            label = f"{name} ({rate})" if name else rate
        ax.loglog(h, positive_or_nan(e[:, j]), marker=MARKERS[j % len(MARKERS)],
                  label=label)
    plain_log_labels(ax.xaxis)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    legend(ax)
    return ax
