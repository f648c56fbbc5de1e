"""Track parameters as vectors: what a fitter varies (METHOD.md section 7).

A ``ParameterSpace`` maps a named vector to a TrackSpec and back, on top of a base spec:

    space = ParameterSpace(rf.preset("site"), ["kp", "eta_p", "kb", "eta_b", "kb[2]"])
    x0 = space.from_spec(space.base)        # vector of the base spec
    spec = space.to_spec(x0 + 0.1)          # a spec for any vector inside the bounds

Names: ``kp``, ``kb`` (pad and ballast stiffness per fastener, N/m), ``eta_p``, ``eta_b``
(their loss factors), ``ms`` (sleeper mass per rail, kg), ``eta_r`` (rail loss factor),
``pad_length`` (m), and per-support deviations ``NAME[i]`` with NAME one of kp, eta_p, ms,
kb, eta_b: the factor on support i's value (i counted from the support at x = 0; discrete
models only; factor 1 is no deviation).

Scales: stiffnesses, the sleeper mass, the loss factors and the deviation factors enter the
vector as log10 of their SI value (a fitter's step is then relative); the pad length
enters in metres. ``lower``/``upper`` are the bounds in vector units; PARAMETERS lists the
defaults (SI), which ``bounds=`` overrides per name.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace

import numpy as np

from .spec import SupportDeviation, TrackSpec

#: name -> (unit, log scale, default SI bounds)
PARAMETERS = {
    "kp": ("N/m", True, (1e6, 1e10)),
    "eta_p": ("-", True, (1e-3, 2.0)),
    "ms": ("kg", True, (10.0, 1000.0)),
    "kb": ("N/m", True, (1e6, 1e10)),
    "eta_b": ("-", True, (1e-3, 5.0)),
    "eta_r": ("-", True, (1e-4, 0.5)),
    "pad_length": ("m", False, (0.0, 0.4)),
    # horizontal support (railfem.track.supports.SupportParameters, issue 15)
    "kp_lat": ("N/m", True, (1e5, 1e10)),
    "eta_p_lat": ("-", True, (1e-3, 2.0)),
    "kp_long": ("N/m", True, (1e5, 1e10)),
    "eta_p_long": ("-", True, (1e-3, 2.0)),
    "kb_lat": ("N/m", True, (1e5, 1e10)),
    "eta_b_lat": ("-", True, (1e-3, 5.0)),
    "ms_lat": ("kg", True, (10.0, 1000.0)),
}
#: the parameters fitted by default (the base model's, railfem.identify.base); here so the
#: command line reads them without loading the fitting machinery
BASE_PARAMETERS = ("kp", "eta_p", "kb", "eta_b", "eta_r")
DEVIATION_FIELDS = ("kp", "eta_p", "ms", "kb", "eta_b")
DEVIATION_BOUNDS = (1e-3, 1e3)  # factors
_DEVIATION = re.compile(r"^(kp|eta_p|ms|kb|eta_b)\[(-?\d+)\]$")


@dataclass(frozen=True)
class Parameter:
    """One vector component: name, SI unit, log10 scale or not, SI bounds."""

    name: str
    unit: str
    log: bool
    lower: float
    upper: float

    def encode(self, value: float) -> float:
        return math.log10(value) if self.log else float(value)

    def decode(self, x: float) -> float:
        return float(10.0 ** x) if self.log else float(x)


def _parameter(name: str, bounds: dict) -> Parameter:
    m = _DEVIATION.match(name)
    if m:
        unit, log, default = "(factor)", True, DEVIATION_BOUNDS
    elif name in PARAMETERS:
        unit, log, default = PARAMETERS[name]
    else:
        raise ValueError(f"unknown track parameter {name!r}; use one of "
                         f"{', '.join(PARAMETERS)} or a deviation NAME[i] with NAME in "
                         f"{', '.join(DEVIATION_FIELDS)}")
    lo, hi = bounds.get(name, default)
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi) or (log and lo <= 0):
        raise ValueError(f"bounds of {name!r} = ({lo!r}, {hi!r}) {unit}: need lower < upper"
                         + (", both > 0 (log scale)" if log else ""))
    return Parameter(name=name, unit=unit, log=log, lower=float(lo), upper=float(hi))


def _deviation(spec: TrackSpec, index: int) -> SupportDeviation:
    for d in spec.deviations:
        if d.index == index:
            return d
    return SupportDeviation(index=index)


class ParameterSpace:
    """Named vectors <-> TrackSpecs around ``base`` (see the module docstring)."""

    def __init__(self, base: TrackSpec, names, bounds: dict | None = None):
        if not isinstance(base, TrackSpec):
            raise TypeError(f"base must be a TrackSpec, got {type(base).__name__}")
        names = tuple(names)
        if len(set(names)) != len(names) or not names:
            raise ValueError(f"parameter names must be non-empty and unique, got {names}")
        unknown = set(bounds or {}) - set(names)
        if unknown:
            raise ValueError(f"bounds given for {sorted(unknown)}, which are not parameters "
                             f"of this space {names}")
        self.base = base
        self.parameters = tuple(_parameter(n, bounds or {}) for n in names)
        if any(_DEVIATION.match(n) for n in names) and not base.kind.is_discrete:
            raise ValueError(f"per-support deviations need a discrete model, base is "
                             f"{base.model!r}")
        self.to_spec(self.from_spec(base))  # the base lies inside the bounds, indices exist

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def lower(self) -> np.ndarray:
        """Lower bounds in vector units (log10 for log-scale parameters)."""
        return np.array([p.encode(p.lower) for p in self.parameters])

    @property
    def upper(self) -> np.ndarray:
        return np.array([p.encode(p.upper) for p in self.parameters])

    def __len__(self) -> int:
        return len(self.parameters)

    def _check(self, x) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        if x.shape != (len(self),):
            raise ValueError(f"parameter vector has shape {x.shape}, expected ({len(self)},) "
                             f"for {self.names}")
        for p, xi in zip(self.parameters, x):
            value = p.decode(xi) if np.isfinite(xi) else float("nan")
            # in vector units, as the box is searched: 10 ** log10(upper) may exceed upper
            if not (np.isfinite(xi) and p.encode(p.lower) <= xi <= p.encode(p.upper)):
                raise ValueError(f"parameter {p.name} = {value!r} {p.unit} is outside its "
                                 f"bounds [{p.lower:g}, {p.upper:g}] {p.unit}")
        return x

    def to_spec(self, x) -> TrackSpec:
        """The base spec with the vector's values set."""
        x = self._check(x)
        changes, devs = {}, {d.index: d for d in self.base.deviations}
        for p, xi in zip(self.parameters, x):
            value = p.decode(xi)
            m = _DEVIATION.match(p.name)
            if m:
                i = int(m.group(2))
                devs[i] = replace(devs.get(i, SupportDeviation(index=i)), **{m.group(1): value})
            else:
                changes[p.name] = value
        if devs:
            changes["deviations"] = tuple(devs[i] for i in sorted(devs))
        return self.base.replace(**changes)

    def from_spec(self, spec: TrackSpec) -> np.ndarray:
        """The vector of ``spec``'s values (the inverse of to_spec on this space)."""
        out = []
        for p in self.parameters:
            m = _DEVIATION.match(p.name)
            if m:
                value = getattr(_deviation(spec, int(m.group(2))), m.group(1))
            elif p.name == "eta_r":
                value = spec.rail.eta
            elif p.name == "pad_length":
                value = spec.pad_length
            else:
                value = getattr(spec.support, p.name)
            if p.log and value <= 0:
                raise ValueError(f"{p.name} = {value!r} {p.unit} has no log10: the space "
                                 "keeps it > 0")
            out.append(p.encode(value))
        return np.array(out)

    def table(self) -> list[dict]:
        """One row per parameter: name, unit, scale, SI bounds (for reports)."""
        return [{"name": p.name, "unit": p.unit, "scale": "log10" if p.log else "linear",
                 "lower": p.lower, "upper": p.upper} for p in self.parameters]
