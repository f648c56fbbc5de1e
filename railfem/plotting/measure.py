"""Estimates against measurements or the truth: band overlay and residual, decay-rate
estimates of several estimators, roughness levels, errors per band."""

from __future__ import annotations

import numpy as np

from .base import (MARKERS, axes_or_new, band_axes, band_ticks, columns, curve_labels, legend,
                  plain_log_labels, readable_log_ticks, vector)


# ------------------------------------------------------- model vs measurement, per band
def _band_centres(centres) -> np.ndarray:
    centres = vector(centres, "centres")
    if np.any(centres <= 0):
        raise ValueError("centres must be positive band centre frequencies in Hz")
    return centres


def plot_band_overlay(centres, measured, model=None, *, valid=None,
                      labels=("measured", "model"), ylabel: str = "Decay rate (dB/m)",
                      ax=None, logy: bool = False):
    """Measured values per band (markers) over model values (line), e.g. decay rates.

    centres : (nb,) band centres (Hz); measured, model : (nb,) or (nb, nc) (model may be
    None); valid : bool like ``measured`` — bands that failed their checks (False) are drawn
    as open markers and named in the legend. Returns the Axes.
    """
    centres = _band_centres(centres)
    meas = columns(measured, centres.size, "measured", "centres")
    ok = (np.ones(meas.shape, bool) if valid is None
          else columns(valid, centres.size, "valid", "centres", dtype=bool))
    if ok.shape != meas.shape:
        raise ValueError(f"valid has shape {ok.shape}, measured {meas.shape}; give one flag "
                         "per value")
    mod = None if model is None else columns(model, centres.size, "model", "centres")
    names = list(labels) if not isinstance(labels, str) else [labels, None]
    ax = axes_or_new(ax)
    for j in range(meas.shape[1]):
        mk = MARKERS[j % len(MARKERS)]
        suffix = f" {j + 1}" if meas.shape[1] > 1 else ""
        line, = ax.plot(centres[ok[:, j]], meas[ok[:, j], j], mk, markersize=5,
                        label=f"{names[0]}{suffix}")
        if (~ok[:, j]).any():
            ax.plot(centres[~ok[:, j]], meas[~ok[:, j], j], mk, markersize=5,
                    markerfacecolor="none", color=line.get_color(),
                    label=f"{names[0]}{suffix}, band failed its checks")
    if mod is not None:
        for j in range(mod.shape[1]):
            suffix = f" {j + 1}" if mod.shape[1] > 1 else ""
            ax.plot(centres, mod[:, j], "-", label=f"{names[1] or 'model'}{suffix}")
    return band_axes(ax, centres, ylabel, logy=logy)


def plot_band_residual(centres, residual, labels=None, *, ylabel: str = "Model - measurement (dB)",
                       ax=None):
    """Residual per band as bars around a zero line; (nb,) or (nb, nc) side by side.

    NaN residuals (bands not compared) leave a gap. Returns the Axes.
    """
    centres = _band_centres(centres)
    r = columns(residual, centres.size, "residual", "centres")
    names = curve_labels(labels, r.shape[1])
    ax = axes_or_new(ax)
    n = r.shape[1]
    width = 2 ** (1 / 3 / (n + 1))  # bars share one third of an octave, in log space
    for j, name in enumerate(names):
        left = centres * width ** (j - n / 2)
        ax.bar(left, r[:, j], width=left * (width - 1), align="edge", label=name)
    ax.axhline(0.0, color="black", linewidth=0.8)
    return band_axes(ax, centres, ylabel, grid_axis="y")


# ------------------------------------------------------------- pass-by decay rates
def plot_decay_rate_estimates(centres, estimates: dict, *, ax=None,
                              ylabel: str = "Decay rate (dB/m)"):
    """Decay rates per one-third-octave band from several estimators, with error bars.

    ``estimates`` maps a label to ``(values, errors)``, each (nb,) in dB/m (errors may be
    None); NaN values (failed bands) leave gaps. An estimator without a value in any band
    draws nothing: its legend entry reads '<label>: every band rejected'. Log value axis,
    nominal band labels.
    """
    centres = vector(centres, "centres")
    if np.any(centres <= 0):
        raise ValueError("centres must be positive band centre frequencies in Hz")
    ax = axes_or_new(ax)
    n = max(len(estimates), 1)
    for j, (label, (values, errors)) in enumerate(estimates.items()):
        v = columns(values, centres.size, f"values of {label!r}", "centres")[:, 0]
        e = None if errors is None else np.nan_to_num(
            columns(errors, centres.size, f"errors of {label!r}", "centres")[:, 0])
        shift = 2.0 ** ((j - (n - 1) / 2) / 24)  # side by side within the band
        if not np.any(v > 0):  # a note in the legend, no symbol: there is nothing to show
            ax.errorbar([], [], linestyle="none", marker="none",
                        label=f"{label}: every band rejected")
            continue
        ax.errorbar(centres * shift, np.where(v > 0, v, np.nan), yerr=e,
                    marker=MARKERS[j % len(MARKERS)], markersize=4, capsize=2,
                    label=str(label))
    ax.set_xscale("log")
    ax.set_yscale("log")
    plain_log_labels(ax.yaxis)
    band_ticks(ax, centres)
    ax.set_xlabel("One-third-octave band centre frequency (Hz)")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    legend(ax)
    return ax


def plot_roughness(wavelength, levels: dict, *, ax=None, limit: bool = True,
                   styles: dict | None = None):
    """Roughness level (dB re 1 um) vs wavelength (cm, long wavelengths on the left) per
    one-third-octave wavelength band, with the EN ISO 3095:2013 limit curve (Figure 2).

    wavelength: (nb,) m, shared by every curve, or a dict label -> (nb,) m per curve.
    levels: label -> (nb,) dB (NaN leaves gaps). styles: label -> matplotlib kwargs."""
    from ..standards.iso3095 import roughness_limit

    ax = axes_or_new(ax)
    for j, (label, lev) in enumerate(levels.items()):
        lam = wavelength[label] if isinstance(wavelength, dict) else wavelength
        lam = vector(lam, f"wavelength of {label!r}")
        y = columns(lev, lam.size, f"levels of {label!r}", "wavelengths")[:, 0]
        kw = {"marker": MARKERS[j % len(MARKERS)], "markersize": 4}
        kw.update((styles or {}).get(label, {}))
        ax.plot(lam * 100, y, label=str(label), **kw)
    if limit:
        lam, lim = roughness_limit()
        ax.plot(lam * 100, lim, color="k", lw=2, ls="--", label="EN ISO 3095:2013 limit")
    ax.set_xscale("log")
    if not ax.xaxis_inverted():
        ax.invert_xaxis()
    readable_log_ticks(ax.xaxis)
    ax.set_xlabel("Wavelength (cm)")
    ax.set_ylabel("Roughness level (dB re 1 um)")
    ax.grid(True, which="both", alpha=0.3)
    legend(ax)
    return ax


def plot_band_errors(x, errors: dict, *, ax=None, xlabel: str = "Wavelength (cm)",
                     ylabel: str = "Estimate - truth (dB)", xscale: float = 100.0,
                     invert: bool = True, band: float | None = 1.0):
    """Errors per band of several estimates (label -> (nb,)) vs x (m, shown times
    ``xscale``: cm by default), a zero line and an optional +-band tolerance."""
    ax = axes_or_new(ax)
    xv = vector(x, "x") * xscale
    for j, (label, e) in enumerate(errors.items()):
        y = columns(e, xv.size, f"errors of {label!r}", "x")[:, 0]
        ax.plot(xv, y, marker=MARKERS[j % len(MARKERS)], markersize=4, label=str(label))
    ax.axhline(0.0, color="k", lw=1)
    if band:
        for s in (-band, band):
            ax.axhline(s, color="0.5", lw=1, ls=":")
    ax.set_xscale("log")
    if invert and not ax.xaxis_inverted():
        ax.invert_xaxis()
    readable_log_ticks(ax.xaxis)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    legend(ax)
    return ax
