"""The track specification: rail, supports, pad geometry and model kind in one frozen value.

``TrackSpec`` is what the model door (railfem.models) takes; presets are named specs
(``preset('site')``, from the Table 1 sets of railfem.track.supports). A spec converts to and
from a plain dict (``spec_to_dict`` / ``spec_from_dict``) with SI numbers, which is what
``run.json`` records and what a TOML config file holds; there a number may also be written
as a string with a unit (``kp = "600 MN/m"``, ``pad_length = "150 mm"``). Unknown keys and
unknown units are errors naming the key.

Model kinds (MODELS; MODEL_KINDS / ``TrackSpec.kind`` say what each is made of, a
``ModelKind``): ``wfe-discrete`` (WFE rail on n_supports discrete supports, each may
deviate), ``wfe-periodic`` (infinitely many identical supports, Floquet), ``wfe-continuous``
(foundation spread along the rail), ``timoshenko-discrete`` and ``timoshenko-continuous``
(the beam on the same supports).
"""
from __future__ import annotations

import logging
from dataclasses import asdict, dataclass, field, fields, replace

from . import validators as v
from .materials import Material
from .track.directions import DIRECTIONS as SUPPORT_DIRECTIONS, GRIP_FIELDS, HORIZONTAL_FIELDS
from .track.supports import PRESETS, SupportLayout, SupportParameters
from .track.supports import RAIL_LOSS_FACTORS, preset_key
from .track.supports import DEFAULT_SPACING, uniform_layout
from .track.sleeper import CASES as LOAD_CASES, Sleeper, load_case

RAILS = ("wfe", "timoshenko")  # ModelKind.rail
SUPPORT_KINDS = ("discrete", "periodic", "continuous")  # ModelKind.supports
BEAM_CONSTANTS = ("mesh", "catalogue")
H_RANGE = (0.5e-3, 0.1)  # m: finer hangs the eigen-solves, coarser cannot carry the section
FOOT_RULES = ("midpoint", "nodes")  # railfem.track.footprints.RULES
# The converged default support footprint (railfem support-convergence, issue 8): a pad
# of this length in these rows, 4 midpoint springs across the foot (Numerics).
DEFAULT_PAD_LENGTH = 0.15  # m
DEFAULT_PAD_ROWS = 3

log = logging.getLogger(__name__)


@dataclass(frozen=True, kw_only=True)
class ModelKind:
    """What a model kind (TrackSpec.model) is made of: its rail and its supports.

    name: the model's name, '<rail>-<supports>'. rail: 'wfe' (the waveguide finite element
    section, railfem.track.wfe) or 'timoshenko' (the vertical beam, railfem.track.beams).
    supports: 'discrete' (n_supports supports, each may deviate), 'periodic' (infinitely
    many identical supports, Floquet) or 'continuous' (a foundation spread along the rail:
    no pad geometry)."""

    name: str
    rail: str
    supports: str

    def __post_init__(self):
        v.one_of("ModelKind.rail", self.rail, RAILS)
        v.one_of("ModelKind.supports", self.supports, SUPPORT_KINDS)
        if self.name != f"{self.rail}-{self.supports}":
            raise ValueError(f"ModelKind.name = {self.name!r}: give "
                             f"'{self.rail}-{self.supports}'")

    @property
    def is_wfe(self) -> bool:
        """The rail is the WFE section (lateral channels, cross-section deformation)."""
        return self.rail == "wfe"

    @property
    def is_beam(self) -> bool:
        """The rail is the vertical Timoshenko beam."""
        return self.rail == "timoshenko"

    @property
    def is_discrete(self) -> bool:
        """A finite set of supports (spec.layout()), which may deviate one by one."""
        return self.supports == "discrete"

    @property
    def is_periodic(self) -> bool:
        """Infinitely many identical supports."""
        return self.supports == "periodic"

    @property
    def is_continuous(self) -> bool:
        """A foundation spread along the rail: no pad length or rows."""
        return self.supports == "continuous"

    @property
    def continuous(self) -> "ModelKind":
        """The same rail on a continuous foundation."""
        return model_kind(f"{self.rail}-continuous")


#: The model kinds by name (MODELS: their names, in this order).
MODEL_KINDS = {k.name: k for k in (
    ModelKind(name="wfe-discrete", rail="wfe", supports="discrete"),
    ModelKind(name="wfe-periodic", rail="wfe", supports="periodic"),
    ModelKind(name="wfe-continuous", rail="wfe", supports="continuous"),
    ModelKind(name="timoshenko-discrete", rail="timoshenko", supports="discrete"),
    ModelKind(name="timoshenko-continuous", rail="timoshenko", supports="continuous"),
)}
MODELS = tuple(MODEL_KINDS)


def model_kind(name: str) -> ModelKind:
    """The ModelKind of the model called ``name`` (one of MODELS)."""
    v.one_of("model", name, MODELS)
    return MODEL_KINDS[name]


def _names_continuous(name) -> bool:
    """``name`` is a model on a continuous foundation (False for anything not a model: the
    TrackSpec it goes into reports that)."""
    return isinstance(name, str) and name in MODEL_KINDS and MODEL_KINDS[name].is_continuous


@dataclass(frozen=True, kw_only=True)
class RailSpec:
    """The rail: section mesh and material.

    profile: '60E1' (= UIC60), 'rect:WIDTHxHEIGHT' (mm) or the path of an outline CSV.
    h: element size of the section mesh (m), 0.5 mm to 100 mm. mesh_file: a saved mesh
    (.npz, railfem mesh) used instead of profile and h. E (Pa), nu (-), rho (kg/m^3): steel.
    eta: rail loss factor (-), E* = E (1 + i eta). beam_constants: where the Timoshenko
    models take A, I and kappa from: 'mesh' (railfem.rail.section on this mesh) or 'catalogue'
    (nominal EN 13674-1 60E1, beams.BeamSection.catalogue).
    """

    profile: str = "60E1"
    h: float = 0.01
    mesh_file: str | None = None
    E: float = 2.1e11
    nu: float = 0.3
    rho: float = 7850.0
    eta: float = 0.01
    beam_constants: str = "mesh"

    def __post_init__(self):
        v.positive("RailSpec.h", self.h, "m")
        if not H_RANGE[0] <= self.h <= H_RANGE[1]:
            raise ValueError(f"RailSpec.h = {self.h!r} m: give an element size between "
                             f"{H_RANGE[0] * 1e3:g} mm and {H_RANGE[1] * 1e3:g} mm (in metres "
                             "here, e.g. 0.01; the shipped 60E1 meshes have 5-20 mm)")
        v.one_of("RailSpec.beam_constants", self.beam_constants, BEAM_CONSTANTS)
        v.non_negative("RailSpec.eta", self.eta, "(-)", "the rail loss factor, e.g. 0.01")
        self.material()  # validates E, nu, rho

    def material(self) -> Material:
        return Material(E=self.E, nu=self.nu, rho=self.rho, loss_factor=self.eta)


@dataclass(frozen=True, kw_only=True)
class SupportDeviation:
    """One support whose parameters differ from the others: factors on its pad stiffness
    (kp), pad loss factor (eta_p), sleeper mass (ms), ballast stiffness (kb) and ballast
    loss factor (eta_b). index: the support counted from the one at x = 0 (negative
    towards -x). A factor 0 on kb is a voided (hanging) sleeper."""

    index: int
    kp: float = 1.0
    eta_p: float = 1.0
    ms: float = 1.0
    kb: float = 1.0
    eta_b: float = 1.0

    def __post_init__(self):
        if isinstance(self.index, bool) or int(self.index) != self.index:
            raise ValueError(f"SupportDeviation.index = {self.index!r}: give an integer")
        object.__setattr__(self, "index", int(self.index))
        for name in ("kp", "eta_p", "ms", "kb", "eta_b"):
            v.non_negative(f"SupportDeviation.{name}", getattr(self, name), "(factor)")

    def apply(self, p: SupportParameters) -> SupportParameters:
        """p with the factors applied; each also scales its horizontal counterparts (a
        pad's factor its lateral and longitudinal pad, the ballast's factor the sleeper's
        horizontal ballast support: a voided sleeper is voided in every direction).

        The fastening's grip (k_roll, k_clip) acts between rail and sleeper like the pad,
        but it is not the pad: steel clips pressing the foot onto the sleeper, in parallel
        with the pad. A pad factor (a softer, harder or worn pad) leaves it unchanged. A
        ballast factor changes what holds the sleeper, so it acts through the chain behind
        the grip, not on the grip: laterally the clips sit in series with the sleeper's
        horizontal ballast support, which the factor scales (a voided sleeper hangs with
        its clips); in roll the sleeper is rigid while the ballast holds it and turns
        against its own rotational inertia once voided (railfem.track.directions.chain), so
        a voided sleeper's grip still acts against the sleeper's inertia but no longer
        against the ground: above sqrt(k_roll / J) / 2 pi (12 Hz for 4e5 N m/rad and the
        default sleeper) nearly as before, below it less. The sleeper-mass factor scales
        that inertia with ms."""
        def f(value, factor):  # 0 * inf is an absent element, not NaN
            return 0.0 if factor == 0 else value * factor
        return replace(p, kp=p.kp * self.kp, eta_p=p.eta_p * self.eta_p, ms=p.ms * self.ms,
                       kb=p.kb * self.kb, eta_b=p.eta_b * self.eta_b,
                       kp_lat=f(p.kp_lat, self.kp), kp_long=f(p.kp_long, self.kp),
                       eta_p_lat=p.eta_p_lat * self.eta_p,
                       eta_p_long=p.eta_p_long * self.eta_p, ms_lat=p.ms_lat * self.ms,
                       kb_lat=f(p.kb_lat, self.kb), eta_b_lat=p.eta_b_lat * self.eta_b)


@dataclass(frozen=True, kw_only=True)
class Numerics:
    """Discretisation choices (defaults are the converged ones of the tests).

    n_foot_springs: springs across the rail foot per support row (-). foot_rule: how they
    sit: 'midpoint' (a distributed bed: springs at the centres of equal strips of the foot
    width, reading and loading the FE field through the P2 edge shape functions; converges
    to the consistent bed as n grows) or 'nodes' (point springs at foot nodes weighted by
    tributary width: the published configuration, which does not converge with the mesh;
    railfem.track.footprints, docs/model.md). n_waves: waves per
    family kept by the shift-invert solver (-). tail: add the frozen near-field tail.
    n_theta: Floquet angles of the periodic model (-). load_length: length along the rail
    over which a force is spread (m). patch_width: width of the head load patch (m).
    """

    n_foot_springs: int = 4
    foot_rule: str = "midpoint"
    n_waves: int = 40
    tail: bool = True
    n_theta: int = 512
    load_length: float = 0.02
    patch_width: float = 0.02

    def __post_init__(self):
        for name, low in (("n_foot_springs", 1), ("n_waves", 4), ("n_theta", 16)):
            val = getattr(self, name)
            if isinstance(val, bool) or int(val) != val or val < low:
                raise ValueError(f"Numerics.{name} = {val!r}: give an integer >= {low}")
        if not isinstance(self.tail, bool):
            raise ValueError(f"Numerics.tail = {self.tail!r}: give true or false")
        v.one_of("Numerics.foot_rule", self.foot_rule, FOOT_RULES)
        v.non_negative("Numerics.load_length", self.load_length, "m", "e.g. 0.02")
        v.positive("Numerics.patch_width", self.patch_width, "m", "e.g. 0.02")


@dataclass(frozen=True, kw_only=True)
class TrackSpec:
    """A track: rail + supports + pad geometry + model kind (all SI).

    name: a label. model: one of MODELS. rail: RailSpec. support: SupportParameters of
    every support (per fastener and rail). spacing: sleeper spacing (m). pad_length: length
    of rail each support is spread over (m), 0 = point supports, less than the spacing;
    not used by the continuous models (they spread the support uniformly). n_rows: spring
    rows per pad (-). n_supports: supports of the discrete models (-). deviations: supports
    of the discrete models that differ (SupportDeviation). numerics: Numerics.
    support_directions: the directions the supports act in, 'z' (vertical springs only:
    the published model, the default) or with 'y' (lateral pads, SupportParameters.kp_lat)
    and/or 'x' (longitudinal pads, kp_long), e.g. 'zyx'; lateral loads and responses need
    'y'. Written in the canonical order z, y, x.
    rails: 1 (one rail, its supports loaded as if both rails moved in phase: the published
    model) or 2 (two identical rails on the same sleepers, solved exactly as the sum of an
    in-phase and an anti-phase single-rail problem; a Point's ``rail`` picks the rail;
    vertical supports only). The sleeper (rigid or flexible) and a participating ballast
    mass are options of the support (SupportParameters.sleeper, mb, kf, eta_f;
    ``replace(sleeper='flexible')``).
    """

    name: str = "custom"
    model: str = "wfe-discrete"
    rail: RailSpec = field(default_factory=RailSpec)
    support: SupportParameters
    spacing: float = 0.6
    pad_length: float = 0.0
    n_rows: int = 1
    n_supports: int = 131
    deviations: tuple[SupportDeviation, ...] = ()
    numerics: Numerics = field(default_factory=Numerics)
    support_directions: str = "z"
    rails: int = 1

    def __post_init__(self):
        v.one_of("TrackSpec.model", self.model, MODELS)
        if isinstance(self.rails, bool) or self.rails not in (1, 2):
            raise ValueError(f"TrackSpec.rails = {self.rails!r}: give 1 or 2")
        dirs = self.support_directions
        if (not isinstance(dirs, str) or "z" not in dirs or len(set(dirs)) != len(dirs)
                or not set(dirs) <= set(SUPPORT_DIRECTIONS)):
            raise ValueError(f"TrackSpec.support_directions = {dirs!r}: give 'z' with "
                             "optionally 'y' (lateral) and 'x' (longitudinal), e.g. 'z' or "
                             "'zyx'")
        object.__setattr__(self, "support_directions",
                           "".join(d for d in SUPPORT_DIRECTIONS if d in dirs))
        if len(self.support_directions) > 1 and self.is_beam:
            raise ValueError(f"TrackSpec.support_directions = {dirs!r} with model "
                             f"{self.model!r}: the Timoshenko models are vertical beams; use "
                             "a WFE model (or railfem.track.lateral_beam for the lateral beam)")
        if not isinstance(self.support, SupportParameters):
            raise TypeError(f"TrackSpec.support must be SupportParameters, got "
                            f"{type(self.support).__name__}")
        v.track_support("TrackSpec.support", self.support)
        if self.support.case != "symmetric" and self.rails == 2:
            raise ValueError("TrackSpec.support.case must be 'symmetric' with rails = 2 (the "
                             "door solves both load cases; TrackSpec.load_case)")
        if self.rails == 2 and self.support_directions != "z":
            raise ValueError(f"TrackSpec.rails = 2 with support_directions = "
                             f"{self.support_directions!r}: the two-rail track is vertical; "
                             "use support_directions = 'z'")
        v.positive("TrackSpec.spacing", self.spacing, "m", "the sleeper spacing, e.g. 0.6")
        v.non_negative("TrackSpec.pad_length", self.pad_length, "m", "0 for point supports")
        if self.pad_length >= self.spacing:
            raise ValueError(
                f"TrackSpec.pad_length = {self.pad_length!r} m is not shorter than the "
                f"sleeper spacing {self.spacing!r} m: neighbouring pads would overlap; give "
                "the pad length in m (typically 0.1-0.2)")
        if self.pad_length > 0 and self.kind.is_continuous:
            raise ValueError(
                f"TrackSpec.pad_length = {self.pad_length!r} m with model {self.model!r}: a "
                "continuous support is already spread along the rail; use pad_length = 0 or "
                "a discrete/periodic model")
        for name in ("n_rows", "n_supports"):
            val = getattr(self, name)
            if isinstance(val, bool) or int(val) != val or val < 1:
                raise ValueError(f"TrackSpec.{name} = {val!r}: give an integer >= 1")
        if self.n_rows > 1 and self.pad_length == 0:
            raise ValueError(f"TrackSpec.n_rows = {self.n_rows} needs pad_length > 0 m (or "
                             "n_rows = 1 for point supports)")
        object.__setattr__(self, "deviations", tuple(self.deviations))
        if self.deviations and not self.kind.is_discrete:
            raise ValueError(f"TrackSpec.deviations need a discrete model; {self.model!r} "
                             "has identical supports")
        half = (self.n_supports - 1) // 2
        seen = set()
        for d in self.deviations:
            if not isinstance(d, SupportDeviation):
                raise TypeError(f"TrackSpec.deviations holds {type(d).__name__}, expected "
                                "SupportDeviation")
            if not -half <= d.index <= self.n_supports - 1 - half or d.index in seen:
                raise ValueError(f"TrackSpec.deviations: support index {d.index} is repeated "
                                 f"or outside the {self.n_supports} supports "
                                 f"({-half}..{self.n_supports - 1 - half})")
            seen.add(d.index)

    @property
    def kind(self) -> ModelKind:
        """The model kind (MODEL_KINDS[model]): its rail and its supports."""
        return MODEL_KINDS[self.model]

    @property
    def is_wfe(self) -> bool:
        """The rail is the WFE section (model wfe-*)."""
        return self.kind.is_wfe

    @property
    def is_beam(self) -> bool:
        """The rail is the Timoshenko beam (model timoshenko-*)."""
        return self.kind.is_beam

    @property
    def uniform(self) -> bool:
        """True when every support is the same (no deviations)."""
        return not self.deviations

    def load_case(self, case: str) -> "TrackSpec":
        """The single-rail track of one load case of this two-rail track: 'symmetric'
        (rails in phase) or 'antisymmetric' (anti-phase), its supports (and deviations) on
        the sleeper in that case (railfem.track.sleeper)."""
        v.one_of("case", case, LOAD_CASES)
        sleeper, case = load_case(self.support.sleeper, case)
        return replace(self, rails=1, support=replace(self.support, sleeper=sleeper, case=case))

    def layout(self) -> SupportLayout:
        """The discrete supports: n_supports at x = n * spacing around x = 0, deviations
        applied."""
        lay = uniform_layout(self.support, self.spacing, self.n_supports,
                             pad_length=self.pad_length, n_rows=self.n_rows)
        if not self.deviations:
            return lay
        params = list(lay.params)
        centre = (self.n_supports - 1) // 2
        for d in self.deviations:
            params[centre + d.index] = d.apply(self.support)
        return replace(lay, params=tuple(params))

    def replace(self, **changes) -> "TrackSpec":
        """A copy with fields changed; also takes the support parameters kp, eta_p, ms, kb,
        eta_b and the horizontal ones (kp_lat, ..., directions.HORIZONTAL_FIELDS) in SI, and
        eta_r (the rail loss factor)."""
        sup = {k: changes.pop(k) for k in ("kp", "eta_p", "ms", "kb", "eta_b")
               + HORIZONTAL_FIELDS + GRIP_FIELDS + BALLAST_FIELDS if k in changes}
        if "sleeper" in changes:
            sup["sleeper"] = sleeper_option(changes.pop("sleeper"))
        if sup:
            changes["support"] = replace(changes.get("support", self.support), **sup)
        if "eta_r" in changes:
            changes["rail"] = replace(changes.get("rail", self.rail), eta=changes.pop("eta_r"))
        if changes.get("pad_length", None) == 0 and "n_rows" not in changes:
            changes["n_rows"] = 1  # point supports have one row
        if (_names_continuous(changes.get("model")) and "pad_length" not in changes
                and self.pad_length > 0):
            # a continuous foundation spreads every support along the rail: a pad length
            # means nothing there, so switching model drops it (state it in a log line)
            log.info("TrackSpec.replace: model %s has no pad geometry; pad_length %g m and "
                     "n_rows %d dropped", changes["model"], self.pad_length, self.n_rows)
            changes.update(pad_length=0.0, n_rows=1)
        return replace(self, **changes)


#: The participating ballast mass of SupportParameters (TrackSpec.replace takes them too).
BALLAST_FIELDS = ("mb", "kf", "eta_f")


def sleeper_option(value) -> Sleeper | None:
    """The support's sleeper from a TrackSpec.replace value: 'rigid' or None (the rigid
    sleeper mass ms: the published model), 'flexible' (the default B90-type Timoshenko
    sleeper, railfem.track.sleeper.B90) or a Sleeper."""
    if value is None or value == "rigid":
        return None
    if value == "flexible":
        return Sleeper()
    if not isinstance(value, Sleeper):
        raise ValueError(f"sleeper = {value!r}: give 'rigid', 'flexible' or a "
                         "railfem.track.sleeper.Sleeper")
    return value


def preset(name: str, **changes) -> TrackSpec:
    """The Table 1 track ``name`` (railfem.track.supports.PRESETS) as a spec, with ``changes``
    applied as in TrackSpec.replace (e.g. model='wfe-periodic', kp=300e6).

    Discrete and periodic models get a pad of DEFAULT_PAD_LENGTH (0.15 m) in
    DEFAULT_PAD_ROWS (3) rows unless ``pad_length`` is given: the rail-on-pad resonance of a
    point-like support does not converge with the section mesh (a line load on a solid), a
    pad of real length does (docs/model.md, railfem support-convergence). pad_length=0
    gives the published point supports."""
    key = preset_key(name)
    model = changes.get("model", "wfe-discrete")
    pad = {} if _names_continuous(model) else {"pad_length": DEFAULT_PAD_LENGTH,
                                               "n_rows": DEFAULT_PAD_ROWS}
    if "pad_length" in changes:
        pad = {}
    spec = TrackSpec(name=key, support=PRESETS[key], spacing=DEFAULT_SPACING,
                     rail=RailSpec(eta=RAIL_LOSS_FACTORS[key]), **pad)
    return spec.replace(**changes) if changes else spec


# --------------------------------------------------------------------- dict / TOML form

UNITS = {
    "stiffness": {"N/m": 1.0, "kN/m": 1e3, "MN/m": 1e6, "GN/m": 1e9},
    "mass": {"kg": 1.0, "t": 1e3},
    "length": {"m": 1.0, "cm": 1e-2, "mm": 1e-3},
    "pressure": {"Pa": 1.0, "MPa": 1e6, "GPa": 1e9},
    "density": {"kg/m^3": 1.0, "kg/m3": 1.0},
}

#: section -> key -> quantity kind (UNITS), 'number', 'int', 'bool' or 'str'
SCHEMA = {
    "": {"preset": "str", "name": "str", "model": "str"},
    "support": {"kp": "stiffness", "eta_p": "number", "ms": "mass", "kb": "stiffness",
                "eta_b": "number", "kp_lat": "stiffness", "eta_p_lat": "number",
                "kp_long": "stiffness", "eta_p_long": "number", "kb_lat": "stiffness",
                "eta_b_lat": "number", "ms_lat": "mass", "mb": "mass", "kf": "stiffness",
                "eta_f": "number", "k_roll": "number", "eta_roll": "number",
                "k_clip": "stiffness", "eta_clip": "number", "seat": "str"},
    "track": {"spacing": "length", "pad_length": "length", "n_rows": "int",
              "n_supports": "int", "support_directions": "str", "rails": "int"},
    "sleeper": {"model": "str", "length": "length", "seat_distance": "length",
                "EI": "number", "kGA": "number", "mass_per_length": "number",
                "rotary_inertia": "number", "eta": "number", "n_elements": "int"},
    "rail": {"profile": "str", "h": "length", "mesh_file": "str", "E": "pressure",
             "nu": "number", "rho": "density", "eta": "number", "beam_constants": "str"},
    "numerics": {"n_foot_springs": "int", "foot_rule": "str", "n_waves": "int", "tail": "bool",
                 "n_theta": "int", "load_length": "length", "patch_width": "length"},
    "deviation": {"index": "int", "kp": "number", "eta_p": "number", "ms": "number",
                  "kb": "number", "eta_b": "number"},
}


def parse_value(key: str, value, kind: str):
    """A config value as SI: numbers as given, strings 'NUMBER UNIT' converted with UNITS."""
    if kind == "str":
        if not isinstance(value, str):
            raise ValueError(f"{key} = {value!r}: give a string")
        return value
    if kind == "bool":
        if not isinstance(value, bool):
            raise ValueError(f"{key} = {value!r}: give true or false")
        return value
    if kind == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"{key} = {value!r}: give an integer")
        return value
    if isinstance(value, str) and kind in UNITS:
        parts = value.split()
        if len(parts) != 2:
            raise ValueError(f"{key} = {value!r}: write a number and a unit, e.g. "
                             f"'{1} {next(iter(UNITS[kind]))}'")
        number, unit = parts
        if unit not in UNITS[kind]:
            raise ValueError(f"{key} = {value!r}: unknown unit {unit!r} for a {kind}; use one "
                             f"of {', '.join(UNITS[kind])}")
        try:
            x = float(number)
        except ValueError:
            raise ValueError(f"{key} = {value!r}: {number!r} is not a number") from None
        return x * UNITS[kind][unit]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        unit = f" ({next(iter(UNITS[kind]))} if a plain number)" if kind in UNITS else ""
        raise ValueError(f"{key} = {value!r}: give a number{unit}")
    return float(value)


def _section(prefix: str, table, kinds: dict, tables=()) -> dict:
    if not isinstance(table, dict):
        raise ValueError(f"{prefix} must be a table of keys, got {table!r}")
    out = {}
    for key, value in table.items():
        name = f"{prefix}.{key}" if prefix else key
        if key not in kinds:
            also = f"; valid tables: {', '.join(tables)}" if tables else ""
            raise ValueError(f"unknown key {name!r}; valid keys: {', '.join(kinds)}{also}")
        out[key] = parse_value(name, value, kinds[key])
    return out


def spec_from_dict(d: dict, base: TrackSpec | None = None) -> TrackSpec:
    """A TrackSpec from the dict/TOML form (see SCHEMA), on top of ``base`` or of the
    ``preset`` it names (default: the site preset). Errors name the offending key."""
    if not isinstance(d, dict):
        raise ValueError(f"a track spec must be a table of keys, got {type(d).__name__}")
    sections = {k for k in SCHEMA if k} | {"deviations"}
    top = {k: x for k, x in d.items() if k not in sections}
    top = _section("", top, SCHEMA[""], tables=[f"[{k}]" for k in SCHEMA if k and k != "deviation"]
                   + ["[[deviations]]"])
    if "preset" in top:
        if top["preset"] not in PRESETS:
            raise ValueError(f"preset = {top['preset']!r} is unknown; use one of "
                             f"{', '.join(PRESETS)}")
        base = preset(top.pop("preset"))
    spec = base or preset("site")
    sup = _section("support", d.get("support", {}), SCHEMA["support"])
    trk = _section("track", d.get("track", {}), SCHEMA["track"])
    rail = _section("rail", d.get("rail", {}), SCHEMA["rail"])
    num = _section("numerics", d.get("numerics", {}), SCHEMA["numerics"])
    slp = _section("sleeper", d.get("sleeper", {}), SCHEMA["sleeper"])
    if slp:  # on top of the base's sleeper, or of the default flexible one
        base_sleeper = spec.support.sleeper or Sleeper()
        sup["sleeper"] = _named("sleeper", lambda: replace(base_sleeper, **slp))
    devs = d.get("deviations", None)
    changes = dict(top, **trk)
    for name, values, obj in (("support", sup, spec.support), ("rail", rail, spec.rail),
                              ("numerics", num, spec.numerics)):
        if values:
            changes[name] = _named(name, lambda: replace(obj, **values))
    if devs is not None:
        if not isinstance(devs, list):
            raise ValueError("deviations must be a list of tables ([[deviations]] in TOML)")
        changes["deviations"] = tuple(
            _named(f"deviations[{j}]", lambda t=t, j=j: SupportDeviation(
                **_section(f"deviations[{j}]", t, SCHEMA["deviation"])))
            for j, t in enumerate(devs))
    return _named("track", lambda: spec.replace(**changes))


def _named(section: str, build):
    """build(), with the config section named in a validation error."""
    try:
        return build()
    except (ValueError, TypeError) as exc:
        msg = str(exc)
        raise ValueError(msg if msg.startswith(f"{section}.") else f"[{section}] {msg}") from None


def spec_to_dict(spec: TrackSpec) -> dict:
    """The dict form of a spec with every value (SI numbers): spec_from_dict inverts it."""
    rail = asdict(spec.rail)
    if rail["mesh_file"] is None:
        del rail["mesh_file"]
    return {
        "name": spec.name, "model": spec.model,
        "support": support_to_dict(spec.support),
        "track": {"spacing": spec.spacing, "pad_length": spec.pad_length,
                  "n_rows": spec.n_rows, "n_supports": spec.n_supports,
                  "support_directions": spec.support_directions, "rails": spec.rails},
        "rail": rail, "numerics": asdict(spec.numerics),
        "deviations": [asdict(d) for d in spec.deviations],
    } | ({} if spec.support.sleeper is None else {"sleeper": asdict(spec.support.sleeper)})


def support_to_dict(p: SupportParameters) -> dict:
    """The support's numbers (SI); the diagnosis hooks (pad_laws, absorber) only when set,
    as {'law': class name, field: value} tables (spec_from_dict does not read them back)."""
    out = {f.name: getattr(p, f.name) for f in fields(p)
           if f.name not in ("pad_laws", "absorber", "sleeper", "case")}
    if p.pad_laws:
        out["pad_laws"] = [{"law": type(law).__name__, **asdict(law)} for law in p.pad_laws]
    if p.absorber is not None:
        out["absorber"] = {"law": type(p.absorber).__name__, **asdict(p.absorber)}
    return out
