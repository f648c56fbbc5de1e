"""Matplotlib figures for railfem results.

Every plotting function draws into ``ax`` (or ``axes``) when given, otherwise on a
new figure, and returns the Axes; save with :func:`save_figure`. Matplotlib is
imported inside the functions (``import railfem`` stays fast), and without a
display the non-interactive Agg backend is selected.

Conventions follow :mod:`railfem.conventions`: frequency (or position, or
element size) is axis 0 of every array; a wave ``exp(-i k x)`` is positive-going
when ``Im k < 0``.
"""

from __future__ import annotations

import logging
import os
import sys
from pathlib import Path

import numpy as np

from .atomic import atomic_path
from .branches import MAX_ATTENUATION, propagating_mask

log = logging.getLogger(__name__)

__all__ = [
    "MAX_ATTENUATION", "propagating_mask", "save_figure", "plot_dispersion",
    "plot_dispersion_k", "plot_branches", "branch_colours", "plot_magnitude_phase",
    "mark_frequencies", "plot_point_mobility", "nominal_band_label", "plot_band_values",
    "plot_decay_rate", "plot_decay_rate_results", "mark_cut_ons", "along_rail_frequencies",
    "plot_along_rail", "convergence_slope", "plot_convergence", "plot_band_overlay",
    "plot_band_residual", "plot_passby_levels", "plot_decay_rate_estimates",
    "plot_roughness", "plot_band_errors", "plot_residual_map", "plot_residual_spectrum",
    "plot_residual_distance", "plot_error_before_after", "plot_candidate_scores",
]

_MARKERS = ("o", "s", "^", "v", "D", "<", ">", "p", "h", "*", "X", "P")
# preferred-number series of nominal one-third-octave centre frequencies (IEC 61260)
_NOMINAL_MANTISSAS = np.array([1.0, 1.25, 1.6, 2.0, 2.5, 3.15, 4.0, 5.0, 6.3, 8.0, 10.0])
# Permissions of written files: what open() would give (0666 minus the umask).
_NON_GUI_BACKENDS = {"agg", "pdf", "pgf", "ps", "svg", "cairo", "template"}


# ------------------------------------------------------------------ matplotlib setup
def _has_display() -> bool:
    if sys.platform in ("win32", "darwin"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def _pyplot():
    """Import pyplot, switching to Agg first when there is no display."""
    import matplotlib

    if not _has_display():
        backend = str(matplotlib.get_backend()).lower()
        if backend not in _NON_GUI_BACKENDS and not backend.startswith("module://"):
            matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _axes(ax, figsize=(6.4, 4.8)):
    """Return ``ax`` or a new Axes on a new figure."""
    if ax is not None:
        return ax
    plt = _pyplot()
    _, ax = plt.subplots(figsize=figsize, layout="constrained")
    return ax


def save_figure(fig, path, *, dpi: int = 150, close: bool = True) -> Path:
    """Write ``fig`` atomically (temporary file in the same folder + os.replace).

    ``fig`` may also be an Axes (its figure is saved). The format follows the
    suffix of ``path`` (PNG when there is none). The figure is closed afterwards
    unless ``close=False``. Returns the path written.
    """
    fig = getattr(fig, "figure", fig)
    if not hasattr(fig, "savefig"):
        raise TypeError(f"save_figure needs a matplotlib Figure or Axes, got {type(fig)!r}")
    path = Path(path)
    if not path.suffix:
        path = path.with_suffix(".png")
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=path.suffix.lstrip(".").lower(), dpi=dpi)
    if close:
        _pyplot().close(fig)
    log.info("wrote figure %s", path)
    return path


# ------------------------------------------------------------------------- checks
def _vector(values, name: str, dtype=float) -> np.ndarray:
    array = np.asarray(values, dtype=dtype)
    if array.ndim != 1 or array.size == 0:
        raise ValueError(f"{name} must be a non-empty 1-D array, got shape {array.shape}")
    return array


def _columns(values, n: int, name: str, axis_name: str, dtype=float) -> np.ndarray:
    """Return ``values`` as (n, c): 1-D becomes one column; axis 0 must have length n."""
    array = np.asarray(values, dtype=dtype)
    if array.ndim == 1:
        array = array[:, None]
    if array.ndim != 2 or array.shape[0] != n:
        hint = ""
        if array.ndim == 2 and array.shape[1] == n:
            hint = f"; {axis_name} is axis 0, so pass {name}.T"
        raise ValueError(
            f"{name} must have shape ({n},) or ({n}, c) to match {axis_name} "
            f"(length {n}), got {np.shape(values)}{hint}"
        )
    return array


def _labels(labels, count: int, name: str = "labels") -> list[str | None]:
    if labels is None:
        return [None] * count
    if isinstance(labels, str):
        labels = [labels]
    labels = [None if lab is None else str(lab) for lab in labels]
    if len(labels) != count:
        raise ValueError(f"got {len(labels)} {name} for {count} curves; "
                         f"pass one label per column or {name}=None")
    return labels


def _plain_log_labels(axis) -> None:
    """Label a log axis with plain numbers (0.5, 2, 1e-05) instead of 2x10^0 forms."""
    from matplotlib.ticker import Formatter

    class PlainLogFormatter(Formatter):
        """'%g' labels; minor ticks (2, 3, 5 x 10^n) labelled only on short axes."""

        def __init__(self, minor: bool):
            self.minor = minor

        def __call__(self, value, pos=None):
            if not self.minor:
                return f"{value:g}"
            low, high = sorted(self.axis.get_view_interval())
            if not (low > 0 and value > 0):
                return ""
            decades = np.log10(high / low)
            mantissa = round(value / 10.0 ** np.floor(np.log10(value) + 1e-9), 6)
            shown = (2, 3, 5) if decades <= 1 else (2, 5) if decades <= 1.6 else ()
            return f"{value:g}" if mantissa in shown else ""

    axis.set_major_formatter(PlainLogFormatter(minor=False))
    axis.set_minor_formatter(PlainLogFormatter(minor=True))


def _legend(ax) -> None:
    handles, names = ax.get_legend_handles_labels()
    if handles:
        ax.legend(fontsize="small")


# --------------------------------------------------------------------- dispersion
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
    frequency = _vector(frequency, "frequency")
    k = _columns(wavenumber, frequency.size, "wavenumber", "frequency", dtype=complex)
    types = _wave_labels(labels, k.shape)
    mask = propagating_mask(k, max_attenuation)
    freq = np.broadcast_to(frequency[:, None], k.shape)
    ax = _axes(ax)
    names = sorted(set(types[mask])) if mask.any() else []
    if not names:
        log.warning("plot_dispersion: no propagating wave (|Im k| <= %g |Re k|)",
                    max_attenuation)
    for i, name in enumerate(names):
        sel = mask & (types == name)
        ax.scatter(k.real[sel], freq[sel], s=10, marker=_MARKERS[i % len(_MARKERS)],
                   color=f"C{i % 10}", label=name or None)
    ax.set_xlabel("Wavenumber Re k (rad/m)")
    ax.set_ylabel("Frequency (Hz)")
    if mask.any() and np.all(k.real[mask] >= 0):
        ax.set_xlim(left=0)
    ax.set_ylim(bottom=min(0.0, float(frequency.min())))
    ax.grid(True, alpha=0.3)
    _legend(ax)
    return ax


def plot_dispersion_k(k_real, frequencies, labels=None, ax=None):
    """omega(k) curves: k (nk,) real rad/m, frequencies (nk, nmodes) Hz.

    ``labels`` gives one name per mode; modes sharing a name share a colour and
    one legend entry.
    """
    k_real = _vector(k_real, "k_real")
    freqs = _columns(frequencies, k_real.size, "frequencies", "k_real")
    names = _labels(labels, freqs.shape[1])
    ax = _axes(ax)
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
    _legend(ax)
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
    """Dispersion branches (railfem.branches.Branches): x = Re k (rad/m), y = frequency (Hz).

    One line per branch, one colour per branch (TYPE_COLOURS for the wave types), solid for
    the symmetric and dashed for the antisymmetric family, and one legend entry per branch
    (``branches.name``, in words). Branches come from k(omega) or omega(k) sweeps alike.
    ``markers`` (default: for k(omega) sweeps) marks the computed points.
    """
    ax = _axes(ax, figsize=(9.6, 5.6) if branches.n_branches > 8 else (6.4, 4.8))
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


# ------------------------------------------------------------- frequency response
def _positive_or_nan(values: np.ndarray) -> np.ndarray:
    return np.where(values > 0, values, np.nan)


def plot_magnitude_phase(frequency, values, labels=None, *,
                         ylabel: str = "Mobility (m/s/N)", axes=None):
    """Magnitude (log-log) above phase (degrees) of complex responses.

    values : (nf,) or (nf, nc) complex; labels : one per column or None;
    axes : a pair (magnitude, phase) to draw into. Returns the pair.
    """
    frequency = _vector(frequency, "frequency")
    v = _columns(values, frequency.size, "values", "frequency", dtype=complex)
    names = _labels(labels, v.shape[1])
    if axes is None:
        plt = _pyplot()
        _, axes = plt.subplots(2, 1, sharex=True, figsize=(6.4, 6.0), layout="constrained",
                               gridspec_kw={"height_ratios": [2, 1]})
    if len(axes) != 2:
        raise ValueError(f"axes must be a pair (magnitude, phase), got {len(axes)} axes")
    ax_mag, ax_phase = axes
    for j, name in enumerate(names):
        ax_mag.loglog(frequency, _positive_or_nan(np.abs(v[:, j])), label=name)
        ax_phase.semilogx(frequency, np.degrees(np.angle(v[:, j])), label=name)
    ax_mag.set_ylabel(ylabel)
    ax_phase.set_ylabel("Phase (deg)")
    ax_phase.set_xlabel("Frequency (Hz)")
    ax_phase.set_ylim(-190, 190)
    ax_phase.set_yticks([-180, -90, 0, 90, 180])
    for ax in axes:
        ax.grid(True, which="both", alpha=0.3)
    _legend(ax_mag)
    return ax_mag, ax_phase


def mark_frequencies(ax, marks, *, color="0.3", text_y: float = 0.97, fmt=None,
                     merge_ratio: float = 1.06):
    """Vertical lines at named frequencies with their names written along them.

    marks : dict name -> frequency (Hz), or a sequence of (name, frequency) pairs when names
    repeat (non-finite values and values outside the x range are skipped with a log
    message). The text reads '<name> <frequency>' unless ``fmt`` (name, frequency -> str)
    says otherwise; marks closer than ``merge_ratio`` share one text, joined by '; '.
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
    lines, groups = [], []
    for f, name in kept:
        line = ax.axvline(f, color=color, linestyle=":", linewidth=1.0, zorder=1)
        line.set_gid(f"mark:{name}")
        lines.append(line)
        if groups and f <= groups[-1][-1][0] * merge_ratio:
            groups[-1].append((f, name))
        else:
            groups.append([(f, name)])
    for group in groups:
        texts = [t for t in (fmt(name, f) for f, name in group) if t]
        if len(texts) == 2:  # two close marks: one name each side of the lines
            sides = [(group[0][0], texts[0], "right"), (group[-1][0], texts[1], "left")]
        else:
            sides = [(group[0][0], "; ".join(texts), "right")] if texts else []
        for f, text, ha in sides:
            ax.text(f, text_y, f" {text} ", transform=ax.get_xaxis_transform(), rotation=90,
                    ha=ha, va="top" if text_y > 0.5 else "bottom", fontsize="x-small",
                    color=color)
    return lines


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


# ------------------------------------------------------------ one-third octaves
def nominal_band_label(centre: float) -> str:
    """Nominal one-third-octave label of a centre frequency: 31.5, 1k, 1.25k, ..."""
    if not centre > 0:
        raise ValueError(f"band centre frequency must be positive, got {centre}")
    exponent = int(np.floor(np.log10(centre)))
    mantissa = centre / 10.0**exponent
    nearest = _NOMINAL_MANTISSAS[np.argmin(np.abs(np.log(_NOMINAL_MANTISSAS / mantissa)))]
    nominal = round(nearest * 10.0**exponent, 6)
    if nominal >= 1000:
        return f"{nominal / 1000:g}k"
    return f"{nominal:g}"


def plot_band_values(centres, values, labels=None, *,
                     ylabel: str = "Decay rate (dB/m)", ax=None, logy: bool = False):
    """Values per one-third-octave band on a log frequency axis with nominal labels.

    centres : (nb,) band centre frequencies (Hz); values : (nb,) or (nb, nc).
    One line with markers per column; ``logy=True`` for a log value axis.
    """
    centres = _vector(centres, "centres")
    if np.any(centres <= 0):
        raise ValueError("centres must be positive band centre frequencies in Hz")
    v = _columns(values, centres.size, "values", "centres")
    names = _labels(labels, v.shape[1])
    ax = _axes(ax)
    for j, name in enumerate(names):
        ax.plot(centres, v[:, j], marker=_MARKERS[j % len(_MARKERS)], markersize=4,
                label=name)
    ax.set_xscale("log")
    if logy:
        ax.set_yscale("log")
        _plain_log_labels(ax.yaxis)
    _band_ticks(ax, centres)
    ax.set_xlabel("One-third-octave band centre frequency (Hz)")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="major", alpha=0.3)
    _legend(ax)
    return ax


def _band_ticks(ax, centres: np.ndarray) -> None:
    from matplotlib.ticker import FixedFormatter, FixedLocator, NullLocator

    ordered = np.sort(centres)
    ax.xaxis.set_major_locator(FixedLocator(ordered))
    ax.xaxis.set_major_formatter(FixedFormatter([nominal_band_label(c) for c in ordered]))
    ax.xaxis.set_minor_locator(NullLocator())
    ax.tick_params(axis="x", labelrotation=90, labelsize="small")
    ax.set_xlim(ordered[0] * 2 ** (-1 / 6), ordered[-1] * 2 ** (1 / 6))


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
    railfem.branches.cut_ons): dotted lines with their names (why a decay rate jumps there).
    Put the model and the sensor direction in the title (``ax.set_title``).
    """
    from matplotlib.lines import Line2D

    centres = _vector(centres, "centres")
    if np.any(centres <= 0):
        raise ValueError("centres must be positive band centre frequencies in Hz")
    d = _columns(decay_rate, centres.size, "decay_rate", "centres")
    names = _labels(labels, d.shape[1])
    bad = np.zeros(d.shape, bool) if fails is None else np.broadcast_to(
        _columns(fails, centres.size, "fails", "centres", dtype=bool), d.shape)
    ax = _axes(ax)
    extra = []
    for j, name in enumerate(names):
        marker = _MARKERS[j % len(_MARKERS)]
        (line,) = ax.plot(centres, _positive_or_nan(d[:, j]), marker=marker, markersize=5,
                          label=name)
        if bad[:, j].any():
            ax.plot(centres[bad[:, j]], _positive_or_nan(d[bad[:, j], j]), linestyle="none",
                    marker=marker, markersize=7, markerfacecolor="white",
                    markeredgecolor=line.get_color(), zorder=3)
    if bad.any():
        extra.append(Line2D([], [], linestyle="none", marker="o", markerfacecolor="white",
                            markeredgecolor="0.3", label="fails EN 15461 check (hollow)"))
    if d_min is not None:
        dm = _columns(d_min, centres.size, "d_min", "centres")
        same = np.allclose(dm, dm[:, :1], equal_nan=True)
        for j in range(1 if same else dm.shape[1]):
            ax.plot(centres, _positive_or_nan(dm[:, j]), color="0.45" if same else f"C{j}",
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
    _plain_log_labels(ax.yaxis)
    _band_ticks(ax, centres)
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
    railfem.branches.CutOn) with dotted lines and '<name> cut-on <f>' along them."""
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
        from .standards.iso3095 import track_decay_limit

        kwargs["limit"] = track_decay_limit(direction)
        kwargs.setdefault("limit_label", f"ISO 3095 lower limit, {direction}")
    return plot_decay_rate(centres, np.column_stack([r.decay_rate for r in results]), labels,
                           d_min=np.column_stack([r.d_min for r in results]),
                           fails=np.column_stack([~np.asarray(r.suitable, bool)
                                                  for r in results]), **kwargs)


# ------------------------------------------------------------------ along the rail
def along_rail_frequencies(frequency, wanted=(250.0, 500.0, 1000.0, 2000.0)) -> np.ndarray:
    """Indices into the computed ``frequency`` grid (Hz, increasing) for along-rail curves.

    Each wanted frequency inside the computed range is taken at its nearest grid point
    (log distance); wanted frequencies outside it are dropped with a log message; two that
    fall on one grid point count once. If none is left, up to ``len(wanted)`` frequencies
    spread evenly (in log) over the computed range are taken instead. The indices returned
    are distinct and increasing.
    """
    f = _vector(frequency, "frequency")
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
    x = _vector(x, "x")
    v = _columns(values, x.size, "values", "x")
    names = _labels(labels, v.shape[1])
    x0 = 0.0 if x_force is None else float(x_force)
    ax = _axes(ax)
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
    _legend(ax)
    return ax


# ------------------------------------------------------------------------ pass-by
def plot_passby_levels(position, levels, labels=None, *, ax=None,
                       ylabel: str = "Band velocity level (dB re 1e-9 m/s)"):
    """Band levels (dB) at the sensor against the train position; position (nx,), levels
    (nx,) or (nx, nc) (one column per band)."""
    x = _vector(position, "position")
    v = _columns(levels, x.size, "levels", "position")
    names = _labels(labels, v.shape[1])
    ax = _axes(ax, figsize=(8.0, 4.8))
    for j, name in enumerate(names):
        ax.plot(x, v[:, j], label=name, linewidth=0.8)
    ax.set_xlabel("Leading-wheel position relative to the sensor (m)")
    ax.set_ylabel(ylabel)
    ax.grid(True, alpha=0.3)
    _legend(ax)
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
    h = _vector(h, "h")
    e = _columns(errors, h.size, "errors", "h")
    names = _labels(labels, e.shape[1])
    ax = _axes(ax)
    for j, name in enumerate(names):
        label = name
        if fit:
            slope = convergence_slope(h, e[:, j])
            rate = f"slope {slope:.2f}" if np.isfinite(slope) else "slope n/a"
            label = f"{name} ({rate})" if name else rate
        ax.loglog(h, _positive_or_nan(e[:, j]), marker=_MARKERS[j % len(_MARKERS)],
                  label=label)
    _plain_log_labels(ax.xaxis)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    _legend(ax)
    return ax


# ------------------------------------------------------- model vs measurement, per band
def _band_centres(centres) -> np.ndarray:
    centres = _vector(centres, "centres")
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
    meas = _columns(measured, centres.size, "measured", "centres")
    ok = (np.ones(meas.shape, bool) if valid is None
          else _columns(valid, centres.size, "valid", "centres", dtype=bool))
    if ok.shape != meas.shape:
        raise ValueError(f"valid has shape {ok.shape}, measured {meas.shape}; give one flag per value")
    mod = None if model is None else _columns(model, centres.size, "model", "centres")
    names = list(labels) if not isinstance(labels, str) else [labels, None]
    ax = _axes(ax)
    for j in range(meas.shape[1]):
        mk = _MARKERS[j % len(_MARKERS)]
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
    return _band_axes(ax, centres, ylabel, logy=logy)


def _band_axes(ax, centres, ylabel: str, *, logy: bool = False, grid_axis: str = "both"):
    """Log band axis with nominal labels, value label, grid and legend; returns ``ax``."""
    ax.set_xscale("log")
    if logy:
        ax.set_yscale("log")
        _plain_log_labels(ax.yaxis)
    _band_ticks(ax, centres)
    ax.set_xlabel("One-third-octave band centre frequency (Hz)")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="major", axis=grid_axis, alpha=0.3)
    _legend(ax)
    return ax


def plot_band_residual(centres, residual, labels=None, *, ylabel: str = "Model - measurement (dB)",
                       ax=None):
    """Residual per band as bars around a zero line; (nb,) or (nb, nc) side by side.

    NaN residuals (bands not compared) leave a gap. Returns the Axes.
    """
    centres = _band_centres(centres)
    r = _columns(residual, centres.size, "residual", "centres")
    names = _labels(labels, r.shape[1])
    ax = _axes(ax)
    n = r.shape[1]
    width = 2 ** (1 / 3 / (n + 1))  # bars share one third of an octave, in log space
    for j, name in enumerate(names):
        left = centres * width ** (j - n / 2)
        ax.bar(left, r[:, j], width=left * (width - 1), align="edge", label=name)
    ax.axhline(0.0, color="black", linewidth=0.8)
    return _band_axes(ax, centres, ylabel, grid_axis="y")


# ------------------------------------------------------------- pass-by decay rates
def plot_decay_rate_estimates(centres, estimates: dict, *, ax=None,
                              ylabel: str = "Decay rate (dB/m)"):
    """Decay rates per one-third-octave band from several estimators, with error bars.

    ``estimates`` maps a label to ``(values, errors)``, each (nb,) in dB/m (errors may be
    None); NaN values (failed bands) leave gaps. Log value axis, nominal band labels.
    """
    centres = _vector(centres, "centres")
    if np.any(centres <= 0):
        raise ValueError("centres must be positive band centre frequencies in Hz")
    ax = _axes(ax)
    n = max(len(estimates), 1)
    for j, (label, (values, errors)) in enumerate(estimates.items()):
        v = _columns(values, centres.size, f"values of {label!r}", "centres")[:, 0]
        e = None if errors is None else np.nan_to_num(
            _columns(errors, centres.size, f"errors of {label!r}", "centres")[:, 0])
        shift = 2.0 ** ((j - (n - 1) / 2) / 24)  # side by side within the band
        ax.errorbar(centres * shift, np.where(v > 0, v, np.nan), yerr=e,
                    marker=_MARKERS[j % len(_MARKERS)], markersize=4, capsize=2,
                    label=str(label))
    ax.set_xscale("log")
    ax.set_yscale("log")
    _plain_log_labels(ax.yaxis)
    _band_ticks(ax, centres)
    ax.set_xlabel("One-third-octave band centre frequency (Hz)")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    _legend(ax)
    return ax


# ------------------------------------------------------------------ diagnosis (residuals)
def plot_residual_map(frequency, positions, values, *, ax=None, title: str | None = None,
                      limit_db: float | None = None):
    """Residual (measured - model, dB) over frequency (axis 0) and hammer distance (axis 1)
    as a colour map; NaN cells (not compared) stay blank. Returns the Axes."""
    f = _vector(frequency, "frequency")
    x = _vector(positions, "positions")
    v = np.asarray(values, dtype=float)
    if v.shape != (len(f), len(x)):
        raise ValueError(f"values has shape {v.shape}, expected (n_frequency, n_positions) "
                         f"= ({len(f)}, {len(x)})")
    ax = _axes(ax)
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
    f = _vector(frequency, "frequency")
    v = _columns(values, len(f), "values", "frequency")
    ax = _axes(ax)
    for j, lab in enumerate(_labels(labels, v.shape[1])):
        ax.semilogx(f, v[:, j], marker=_MARKERS[j % len(_MARKERS)], markersize=3, label=lab)
    ax.axhline(0.0, color="0.4", lw=0.8)
    ax.set_xlabel("Frequency (Hz)")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    _legend(ax)
    return ax


def plot_residual_distance(positions, values, labels=None, *, ax=None,
                           ylabel: str = "Measured - model (dB)"):
    """Residual over hammer distance (values: (n_positions, n_curves), e.g. one curve per
    one-third-octave band). Returns the Axes."""
    x = _vector(positions, "positions")
    v = _columns(values, len(x), "values", "positions")
    ax = _axes(ax)
    order = np.argsort(x)
    for j, lab in enumerate(_labels(labels, v.shape[1])):
        ax.plot(x[order], v[order, j], marker=_MARKERS[j % len(_MARKERS)], markersize=3,
                label=lab)
    ax.axhline(0.0, color="0.4", lw=0.8)
    ax.set_xscale("symlog", linthresh=0.6)
    ax.set_xlabel("Hammer distance from the sensor (m)")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    _legend(ax)
    return ax


def plot_error_before_after(centres, before, after, *, ax=None, label: str = "",
                            ylabel: str = "Residual RMS (dB)"):
    """Residual RMS per one-third-octave band before (base model) and after (with the
    chosen effect): two bar series. NaN bands are left empty. Returns the Axes."""
    c = _vector(centres, "centres")
    b = _vector(before, "before")
    a = _vector(after, "after")
    if not len(b) == len(a) == len(c):
        raise ValueError("centres, before and after must have the same length")
    ax = _axes(ax)
    i = np.arange(len(c))
    ax.bar(i - 0.2, b, width=0.4, label=f"before {label}".strip())
    ax.bar(i + 0.2, a, width=0.4, label=f"after {label}".strip())
    ax.set_xticks(i)
    ax.set_xticklabels([nominal_band_label(x) for x in c], rotation=90, fontsize=8)
    ax.set_xlabel("One-third-octave band centre frequency (Hz)")
    ax.set_ylabel(ylabel)
    ax.grid(True, axis="y", alpha=0.3)
    _legend(ax)
    return ax


def plot_roughness(wavelength, levels: dict, *, ax=None, limit: bool = True,
                   styles: dict | None = None):
    """Roughness level (dB re 1 um) vs wavelength (cm, long wavelengths on the left) per
    one-third-octave wavelength band, with the EN ISO 3095:2013 limit curve (Figure 2).

    wavelength: (nb,) m, shared by every curve, or a dict label -> (nb,) m per curve.
    levels: label -> (nb,) dB (NaN leaves gaps). styles: label -> matplotlib kwargs."""
    from .standards.iso3095 import roughness_limit

    ax = _axes(ax)
    for j, (label, lev) in enumerate(levels.items()):
        lam = wavelength[label] if isinstance(wavelength, dict) else wavelength
        lam = _vector(lam, f"wavelength of {label!r}")
        y = _columns(lev, lam.size, f"levels of {label!r}", "wavelengths")[:, 0]
        kw = {"marker": _MARKERS[j % len(_MARKERS)], "markersize": 4}
        kw.update((styles or {}).get(label, {}))
        ax.plot(lam * 100, y, label=str(label), **kw)
    if limit:
        lam, lim = roughness_limit()
        ax.plot(lam * 100, lim, color="k", lw=2, ls="--", label="EN ISO 3095:2013 limit")
    ax.set_xscale("log")
    if not ax.xaxis_inverted():
        ax.invert_xaxis()
    _plain_log_labels(ax.xaxis)
    ax.set_xlabel("Wavelength (cm)")
    ax.set_ylabel("Roughness level (dB re 1 um)")
    ax.grid(True, which="both", alpha=0.3)
    _legend(ax)
    return ax


def plot_band_errors(x, errors: dict, *, ax=None, xlabel: str = "Wavelength (cm)",
                     ylabel: str = "Estimate - truth (dB)", xscale: float = 100.0,
                     invert: bool = True, band: float | None = 1.0):
    """Errors per band of several estimates (label -> (nb,)) vs x (m, shown times
    ``xscale``: cm by default), a zero line and an optional +-band tolerance."""
    ax = _axes(ax)
    xv = _vector(x, "x") * xscale
    for j, (label, e) in enumerate(errors.items()):
        y = _columns(e, xv.size, f"errors of {label!r}", "x")[:, 0]
        ax.plot(xv, y, marker=_MARKERS[j % len(_MARKERS)], markersize=4, label=str(label))
    ax.axhline(0.0, color="k", lw=1)
    if band:
        for s in (-band, band):
            ax.axhline(s, color="0.5", lw=1, ls=":")
    ax.set_xscale("log")
    if invert and not ax.xaxis_inverted():
        ax.invert_xaxis()
    _plain_log_labels(ax.xaxis)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    _legend(ax)
def plot_candidate_scores(names, delta_bic, held_reduction, kept=None, *, ax=None):
    """Candidates of a diagnosis: BIC change against the base (bars, left axis, clipped
    symlog) and held-out error reduction in % (markers, right axis); kept candidates
    hatched. Returns the (left) Axes."""
    n = len(names)
    d = _vector(delta_bic, "delta_bic")
    r = _vector(held_reduction, "held_reduction")
    if not len(d) == len(r) == n:
        raise ValueError("names, delta_bic and held_reduction must have the same length")
    kept = [False] * n if kept is None else list(kept)
    ax = _axes(ax, figsize=(7.0, 4.8))
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
    ax2.plot(i, 100 * r, "o", color="tab:red")
    ax2.set_ylabel("Held-out error reduction (%)", color="tab:red")
    ax2.axhline(0.0, color="tab:red", lw=0.5, ls=":")
    return ax
