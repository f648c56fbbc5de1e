"""What the plotting modules share: matplotlib setup (Agg without a display), the Axes
helper, :func:`save_figure`, checks of array arguments, labels and legends, log-axis
labels, markers and the one-third-octave band axis."""

from __future__ import annotations

import logging
import os
import sys
from pathlib import Path

import numpy as np

from ..atomic import atomic_path

log = logging.getLogger(__name__)


#: Marker cycle: curve j of a plot gets MARKERS[j % len(MARKERS)].
MARKERS = ("o", "s", "^", "v", "D", "<", ">", "p", "h", "*", "X", "P")
# preferred-number series of nominal one-third-octave centre frequencies (IEC 61260)
_NOMINAL_MANTISSAS = np.array([1.0, 1.25, 1.6, 2.0, 2.5, 3.15, 4.0, 5.0, 6.3, 8.0, 10.0])
_NON_GUI_BACKENDS = {"agg", "pdf", "pgf", "ps", "svg", "cairo", "template"}


# ------------------------------------------------------------------ matplotlib setup
def _has_display() -> bool:
    if sys.platform in ("win32", "darwin"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def pyplot():
    """Import pyplot, switching to Agg first when there is no display."""
    import matplotlib

    if not _has_display():
        backend = str(matplotlib.get_backend()).lower()
        if backend not in _NON_GUI_BACKENDS and not backend.startswith("module://"):
            matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def axes_or_new(ax, figsize=(6.4, 4.8)):
    """Return ``ax`` or a new Axes on a new figure."""
    if ax is not None:
        return ax
    plt = pyplot()
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
        pyplot().close(fig)
    log.info("wrote figure %s", path)
    return path


# ------------------------------------------------------------------------- checks
def vector(values, name: str, dtype=float) -> np.ndarray:
    array = np.asarray(values, dtype=dtype)
    if array.ndim != 1 or array.size == 0:
        raise ValueError(f"{name} must be a non-empty 1-D array, got shape {array.shape}")
    return array


def columns(values, n: int, name: str, axis_name: str, dtype=float) -> np.ndarray:
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


def curve_labels(labels, count: int, name: str = "labels") -> list[str | None]:
    if labels is None:
        return [None] * count
    if isinstance(labels, str):
        labels = [labels]
    labels = [None if lab is None else str(lab) for lab in labels]
    if len(labels) != count:
        raise ValueError(f"got {len(labels)} {name} for {count} curves; "
                         f"pass one label per column or {name}=None")
    return labels


def plain_log_labels(axis) -> None:
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


def readable_log_ticks(axis) -> None:
    """Labelled ticks at 1, 2 and 5 times the powers of ten ('%g': 0.5, 1, 2, 5, 10, ...) on
    a log axis (1, 2, 3, 5, 7 on less than 1.5 decades, decades alone on more than 4): four
    or more over the range, where decade ticks alone give two on two decades (roughness
    wavelengths, hammer distances). Unlabelled minor ticks between."""
    from matplotlib.ticker import FuncFormatter, Locator, LogLocator, NullFormatter

    class OneTwoFiveLocator(Locator):
        def __call__(self):
            low, high = sorted(self.axis.get_view_interval())
            if not low > 0:
                return []
            decades = np.log10(high / low)
            subs = (1.0,) if decades > 4 else (1.0, 2.0, 5.0) if decades > 1.5 else (
                1.0, 2.0, 3.0, 5.0, 7.0)
            powers = 10.0 ** np.arange(np.floor(np.log10(low)), np.ceil(np.log10(high)) + 1)
            ticks = np.sort(np.outer(powers, subs).ravel())
            return ticks[(ticks >= low * (1 - 1e-9)) & (ticks <= high * (1 + 1e-9))]

    axis.set_major_locator(OneTwoFiveLocator())
    axis.set_major_formatter(FuncFormatter(lambda value, pos=None: f"{value:g}"))
    axis.set_minor_locator(LogLocator(base=10.0, subs=np.arange(2.0, 10.0), numticks=30))
    axis.set_minor_formatter(NullFormatter())


def legend(ax) -> None:
    handles, names = ax.get_legend_handles_labels()
    if handles:
        ax.legend(fontsize="small")


# ------------------------------------------------------------ values and band axes
def positive_or_nan(values: np.ndarray) -> np.ndarray:
    return np.where(values > 0, values, np.nan)


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


def band_ticks(ax, centres: np.ndarray) -> None:
    from matplotlib.ticker import FixedFormatter, FixedLocator, NullLocator

    ordered = np.sort(centres)
    ax.xaxis.set_major_locator(FixedLocator(ordered))
    ax.xaxis.set_major_formatter(FixedFormatter([nominal_band_label(c) for c in ordered]))
    ax.xaxis.set_minor_locator(NullLocator())
    ax.tick_params(axis="x", labelrotation=90, labelsize="small")
    ax.set_xlim(ordered[0] * 2 ** (-1 / 6), ordered[-1] * 2 ** (1 / 6))


def band_axes(ax, centres, ylabel: str, *, logy: bool = False, grid_axis: str = "both"):
    """Log band axis with nominal labels, value label, grid and legend; returns ``ax``."""
    ax.set_xscale("log")
    if logy:
        ax.set_yscale("log")
        plain_log_labels(ax.yaxis)
    band_ticks(ax, centres)
    ax.set_xlabel("One-third-octave band centre frequency (Hz)")
    ax.set_ylabel(ylabel)
    ax.grid(True, which="major", axis=grid_axis, alpha=0.3)
    legend(ax)
    return ax
