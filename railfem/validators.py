"""Shared checks for parameters, used by the dataclasses' ``__post_init__``.

Each check returns the value converted (float, read-only array, ...) or raises ``ValueError``
whose message names the quantity, the value given, the unit and the fix. ``name`` is what the
user sees, e.g. ``"HammerMeasurement.sleeper_spacing"``.
"""
from __future__ import annotations

from collections.abc import Iterable
import logging

import numpy as np

__all__ = [
    "show",
    "finite",
    "positive",
    "non_negative",
    "one_of",
    "finite_array",
    "strictly_increasing",
    "readonly",
    "track_support",
]

#: Arrays longer than this are shown by their first and last few entries.
SHOW_ITEMS = 6


def show(value) -> str:
    """``value`` as the user wrote it, for messages: ``0.3``, not numpy's ``np.float64(0.3)``;
    arrays and long sequences shortened to their first and last entries."""
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if isinstance(value, np.integer):
        return str(int(value))
    if isinstance(value, np.floating):
        return repr(float(value))
    if isinstance(value, np.complexfloating):
        return repr(complex(value))
    if isinstance(value, np.str_):
        return repr(str(value))
    if isinstance(value, np.ndarray):
        if value.ndim == 0:
            return show(value.item())
        return np.array2string(value, threshold=SHOW_ITEMS, edgeitems=SHOW_ITEMS // 2,
                               separator=", ")
    if isinstance(value, (list, tuple)):
        items = [show(x) for x in value]
        if len(items) > SHOW_ITEMS:
            items = items[:SHOW_ITEMS // 2] + ["..."] + items[-(SHOW_ITEMS // 2):]
        inner = ", ".join(items) + ("," if isinstance(value, tuple) and len(value) == 1 else "")
        return f"({inner})" if isinstance(value, tuple) else f"[{inner}]"
    return repr(value)


def _number(name: str, value, unit: str) -> float:
    if isinstance(value, (bool, np.bool_)) or isinstance(value, complex):
        raise ValueError(f"{name} = {show(value)}: give a real number in {unit}.")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {show(value)} is not a number; give it in {unit}.") from None


def finite(name: str, value, unit: str) -> float:
    """``value`` as a finite float."""
    v = _number(name, value, unit)
    if not np.isfinite(v):
        raise ValueError(f"{name} = {show(value)} {unit}: give a finite number.")
    return v


def positive(name: str, value, unit: str, hint: str = "") -> float:
    """``value`` as a finite float > 0; ``hint`` (e.g. 'typical 0.6 m') ends the message."""
    v = finite(name, value, unit)
    if v <= 0.0:
        raise ValueError(f"{name} = {show(value)} {unit}: give a value > 0{_tail(hint)}.")
    return v


def non_negative(name: str, value, unit: str, hint: str = "") -> float:
    """``value`` as a finite float >= 0."""
    v = finite(name, value, unit)
    if v < 0.0:
        raise ValueError(f"{name} = {show(value)} {unit}: give a value >= 0{_tail(hint)}.")
    return v


def one_of(name: str, value, choices: Iterable[str]) -> str:
    """``value`` if it is one of ``choices``."""
    choices = tuple(choices)
    if value not in choices:
        raise ValueError(f"{name} = {show(value)} is unknown; use one of {', '.join(choices)}.")
    return value


def readonly(a) -> np.ndarray:
    """A read-only copy of ``a``."""
    a = np.array(a, copy=True)
    a.setflags(write=False)
    return a


def finite_array(name: str, values, unit: str, *, ndim: int | None = None,
                 dtype=float, allow_nan: bool = False) -> np.ndarray:
    """``values`` as a read-only array without inf (and without NaN unless ``allow_nan``)."""
    a = np.asarray(values, dtype=dtype)
    if ndim is not None and a.ndim != ndim:
        raise ValueError(f"{name} must be a {ndim}-D array ({unit}), got shape {a.shape}.")
    bad = np.isinf(a) if allow_nan else ~np.isfinite(a)
    if bad.any():
        k = tuple(int(i) for i in np.argwhere(bad)[0])
        what = "inf" if allow_nan else "NaN/inf"
        raise ValueError(
            f"{name} has {int(bad.sum())} {what} value(s), first at index {k} "
            f"({show(a[k])} {unit}); remove or replace them.")
    return readonly(a)


def strictly_increasing(name: str, values, unit: str) -> np.ndarray:
    """A finite 1-D array whose entries strictly increase (read-only copy)."""
    a = finite_array(name, values, unit, ndim=1)
    steps = np.flatnonzero(np.diff(a) <= 0.0)
    if steps.size:
        k = int(steps[0])
        raise ValueError(
            f"{name} must be strictly increasing, but {name}[{k}] = {show(a[k])} {unit} >= "
            f"{name}[{k + 1}] = {show(a[k + 1])} {unit}; sort the values and remove duplicates.")
    return a


#: The parts every support of a track needs: field, what it is, unit, what 0 would mean,
#: a typical value (SI, and as the command line takes it).
TRACK_SUPPORT_PARTS = (
    ("kp", "rail pad stiffness", "N/m", "no pad: the rail would rest on nothing",
     "e.g. 300e6 N/m (--kp 300, in MN/m)"),
    ("ms", "sleeper mass", "kg", "no sleeper", "e.g. 120 kg per rail (--ms 120)"),
    ("kb", "ballast stiffness", "N/m", "every sleeper hanging free",
     "e.g. 100e6 N/m (--kb 100, in MN/m)"),
)


def track_support(name: str, support) -> None:
    """The support of every sleeper of a track: pad stiffness, sleeper mass and ballast
    stiffness > 0 (a rigid pad or ballast, inf, is allowed). A single support may lack a
    part (SupportParameters allows 0: a voided sleeper among others), a whole track not."""
    for field, what, unit, zero, example in TRACK_SUPPORT_PARTS:
        value = getattr(support, field)
        if not value > 0:
            raise ValueError(f"{name}.{field} = {show(value)} {unit}: a track needs a {what} "
                             f"> 0 (0 would be {zero}); give {example}.")


def _tail(hint: str) -> str:
    return f" ({hint})" if hint else ""


_SAID: set[tuple[str, str]] = set()


def warn_once(logger: logging.Logger, message: str, *args) -> None:
    """logger.warning(message % args), once per process for each distinct text: a fitter
    calls the models thousands of times with the same out-of-range request."""
    text = message % args if args else message
    if (logger.name, text) not in _SAID:
        _SAID.add((logger.name, text))
        logger.warning(text)


def reset_warn_once() -> None:
    """Forget what warn_once has said (a new session of calls says it again)."""
    _SAID.clear()
