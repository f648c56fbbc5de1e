"""The forward model of a fit: a parameter vector in, receptances at the data's geometry out.

A fit varies the track parameters of a railfem.params.ParameterSpace. They fall in two
kinds (METHOD.md section 7, "Separate what depends on parameters from what does not"):

* **support parameters** (FAST: kp, eta_p, kb, eta_b, ms) enter the discrete and periodic
  models only through the support dynamic stiffness K_s(omega): the parameter-free kernel
  is computed once (railfem.models.discrete_kernel, cached by railfem.track.kernelcache) and a new
  parameter set costs the coupling alone; on uniform discrete tracks the coupling itself is
  a short sum (railfem.identify.spectral);
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
from dataclasses import dataclass, replace

import numpy as np


from railfem import __version__, models
from railfem.track import kernelcache
from railfem.identify.spectral import SpectralCoupling, check, spectral_coupling
from railfem.params import ParameterSpace
from railfem.spec import TrackSpec, spec_to_dict
from railfem.track.supports import dynamic_stiffness

log = logging.getLogger(__name__)

FAST = ("kp", "eta_p", "kb", "eta_b", "ms", "kp_lat", "eta_p_lat", "kp_long", "eta_p_long",
        "kb_lat", "eta_b_lat", "ms_lat")
SLOW = ("eta_r", "pad_length")
SPECTRAL_TOLERANCE = 1e-8  # largest relative difference to the direct coupling accepted


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

    def __init__(self, spec: TrackSpec, geometry: Geometry, cache=False, progress=None):
        g = self.geometry = geometry
        self.kernel_values = kernel_values(spec)
        self.omega = 2 * np.pi * g.frequency
        self.beam = spec.is_beam
        store = kernelcache.resolve(cache)
        canon = spec.replace(kp=1.0, eta_p=0.0, kb=1.0, eta_b=0.0, ms=1.0, name="fit")
        key = kernelcache.content_key("spectral-fit", __version__,
                                      str(spec_to_dict(canon)), g.frequency, g.force_x,
                                      float(g.sensor_x), g.outputs)

        def compute():
            kernel, jr, jf = models.discrete_kernel(spec, g.frequency, g.force_x,
                                                    [g.sensor_x], outputs=g.outputs,
                                                    cache=cache, progress=progress)
            soft = replace(spec.support, kp=spec.support.kp / 10, kb=spec.support.kb / 10)
            sc = checked_coupling(kernel, spec, jr[0], jf[0], (spec.support, soft),
                                  g.frequency)
            return {"lam": sc.lam, "residue": sc.residue, "direct": sc.direct}

        arrays = store.cached(key, compute)
        self.coupling = SpectralCoupling(frequency=g.frequency, lam=arrays["lam"],
                                         residue=arrays["residue"], direct=arrays["direct"])

    def receptance(self, spec: TrackSpec) -> np.ndarray:
        Ks = dynamic_stiffness(spec.support, self.omega)
        a = self.coupling.receptance(Ks)
        if self.beam and len(self.geometry.outputs) > 1:
            a = np.repeat(a, len(self.geometry.outputs), axis=1)
        return a


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


def door_receptance(spec: TrackSpec, frequency, sensor_x: float, force_x, outputs, *,
                    force: str = "head", cache=False) -> np.ndarray:
    """(nf, n_out, n_force) receptance of any model through the door
    (railfem.models.receptance) at one sensor position."""
    a = models.receptance(spec, frequency, force_x, [sensor_x], outputs=outputs,
                          force=force, cache=cache)
    return a[:, :, 0, :]


def kernel_values(spec: TrackSpec) -> tuple[float, float]:
    """(eta_r, pad_length): what a kernel depends on among the fit parameters."""
    return (float(spec.rail.eta), float(spec.pad_length))


class ForwardModel:
    """Receptance (nf, n_out, n_force) at ``geometry`` for vectors of ``space``.

    engine: 'auto' (spectral for uniform discrete models, the door otherwise), 'spectral'
    or 'direct'. cache: kernel cache as in railfem.models (False: memory only)."""

    def __init__(self, space: ParameterSpace, geometry: Geometry, *, engine: str = "auto",
                 cache=False, progress=None):
        self.space, self.geometry, self.cache, self.progress = space, geometry, cache, progress
        model = space.base.model
        # the eigen form needs one support stiffness per frequency: vertical springs only
        spectral_ok = (space.base.kind.is_discrete and space.base.uniform
                       and space.base.support_directions == "z" and geometry.force == "head")
        if engine == "auto":
            engine = "spectral" if spectral_ok else "direct"
        if engine == "spectral" and not spectral_ok:
            raise ValueError(f"engine 'spectral' needs a uniform discrete model, got {model!r}")
        if engine not in ("spectral", "direct"):
            raise ValueError(f"engine = {engine!r}: use 'auto', 'spectral' or 'direct'")
        self.kind = engine
        self.slow = slow_names(space)
        self._engines: dict = {}

    def engine(self, spec: TrackSpec):
        """The engine for spec's kernel parameters (built once per distinct value)."""
        if self.kind == "direct":
            if "direct" not in self._engines:
                self._engines["direct"] = DirectEngine(self.geometry, self.cache)
            return self._engines["direct"]
        key = kernel_values(spec)
        if key not in self._engines:
            log.info("fit: building the %s engine for eta_r = %.4g, pad length = %.3g m",
                     spec.model, *key)
            self._engines[key] = SpectralEngine(spec, self.geometry, self.cache,
                                                self.progress)
        return self._engines[key]

    def add_engine(self, engine) -> None:
        """Adopt an engine built elsewhere (e.g. in a worker process)."""
        if self.kind == "spectral":
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
