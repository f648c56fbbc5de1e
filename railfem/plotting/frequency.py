"""Responses over frequency: magnitude and phase, point mobility with named resonances,
values per one-third-octave band and the track decay rate."""

from __future__ import annotations

import logging

import numpy as np

from .base import (MARKERS, axes_or_new, band_axes, band_ticks, columns, curve_labels, legend,
                  plain_log_labels, positive_or_nan, pyplot, vector)

log = logging.getLogger(__name__)


def plot_magnitude_phase(frequency, values, labels=None, *,
                         ylabel: str = "Mobility (m/s/N)", axes=None):
    """Magnitude (log-log) above phase (degrees) of complex responses.

    values : (nf,) or (nf, nc) complex; labels : one per column or None;
    axes : a pair (magnitude, phase) to draw into. Returns the pair.
    """
    frequency = vector(frequency, "frequency")
    v = columns(values, frequency.size, "values", "frequency", dtype=complex)
    names = curve_labels(labels, v.shape[1])
    if axes is None:
        plt = pyplot()
        _, axes = plt.subplots(2, 1, sharex=True, figsize=(6.4, 6.0), layout="constrained",
                               gridspec_kw={"height_ratios": [2, 1]})
    if len(axes) != 2:
        raise ValueError(f"axes must be a pair (magnitude, phase), got {len(axes)} axes")
    ax_mag, ax_phase = axes
    for j, name in enumerate(names):
        ax_mag.loglog(frequency, positive_or_nan(np.abs(v[:, j])), label=name)
        ax_phase.semilogx(frequency, np.degrees(np.angle(v[:, j])), label=name)
    ax_mag.set_ylabel(ylabel)
    ax_phase.set_ylabel("Phase (deg)")
    ax_phase.set_xlabel("Frequency (Hz)")
    ax_phase.set_ylim(-190, 190)
    ax_phase.set_yticks([-180, -90, 0, 90, 180])
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    legend(ax_mag)
    return ax_mag, ax_phase


def mark_frequencies(ax, marks, *, color="0.3", text_y: float = 0.97, fmt=None,
                     merge_ratio: float | None = None):
    """Vertical lines at named frequencies with their names written along them.

    marks : dict name -> frequency (Hz), or a sequence of (name, frequency) pairs when names
    repeat (non-finite values and values outside the x range are skipped with a log
    message). The text reads '<name> <frequency>' unless ``fmt`` (name, frequency -> str)
    says otherwise. A text goes left of its line, or right of it when the left is taken;
    marks too close for either share one text, a line each, left to right (as do marks
    closer than ``merge_ratio``, when given), so no two texts overlap.
    ``text_y`` (axes fraction) is where the text starts: near the top (the default) it
    hangs down, below 0.5 it rises. Returns the list of lines drawn.
    """
    fmt = fmt or (lambda name, f: f"{name} {_hz_text(f)}")
    low, high = sorted(ax.get_xlim())
    pairs = marks.items() if isinstance(marks, dict) else marks
    kept = []
    for name, f in pairs:
        f = float(f)
        if not (np.isfinite(f) and low <= f <= high):
            log.info("not marking %s at %s Hz: outside the plotted %g-%g Hz", name, f, low,
                     high)
            continue
        kept.append((f, str(name)))
    kept.sort()
    lines = []
    for f, name in kept:
        line = ax.axvline(f, color=color, linestyle=":", linewidth=1.0, zorder=1)
        line.set_gid(f"mark:{name}")
        lines.append(line)
    for f, texts, ha in _mark_text_layout(ax, [(f, fmt(name, f)) for f, name in kept],
                                          merge_ratio):
        rising = text_y <= 0.5  # the lines start together at text_y
        ax.text(f, text_y, "\n".join(f" {t} " for t in texts),
                transform=ax.get_xaxis_transform(), rotation=90, ha=ha,
                va="bottom" if rising else "top", multialignment="left" if rising else "right",
                fontsize="x-small", color=color)
    return lines


#: Across the axis, in font sizes: the thickness of a vertical one-line text, the step per
#: further line and the least gap between two texts; all times _SHRINK, a margin for the
#: layout changing the width of the axes (a constrained layout mostly widens them).
_TEXT_THICKNESS, _LINE_STEP, _TEXT_GAP, _SHRINK = 1.1, 1.2, 0.5, 1.1


def _mark_text_layout(ax, marks, merge_ratio=None):
    """Where the texts of ``marks`` ((frequency, text)) go, so that no two texts overlap:
    a list of (frequency of the line, lines of text, 'right' | 'left'). A text stands left
    of its line, or right of the last line of its group when the left is taken; marks with
    no room for either share one text, a line each (and marks closer than ``merge_ratio``)."""
    from matplotlib.font_manager import FontProperties

    size = FontProperties(size="x-small").get_size_in_points()
    fig = ax.figure
    width = ax.get_position().width * fig.get_figwidth() * 72.0  # axes width, points
    unit = _SHRINK * size / max(width, 1.0)  # one font size, as an axes fraction
    to_axes = ax.transAxes.inverted()
    at = sorted((float(to_axes.transform(ax.transData.transform((f, 0.0)))[0]), f, text)
                for f, text in marks if text)
    groups = []  # [marks, ha, end of the text (axes fraction)]
    for mark in at:
        group = [mark]
        while True:
            end = groups[-1][2] if groups else -np.inf
            close = (merge_ratio is not None and groups and abs(
                np.log(group[0][1] / groups[-1][0][-1][1])) <= np.log(merge_ratio))
            thick = unit * (_TEXT_THICKNESS + _LINE_STEP * (len(group) - 1))
            if not close and group[0][0] - thick - unit * _TEXT_GAP >= end:
                groups.append([group, "right", group[0][0]])  # ends at its first line
                break
            if not close and group[-1][0] - unit * _TEXT_GAP >= end:
                groups.append([group, "left", group[-1][0] + thick])  # from its last line
                break
            group = groups.pop()[0] + group
    return [(g[0][1] if ha == "right" else g[-1][1], [m[2] for m in g], ha)
            for g, ha, _ in groups]


def _hz_text(f: float) -> str:
    return f"{f / 1000:.3g} kHz" if f >= 1000 else f"{f:.3g} Hz"


def plot_point_mobility(frequency, values, labels=None, *, marks=None,
                        ylabel: str = "Point mobility (m/s/N)", axes=None):
    """Point mobility magnitude and phase with named resonances marked.

    frequency : (nf,) Hz; values : (nf,) or (nf, nc) complex mobility (m/s/N). Use a fine
    frequency grid (a 1/24 octave or finer resolves the pinned-pinned peak).
    marks : dict name -> frequency (Hz), e.g. {"rail on pad": 480.0, "sleeper on ballast":
    95.0, "pinned-pinned": 1050.0}; a dotted line with the name on both axes.
    Returns the (magnitude, phase) axes.
    """
    ax_mag, ax_phase = plot_magnitude_phase(frequency, values, labels, ylabel=ylabel,
                                            axes=axes)
    if marks:
        mark_frequencies(ax_mag, marks)
        mark_frequencies(ax_phase, marks, fmt=lambda name, f: "")
    return ax_mag, ax_phase


def plot_band_values(centres, values, labels=None, *,
                     ylabel: str = "Decay rate (dB/m)", ax=None, logy: bool = False):
    """Values per one-third-octave band on a log frequency axis with nominal labels.

    centres : (nb,) band centre frequencies (Hz); values : (nb,) or (nb, nc).
    One line with markers per column; ``logy=True`` for a log value axis.
    """
    centres = vector(centres, "centres")
    if np.any(centres <= 0):
        raise ValueError("centres must be positive band centre frequencies in Hz")
    v = columns(values, centres.size, "values", "centres")
    names = curve_labels(labels, v.shape[1])
    ax = axes_or_new(ax)
    for j, name in enumerate(names):
        ax.plot(centres, v[:, j], marker=MARKERS[j % len(MARKERS)], markersize=4,
                label=name)
    return band_axes(ax, centres, ylabel, logy=logy)


#: Default decay-rate axis (dB/m): log scale over the range of track decay rates.
DECAY_RATE_YLIM = (0.1, 100.0)


def plot_decay_rate(centres, decay_rate, labels=None, *, d_min=None, fails=None,
                    limit=None, limit_label: str = "ISO 3095 lower limit",
                    cut_on=None, ax=None, ylim=DECAY_RATE_YLIM):
    """Track decay rate per one-third-octave band on a logarithmic dB/m axis.

    centres : (nb,) band centres (Hz); decay_rate : (nb,) or (nb, nc) dB/m (one column
    per sensor or direction, named by ``labels``).
    d_min : (nb,) or (nb, nc) lowest measurable decay rate (EN 15461, dB/m), drawn dotted.
    fails : (nb,) or (nb, nc) bool, bands that fail the EN 15461 checks (far-field drop,
    D >= D_min): hollow markers, with a legend entry.
    limit : (band centres Hz, limit dB/m), e.g. railfem.standards.iso3095.track_decay_limit
    ('vertical'): drawn black dashed; bands below it get a red cross and a legend entry.
    cut_on : dict name -> frequency (Hz) of waves cutting on in the plotted range (see
    railfem.rail.branches.cut_ons): dotted lines with their names (why a decay rate jumps there).
    Put the model and the sensor direction in the title (``ax.set_title``).
    """
    from matplotlib.lines import Line2D

    centres = vector(centres, "centres")
    if np.any(centres <= 0):
        raise ValueError("centres must be positive band centre frequencies in Hz")
    d = columns(decay_rate, centres.size, "decay_rate", "centres")
    names = curve_labels(labels, d.shape[1])
    bad = np.zeros(d.shape, bool) if fails is None else np.broadcast_to(
        columns(fails, centres.size, "fails", "centres", dtype=bool), d.shape)
    ax = axes_or_new(ax)
    extra = []
    for j, name in enumerate(names):
        marker = MARKERS[j % len(MARKERS)]
        (line,) = ax.plot(centres, positive_or_nan(d[:, j]), marker=marker, markersize=5,
                          label=name)
        if bad[:, j].any():
            ax.plot(centres[bad[:, j]], positive_or_nan(d[bad[:, j], j]), linestyle="none",
                    marker=marker, markersize=7, markerfacecolor="white",
                    markeredgecolor=line.get_color(), zorder=3)
    if bad.any():
        extra.append(Line2D([], [], linestyle="none", marker="o", markerfacecolor="white",
                            markeredgecolor="0.3", label="fails EN 15461 check (hollow)"))
    if d_min is not None:
        dm = columns(d_min, centres.size, "d_min", "centres")
        same = np.allclose(dm, dm[:, :1], equal_nan=True)
        for j in range(1 if same else dm.shape[1]):
            ax.plot(centres, positive_or_nan(dm[:, j]), color="0.45" if same else f"C{j}",
                    linestyle=":", linewidth=1.5,
                    label="EN 15461 lowest measurable D_min" if j == 0 else None)
    if limit is not None:
        lf, lv = (np.asarray(v, dtype=float) for v in limit)
        ax.plot(lf, lv, color="black", linestyle="--", linewidth=1.5, label=limit_label,
                gid="limit")
        below = np.zeros(d.shape, bool)
        for j in range(d.shape[1]):
            lim = np.interp(np.log(centres), np.log(lf), lv, left=np.nan, right=np.nan)
            with np.errstate(invalid="ignore"):
                below[:, j] = d[:, j] < lim * (1 - 1e-9)
        if below.any():
            cf = np.broadcast_to(centres[:, None], d.shape)[below]
            ax.plot(cf, d[below], linestyle="none", marker="x", markersize=9, color="red",
                    zorder=4)
            extra.append(Line2D([], [], linestyle="none", marker="x", color="red",
                                label=f"below the {limit_label}"))
    ax.set_xscale("log")
    ax.set_yscale("log")
    finite = d[np.isfinite(d) & (d > 0)]
    low, high = ylim
    if finite.size:
        low, high = min(low, finite.min() / 1.5), max(high, finite.max() * 1.5)
    ax.set_ylim(low, high)
    plain_log_labels(ax.yaxis)
    band_ticks(ax, centres)
    ax.set_xlabel("One-third-octave band centre frequency (Hz)")
    ax.set_ylabel("Track decay rate (dB/m)")
    ax.grid(True, which="major", alpha=0.4)
    ax.grid(True, which="minor", axis="y", alpha=0.15)
    if cut_on:
        mark_cut_ons(ax, cut_on)
    handles, _ = ax.get_legend_handles_labels()
    if handles or extra:
        # low bands at low decay rates are empty on track decay-rate plots
        ax.legend(handles=handles + extra, fontsize="small", loc="lower left")
    return ax


def mark_cut_ons(ax, cut_on):
    """Mark the cut-on frequencies ``cut_on`` (dict name -> Hz, or a sequence of
    railfem.rail.branches.CutOn) with dotted lines and '<name> cut-on <f>' along them."""
    if not isinstance(cut_on, dict):
        cut_on = [(c.name, c.frequency) if hasattr(c, "frequency") else tuple(c)
                  for c in cut_on]
    return mark_frequencies(ax, cut_on, color="tab:purple", text_y=0.03,
                            fmt=lambda name, f: f"{name} cut-on {_hz_text(f)}")


def plot_decay_rate_results(results, labels=None, *, direction: str | None = None, **kwargs):
    """:func:`plot_decay_rate` of EN 15461 results (railfem.standards.en15461
    DecayRateResult, one or a sequence: one curve each, e.g. head and foot sensor).

    D_min and the failed checks come from the results; ``direction`` ('vertical' or
    'lateral') draws the ISO 3095:2013 lower limit of that direction.
    """
    if hasattr(results, "decay_rate"):
        results = [results]
    results = list(results)
    if not results:
        raise ValueError("results is empty: pass at least one DecayRateResult")
    centres = np.asarray(results[0].frequency, dtype=float)
    for r in results[1:]:
        if not np.array_equal(np.asarray(r.frequency, dtype=float), centres):
            raise ValueError("all results must have the same bands (frequency)")
    if direction is not None and "limit" not in kwargs:
        from ..standards.iso3095 import track_decay_limit

        kwargs["limit"] = track_decay_limit(direction)
        kwargs.setdefault("limit_label", f"ISO 3095 lower limit, {direction}")
    return plot_decay_rate(centres, np.column_stack([r.decay_rate for r in results]), labels,
                           d_min=np.column_stack([r.d_min for r in results]),
                           fails=np.column_stack([~np.asarray(r.suitable, bool)
                                                  for r in results]), **kwargs)
