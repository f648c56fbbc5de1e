"""The forward model of a fit: a parameter vector in, receptances at the data's geometry out.

A fit varies the track parameters of a railfem.params.ParameterSpace. They fall in two
kinds (METHOD.md section 7, "Separate what depends on parameters from what does not"):

* **support parameters** (FAST: kp, eta_p, kb, eta_b, ms) enter the discrete and periodic
  models only through the support dynamic stiffness K_s(omega): the parameter-free kernel
  is computed once (railfem.models.discrete_kernel, cached by railfem.track.kernelcache) and a new
  parameter set costs the coupling alone; on uniform discrete tracks the coupling itself is
  a short sum (railfem.identify.spectral); with springs in several directions (lateral
  data) it is one as well when the fitted parameters change the springs of one direction
  only (the lateral chain): the others are held and eliminated once, the coupling is put
  in eigen form in that direction's stiffness (DirectionalEngine,
  railfem.track.directional);
* **kernel parameters** (SLOW: eta_r, pad_length) change the free rail or the support
  footprints, hence the kernel: every distinct value costs a kernel (seconds for the
  Timoshenko beam, tens of seconds for the WFE rail). ``ForwardModel.engine`` keeps one
  engine per distinct kernel-parameter value; the fitter profiles over such a parameter
  instead of differentiating through it (railfem.identify.fit).

The continuous Timoshenko model has no kernel (a closed-form wavenumber integral per call):
all its parameters are cheap, so it has no SLOW parameters.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, fields, replace

import numpy as np


from railfem import __version__, models
from railfem.track import kernelcache
from railfem.identify.spectral import SpectralCoupling, check, spectral_coupling
from railfem.params import ParameterSpace
from railfem.spec import TrackSpec, spec_to_dict
from railfem.track import wfe as track_wfe
from railfem.track.coupling import couple_discrete
from railfem.track.directional import DirectionalSpectral, directional_spectral
from railfem.track.directions import PAD_ROLL, directional_stiffness
from railfem.track.supports import dynamic_stiffness

log = logging.getLogger(__name__)

FAST = ("kp", "eta_p", "kb", "eta_b", "ms", "kp_lat", "eta_p_lat", "kp_long", "eta_p_long",
        "kb_lat", "eta_b_lat", "ms_lat")
SLOW = ("eta_r", "pad_length")
SPECTRAL_TOLERANCE = 1e-8  # largest relative difference to the direct coupling accepted
PROBE_OMEGA = 2 * np.pi * np.array([7.0, 130.0, 2900.0])  # rad/s: see probe


@dataclass(frozen=True, kw_only=True, eq=False)
class Geometry:
    """Where the model is evaluated: sensors ('head'/'foot') at ``sensor_x`` (m), vertical
    forces on the head at ``force_x`` (m, absolute), at ``frequency`` (Hz)."""

    frequency: np.ndarray
    outputs: tuple[str, ...]
    sensor_x: float
    force_x: np.ndarray

    def __post_init__(self):
        for o in self.outputs:
            if o not in models.CHANNELS:
                raise ValueError(f"sensor {o!r}: the models have 'head' and 'foot' sensors "
                                 "(and the lateral 'head_lateral'); name the measurement's "
                                 "sensors head/foot (or map them)")
        if len({o in models.LATERAL for o in self.outputs}) > 1:
            raise ValueError(f"sensors {self.outputs}: fit vertical and lateral data "
                             "separately (one hammer direction per geometry)")
        object.__setattr__(self, "frequency", np.asarray(self.frequency, dtype=float))
        object.__setattr__(self, "force_x", np.asarray(self.force_x, dtype=float))

    @property
    def force(self) -> str:
        """The hammer channel: lateral on the side of the head for lateral sensors."""
        return "head_lateral" if self.outputs[0] in models.LATERAL else "head"


def slow_names(space: ParameterSpace) -> tuple[str, ...]:
    """The kernel parameters of ``space`` for its base model (none for the continuous
    Timoshenko model, whose every evaluation is a closed-form solve)."""
    if space.base.is_beam and space.base.kind.is_continuous:
        return ()
    return tuple(n for n in space.names if n in SLOW)


def varied_directions(space: ParameterSpace) -> tuple[str, ...] | None:
    """The directions ('z', 'y', 'x', 'r': railfem.models.spring_directions, and the
    vertical springs' roll part PAD_ROLL with 'z') whose support stiffness the fitted
    support parameters of ``space`` change (the chain of each, railfem.track.directions
    .chain: on a track with lateral and longitudinal springs the sleeper's horizontal
    fields kb_lat, eta_b_lat, ms_lat enter both; the vertical pad enters 'z' and PAD_ROLL);
    None when a fitted parameter is neither a support nor a kernel parameter."""
    sup = space.base.support
    dirs = list(models.spring_directions(space.base))
    dirs += [PAD_ROLL] if "z" in dirs else []
    out: set[str] = set()
    for name in space.names:
        if name in SLOW:
            continue
        if name not in FAST:
            return None
        value = getattr(sup, name)
        other = replace(sup, **{name: value * 1.5 if value else 1.0})
        out |= {d for d in dirs if probe(sup, d) != probe(other, d)}
    return tuple(d for d in dirs if d in out)


def probe(support, direction: str) -> tuple:
    """The dynamic stiffness of ``support`` in ``direction`` at PROBE_OMEGA: what tells
    two supports apart in that direction."""
    return tuple(directional_stiffness(support, PROBE_OMEGA, direction))


class DirectEngine:
    """Any model through the door (railfem.models.receptance), one call per evaluation."""

    def __init__(self, geometry: Geometry, cache=False):
        self.geometry, self.cache = geometry, cache

    def receptance(self, spec: TrackSpec) -> np.ndarray:
        g = self.geometry
        return door_receptance(spec, g.frequency, g.sensor_x, g.force_x, g.outputs,
                               force=g.force, cache=self.cache)


class SpectralEngine:
    """A uniform discrete track (wfe-discrete, timoshenko-discrete) at fixed kernel
    parameters: receptance(spec) for any support parameters in a few milliseconds."""

    def __init__(self, spec: TrackSpec, geometry: Geometry, cache=False, progress=None,
                 kernel=None):
        g, given = geometry, kernel
        self.geometry = g
        self.kernel_values = kernel_values(spec)
        self.omega = 2 * np.pi * g.frequency
        self.beam = spec.is_beam
        store = kernelcache.resolve(cache)
        key = spectral_key(spec, g)

        def compute():  # given: (kernel, jr, jf) of models.discrete_kernel, if at hand
            return spectral_arrays(spec, g, cache=cache, progress=progress, kernel=given)

        arrays = store.cached(key, compute)
        self.coupling = SpectralCoupling(frequency=g.frequency, lam=arrays["lam"],
                                         residue=arrays["residue"], direct=arrays["direct"])

    def receptance(self, spec: TrackSpec) -> np.ndarray:
        Ks = dynamic_stiffness(spec.support, self.omega)
        a = self.coupling.receptance(Ks)
        if self.beam and len(self.geometry.outputs) > 1:
            a = np.repeat(a, len(self.geometry.outputs), axis=1)
        return a


def spectral_arrays(spec: TrackSpec, g: Geometry, *, cache=False, progress=None, kernel=None,
                    tail_frequency: float | None = None) -> dict:
    """SpectralEngine's arrays (lam, residue, direct; railfem.identify.spectral) of ``spec``
    at ``g``: its kernel (``kernel``: (kernel, jr, jf) of models.discrete_kernel if at
    hand) in eigen form, checked against the coupling solve at spec's support and a ten
    times softer one (checked_coupling). Each frequency's entries depend on that frequency
    alone, and on ``tail_frequency`` (models.receptance): the arrays of a grid are those
    of its parts computed with the grid's lowest frequency, concatenated."""
    kernel, jr, jf = kernel or models.discrete_kernel(
        spec, g.frequency, g.force_x, [g.sensor_x], outputs=g.outputs, cache=cache,
        progress=progress, tail_frequency=tail_frequency)
    soft = replace(spec.support, kp=spec.support.kp / 10, kb=spec.support.kb / 10)
    sc = checked_coupling(kernel, spec, jr[0], jf[0], (spec.support, soft), g.frequency)
    return {"lam": sc.lam, "residue": sc.residue, "direct": sc.direct}


def part(g: Geometry, rows) -> Geometry:
    """``g`` at the frequencies g.frequency[rows]."""
    return Geometry(frequency=g.frequency[rows], outputs=g.outputs, sensor_x=g.sensor_x,
                    force_x=g.force_x)


class DirectionalEngine:
    """A uniform discrete WFE track whose fitted support parameters change the springs of
    one ``direction`` only (e.g. the lateral chain on lateral data, varied_directions): the
    springs of the other directions held at spec's stiffness, the coupling in eigen form
    in that direction's stiffness (railfem.track.directional), so receptance(spec) costs a
    short sum per frequency. ``names``: the fitted parameters (their values are not part
    of the engine; every other support value is, and receptance refuses a spec that
    changes one: the springs of the other directions are held at the values built with)."""

    def __init__(self, spec: TrackSpec, geometry: Geometry, direction: str, names,
                 cache=False, progress=None):
        g = self.geometry = geometry
        self.kernel_values = kernel_values(spec)
        self.direction = direction
        self.omega = 2 * np.pi * g.frequency
        self.held_fields = tuple(f.name for f in fields(spec.support) if f.name not in names)
        self.held = held_values(spec.support, self.held_fields)
        store = kernelcache.resolve(cache)
        canon = spec.replace(**{n: 1.0 for n in names if n in FAST}, name="fit")
        key = kernelcache.content_key("directional-fit", __version__, direction,
                                      str(spec_to_dict(canon)), g.frequency, g.force_x,
                                      float(g.sensor_x), g.outputs, g.force)

        def compute():
            kernel, jr, jf = models.discrete_kernel(spec, g.frequency, g.force_x,
                                                    [g.sensor_x], outputs=g.outputs,
                                                    force=g.force, cache=cache,
                                                    progress=progress)
            form = checked_directional(kernel, spec, jr[0], jf[0], direction)
            return {"lam": form.lam, "residue": form.residue, "direct": form.direct}

        arrays = store.cached(key, compute)
        self.form = DirectionalSpectral(frequency=g.frequency, lam=arrays["lam"],
                                        residue=arrays["residue"], direct=arrays["direct"],
                                        direction="xyzr".index(direction))

    def receptance(self, spec: TrackSpec) -> np.ndarray:
        if held_values(spec.support, self.held_fields) != self.held:
            raise ValueError(f"the {self.direction!r} eigen form holds the support values "
                             "it was built with but the fitted ones; this spec changes "
                             "another (fit it as well, or use engine='direct')")
        k = directional_stiffness(spec.support, self.omega, self.direction)
        return self.form.receptance(k)


def held_values(support, names) -> tuple:
    """The values of ``support``'s fields ``names``: what a DirectionalEngine holds."""
    return tuple(getattr(support, n) for n in names)


def checked_directional(kernel, spec: TrackSpec, jr, jf, direction: str) -> DirectionalSpectral:
    """The eigen form of ``kernel``'s coupling (spec's layout, railfem.track.directional) in
    the stiffness of ``direction`` at the pairs (jr, jf), checked against the coupling
    solve (railfem.track.coupling.couple_discrete) at spec's stiffness and at a ten times
    softer one in that direction: a RuntimeError beyond SPECTRAL_TOLERANCE."""
    omega = 2 * np.pi * np.asarray(kernel.frequency, dtype=float)
    lay = spec.layout()
    pattern = lay.springs().weight
    K = track_wfe.spring_stiffness(lay, omega, kernel)
    form = directional_spectral(kernel, K, pattern, direction, jr, jf)
    code = "xyzr".index(direction)
    k0 = directional_stiffness(spec.support, omega, direction)
    err = 0.0
    for k in (k0, k0 / 10):
        Kk = np.array(K, dtype=complex)
        Kk[:, :, code] = k[:, None] * pattern[None, :]
        ref = couple_discrete(kernel, Kk)[:, :, np.ravel(jr), np.ravel(jf)]
        scale = np.abs(ref).max(axis=(1, 2), keepdims=True)
        err = max(err, float((np.abs(form.receptance(k) - ref) / scale).max()))
    if err > SPECTRAL_TOLERANCE:
        raise RuntimeError(f"the eigen form in the {direction!r} stiffness differs from the "
                           f"coupling solve by {err:.1e} (relative) for {spec.model}")
    return form


def spectral_key(spec: TrackSpec, g: Geometry) -> str:
    """The content key of SpectralEngine's eigen form of ``spec`` at ``g``."""
    canon = spec.replace(kp=1.0, eta_p=0.0, kb=1.0, eta_b=0.0, ms=1.0, name="fit")
    return kernelcache.content_key("spectral-fit", __version__, str(spec_to_dict(canon)),
                                   g.frequency, g.force_x, float(g.sensor_x), g.outputs)


def checked_coupling(kernel, spec: TrackSpec, jr, jf, supports, frequency) -> SpectralCoupling:
    """The eigen form (railfem.identify.spectral) of the coupling of ``kernel`` (the
    parameter-free kernel of spec's layout at ``frequency``, Hz) at the pairs (jr, jf),
    checked against the direct solve at each support of ``supports``: a RuntimeError
    beyond SPECTRAL_TOLERANCE."""
    pattern = spec.layout().springs().weight
    sc = spectral_coupling(kernel, pattern, jr, jf)
    omega = 2 * np.pi * np.asarray(frequency, dtype=float)
    err = max(check(sc, kernel, pattern, jr, jf, dynamic_stiffness(p, omega))
              for p in supports)
    if err > SPECTRAL_TOLERANCE:
        raise RuntimeError(f"the eigen form of the coupling differs from the direct "
                           f"solve by {err:.1e} (relative) for {spec.model}; the "
                           "support matrix is too close to defective here")
    return sc


def log_building(spec: TrackSpec) -> None:
    """Say that the engine of spec's kernel parameters is being built."""
    log.info("fit: building the %s engine for eta_r = %.4g, pad length = %.3g m",
             spec.model, *kernel_values(spec))


def door_receptance(spec: TrackSpec, frequency, sensor_x: float, force_x, outputs, *,
                    force: str = "head", cache=False,
                    tail_frequency: float | None = None) -> np.ndarray:
    """(nf, n_out, n_force) receptance of any model through the door
    (railfem.models.receptance) at one sensor position."""
    a = models.receptance(spec, frequency, force_x, [sensor_x], outputs=outputs,
                          force=force, cache=cache, tail_frequency=tail_frequency)
    return a[:, :, 0, :]


def kernel_values(spec: TrackSpec) -> tuple[float, float]:
    """(eta_r, pad_length): what a kernel depends on among the fit parameters."""
    return (float(spec.rail.eta), float(spec.pad_length))


class ForwardModel:
    """Receptance (nf, n_out, n_force) at ``geometry`` for vectors of ``space``.

    engine: 'auto' (spectral for uniform discrete models with vertical springs and load;
    eigen for uniform discrete WFE models with springs in several directions whose fitted
    support parameters change one direction only, e.g. the lateral chain on lateral data:
    varied_directions; the door otherwise), 'spectral', 'eigen' or 'direct'. cache: kernel
    cache as in railfem.models (False: memory only).

    ``builder``: None, or a callable(list of specs) that puts the SpectralEngine arrays of
    those specs into the kernel store (under spectral_key), e.g. built in parallel
    processes (railfem.identify.profiling.Lanes); ``engine`` then reads them from it."""

    def __init__(self, space: ParameterSpace, geometry: Geometry, *, engine: str = "auto",
                 cache=False, progress=None):
        self.space, self.geometry, self.cache, self.progress = space, geometry, cache, progress
        model = space.base.model
        # the eigen form needs one support stiffness per frequency: vertical springs only
        spectral_ok = (space.base.kind.is_discrete and space.base.uniform
                       and space.base.support_directions == "z" and geometry.force == "head")
        varied = varied_directions(space)
        # a lateral load's kernel has the vertical springs' roll part (PAD_ROLL) as well,
        # which railfem.track.directional does not hold for the vertical chain
        eigen_ok = (space.base.kind.is_discrete and space.base.uniform and space.base.is_wfe
                    and models.spring_directions(space.base) != "z" and varied is not None
                    and len(varied) == 1 and (varied != ("z",) or geometry.force == "head"))
        self.direction = varied[0] if eigen_ok else None
        if engine == "auto":
            engine = "spectral" if spectral_ok else ("eigen" if eigen_ok else "direct")
        if engine == "spectral" and not spectral_ok:
            raise ValueError(f"engine 'spectral' needs a uniform discrete model, got {model!r}")
        if engine == "eigen" and not eigen_ok:
            raise ValueError(f"engine 'eigen' needs a uniform discrete WFE model with springs "
                             "in several directions whose fitted support parameters change "
                             f"one direction only (they change {varied})")
        if engine not in ("spectral", "eigen", "direct"):
            raise ValueError(f"engine = {engine!r}: use 'auto', 'spectral', 'eigen' or "
                             "'direct'")
        self.kind = engine
        self.slow = slow_names(space)
        self._engines: dict = {}
        self.builder = None

    def engine(self, spec: TrackSpec):
        """The engine for spec's kernel parameters (built once per distinct value)."""
        if self.kind == "direct":
            if "direct" not in self._engines:
                self._engines["direct"] = DirectEngine(self.geometry, self.cache)
            return self._engines["direct"]
        key = kernel_values(spec)
        if key not in self._engines:
            if self.kind == "spectral" and self.builder is not None:
                self.builder([spec])  # logs the building itself
            else:
                log_building(spec)
            if self.kind == "eigen":
                self._engines[key] = DirectionalEngine(spec, self.geometry, self.direction,
                                                       self.space.names, self.cache,
                                                       self.progress)
            else:
                self._engines[key] = SpectralEngine(spec, self.geometry, self.cache,
                                                    self.progress)
        return self._engines[key]

    def __getstate__(self):  # a builder (parallel processes) stays in its process
        return {**self.__dict__, "builder": None}

    def add_engine(self, engine) -> None:
        """Adopt an engine built elsewhere (e.g. in a worker process)."""
        if self.kind in ("spectral", "eigen"):
            self._engines[engine.kernel_values] = engine

    def slow_values(self, i: int) -> list[float]:
        """Vector values of parameter i (a kernel parameter) that have an engine."""
        p = self.space.parameters[i]
        j = 0 if p.name == "eta_r" else 1
        return [p.encode(k[j]) for k in self._engines if isinstance(k, tuple)
                and (k[j] > 0 or not p.log)]

    def spec(self, x) -> TrackSpec:
        """The spec of x; a vector on a bound is moved in by 1e-12 (vector units) so that
        the round trip through log10 cannot step outside the space's bounds."""
        sp = self.space
        return sp.to_spec(np.clip(x, sp.lower + 1e-12, sp.upper - 1e-12))

    def receptance(self, x) -> np.ndarray:
        spec = self.spec(x)
        return self.engine(spec).receptance(spec)
