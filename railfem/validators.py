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
    "finite",
    "positive",
    "non_negative",
    "one_of",
    "finite_array",
    "strictly_increasing",
    "readonly",
]


def _number(name: str, value, unit: str) -> float:
    if isinstance(value, (bool, np.bool_)) or isinstance(value, complex):
        raise ValueError(f"{name} = {value!r}: give a real number in {unit}.")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} = {value!r} is not a number; give it in {unit}.") from None


def finite(name: str, value, unit: str) -> float:
    """``value`` as a finite float."""
    v = _number(name, value, unit)
    if not np.isfinite(v):
        raise ValueError(f"{name} = {value!r} {unit}: give a finite number.")
    return v


def positive(name: str, value, unit: str, hint: str = "") -> float:
    """``value`` as a finite float > 0; ``hint`` (e.g. 'typical 0.6 m') ends the message."""
    v = finite(name, value, unit)
    if v <= 0.0:
        raise ValueError(f"{name} = {value!r} {unit}: give a value > 0{_tail(hint)}.")
    return v


def non_negative(name: str, value, unit: str, hint: str = "") -> float:
    """``value`` as a finite float >= 0."""
    v = finite(name, value, unit)
    if v < 0.0:
        raise ValueError(f"{name} = {value!r} {unit}: give a value >= 0{_tail(hint)}.")
    return v


def one_of(name: str, value, choices: Iterable[str]) -> str:
    """``value`` if it is one of ``choices``."""
    choices = tuple(choices)
    if value not in choices:
        raise ValueError(f"{name} = {value!r} is unknown; use one of {', '.join(choices)}.")
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
            f"({a[k]!r} {unit}); remove or replace them.")
    return readonly(a)


def strictly_increasing(name: str, values, unit: str) -> np.ndarray:
    """A finite 1-D array whose entries strictly increase (read-only copy)."""
    a = finite_array(name, values, unit, ndim=1)
    steps = np.flatnonzero(np.diff(a) <= 0.0)
    if steps.size:
        k = int(steps[0])
        raise ValueError(
            f"{name} must be strictly increasing, but {name}[{k}] = {a[k]!r} {unit} >= "
            f"{name}[{k + 1}] = {a[k + 1]!r} {unit}; sort the values and remove duplicates.")
    return a


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
