"""A small container for frequency response functions (in the spirit of scikit-rf).

``FRF.values[f, o, i]`` is the response ``o`` per unit force ``i`` at ``frequency[f]``, in
the quantity named by ``FRF.quantity`` (receptance m/N, mobility m/s/N or accelerance
m/s^2/N). Time dependence ``exp(+i omega t)``, so ``v = i omega u`` and converting between
quantities multiplies by ``(i omega)^(order difference)`` (railfem.conventions).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from railfem.conventions import QUANTITIES, QUANTITY_ORDER, QUANTITY_UNITS
from railfem.standards.iec61260 import ThirdOctaveBands
from railfem.standards.iec61260 import band_average as _band_average
from railfem.validators import show

__all__ = ["FRF"]


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, copy=True)
    a.setflags(write=False)
    return a


def _labels(name: str, labels, n: int, axis: str) -> tuple[str, ...]:
    if isinstance(labels, str):
        labels = (labels,)
    labels = tuple(labels)
    if len(labels) != n:
        raise ValueError(
            f"FRF.{name} has {len(labels)} label(s) {labels!r} but values has {n} {axis} "
            f"(axis {'1' if name == 'response' else '2'} of shape (n_freq, n_out, n_in)); "
            f"give one label per {axis[:-1]}."
        )
    for lab in labels:
        if not isinstance(lab, str) or not lab:
            raise ValueError(f"FRF.{name} labels must be non-empty strings, got {lab!r}.")
    if len(set(labels)) != n:
        raise ValueError(f"FRF.{name} labels must be unique, got {labels!r}.")
    return labels


def _few(labels: tuple[str, ...], keep: int = 2) -> str:
    """The labels, or the first and last ``keep`` of a long list with its length."""
    if len(labels) <= 2 * keep + 1:
        return ", ".join(labels)
    return f"{', '.join(labels[:keep])}, ..., {', '.join(labels[-keep:])} ({len(labels)})"


def _positions(name: str, x, n: int) -> np.ndarray | None:
    if x is None:
        return None
    x = np.asarray(x, dtype=float).reshape(-1)
    if x.size != n:
        raise ValueError(
            f"FRF.{name} has {x.size} position(s) but there are {n} labels; give one "
            "position (m) per label or None."
        )
    if not np.all(np.isfinite(x)):
        raise ValueError(f"FRF.{name} contains NaN/inf: {x}; positions are finite metres.")
    return _readonly(x)


@dataclass(frozen=True, kw_only=True, eq=False)
class FRF:
    """Frequency response functions of one quantity on one frequency axis.

    A 1-D ``values`` array (n_freq,) is accepted for one response and one force and stored
    as (n_freq, 1, 1). Arrays are copied and made read-only.
    """

    frequency: np.ndarray
    """(n_freq,) frequency, Hz; positive, strictly increasing."""
    values: np.ndarray
    """(n_freq, n_out, n_in) complex FRF in ``units``."""
    quantity: str
    """'receptance' (m/N), 'mobility' (m/s/N) or 'accelerance' (m/s^2/N)."""
    response: tuple[str, ...]
    """n_out response labels, e.g. 'head_z@x=0.300'."""
    force: tuple[str, ...]
    """n_in force labels."""
    response_x: np.ndarray | None = None
    """Optional (n_out,) response positions along the rail, m."""
    force_x: np.ndarray | None = None
    """Optional (n_in,) force positions along the rail, m."""

    def __post_init__(self) -> None:
        if self.quantity not in QUANTITIES:
            raise ValueError(
                f"FRF.quantity {self.quantity!r} is unknown; use one of {QUANTITIES}."
            )
        f = np.asarray(self.frequency, dtype=float)
        if f.ndim != 1 or f.size == 0:
            raise ValueError(
                f"FRF.frequency must be a non-empty 1-D array (Hz), got shape {f.shape}."
            )
        if not np.all(np.isfinite(f)) or f[0] <= 0.0:
            raise ValueError(
                f"FRF.frequency must be finite and positive (Hz), got first value {float(f[0])!r} "
                f"and {int(np.sum(~np.isfinite(f)))} non-finite value(s); drop 0 Hz and NaNs."
            )
        steps = np.flatnonzero(np.diff(f) <= 0.0)
        if steps.size:
            k = int(steps[0])
            raise ValueError(
                f"FRF.frequency must be strictly increasing, but frequency[{k}]={float(f[k])!r} Hz "
                f">= frequency[{k + 1}]={float(f[k + 1])!r} Hz; sort and remove duplicates."
            )
        v = np.asarray(self.values)
        if v.ndim == 1:
            v = v[:, None, None]
        if v.ndim != 3 or v.shape[0] != f.size:
            raise ValueError(
                f"FRF.values has shape {v.shape}, expected (n_freq, n_out, n_in) with "
                f"n_freq={f.size}; frequency must be axis 0."
            )
        v = v.astype(complex)
        bad = ~np.isfinite(v)
        if bad.any():
            k, o, i = np.argwhere(bad)[0]
            raise ValueError(
                f"FRF.values ({self.quantity}) has {int(bad.sum())} NaN/inf value(s), first "
                f"at frequency {float(f[k])!r} Hz, response {o}, force {i} "
                f"(value {complex(v[k, o, i])!r}); "
                "remove or interpolate the bad points before building the FRF."
            )
        n_out, n_in = v.shape[1:]
        # frozen dataclass: normalised fields are stored with object.__setattr__
        set_ = object.__setattr__
        set_(self, "frequency", _readonly(f))
        set_(self, "values", _readonly(v))
        set_(self, "response", _labels("response", self.response, n_out, "responses"))
        set_(self, "force", _labels("force", self.force, n_in, "forces"))
        set_(self, "response_x", _positions("response_x", self.response_x, n_out))
        set_(self, "force_x", _positions("force_x", self.force_x, n_in))

    def __repr__(self) -> str:
        """A few lines: quantity, shape, frequency range and labels (not the arrays)."""
        f = self.frequency
        return (f"FRF({self.quantity} in {self.units}, shape {self.shape}: {f.size} "
                f"frequencies {f[0]:g} Hz .. {f[-1]:g} Hz,\n"
                f"    response: {_few(self.response)},\n    force: {_few(self.force)})")

    @property
    def units(self) -> str:
        """Units of ``values``, e.g. 'm/s/N'."""
        return QUANTITY_UNITS[self.quantity]

    @property
    def omega(self) -> np.ndarray:
        """Angular frequency 2 pi f, rad/s, shape (n_freq,)."""
        return 2.0 * np.pi * self.frequency

    def to(self, quantity: str) -> FRF:
        """The same FRF as ``quantity``: values times ``(i omega)^(order(new) - order(old))``."""
        if quantity not in QUANTITIES:
            raise ValueError(f"cannot convert FRF to {quantity!r}; use one of {QUANTITIES}.")
        power = QUANTITY_ORDER[quantity] - QUANTITY_ORDER[self.quantity]
        factor = (1j * self.omega) ** power
        return replace(self, values=self.values * factor[:, None, None], quantity=quantity)

    def select(
        self,
        response: str | Sequence[str] | None = None,
        force: str | Sequence[str] | None = None,
    ) -> FRF:
        """Sub-FRF for the given response/force labels (None keeps all), in the order given."""
        ro = self._indices("response", self.response, response)
        fi = self._indices("force", self.force, force)
        return replace(
            self,
            values=self.values[:, ro][:, :, fi],
            response=tuple(self.response[k] for k in ro),
            force=tuple(self.force[k] for k in fi),
            response_x=None if self.response_x is None else self.response_x[ro],
            force_x=None if self.force_x is None else self.force_x[fi],
        )

    @staticmethod
    def _indices(name: str, have: tuple[str, ...], want) -> list[int]:
        if want is None:
            return list(range(len(have)))
        if isinstance(want, str):
            want = [want]
        missing = [w for w in want if w not in have]
        if missing:
            raise KeyError(f"FRF has no {name} label(s) {missing}; available: {list(have)}.")
        return [have.index(w) for w in want]

    def band_average(self, bands: ThirdOctaveBands, *, on_empty: str = "nan") -> np.ndarray:
        """Band RMS ``sqrt(mean |Y|^2)`` per band, shape (n_bands, n_out, n_in), in ``units``."""
        return _band_average(self.frequency, self.values, bands, on_empty=on_empty)

    def db(self, ref: float = 1.0) -> np.ndarray:
        """Level ``20 lg(|Y| / ref)`` in dB, ``ref`` in ``units`` (default 1 unit).

        State the reference with the result, e.g. 'dB re 1 m/s/N'. Zero values give -inf.
        """
        if not (np.isfinite(ref) and ref > 0.0):
            raise ValueError(
                f"db reference must be positive and finite (in {self.units}), got {show(ref)}."
            )
        with np.errstate(divide="ignore"):
            return 20.0 * np.log10(np.abs(self.values) / ref)

    def interpolate(self, frequency: np.ndarray) -> FRF:
        """FRF at new frequencies (Hz) inside the current range.

        Real and imaginary parts are interpolated linearly; that is exact only on a grid
        fine enough to resolve the resonances (no extrapolation: a frequency outside
        ``[frequency[0], frequency[-1]]`` raises).
        """
        f_new = np.asarray(frequency, dtype=float).reshape(-1)
        lo, hi = self.frequency[0], self.frequency[-1]
        outside = (f_new < lo) | (f_new > hi) | ~np.isfinite(f_new)
        if outside.any():
            raise ValueError(
                f"cannot interpolate FRF to {f_new[outside][:3].tolist()} Hz: outside the "
                f"data range [{float(lo)}, {float(hi)}] Hz (no extrapolation); restrict the "
                "new frequencies."
            )
        flat = self.values.reshape(self.frequency.size, -1)
        out = np.empty((f_new.size, flat.shape[1]), dtype=complex)
        for c in range(flat.shape[1]):
            out[:, c] = np.interp(f_new, self.frequency, flat[:, c].real) + 1j * np.interp(
                f_new, self.frequency, flat[:, c].imag
            )
        out = out.reshape((f_new.size,) + self.values.shape[1:])
        return replace(self, frequency=f_new, values=out)

    @property
    def shape(self) -> tuple[int, int, int]:
        """(n_freq, n_out, n_in)."""
        return self.values.shape
