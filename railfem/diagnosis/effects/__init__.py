"""The effect library: physical mechanisms the base track model lacks (METHOD.md section 9).

Each effect is one small module of this package defining ``EFFECT = Effect(...)``; the
registry (``REGISTRY``, ``get``, ``names``) finds every such module, so adding an effect is
one module (and its test). An effect has parameters with bounds and a physical meaning and
enters the model in one of four ways (``Effect.kind``):

* ``spec``: ``apply(spec, theta, record) -> spec`` changes the track (a support law, the pad
  length, a weak support at some index);
* ``geometry``: ``geometry(theta, record) -> (sensor shift, hammer shift)`` moves where the
  model is evaluated (m);
* ``measurement``: ``apply_measurement(receptance, theta, record) -> receptance`` acts after
  the model, on the (nf, n_out, n_pos) receptance the data are compared with (the sensor's
  mounting, an additive noise floor); a random additive term has two faces: its expected
  level in dB (``apply_measurement``, what a transfer in dB is compared with) and its
  expected band power (``apply_power``, what the EN 15461 decay rate of the data sums);
  without ``apply_power`` both are the same operator; ``variance(receptance, theta,
  record)`` (optional) gives the variance (dB^2) such a term adds to each FRF entry's
  level: the residual's noise the structure test then expects;
* ``campaign``: a ``spec`` effect whose change depends on each record's metadata (its
  temperature, its static load): it needs several records that differ in that covariate.

``theta`` is a dict {parameter name: SI value}. Parameters in ``Effect.grid`` are not
differentiated: the refit profiles over the listed values (each a new kernel or a discrete
choice such as a support index); a grid may also be categorical (which sensor) and then
has no EffectParameter. A numeric grid value may be refined between its best neighbours.

``prior(theta) -> array`` (optional) adds dimensionless residual entries to the fit: a
Gaussian prior that shrinks weakly identified parameters towards their mean (random
effects, e.g. the stiffness of each support of a randomly inhomogeneous track).
``deviation_of(name) -> (support indices, 'kp' | 'kb')`` says that a parameter is the factor
on those supports' stiffness (log scale; one support, or a block sharing one factor): the
refit then differentiates it in closed form.
``unfitted(spec) -> {(support index, 'kp' | 'kb'): SD of ln factor}`` (optional) names the
part of a random effect's realisation the fit leaves at the mean (the supports outside
its window) and its scatter: it does not enter the fit, but the uncertainty of the fitted
parameters includes what that scatter can do to them (railfem.identify.uncertainty,
``nuisance``).
``assumed`` (optional, AssumedValue): the spec values an effect sets but does not fit
(the data do not fix them), each with the standard deviation of its log10 (decades): it
enters ``apply`` as theta[name] at its value in the fit, and its uncertainty enters the
intervals of the fitted parameters as an unfitted random term, as the unfitted support
factors do (the residual's change per decade of the value times its SD, by a central
difference at the estimate: railfem.diagnosis.problem.EffectModel.unfitted_tangents) in
the screening; the chosen model's final intervals are instead the envelope over the
value's range, centre x 10^(+-2 SD) (railfem.diagnosis.envelope).
``derived(parameters) -> [entries]`` (optional) adds the physical quantities a fitted
parameter stands for to the reported parameters (group 'derived'; e.g. the roll stiffness
of roll_restraint's grip share, with an interval open at the top).
``screened=False`` leaves an effect out of the default search (it must be named): for
costly effects with tens of parameters.
"""
from __future__ import annotations

import importlib
import pkgutil
from dataclasses import dataclass, field
from typing import Callable

from railfem import validators as v
from railfem.params import Parameter

KINDS = ("spec", "geometry", "measurement", "campaign")


@dataclass(frozen=True, kw_only=True)
class EffectParameter:
    """One parameter of an effect: name, SI unit, bounds, log10 scale or not, a start value
    and what it means physically; ``scan``: SI start values the refit's multi-start tries
    instead of three across the range (a parameter whose cost has narrow basins, e.g. the
    frequency of a lightly damped mode)."""

    name: str
    unit: str
    lower: float
    upper: float
    log: bool
    start: float
    meaning: str
    scan: tuple = ()

    def __post_init__(self):
        if not self.lower < self.upper or (self.log and self.lower <= 0):
            raise ValueError(f"EffectParameter {self.name}: bounds ({self.lower}, "
                             f"{self.upper}) need lower < upper (and > 0 on a log scale)")
        if not self.lower <= self.start <= self.upper:
            raise ValueError(f"EffectParameter {self.name}: start {self.start} is outside "
                             f"its bounds ({self.lower}, {self.upper})")
        if not all(self.lower <= v <= self.upper for v in self.scan):
            raise ValueError(f"EffectParameter {self.name}: a scan value is outside its "
                             f"bounds ({self.lower}, {self.upper})")

    def parameter(self) -> Parameter:
        """As a railfem.params.Parameter (encode/decode between SI and vector units)."""
        return Parameter(name=self.name, unit=self.unit, log=self.log, lower=self.lower,
                         upper=self.upper)


@dataclass(frozen=True, kw_only=True)
class AssumedValue:
    """A spec value an effect sets and does not fit: ``name`` (the key its ``apply`` reads
    in theta), SI ``unit`` and ``value``, ``sd`` the standard deviation of its log10
    (decades: 0.3 is a factor 2), ``source`` where value and SD come from (words)."""

    name: str
    unit: str
    value: float
    sd: float
    source: str

    def __post_init__(self):
        v.positive(f"AssumedValue {self.name}: value", self.value, self.unit)
        v.positive(f"AssumedValue {self.name}: sd", self.sd, "decades")
        if not self.source:
            raise ValueError(f"AssumedValue {self.name}: say where the value and its SD "
                             "come from (source)")


@dataclass(frozen=True, kw_only=True, eq=False)
class Effect:
    """A candidate model extension (see the module docstring)."""

    name: str
    title: str
    meaning: str
    kind: str
    parameters: tuple[EffectParameter, ...]
    apply: Callable | None = None
    apply_measurement: Callable | None = None
    apply_power: Callable | None = None  # measurement: the band-power face (decay rate)
    variance: Callable | None = None  # measurement: the dB^2 it adds to each FRF level
    geometry: Callable | None = None
    prior: Callable | None = None
    screened: bool = True  # False: left out of the default screen; named on request
    deviation_of: Callable | None = None  # parameter name -> ((support indices), 'kp' | 'kb')
    unfitted: Callable | None = None  # spec -> {(support index, 'kp' | 'kb'): SD of ln}
    derived: Callable | None = None  # [parameter entries] -> [entries of derived quantities]
    assumed: tuple[AssumedValue, ...] = ()  # spec values set, not fitted, with their SD
    grid: dict = field(default_factory=dict)
    needs: tuple[str, ...] = ()
    quantities: tuple[str, ...] = ("point", "phase", "transfer", "tdr")

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"Effect {self.name}: kind {self.kind!r}, use one of {KINDS}")
        hook = {"spec": self.apply, "campaign": self.apply, "geometry": self.geometry,
                "measurement": self.apply_measurement}[self.kind]
        if hook is None:
            raise ValueError(f"Effect {self.name} of kind {self.kind!r} has no hook")
        names = [p.name for p in self.parameters]
        names += [a.name for a in self.assumed] + [g for g in self.grid if g not in names]
        if len(set(names)) != len(names):
            raise ValueError(f"Effect {self.name}: repeated names of parameters, grids "
                             f"or assumed values {names}")
        for k, values in self.grid.items():
            if not values:
                raise ValueError(f"Effect {self.name}: grid {k!r} has no values")

    @property
    def continuous(self) -> tuple[EffectParameter, ...]:
        """The parameters fitted by least squares (all but the grid ones)."""
        return tuple(p for p in self.parameters if p.name not in self.grid)

    def describe(self) -> dict:
        """JSON-ready: name, title, meaning, parameters with bounds, grids."""
        return {"name": self.name, "title": self.title, "meaning": self.meaning,
                "kind": self.kind,
                "parameters": [{"name": p.name, "unit": p.unit, "lower": p.lower,
                                "upper": p.upper, "scale": "log10" if p.log else "linear",
                                "meaning": p.meaning} for p in self.parameters],
                "grid": {k: list(v) for k, v in self.grid.items()},
                "assumed": [{"name": a.name, "unit": a.unit, "value": a.value,
                             "sd_decades": a.sd, "source": a.source} for a in self.assumed],
                "screened_by_default": self.screened,
                "needs": list(self.needs)}


def _discover() -> dict[str, Effect]:
    out = {}
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        mod = importlib.import_module(f"{__name__}.{info.name}")
        eff = getattr(mod, "EFFECT", None)
        if isinstance(eff, Effect):
            if eff.name in out:
                raise RuntimeError(f"two effect modules define {eff.name!r}")
            out[eff.name] = eff
    return out


REGISTRY: dict[str, Effect] = _discover()


def names() -> tuple[str, ...]:
    return tuple(REGISTRY)


def get(name: str) -> Effect:
    try:
        return REGISTRY[name]
    except KeyError:
        raise ValueError(f"unknown effect {name!r}; the library has {', '.join(REGISTRY)}") \
            from None


def support_only(e: Effect) -> bool:
    """An effect that changes the uniform supports' dynamic stiffness alone (no kernel grid,
    no deviating or lateral support): a rail-loss profile costs one kernel per value."""
    return (e.kind == "spec" and e.prior is None and set(e.grid) <= {"spread"}
            and not set(e.needs) & {"deviations", "lateral", "wfe"})


def changes_section(e: Effect) -> bool:
    """An effect that changes the rail's cross-section (a kernel grid of section shapes,
    WFE only): each of its values is a rail of its own."""
    return e.kind == "spec" and e.prior is None and bool(e.grid) and "wfe" in e.needs


def rail_loss_traded(e: Effect) -> bool:
    """An effect the base's rail loss factor can stand in for on a WFE track, whose
    screening therefore frees it (railfem.diagnosis.loop.screen_single): added damping at
    the supports (support_only) or a changed section, whose moved cut-on the base widens
    with rail loss."""
    return support_only(e) or changes_section(e)


def deviation_refusal(kind) -> str:
    """Why an effect with deviating supports (needs 'deviations') cannot be tried on the
    model kind ``kind`` (railfem.spec.ModelKind); '' where it can: the discrete tracks
    (beam and WFE rail) take deviations as a low-rank update of their coupling
    (railfem.track.woodbury.SupportUpdate)."""
    if kind.is_periodic:
        return ("a deviating support breaks the periodicity the periodic model is built on "
                "(one cell, Floquet sums over identical supports); as a deviation on a finite "
                "window it would need the periodic track's receptances between the springs "
                "of every window support, which its kernel does not carry (not "
                "implemented): diagnose with wfe-discrete, which tries it")
    if kind.is_continuous:
        return f"a continuous foundation ({kind.name}) has no supports to deviate"
    return ""


def not_tried(skipped: dict) -> str:
    """The clause a diagnosis statement ends with: every effect of the library that was not
    tried and why ('' when all were), so that nothing is skipped silently."""
    if not skipped:
        return ""
    return "; not tried: " + "; ".join(f"{k} ({v})" for k, v in skipped.items())
