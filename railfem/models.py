"""The model door: a TrackSpec in, an FRF out (METHOD.md sections 2 and 3).

    import railfem as rf
    spec = rf.preset("site").replace(kp=300e6, model="wfe-periodic")
    Y = rf.frf(spec, f, force=[rf.head(0.32)], response=[rf.head(0.3), rf.foot(0.3)])
    tdr = rf.decay_rate(spec, f)                   # EN 15461, head sensor at mid-span

``frf`` serves every model kind of railfem.spec.MODELS with any force and response
positions (m along the rail) and any frequencies (Hz). The parameter-free part of the
discrete and periodic models (free-rail Green's functions, railfem.track.wfe / railfem.track.beams)
is cached by content (railfem.track.kernelcache): a second call that changes only the support
parameters costs the coupling solve alone. The continuous WFE model has its foundation
inside the wave solve and is recomputed on every call.

Points: ``head(x)`` is a vertical force on a patch across the head top (width
``numerics.patch_width``, spread over ``numerics.load_length`` along the rail) or the
vertical response of the head-top node; ``foot(x)`` the response of the foot-top sensor
node. ``head(x, "y")`` is the lateral channel 'head_lateral': a lateral (+y) force on a
patch of the same height on the side face of the head (centred HEAD_SIDE_DEPTH below the
head top, the +y side), or the lateral response of the side-face node there. A lateral
load excites both wave families and needs supports acting laterally
(``TrackSpec.support_directions`` with 'y'); the WFE models superpose the families.
Beam models have no cross-section and are vertical: head and foot responses both read the
beam's deflection at x.

Two rails (``TrackSpec.rails = 2``): identical rails on common sleepers split exactly into
an in-phase and an anti-phase single-rail track (``TrackSpec.load_case``) with receptances
Y_s and Y_a; a force on one rail gives (Y_s + Y_a) / 2 on that rail and (Y_s - Y_a) / 2 on
the other. ``head(x, rail=2)`` is a point on rail 2 (default rail 1).

Discrete models: a track without deviations is periodic, so each force-response pair is
computed on the n_supports supports re-centred on the pair (the support nearest to their
midpoint at the centre); with deviations the supports stay at x = n * spacing and
positions are absolute (keep them well inside the supported stretch).
"""
from __future__ import annotations

import logging
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .track import beams
from .track import kernelcache
from .rail import meshing
from .rail import mobility
from .rail import profiles
from .track import wfe as track
from .rail import waveguide
from .track.coupling import DiscreteKernel, PeriodicKernel, couple_discrete, couple_periodic
from .response import FRF
from .spec import RailSpec, TrackSpec
from .validators import warn_once
from .standards import en15461

log = logging.getLogger(__name__)

WHERE = ("head", "foot")  # the vertical channels
LATERAL = ("head_lateral",)  # the lateral channel: u_y on the side face of the head
CHANNELS = WHERE + LATERAL
FORCES = ("head", "head_lateral")
POINT_OFFSET = 0.02  # m: hammer position 0 is realised 20 mm from the accelerometer
#: Depth (m) below the head top of the lateral hammer and sensor on the head's side face:
#: the gauge measuring point of EN 13848-1 / EN 13674-1 (14 mm below the running surface).
HEAD_SIDE_DEPTH = 0.014


@dataclass(frozen=True)
class Point:
    """A force or response point: ``where`` on the section ('head' or 'foot'), ``x`` along
    the rail (m) and the direction ('z' vertical; 'y' lateral, on the head only: the
    channel 'head_lateral' on the side face of the head). rail: 1 or 2, the rail of a
    two-rail track (TrackSpec.rails = 2)."""

    where: str
    x: float
    direction: str = "z"
    rail: int = 1

    def __post_init__(self):
        if self.where not in WHERE:
            raise ValueError(f"Point.where = {self.where!r}: use one of {', '.join(WHERE)}")
        if not np.isfinite(self.x):
            raise ValueError(f"Point.x = {self.x!r}: give a finite position along the rail (m)")
        if self.direction not in ("z", "y"):
            raise ValueError(f"Point.direction = {self.direction!r}: the track models take "
                             "vertical ('z') and lateral ('y') forces and responses")
        if self.direction == "y" and self.where != "head":
            raise ValueError(f"Point({self.where!r}, direction='y'): the lateral channel is on "
                             "the side of the head; use head(x, 'y')")
        if isinstance(self.rail, bool) or self.rail not in (1, 2):
            raise ValueError(f"Point.rail = {self.rail!r}: give 1 or 2")

    @property
    def channel(self) -> str:
        """'head', 'foot' or 'head_lateral'."""
        return self.where if self.direction == "z" else f"{self.where}_lateral"

    @property
    def label(self) -> str:
        rail = "" if self.rail == 1 else f"@rail{self.rail}"
        return f"{self.where}_{self.direction}@x={self.x:.3f}{rail}"


def head(x: float = 0.0, direction: str = "z", rail: int = 1) -> Point:
    """A point on the rail head at x (m), on ``rail`` (1 or 2)."""
    return Point("head", float(x), direction, rail)


def foot(x: float = 0.0, direction: str = "z", rail: int = 1) -> Point:
    """The foot-top sensor at x (m), on ``rail`` (1 or 2)."""
    return Point("foot", float(x), direction, rail)


# ----------------------------------------------------------------------------- the rail


@dataclass(frozen=True, eq=False)
class Rail:
    """A prepared WFE rail: waveguide, the head load patch (``load``, vertical) and the
    load of every force channel (``loads``), the output locations and the foot springs,
    plus the content key of all of them (for the kernel cache)."""

    guide: waveguide.Waveguide
    load: mobility.Location
    outputs: dict
    springs: track.FootSprings
    key: tuple
    loads: dict | None = None


def head_side(guide: waveguide.Waveguide, depth: float = HEAD_SIDE_DEPTH) -> tuple:
    """(y, z) in m of the point on the +y side face of the head ``depth`` below the head
    top: the outermost boundary point at that height."""
    top = guide.nodes[guide.node("head_top")]
    z = float(top[1]) - depth
    b = guide.node_sets["boundary"]
    e = guide.elements
    edges = np.vstack([e[:, [0, 1, 3]], e[:, [1, 2, 4]], e[:, [2, 0, 5]]])
    edges = edges[np.isin(edges[:, 2], b)]
    zn = guide.nodes[edges[:, :2], 1]
    cross = edges[(zn.min(axis=1) <= z) & (zn.max(axis=1) >= z)]
    if len(cross) == 0:
        raise ValueError(f"no boundary of the section at {depth} m below the head top")
    a, c = guide.nodes[cross[:, 0]], guide.nodes[cross[:, 1]]
    t = (z - a[:, 1]) / np.where(c[:, 1] != a[:, 1], c[:, 1] - a[:, 1], 1.0)
    y = a[:, 0] + t * (c[:, 0] - a[:, 0])  # chord; the patch is read on the curved edges
    return float(y.max()), z


def rail_mesh(rail: RailSpec):
    """The mesh file if given, else the shipped mesh of (profile, h) or a new Gmsh mesh
    (memoised by those alone: the material and loss factor do not change the mesh)."""
    return section_mesh(rail.profile, rail.h, rail.mesh_file)


@lru_cache(maxsize=4)
def section_mesh(profile: str, h: float, mesh_file: str | None = None):
    """rail_mesh of a RailSpec with these ``profile``, ``h`` and ``mesh_file``."""
    if mesh_file is not None:
        return meshing.load_mesh(mesh_file)
    return meshing.get_mesh(profiles.get_profile(profile), h)


@lru_cache(maxsize=4)
def wfe_rail(rail: RailSpec, patch_width: float, n_foot_springs: int,
             foot_rule: str = "midpoint", directions: str = "z") -> Rail:
    """The WFE rail of ``rail`` (memoised: a fitter's repeated calls reuse it), its foot
    springs acting in ``directions`` (TrackSpec.support_directions)."""
    mesh = rail_mesh(rail)
    guide = waveguide.assemble(mesh, rail.material())
    outputs = {"head": mobility.point(guide, "head_top", label="head"),
               "foot": mobility.point(guide, "foot_sensor", label="foot")}
    load = mobility.head_patch(guide, patch_width)
    side = head_side(guide)
    lateral = mobility.surface_patch(guide, side, patch_width, "y", label="head_lateral",
                                     along="z")
    node = waveguide.nearest_boundary_node(guide, *side)
    outputs["head_lateral"] = mobility.point(guide, node, "y", label="head_lateral")
    springs = track.foot_springs(guide, n_foot_springs, rule=foot_rule,
                                 directions=directions)
    m = rail.material()
    # the vertical channels' key as before; other channels and springs add to it
    key = (mesh.nodes, mesh.elements, (m.E, m.nu, m.rho, m.loss_factor), load.weights,
           tuple(outputs[o].weights for o in WHERE), tuple(p.weights for p in springs.pairs),
           np.asarray(springs.weight))
    if directions != "z":
        key += (directions, tuple(p.weights for p in springs.others),
                springs.other_weight)
    return Rail(guide=guide, load=load, outputs=outputs, springs=springs, key=key,
                loads={"head": load, "head_lateral": lateral})


def _rail_of(spec: TrackSpec) -> Rail:
    n = spec.numerics
    if spring_directions(spec) == "z":  # the memo key of vertical models as before
        return wfe_rail(spec.rail, n.patch_width, n.n_foot_springs, n.foot_rule)
    return wfe_rail(spec.rail, n.patch_width, n.n_foot_springs, n.foot_rule,
                    spring_directions(spec))


def spring_directions(spec: TrackSpec) -> str:
    """The foot springs' directions: TrackSpec.support_directions, and 'r' (the foot's roll
    column) when the fastening restrains the roll (SupportParameters.k_roll > 0)."""
    return spec.support_directions + ("r" if spec.support.k_roll > 0 else "")


def _channel_key(rail: Rail, force: str, outputs) -> tuple:
    """Kernel-cache key parts of the force and output channels beyond the vertical ones."""
    extra = [o for o in outputs if o not in WHERE]
    if force == "head" and not extra:
        return ()
    return (force, rail.loads[force].weights, tuple(rail.outputs[o].weights for o in extra))


@lru_cache(maxsize=8)
def beam_section(spec_rail: RailSpec) -> beams.BeamSection:
    """Timoshenko vertical-bending section: A, I, kappa from the mesh (railfem.rail.section) or
    the nominal 60E1 catalogue values, with the rail's material (METHOD.md section 3)."""
    if spec_rail.beam_constants == "catalogue":
        return beams.BeamSection.catalogue(spec_rail.material())
    area, second_moment, kappa = mesh_beam_constants(spec_rail.profile, spec_rail.h,
                                                     spec_rail.mesh_file)
    return beams.BeamSection.from_material(spec_rail.material(), area=area, I=second_moment,
                                           kappa=kappa)


@lru_cache(maxsize=8)
def mesh_beam_constants(profile: str, h: float, mesh_file: str | None = None) -> tuple:
    """(A, I, kappa) of the vertical bending of the section mesh (BeamSection.from_mesh),
    memoised by the mesh alone: a profile over the rail loss factor (a new RailSpec each)
    does not solve the section's shear problem again."""
    s = beams.BeamSection.from_mesh(section_mesh(profile, h, mesh_file))
    return s.area, s.I, s.kappa


# ----------------------------------------------------------------------------- the door


def _frequency(frequency) -> np.ndarray:
    f = np.atleast_1d(np.asarray(frequency, dtype=float))
    if f.ndim != 1 or f.size == 0 or not np.all(np.isfinite(f)) or np.any(f <= 0):
        raise ValueError(f"frequency must be a non-empty 1-D array of positive finite values "
                         f"in Hz, got {np.asarray(frequency)!r:.80}")
    return f


def _version() -> str:
    from . import __version__

    return __version__


def _check_channels(spec: TrackSpec, force: str, outputs) -> None:
    if force not in FORCES:
        raise ValueError(f"force channel {force!r}: use one of {', '.join(FORCES)}")
    for o in outputs:
        if o not in CHANNELS:
            raise ValueError(f"output {o!r}: use one of {', '.join(CHANNELS)}")
    lateral = [c for c in (force, *outputs) if c in LATERAL]
    if not lateral:
        return
    if spec.is_beam:
        raise ValueError(f"channel {lateral[0]!r} with model {spec.model!r}: the Timoshenko "
                         "models are vertical; use a WFE model for lateral channels")
    if "y" not in spec.support_directions:
        raise ValueError(f"channel {lateral[0]!r} needs supports that act laterally: the spec "
                         f"has support_directions = {spec.support_directions!r}; set "
                         "support_directions = 'zyx' (and the lateral pad kp_lat > 0)")


def receptance(spec: TrackSpec, frequency, force_x, response_x, *, outputs=WHERE,
               force: str = "head", cache=None, progress=None, rail: int = 1,
               tail_frequency: float | None = None) -> np.ndarray:
    """Receptance (nf, n_out, n_rx, n_fx) in m/N of the track ``spec``: unit force in the
    channel ``force`` ('head': vertical on the head top, default; 'head_lateral': lateral
    on the side of the head) at each force_x, response at each response_x (m) for each
    output in ``outputs`` ('head', 'foot', 'head_lateral'). The grid form behind ``frf``.

    cache: kernel cache (railfem.track.kernelcache.resolve: None = the default folder, a folder,
    False = memory only, or a KernelStore). rail: the response on the rail of the force (1)
    or on the other rail (2) of a two-rail track (TrackSpec.rails = 2). tail_frequency
    (Hz, uniform wfe-discrete only): where the WFE near-field tail is solved, default the
    lowest frequency (railfem.track.wfe.discrete_kernel): part of a grid, computed with the
    grid's lowest, is the whole grid's result there."""
    if not isinstance(spec, TrackSpec):
        raise TypeError(f"spec must be a TrackSpec, got {type(spec).__name__}")
    if rail not in (1, 2) or (rail == 2 and spec.rails == 1):
        raise ValueError(f"rail = {rail!r}: give 1 (the force's rail) or 2 (the other rail, "
                         "with TrackSpec.rails = 2)")
    if spec.rails == 2:
        return two_rail_receptance(spec, frequency, force_x, response_x, outputs=outputs,
                                   force=force, cache=cache, progress=progress)[rail - 1]
    f = _frequency(frequency)
    fx = np.atleast_1d(np.asarray(force_x, dtype=float))
    rx = np.atleast_1d(np.asarray(response_x, dtype=float))
    for name, x in (("force_x", fx), ("response_x", rx)):
        if x.ndim != 1 or not np.all(np.isfinite(x)):
            raise ValueError(f"{name} must be a 1-D array of finite positions (m)")
    outputs = tuple(outputs)
    _check_channels(spec, force, outputs)
    _warn_validity(spec, f, fx, rx)
    store = kernelcache.resolve(cache)
    kind = spec.kind
    if kind.is_discrete and spec.uniform:
        return _centred_on_pairs(spec, f, fx, rx, outputs, store, progress, force,
                                 tail_frequency)
    if kind.is_discrete and kind.is_wfe:
        return _wfe_discrete(spec, f, fx, rx, outputs, store, progress, force=force)
    if kind.is_discrete:
        return _beam_discrete(spec, f, fx, rx, outputs, store)
    if kind.is_periodic:
        return _wfe_periodic(spec, f, fx, rx, outputs, store, progress, force)
    sep = rx[:, None] - fx[None, :]
    if kind.is_beam:
        a = beams.continuous_track_receptance(beam_section(spec.rail), spec.support,
                                              spec.spacing, 2 * np.pi * f, sep.ravel(),
                                              load_length=spec.numerics.load_length)
        return np.repeat(a.reshape(len(f), 1, *sep.shape), len(outputs), axis=1)
    rail = _rail_of(spec)
    u, inv = np.unique(np.round(sep, 12), return_inverse=True)
    r = track.continuous_receptance(rail.guide, spec.support, spec.spacing, f,
                                    load=rail.loads[force],
                                    outputs=[rail.outputs[o] for o in outputs], x=u,
                                    load_length=spec.numerics.load_length,
                                    n_waves=spec.numerics.n_waves, tail=spec.numerics.tail,
                                    directions=spring_directions(spec), progress=progress)
    return r.receptance[:, :, inv.reshape(sep.shape), 0]


def two_rail_receptance(spec: TrackSpec, frequency, force_x, response_x, **options):
    """(same rail, other rail) receptances of the two-rail track ``spec`` (rails = 2), each
    as ``receptance``: (Y_s + Y_a) / 2 and (Y_s - Y_a) / 2 from its in-phase and anti-phase
    single-rail tracks (TrackSpec.load_case), which share one free-rail kernel."""
    a_s, a_a = (receptance(spec.load_case(c), frequency, force_x, response_x, **options)
                for c in ("symmetric", "antisymmetric"))
    return (a_s + a_a) / 2, (a_s - a_a) / 2


def _centring(spec, fx, rx):
    """Re-centred positions (uf, ur) and the gather (jr, jf) of _centred_on_pairs."""
    d = spec.spacing
    c = np.round((rx[:, None] + fx[None, :]) / (2 * d)) * d
    uf, jf = np.unique(np.round(fx[None, :] - c, 10), return_inverse=True)
    ur, jr = np.unique(np.round(rx[:, None] - c, 10), return_inverse=True)
    return uf, ur, jr.reshape(c.shape), jf.reshape(c.shape)


#: Hz: above this the 60E1 section deforms (foot-flapping cut-on 5.0 kHz, its near field
#: felt from ~2 kHz; head and foot responses part there): a beam model is out of its range
BEAM_VALIDITY_HZ = 2000.0


def _warn_validity(spec: TrackSpec, f, fx, rx) -> None:
    """Say when a request leaves what the model can stand for (results are still given):
    a beam above BEAM_VALIDITY_HZ, a WFE section mesh with too few elements per wavelength,
    a discrete track asked for points beyond its supported stretch."""
    if spec.is_beam and f.max() > BEAM_VALIDITY_HZ:
        warn_once(log, "%s up to %.4g Hz: a beam has no cross-section deformation; above "
                  "about %g Hz the rail's foot and web deform (foot flapping cuts on at ~5 kHz "
                  "on 60E1) and head and foot responses differ: use a wfe-* model there",
                  spec.model, f.max(), BEAM_VALIDITY_HZ)
    if spec.is_wfe:
        waveguide.check_resolution(_rail_of(spec).guide, f.max())  # the model's own rail
    if spec.kind.is_discrete:
        reach = (spec.n_supports - 1) / 2 * spec.spacing
        sep = np.abs(rx[:, None] - fx[None, :]).max()
        # uniform tracks are re-centred on each pair: each point is sep/2 from the centre
        span = sep / 2 if spec.uniform else max(np.abs(fx).max(), np.abs(rx).max())
        if span > reach - 2 * spec.spacing:
            warn_once(log, "positions up to %.4g m from the centre of the %d supports (they "
                      "reach +-%.4g m): beyond the supported stretch the rail is free; raise "
                      "n_supports or use wfe-periodic", span, spec.n_supports, reach)


def _centred_on_pairs(spec, f, fx, rx, outputs, store, progress, force="head",
                      tail_frequency=None):
    """Uniform discrete tracks: each pair (x_P, x_r) is computed as (x_P - c, x_r - c), c the
    support nearest to their midpoint; one solve serves every pair."""
    uf, ur, jr, jf = _centring(spec, fx, rx)
    if spec.is_beam:
        a = _beam_discrete(spec, f, uf, ur, outputs, store)
    else:
        a = _wfe_discrete(spec, f, uf, ur, outputs, store, progress, force=force,
                          tail_frequency=tail_frequency)
    return a[:, :, jr, jf]


def discrete_kernel(spec: TrackSpec, frequency, force_x, response_x, *, outputs=WHERE,
                    force: str = "head", cache=None, progress=None,
                    tail_frequency: float | None = None):
    """The parameter-free kernel of a uniform discrete track (wfe-discrete or
    timoshenko-discrete) for the fitter (railfem.identify): returns (kernel, jr, jf) such
    that ``couple_discrete(kernel, K)[:, :, jr, jf]`` is ``receptance(spec, ...)``, with K
    the (nf, n_sets) stiffness of spec.layout()'s spring sets. A beam kernel has one
    output (the beam's deflection serves head and foot). With horizontal springs
    (support_directions beyond 'z') K is (nf, n_sets, 3) per direction x, y, z
    (track.spring_stiffness). tail_frequency: as in ``receptance``."""
    _check_channels(spec, force, tuple(outputs))
    if spec.rails == 2:
        raise ValueError("discrete_kernel is a single-rail kernel: take each load case of a "
                         "two-rail track, spec.load_case('symmetric' / 'antisymmetric')")
    if not spec.kind.is_discrete or not spec.uniform:
        raise ValueError(f"discrete_kernel needs a uniform discrete model, got {spec.model!r}"
                         + ("" if spec.uniform else " with deviations"))
    f = _frequency(frequency)
    fx = np.atleast_1d(np.asarray(force_x, dtype=float))
    rx = np.atleast_1d(np.asarray(response_x, dtype=float))
    uf, ur, jr, jf = _centring(spec, fx, rx)
    store = kernelcache.resolve(cache)
    if spec.is_beam:
        kernel = _beam_discrete(spec, f, uf, ur, tuple(outputs), store, couple=False)
    else:
        kernel = _wfe_discrete(spec, f, uf, ur, tuple(outputs), store, progress, couple=False,
                               force=force, tail_frequency=tail_frequency)
    return kernel, jr, jf


def _key(kind, spec, *parts):
    n = spec.numerics
    return kernelcache.content_key(kind, _version(), n.n_waves, n.tail, n.load_length, *parts)


def _wfe_discrete(spec, f, fx, rx, outputs, store, progress, couple=True, force="head",
                  tail_frequency=None):
    rail = _rail_of(spec)
    lay = spec.layout()
    xs = lay.springs().x
    outs = [rail.outputs[o] for o in outputs]
    if tail_frequency is not None and float(tail_frequency) == float(f.min()):
        tail_frequency = None  # the default: the same kernel and key
    key = _key("wfe-discrete", spec, rail.key, outputs, xs, lay.row_length, fx, rx, f,
               *_channel_key(rail, force, outputs),
               *(() if tail_frequency is None else (("tail_hz", float(tail_frequency)),)))
    n = spec.numerics

    def compute():
        return track.discrete_kernel(rail.guide, rail.springs, xs, f, load=rail.loads[force],
                                     outputs=outs, force_x=fx, response_x=rx,
                                     spring_length=lay.row_length, load_length=n.load_length,
                                     n_waves=n.n_waves, tail=n.tail, progress=progress,
                                     tail_frequency=tail_frequency).to_arrays()

    kernel = DiscreteKernel.from_arrays(store.cached(key, compute))
    if not couple:
        return kernel
    return couple_discrete(kernel, track.spring_stiffness(lay, 2 * np.pi * f, kernel))


def _beam_discrete(spec, f, fx, rx, outputs, store, couple=True):
    bs = beam_section(spec.rail)
    lay = spec.layout()
    xs = lay.springs().x
    w = 2 * np.pi * f
    key = _key("timoshenko-discrete", spec, repr(bs), xs, lay.row_length, fx, rx, f)

    def compute():
        return beams.discrete_kernel(bs, xs, w, fx, rx, spring_length=lay.row_length,
                                     load_length=spec.numerics.load_length).to_arrays()

    kernel = DiscreteKernel.from_arrays(store.cached(key, compute))
    if not couple:
        return kernel
    a = couple_discrete(kernel, lay.spring_stiffness(w))
    return np.repeat(a, len(outputs), axis=1)


def _wfe_periodic(spec, f, fx, rx, outputs, store, progress, force="head"):
    from .track.supports import uniform_layout

    rail = _rail_of(spec)
    cell = uniform_layout(spec.support, spec.spacing, n=1, pad_length=spec.pad_length,
                          n_rows=spec.n_rows)
    o = cell.springs().x
    n = spec.numerics
    outs = [rail.outputs[x] for x in outputs]
    key = _key("wfe-periodic", spec, rail.key, outputs, o, cell.row_length, spec.spacing,
               n.n_theta, fx, rx, f, *_channel_key(rail, force, outputs))

    def compute():
        return track.periodic_kernel(rail.guide, rail.springs, o, spec.spacing, f,
                                     load=rail.loads[force], outputs=outs, force_x=fx,
                                     response_x=rx,
                                     spring_length=cell.row_length,
                                     load_length=n.load_length, n_theta=n.n_theta,
                                     n_waves=n.n_waves, tail=n.tail,
                                     progress=progress).to_arrays()

    kernel = PeriodicKernel.from_arrays(store.cached(key, compute))
    return couple_periodic(kernel, track.spring_stiffness(cell, 2 * np.pi * f, kernel))


def frf(spec: TrackSpec, frequency, *, force, response, quantity: str = "mobility",
        cache=None, progress=None) -> FRF:
    """The FRF (quantity: receptance, mobility or accelerance) of the track ``spec`` between
    the Points ``force`` (forces on the head: vertical, or lateral with direction 'y') and
    ``response``, at ``frequency`` (Hz). values[f, i, j] is response i per unit force j."""
    force, response = list(force), list(response)
    if not force or not response:
        raise ValueError("give at least one force and one response Point")
    for p in force + response:
        if not isinstance(p, Point):
            raise TypeError(f"forces and responses are Points (railfem.models.head/foot), "
                            f"got {p!r}")
    bad = [p for p in force if p.where != "head"]
    if bad:
        raise ValueError(f"force at {bad[0].label}: the track models take vertical forces on "
                         "the rail head")
    f = _frequency(frequency)
    rx, jr = np.unique([p.x for p in response], return_inverse=True)
    outputs = tuple(o for o in CHANNELS if any(p.channel == o for p in response))
    jo = np.array([outputs.index(p.channel) for p in response])
    values = np.empty((len(f), len(response), len(force)), dtype=complex)
    for channel in FORCES:  # one solve per force channel, the families superposed inside
        cols = [j for j, p in enumerate(force) if p.channel == channel]
        if not cols:
            continue
        fx, jf = np.unique([force[j].x for j in cols], return_inverse=True)
        if spec.rails == 1 and any(p.rail != 1 for p in response + force):
            raise ValueError("a point on rail 2 needs a two-rail track (TrackSpec.rails = 2)")
        if spec.rails == 2:  # same rail / other rail, from the two load cases
            a = two_rail_receptance(spec, f, fx, rx, outputs=outputs, force=channel,
                                    cache=cache, progress=progress)
        else:
            a = (receptance(spec, f, fx, rx, outputs=outputs, force=channel, cache=cache,
                            progress=progress),)
        other = np.array([[int(p.rail != force[j].rail) for j in cols] for p in response])
        values[:, :, cols] = _pick(np.stack(a), other, jo, jr, jf)
    out = FRF(frequency=f, values=values, quantity="receptance",
              response=tuple(p.label for p in response), force=tuple(p.label for p in force),
              response_x=[p.x for p in response], force_x=[p.x for p in force])
    return out.to(quantity)


def _pick(a, other, jo, jr, jf):
    """values[:, i, j] = a[other[i, j], :, jo[i], jr[i], jf[j]] (a: stacked receptances)."""
    return a[other, :, jo[:, None], jr[:, None], jf[None, :]].transpose(2, 0, 1)


def hammer_x(spec: TrackSpec, positions=None, offset: float = POINT_OFFSET,
             sensor_x: float | None = None):
    """(sensor x, hammer positions relative to it, hammer x) of an EN 15461 test on spec:
    the sensor at mid-span (spacing / 2) unless given, positions default to the standard's
    29 (en15461.hammer_positions), position 0 realised ``offset`` (m) from the sensor."""
    xs = spec.spacing / 2 if sensor_x is None else float(sensor_x)
    pos = en15461.hammer_positions(spec.spacing) if positions is None else np.asarray(
        positions, dtype=float)
    if not np.isfinite(offset) or offset < 0:
        raise ValueError(f"offset = {offset!r} m: give the hammer offset at position 0, >= 0")
    # rounded to the nanometre: 0.6 * 0.75 prints as 0.44999999999999996 in the output files
    pos = np.round(pos, 9)
    return xs, pos, np.round(xs + np.where(pos == 0, offset, pos), 9)


def decay_rate(spec: TrackSpec, frequency, *, output: str = "head", positions=None,
               offset: float = POINT_OFFSET, sensor_x: float | None = None, cache=None,
               progress=None, force: str | None = None,
               **options) -> en15461.DecayRateResult:
    """EN 15461 track decay rate of ``spec`` per one-third-octave band (arrays, no files).

    frequency: narrow-band frequencies (Hz, 1/9 octave or finer, e.g.
    iec61260.ninth_octave_grid). output: the sensor, 'head' or 'foot' (vertical hammer on
    the head top) or 'head_lateral' (lateral hammer and sensor on the side of the head,
    HEAD_SIDE_DEPTH below its top; ``force`` overrides the hammer channel). positions: hammer
    positions relative to the sensor (m), default the standard's 29 for the spacing;
    position 0 is the point FRF, realised with the hammer ``offset`` m (default 0.02) from
    the sensor, which sits at ``sensor_x`` (default mid-span). options go to
    en15461.decay_rate (threshold_db, attenuation_range, ...)."""
    xs, pos, hx = hammer_x(spec, positions, offset, sensor_x)
    if force is None:
        force = "head_lateral" if output in LATERAL else "head"
    a = receptance(spec, frequency, hx, [xs], outputs=(output,), force=force, cache=cache,
                   progress=progress)
    f = _frequency(frequency)
    return en15461.decay_rate(f, 2j * np.pi * f[:, None] * a[:, 0, 0, :], pos, **options)
