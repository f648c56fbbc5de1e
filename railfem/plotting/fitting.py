"""Figures of a fit: measured against fitted transfer mobilities, profile likelihoods."""

from __future__ import annotations

import numpy as np

from .base import axes_or_new, pyplot, vector


def plot_transfer_fit(frequency, measured, fitted, label: str = "", *, ax=None):
    """Magnitude of a measured (markers) and a fitted (line, same colour) mobility, log-log.

    frequency : (nf,) Hz; measured, fitted : (nf,) complex mobility (m/s/N); label names the
    pair ('<label> measured', '<label> fitted'). Call again with the returned Axes for more
    pairs (e.g. one per hammer position). Returns the Axes.
    """
    f = vector(frequency, "frequency")
    m = vector(measured, "measured", dtype=complex)
    y = vector(fitted, "fitted", dtype=complex)
    if not len(m) == len(y) == len(f):
        raise ValueError(f"measured ({len(m)}) and fitted ({len(y)}) need one value per "
                         f"frequency ({len(f)})")
    ax = axes_or_new(ax, figsize=(7.0, 5.0))
    name = f"{label} " if label else ""
    line, = ax.loglog(f, np.abs(m), "o", markersize=3, label=f"{name}measured")
    ax.loglog(f, np.abs(y), "-", color=line.get_color(), label=f"{name}fitted")
    ax.set_xlabel("Frequency (Hz)")
    ax.set_ylabel("Mobility (m/s/N)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    return ax


def plot_profiles(profiles: dict, *, units: dict | None = None, threshold: float | None = None,
                  axes=None):
    """Profile likelihoods, one panel per parameter: the rise of chi-square over its
    minimum against the parameter value (log axis), with the ``threshold`` of the 95 %
    interval (e.g. railfem.identify.profiling.CHI2_95) as a dashed line.

    profiles : name -> {"value": (n,), "delta_chi2": (n,)} (a fit result's ``profiles``);
    units : name -> unit for the axis labels. axes : one Axes per profile. Returns the list
    of Axes.
    """
    if not profiles:
        raise ValueError("profiles is empty: nothing to plot")
    n = len(profiles)
    if axes is None:
        _, grid = pyplot().subplots(1, n, figsize=(4.0 * n, 3.5), layout="constrained",
                                    squeeze=False)
        axes = list(grid[0])
    axes = list(np.ravel(axes))
    if len(axes) != n:
        raise ValueError(f"got {len(axes)} axes for {n} profiles")
    for ax, (name, p) in zip(axes, profiles.items()):
        ax.semilogx(p["value"], p["delta_chi2"], "o-")
        unit = (units or {}).get(name)
        ax.set_xlabel(f"{name} ({unit})" if unit else name)
        ax.set_ylabel("Delta chi-square")
        if threshold is not None:
            ax.axhline(threshold, color="k", linestyle="--", linewidth=0.8,
                       label="95 % threshold")
            ax.set_ylim(0, max(4 * threshold, 1.0))
            ax.legend(fontsize=7)
        ax.grid(True, which="both", alpha=0.3)
    return axes
