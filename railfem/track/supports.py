"""Rail supports: pad, sleeper and ballast, continuous and per-support discrete layouts.

METHOD.md section 2. One support per fastener: rail pad ``kp* = kp (1 + i eta_p)`` on top of
the sleeper mass ``ms`` (per rail) on the ballast ``kb* = kb (1 + i eta_b)``. Seen from the
rail (sleeper base fixed) the support's dynamic stiffness is

    K_s(omega) = kp* (kb* - omega^2 ms) / (kp* + kb* - omega^2 ms)

i.e. the pad in series with the sleeper/ballast dynamic stiffness ``kb* - omega^2 ms``.
Its mobility is ``Y_s = i omega / K_s`` and its receptance ``1 / K_s``.

Conventions (railfem.conventions): exp(+i omega t); frequency is axis 0 of every
frequency-dependent array; SI units throughout (N/m, kg, m, rad/s).
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace

import numpy as np

from .directions import (GRIP_SCALED, HORIZONTAL_LOSS, HORIZONTAL_SCALED, HORIZONTAL_STIFFNESS,
                         directional_stiffness)
from .sleeper import CASES as LOAD_CASES, Sleeper, seat_stiffness

log = logging.getLogger(__name__)

DEFAULT_SPACING = 0.6  # m, sleeper spacing of METHOD.md Table 1
DEFAULT_SLEEPER_MASS = 120.0  # kg per rail, METHOD.md section 2
#: How the foot springs meet the sleeper (SupportParameters.seat; docs/supports.md).
SEATS = ("rigid", "per_spring")


def _check_stiffness(name: str, value: float) -> None:
    # Stiffness may be 0 (a missing / voided element) or +inf (rigid), never NaN or negative.
    if isinstance(value, complex) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise TypeError(
            f"SupportParameters.{name} must be a real number in N/m, got {value!r} "
            f"(give the loss factor separately in eta_*)")
    if math.isnan(value) or value < 0:
        raise ValueError(
            f"SupportParameters.{name} = {value!r} N/m is not allowed: use a stiffness >= 0 "
            f"(0 for a missing/voided element, float('inf') for a rigid one)")


def _check_loss_factor(name: str, value: float) -> None:
    if not np.isfinite(value) or value < 0:
        raise ValueError(
            f"SupportParameters.{name} = {value!r} is not allowed: use a finite loss factor "
            f">= 0 (a negative loss factor creates energy)")


# ---------------------------------------------------------------------------------------------
# Hooks for what the plain chain lacks (used by railfem.diagnosis.effects; default: none)


@dataclass(frozen=True, kw_only=True)
class FractionalZener:
    """Frequency-dependent pad stiffness: a fractional standard linear solid (Zener) law

        kp*(omega) = kp (1 + i eta_p) (1 + ratio (i omega / omega_c)^alpha)
                                     / (1 + (i omega / omega_c)^alpha)

    kp is then the static (low-frequency) stiffness and ratio * kp the high-frequency one;
    the law adds its own loss, largest near omega_c. ratio: k_inf / k_0 (-), >= 1.
    fc: omega_c / (2 pi) (Hz), > 0. alpha: fractional order (-), 0 < alpha <= 1
    (1 = the classical standard linear solid). Relative, so a support split into springs
    keeps it unchanged."""

    ratio: float
    fc: float
    alpha: float = 0.5

    def __post_init__(self):
        if not (np.isfinite(self.ratio) and self.ratio >= 1):
            raise ValueError(f"FractionalZener.ratio = {self.ratio!r}: give k_inf / k_0 >= 1")
        if not (np.isfinite(self.fc) and self.fc > 0):
            raise ValueError(f"FractionalZener.fc = {self.fc!r} Hz: give a transition "
                             "frequency > 0 Hz")
        if not (np.isfinite(self.alpha) and 0 < self.alpha <= 1):
            raise ValueError(f"FractionalZener.alpha = {self.alpha!r}: give 0 < alpha <= 1")

    def stiffness(self, kp_star: complex, omega: np.ndarray) -> np.ndarray:
        s = (1j * np.asarray(omega, dtype=float) / (2 * np.pi * self.fc)) ** self.alpha
        return kp_star * (1 + self.ratio * s) / (1 + s)


@dataclass(frozen=True, kw_only=True)
class FootDashpot:
    """Viscous dissipation at the rail foot / fastening, in parallel with the pad:

        kp*(omega) -> kp*(omega) + i Re(kp*(omega)) eta_1k (f / 1 kHz)

    i.e. a dashpot c = kp eta_1k / (2 pi 1000 Hz) (N s/m) for a frequency-independent pad;
    eta_1k is the loss factor it adds to the pad at 1 kHz (-), >= 0. Relative to kp, so
    splitting a support keeps it."""

    eta_1k: float

    def __post_init__(self):
        if not (np.isfinite(self.eta_1k) and self.eta_1k >= 0):
            raise ValueError(f"FootDashpot.eta_1k = {self.eta_1k!r}: give a loss factor >= 0")

    def stiffness(self, kp_star: complex, omega: np.ndarray) -> np.ndarray:
        return kp_star + 1j * np.real(kp_star) * self.eta_1k * np.asarray(omega) / (2e3 * np.pi)


@dataclass(frozen=True, kw_only=True)
class RailAbsorber:
    """A tuned mass-spring-damper on the rail at each support (a rail damper; modelled at
    the support's footprint, in parallel with the support, not at mid-span):

        K_a(omega) = -omega^2 m k_a* / (k_a* - omega^2 m),  k_a* = m (2 pi f_a)^2 (1 + i eta)

    mass: absorber mass per support (kg) > 0; fa: tuning frequency (Hz) > 0; eta: loss
    factor of its elastic layer (-) >= 0."""

    mass: float
    fa: float
    eta: float = 0.3

    def __post_init__(self):
        for name in ("mass", "fa"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise ValueError(f"RailAbsorber.{name} = {getattr(self, name)!r}: give a "
                                 f"value > 0 ({'kg' if name == 'mass' else 'Hz'})")
        if not (np.isfinite(self.eta) and self.eta >= 0):
            raise ValueError(f"RailAbsorber.eta = {self.eta!r}: give a loss factor >= 0")

    def stiffness(self, omega: np.ndarray) -> np.ndarray:
        w = np.asarray(omega, dtype=float)
        ka = self.mass * (2 * np.pi * self.fa) ** 2 * (1 + 1j * self.eta)
        return -w ** 2 * self.mass * ka / (ka - w ** 2 * self.mass)


@dataclass(frozen=True, kw_only=True)
class SupportParameters:
    """Parameters of one support (one fastener, one rail).

    kp: rail pad stiffness per fastener (N/m); 0 = no pad contact, inf = rigid pad.
    eta_p: rail pad loss factor (-), kp* = kp (1 + i eta_p).
    ms: sleeper mass per rail (kg); 0 is allowed (pad and ballast springs in series).
    kb: ballast stiffness per fastener and rail (N/m); 0 = voided (hanging) sleeper,
        inf = rigid ballast (the sleeper then does not move).
    eta_b: ballast loss factor (-), kb* = kb (1 + i eta_b).
    pad_laws: frequency-dependent pad terms applied in turn to kp* (FractionalZener,
        FootDashpot); default none (the frequency-independent pad of METHOD.md section 2).
    absorber: a RailAbsorber acting in parallel with the support, or None.

    Horizontal chains (used where the track's ``support_directions`` include y or x;
    railfem.spec.TrackSpec): the same pad - sleeper - ballast series in each direction,
    railfem.track.directions.
    kp_lat, eta_p_lat: lateral (y) pad stiffness per fastener (N/m) and loss factor (-);
        0 = no lateral restraint by the pad (the default: a vertical-only support).
    kp_long, eta_p_long: longitudinal (x) pad stiffness per fastener (N/m), loss factor.
    kb_lat, eta_b_lat: horizontal stiffness of the sleeper in the ballast per rail (N/m)
        and its loss factor, used laterally and longitudinally; inf (default) = the sleeper
        does not move horizontally.
    ms_lat: sleeper mass per rail moving horizontally with the rail (kg).

    The fastening's grip (defaults 0: the pad alone, as published):
    k_roll, eta_roll: roll (rotational, about the rail axis) stiffness of the fastening on
        the rail foot per support (N m/rad) and its loss factor, beyond the roll stiffness
        that the vertical pad springs across the foot give; it acts on the foot's roll
        theta = sum w_j y_j u_z,j / sum w_j y_j^2 over the foot springs (a generalised
        spring, direction 'r'). The sleeper is taken as rigid in rotation about the rail
        axis (its rocking on the ballast is much stiffer: assumed).
    k_clip, eta_clip: lateral stiffness of the clips on the foot per support (N/m) and its
        loss factor, in parallel with the lateral pad kp_lat and in series with the same
        lateral sleeper-ballast chain (ms_lat, kb_lat).

    Real track (railfem.track.sleeper; defaults: the published chain above).
    mb: participating ballast mass per rail (kg) between the ballast spring kb* and the
        subgrade spring kf* = kf (1 + i eta_f); 0 (default) = no ballast mass.
    kf: subgrade stiffness per rail (N/m); inf (default) = rigid subgrade. eta_f: its loss
        factor (-).
    sleeper: a sleeper.Sleeper carrying both rails (flexible beam, or rigid with its
        length and rail seats), or None (default): the rigid mass ms, rails in phase.
    case: the load case of a two-rail track this support stands for, 'symmetric' (rails
        in phase, the single-rail model; default) or 'antisymmetric' (needs a sleeper).

    seat: how the vertical pad springs across the foot meet the sleeper (docs/supports.md).
        'rigid' (default): they act between the rail foot and one rail seat that moves as
        the sleeper does; on the rigid sleeper of a symmetric track the seat translates but
        does not turn about the rail axis, so against the foot's roll the pad acts alone
        (its roll stiffness kp* sum w_j y_j^2, kp* W^2 / 12 for a uniform pad of width W),
        while the vertical translation sees the whole pad - sleeper - ballast chain.
        'per_spring': each spring is its own pad - sleeper - ballast chain carrying its
        share of the sleeper mass (METHOD.md section 2 as published): the seat then rolls
        with the foot against the shares' rotational inertia ms W^2 / 12 only, a mass-like
        roll restraint above the sleeper-ballast resonance. Vertical loads on the rail's
        mirror plane do not excite the roll: their results are the same for both.
    """

    kp: float
    eta_p: float = 0.0
    ms: float = DEFAULT_SLEEPER_MASS
    kb: float
    eta_b: float = 0.0
    pad_laws: tuple = ()
    absorber: RailAbsorber | None = None
    kp_lat: float = 0.0
    eta_p_lat: float = 0.0
    kp_long: float = 0.0
    eta_p_long: float = 0.0
    kb_lat: float = math.inf
    eta_b_lat: float = 0.0
    ms_lat: float = DEFAULT_SLEEPER_MASS
    mb: float = 0.0
    kf: float = math.inf
    eta_f: float = 0.0
    sleeper: Sleeper | None = None
    case: str = "symmetric"
    k_roll: float = 0.0
    eta_roll: float = 0.0
    k_clip: float = 0.0
    eta_clip: float = 0.0
    seat: str = "rigid"

    def __post_init__(self):
        if self.seat not in SEATS:
            raise ValueError(f"SupportParameters.seat = {self.seat!r}: use one of "
                             f"{', '.join(repr(x) for x in SEATS)}")
        _check_stiffness("kf", self.kf)
        _check_loss_factor("eta_f", self.eta_f)
        if not np.isfinite(self.mb) or self.mb < 0:
            raise ValueError(f"SupportParameters.mb = {self.mb!r} kg: give a finite ballast "
                             "mass >= 0 kg per rail (0 = no participating ballast mass)")
        if self.sleeper is not None and not isinstance(self.sleeper, Sleeper):
            raise TypeError("SupportParameters.sleeper must be a railfem.track.sleeper."
                            f"Sleeper or None, got {type(self.sleeper).__name__}")
        if self.case not in LOAD_CASES or (self.case != "symmetric" and self.sleeper is None):
            raise ValueError(f"SupportParameters.case = {self.case!r}: use 'symmetric', or "
                             "'antisymmetric' with a sleeper (sleeper.load_case)")
        _check_stiffness("kp", self.kp)
        _check_stiffness("kb", self.kb)
        _check_loss_factor("eta_p", self.eta_p)
        _check_loss_factor("eta_b", self.eta_b)
        for name in HORIZONTAL_STIFFNESS + ("k_roll", "k_clip"):
            _check_stiffness(name, getattr(self, name))
        for name in ("eta_roll", "eta_clip"):
            _check_loss_factor(name, getattr(self, name))
        for name in HORIZONTAL_LOSS:
            _check_loss_factor(name, getattr(self, name))
        if not np.isfinite(self.ms_lat) or self.ms_lat < 0:
            raise ValueError(
                f"SupportParameters.ms_lat = {self.ms_lat!r} kg is not allowed: use a finite "
                f"sleeper mass >= 0 kg per rail")
        if not np.isfinite(self.ms) or self.ms < 0:
            raise ValueError(
                f"SupportParameters.ms = {self.ms!r} kg is not allowed: use a finite sleeper "
                f"mass >= 0 kg per rail (0 puts pad and ballast directly in series)")
        object.__setattr__(self, "pad_laws", tuple(self.pad_laws))
        for law in self.pad_laws:
            if not isinstance(law, (FractionalZener, FootDashpot)):
                raise TypeError(f"SupportParameters.pad_laws holds {type(law).__name__}; use "
                                "FractionalZener or FootDashpot")
        if self.absorber is not None and not isinstance(self.absorber, RailAbsorber):
            raise TypeError(f"SupportParameters.absorber must be a RailAbsorber or None, got "
                            f"{type(self.absorber).__name__}")
        if self.kp == 0 and self.kb == 0 and self.ms == 0:
            log.debug("SupportParameters with kp = kb = ms = 0 is an absent support")

    @property
    def kp_complex(self) -> complex:
        """kp (1 + i eta_p) in N/m (inf if the pad is rigid)."""
        return _complex_stiffness(self.kp, self.eta_p)

    @property
    def kb_complex(self) -> complex:
        """kb (1 + i eta_b) in N/m (inf if the ballast is rigid)."""
        return _complex_stiffness(self.kb, self.eta_b)

    def scaled(self, weight: float) -> "SupportParameters":
        """The same chain scaled by ``weight`` (kp, ms, kb all times weight): K_s scales too."""
        if not np.isfinite(weight) or weight < 0:
            raise ValueError(f"support weight must be finite and >= 0, got {weight!r}")
        def scale(k):  # 0 * inf is an absent element, not NaN
            return 0.0 if weight == 0 else k * weight
        absorber = self.absorber
        if absorber is not None:  # the pad laws are relative to kp; the absorber's mass is not
            absorber = None if weight == 0 else replace(absorber, mass=absorber.mass * weight)
        sleeper = self.sleeper  # a flexible sleeper's receptance / weight, as the chain's
        if sleeper is not None and sleeper.model == "flexible" and weight > 0:
            sleeper = sleeper.scaled(weight)
        return replace(self, kp=scale(self.kp), ms=scale(self.ms), kb=scale(self.kb),
                       absorber=absorber, mb=scale(self.mb), kf=scale(self.kf),
                       sleeper=sleeper,
                       **{n: scale(getattr(self, n)) for n in HORIZONTAL_SCALED + GRIP_SCALED})


def _complex_stiffness(k: float, eta: float) -> complex:
    # inf * (1 + i eta) would give inf + inf j (or nan j for eta = 0): keep a rigid element real.
    return complex(math.inf) if math.isinf(k) else k * (1 + 1j * eta)


def _as_omega(omega) -> np.ndarray:
    w = np.asarray(omega, dtype=float)
    if np.any(~np.isfinite(w)) or np.any(w < 0):
        raise ValueError("omega must be finite and >= 0 rad/s (angular frequency, not Hz)")
    return w


def dynamic_stiffness(params: SupportParameters, omega) -> np.ndarray:
    """Dynamic stiffness K_s(omega) of one support seen from the rail (N/m, complex).

    K_s = kp* (kb* - omega^2 ms) / (kp* + kb* - omega^2 ms). Vectorised: the result has the
    shape of ``omega`` (frequency on axis 0). Limits handled exactly:
    rigid ballast (kb = inf) gives kp*; rigid pad (kp = inf) gives kb* - omega^2 ms; both
    rigid gives inf; kp = 0 gives 0; an undamped two-spring antiresonance
    (kp + kb = omega^2 ms) gives inf.
    """
    w = _as_omega(omega)
    out = _chain_stiffness(params, w)
    if params.absorber is not None:  # in parallel with the chain
        out = out + params.absorber.stiffness(w)
    return out


def _chain_stiffness(params: SupportParameters, w: np.ndarray) -> np.ndarray:
    kp = params.kp_complex
    if math.isinf(params.kp) and math.isinf(params.kb):
        return np.full(w.shape, complex(math.inf))
    if not math.isinf(params.kp):
        for law in params.pad_laws:  # frequency-dependent pad (hooks above), kp stays finite
            kp = law.stiffness(kp, w)
    kp = np.broadcast_to(np.asarray(kp, dtype=complex), w.shape)
    if math.isinf(params.kb) and math.isinf(params.kf):
        return np.array(kp, dtype=complex)
    z = seat_stiffness(params, w)  # sleeper on ballast: kb* - omega^2 ms by default
    if math.isinf(params.kp):
        return z
    num = np.asarray(kp * z)
    den = np.asarray(kp + z)
    out = np.empty(w.shape, dtype=complex)
    zero_den = den == 0
    # den = 0 with num != 0 is the undamped pole of K_s; num = den = 0 only if kp = 0.
    out[zero_den] = np.where(num[zero_den] == 0, 0.0, complex(math.inf))
    out[~zero_den] = num[~zero_den] / den[~zero_den]
    return out


def support_receptance(params: SupportParameters, omega) -> np.ndarray:
    """Receptance 1 / K_s of one support (m/N); mobility is 1j * omega * receptance."""
    k = dynamic_stiffness(params, omega)
    out = np.zeros(k.shape, dtype=complex)  # a rigid support (K_s = inf) does not deflect
    regular = np.isfinite(k) & (k != 0)
    out[regular] = 1.0 / k[regular]
    out[k == 0] = complex(math.inf)
    return out


def continuous_stiffness(params: SupportParameters, omega, spacing: float = DEFAULT_SPACING):
    """Support stiffness per unit length of rail, K_s(omega) / spacing (N/m^2, complex)."""
    if not np.isfinite(spacing) or spacing <= 0:
        raise ValueError(f"spacing = {spacing!r} m is not allowed: give the sleeper spacing > 0 m")
    return dynamic_stiffness(params, omega) / spacing


# ---------------------------------------------------------------------------------------------
# Table 1 presets


#: Horizontal support of the presets relative to their vertical values (docs/presets.md
#: gives the sources and what is assumed): lateral and longitudinal pad stiffness a
#: seventh of the vertical (the middle of the 1/5-1/10 range quoted for rail fasteners,
#: Thompson, Railway Noise and Vibration, 2009, ch. 3), with the vertical pad's loss
#: factor; the sleeper's horizontal ballast support half the vertical ballast stiffness
#: with its loss factor; the per-rail sleeper mass moves laterally with the rail.
HORIZONTAL_RATIOS = {"pad": 1 / 7, "ballast": 1 / 2}


def horizontal_support(kp: float, eta_p: float, kb: float, eta_b: float,
                       ms: float = DEFAULT_SLEEPER_MASS) -> dict:
    """The preset rule for the horizontal fields from the vertical ones (HORIZONTAL_RATIOS)."""
    r = HORIZONTAL_RATIOS
    return dict(kp_lat=kp * r["pad"], eta_p_lat=eta_p, kp_long=kp * r["pad"],
                eta_p_long=eta_p, kb_lat=kb * r["ballast"], eta_b_lat=eta_b, ms_lat=ms)


#: METHOD.md Table 1: name -> (kp MN/m, eta_p, kb MN/m, eta_b, eta_r, description); kp and
#: kb per fastener and rail, eta_r the rail loss factor. railfem.spec.preset(name) is the
#: track (a TrackSpec) made of these numbers, the sleeper spacing DEFAULT_SPACING and the
#: sleeper mass DEFAULT_SLEEPER_MASS.
TABLE1 = {
    "stiff": (600, 0.05, 48, 2.0, 0.05, "stiff pads"),
    "medium": (300, 0.10, 90, 1.5, 0.04, "medium pads"),
    "soft": (120, 0.15, 120, 1.0, 0.03, "soft pads"),
    "very_soft": (60, 0.20, 360, 0.5, 0.02, "very soft pads"),
    "site": (600, 0.25, 42, 1.0, 0.01, "site, estimated, unloaded"),
}


def _table1_support(kp_mn, eta_p, kb_mn, eta_b) -> SupportParameters:
    kp, kb = kp_mn * 1e6, kb_mn * 1e6
    return SupportParameters(kp=kp, eta_p=eta_p, ms=DEFAULT_SLEEPER_MASS, kb=kb, eta_b=eta_b,
                             **horizontal_support(kp, eta_p, kb, eta_b))


#: The supports of the Table 1 tracks (name -> SupportParameters per fastener and rail).
PRESETS: dict[str, SupportParameters] = {
    name: _table1_support(*row[:4]) for name, row in TABLE1.items()}
#: The rail loss factors of the Table 1 tracks (name -> eta_r).
RAIL_LOSS_FACTORS: dict[str, float] = {name: row[4] for name, row in TABLE1.items()}


def preset_key(name: str) -> str:
    """The key in PRESETS of a Table 1 track ``name`` ('very soft' and 'very-soft' also
    work); KeyError naming the valid ones otherwise."""
    key = str(name).strip().lower().replace(" ", "_").replace("-", "_")
    if key not in PRESETS:
        raise KeyError(
            f"unknown track preset {name!r}; valid names: {', '.join(PRESETS)}")
    return key


# ---------------------------------------------------------------------------------------------
# Discrete layouts


@dataclass(frozen=True)
class SpringSet:
    """The point springs a layout puts on the rail.

    x: spring positions along the rail (m). weight: fraction of its support each spring
    carries (-), summing to 1 per support. support_index: which support each spring belongs to.
    """

    x: np.ndarray
    weight: np.ndarray
    support_index: np.ndarray


@dataclass(frozen=True, kw_only=True)
class SupportLayout:
    """Discrete supports along the rail; each support may differ (inhomogeneous track).

    positions: support centre positions x_j along the rail (m), a tuple of floats.
    params: one SupportParameters per support (same length as positions).
    pad_length: length of rail over which each support is spread (m); 0 = point support.
    n_rows: number of spring rows per support along the rail (-). Rows sit at the midpoints of
        n_rows equal slices of the pad length, each carrying 1/n_rows of the support (the pad
        chain scaled by 1/n_rows, so the rows are independent).
    """

    positions: tuple[float, ...]
    params: tuple[SupportParameters, ...]
    pad_length: float = 0.0
    n_rows: int = 1

    def __post_init__(self):
        # Accept any sequences but store tuples so the dataclass stays immutable and hashable.
        object.__setattr__(self, "positions", tuple(float(x) for x in self.positions))
        object.__setattr__(self, "params", tuple(self.params))
        if len(self.positions) == 0:
            raise ValueError("SupportLayout needs at least one support position")
        if len(self.positions) != len(self.params):
            raise ValueError(
                f"SupportLayout has {len(self.positions)} positions but {len(self.params)} "
                f"params: give one SupportParameters per support")
        if not all(np.isfinite(self.positions)):
            raise ValueError("SupportLayout.positions must all be finite (m)")
        for j, p in enumerate(self.params):
            if not isinstance(p, SupportParameters):
                raise TypeError(f"SupportLayout.params[{j}] is {type(p).__name__}, "
                                f"expected SupportParameters")
        if not np.isfinite(self.pad_length) or self.pad_length < 0:
            raise ValueError(f"SupportLayout.pad_length = {self.pad_length!r} m: use >= 0 m")
        if int(self.n_rows) != self.n_rows or self.n_rows < 1:
            raise ValueError(f"SupportLayout.n_rows = {self.n_rows!r}: use an integer >= 1")
        if self.n_rows > 1 and self.pad_length == 0:
            raise ValueError(
                f"SupportLayout.n_rows = {self.n_rows} needs pad_length > 0 m "
                f"(or set n_rows = 1 for point supports)")

    def __len__(self) -> int:
        return len(self.positions)

    @property
    def x(self) -> np.ndarray:
        """Support centre positions as an array (m)."""
        return np.asarray(self.positions)

    @property
    def row_length(self) -> float:
        """Length of rail over which each spring row spreads its force (m): its slice of the
        pad length (0 for point supports)."""
        return self.pad_length / self.n_rows if self.pad_length > 0 else 0.0

    def row_offsets(self) -> np.ndarray:
        """Offsets of the spring rows from the support centre (m), midpoint rule."""
        n = int(self.n_rows)
        return (np.arange(n) + 0.5) / n * self.pad_length - self.pad_length / 2

    def springs(self) -> SpringSet:
        """All point springs, support by support, rows in increasing x."""
        off = self.row_offsets()
        n = len(off)
        x = (self.x[:, None] + off[None, :]).ravel()
        idx = np.repeat(np.arange(len(self)), n)
        return SpringSet(x=x, weight=np.full(x.shape, 1.0 / n), support_index=idx)

    def spring_stiffness(self, omega, direction: str = "z") -> np.ndarray:
        """Dynamic stiffness of every spring, shape (n_freq, n_springs) (N/m, complex), in
        ``direction`` ('z' vertical, 'y' lateral, 'x' longitudinal)."""
        w = np.atleast_1d(_as_omega(omega))
        per_support = np.stack([directional_stiffness(p, w, direction) if direction != "z"
                                else dynamic_stiffness(p, w) for p in self.params], axis=-1)
        s = self.springs()
        per_spring = per_support[:, s.support_index]
        # complex inf * weight would give inf + nan j: a rigid support stays rigid when split
        with np.errstate(invalid="ignore"):
            scaled = per_spring * s.weight[None, :]
        return np.where(np.isinf(per_spring), complex(math.inf), scaled)

    def nearest_support(self, x: float) -> int:
        """Index of the support whose centre is closest to x (m)."""
        return int(np.argmin(np.abs(self.x - x)))


def uniform_layout(params: SupportParameters, spacing: float = DEFAULT_SPACING, n: int = 131,
                   centre: float = 0.0, pad_length: float = 0.0,
                   n_rows: int = 1) -> SupportLayout:
    """n identical supports at ``spacing`` (m), symmetric about ``centre`` (m).

    With n odd a support sits at ``centre``; with n even ``centre`` is mid-span.
    """
    if not np.isfinite(spacing) or spacing <= 0:
        raise ValueError(f"spacing = {spacing!r} m is not allowed: use a spacing > 0 m")
    if int(n) != n or n < 1:
        raise ValueError(f"n = {n!r}: the number of supports must be an integer >= 1")
    x = centre + (np.arange(int(n)) - (n - 1) / 2) * spacing
    return SupportLayout(positions=tuple(x), params=(params,) * int(n),
                         pad_length=pad_length, n_rows=n_rows)


def with_support(layout: SupportLayout, index: int, params: SupportParameters) -> SupportLayout:
    """A copy of ``layout`` with support ``index`` (Python indexing) replaced by ``params``."""
    n = len(layout)
    if not -n <= index < n:
        raise IndexError(f"support index {index} out of range for a layout of {n} supports")
    new = list(layout.params)
    new[index] = params
    return replace(layout, params=tuple(new))


def foot_spring_weights(y_nodes, foot_width: float) -> np.ndarray:
    """Tributary lateral width of each foot spring node over the foot width (sum = 1).

    Node i carries the strip between the midpoints to its neighbours; the outermost nodes
    extend to the foot edges -foot_width/2 and +foot_width/2 (y = 0 on the rail axis).
    Weights are returned in the order of ``y_nodes`` (which need not be sorted).
    """
    y = np.asarray(y_nodes, dtype=float)
    if y.ndim != 1 or y.size == 0:
        raise ValueError("y_nodes must be a non-empty 1-D sequence of lateral positions (m)")
    if not np.isfinite(foot_width) or foot_width <= 0:
        raise ValueError(f"foot_width = {foot_width!r} m: use the foot width > 0 m")
    half = foot_width / 2
    if np.any(np.abs(y) > half * (1 + 1e-9)):
        raise ValueError(f"y_nodes must lie within the foot, |y| <= {half} m; got {y}")
    order = np.argsort(y)
    ys = y[order]
    if np.any(np.diff(ys) <= 0):
        raise ValueError("y_nodes contains repeated positions: each spring node must be distinct")
    edges = np.concatenate(([-half], (ys[1:] + ys[:-1]) / 2, [half]))
    w_sorted = np.diff(edges) / foot_width
    w = np.empty_like(w_sorted)
    w[order] = w_sorted
    return w


__all__ = [
    "FractionalZener", "FootDashpot", "RailAbsorber", "SupportParameters", "dynamic_stiffness",
    "support_receptance", "continuous_stiffness", "TABLE1", "PRESETS", "RAIL_LOSS_FACTORS",
    "preset_key", "SpringSet", "SupportLayout", "uniform_layout", "with_support",
    "foot_spring_weights", "DEFAULT_SPACING", "DEFAULT_SLEEPER_MASS", "SEATS",
]
