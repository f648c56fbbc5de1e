"""A monobloc sleeper carrying both rails: rigid or flexible (Timoshenko beam) on the ballast.

The published support (railfem.track.supports, METHOD.md section 2) puts each rail on a
rigid sleeper mass ``ms`` (per rail) on the ballast ``kb*``; both rails are then tacitly
loaded in phase. A real monobloc sleeper carries both rails at the rail seats
``x = +-seat_distance / 2`` (1.5 m apart for the 1435 mm gauge) and bends. This module gives
the seat receptance of such a sleeper on an elastic, damped ballast bed:

    alpha11 = u_1 / F_1 (direct),  alpha12 = u_2 / F_1 (cross),  at the two rail seats

and the two load cases into which a track of two identical rails splits exactly:

    symmetric (rails in phase):     alpha_s = alpha11 + alpha12
    antisymmetric (anti-phase):     alpha_a = alpha11 - alpha12

Through the pad each rail then sees the support stiffness ``K = kp* / (1 + kp* alpha)`` with
``alpha = alpha_s`` or ``alpha_a`` (railfem.track.supports.dynamic_stiffness).

**Flexible sleeper.** A uniform, free-free Timoshenko beam (bending stiffness EI, shear
stiffness kappa G A, mass per length rho A, rotary inertia rho I, loss factor eta: E* = E
(1 + i eta)) on a Winkler bed spread uniformly over its whole length with stiffness per
length ``s = 2 kb* / length`` (kb per rail, as in the rigid model, so a rigid sleeper on
this bed is the published model). The sleeper and its bed are symmetric about the track
centre, so each load case is a half sleeper ``0 <= x <= length / 2`` with the condition of
its symmetry at x = 0 (symmetric: rotation 0; antisymmetric: deflection 0), discretised by
two-node Timoshenko elements with interdependent interpolation (Friedman & Kosmatka,
Computers & Structures 47, 1993: exact static stiffness, the Euler-Bernoulli Hermite
element when kappa G A -> inf) and a consistent mass. In the basis of the half sleeper's
undamped free modes Phi (mass-normalised; the rigid-body mode, bounce or rocking about the
centre, built exactly and the flexible modes computed in its mass-orthogonal complement, so
a very stiff sleeper tends to the rigid one without loss of precision) the seat receptance
is

    alpha = Phi_seat^T [diag(omega_n^2 (1 + i eta)) + s*(omega) Phi^T B Phi - omega^2 I]^-1
            Phi_seat

(B the bed matrix per unit stiffness). The sleeper's hysteretic damping is diagonal in the
modes. The bed is not in general: the consistent mass is M = rho A B + rho I R (R the
rotary-inertia matrix of the element), so Phi^T B Phi = (I - rho I Phi^T R Phi) / rho A,
diagonal for rho I = 0 only (then alpha is an exact sum of single-mode terms); with rotary
inertia the bed couples the modes, most the shear-dominated modes of the second spectrum
(above sqrt(kappa G A / rho I) / 2 pi, 6.6 kHz for the default sleeper). The modes depend
on the geometry only (length, seat distance, elements, EI / kappa G A, rho I / rho A):
they are computed once per geometry for unit EI and rho A and scaled (omega_n^2 by
EI / rho A, Phi by rho A^-1/2), so a fit of the sleeper's stiffness, mass or loss factor
does not recompute them. Each evaluation is split at ``MODAL_CUTOFF_HZ``: the retained
modes (omega_n below it) are solved coupled by the bed, a small dense solve; the modes
above it enter as single-mode terms, each with its own bed and inertia term (their static
flexibility, the residual-flexibility correction, is this term's omega -> 0 limit), and
their bed coupling to the retained modes to first order (the Schur complement of the
truncated block taken diagonal). The static residual alone leaves errors of a few percent
near the seat's anti-resonances at 4-5 kHz, the truncated modes' dynamic terms being
needed there. ``reference_seat_receptance`` keeps the full solve (all modes coupled) as
the reference. Relative difference at every frequency from 20 Hz to 5 kHz, largest of
both load cases: the default sleeper 2e-5 on the site ballast, < 1.5e-4 on the Table 1
ballasts, 4e-4 on an undamped 1 GN/m bed; stiffer or softer sleepers (first mode 40 or
800 Hz) and more damping less; the largest found, 1.4e-3, a lightly damped sleeper (eta
0.002) on the undamped 1 GN/m bed (tests/test_sleeper.py; the cost in
benchmarks/bench_sleeper.py).

**Rigid sleeper, anti-phase load.** A rigid sleeper of mass 2 ms and length L rocks about
its centre: rotational inertia J = 2 ms L^2 / 12 (uniform bar), rotational bed stiffness
K_theta = s L^3 / 12 = kb* L^2 / 6 (uniform bed s = 2 kb* / L). Seat forces +F, -F at
+-g/2 give the moment F g and the seat deflection theta g / 2, so

    alpha_a = g^2 / (2 (K_theta - omega^2 J)) = 1 / (r (kb* - omega^2 ms)),  r = L^2 / (3 g^2)

i.e. the in-phase chain with the sleeper's ballast stiffness and mass (and a participating
ballast mass and subgrade under it) scaled by ``r`` (``Sleeper.rocking_ratio``; 1.0015 for
L = 2.6 m, g = 1.5 m: a uniform rigid sleeper rocks at the frequency it bounces at). In
phase, alpha_s = 1 / (kb* - omega^2 ms): the published model.

**Default sleeper (B90/B91-type monobloc prestressed concrete, equivalent uniform
section; assumed values, with the sources they lean on):** length 2.6 m (the length of
the German B70/B90 family); rail seats at +-0.75 m (1435 mm gauge, rail centres 1.5 m
apart); mass 300 kg (assumed: sleepers of this family weigh about 280-320 kg); modelled as
a uniform Timoshenko beam, as in the sleeper models of Grassie (J. Sound Vib. 187, 1995)
and Thompson (Railway Noise and Vibration, 2009, ch. 3); equivalent rectangle 0.25 m wide
(between the ~0.30 m base and the ~0.20 m top) and 0.1923 m deep (so that rho A L =
300 kg); concrete E = 37 GPa (E_cm of C50/60, EN 1992-1-1 Table 3.1), nu = 0.2, rho =
2400 kg/m^3; kappa = 5/6 (rectangle); loss factor 0.02 (assumed: free sleeper modes with
about 1 % of critical damping, the order reported for prestressed concrete sleepers by
Grassie and by Kaewunruen & Remennikov, 2005-2008). This gives a first free-free bending
mode at 113 Hz; measured monobloc concrete sleepers have it at about 100-200 Hz.

Conventions (railfem.conventions): exp(+i omega t); SI units (N, m, kg, rad/s).
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from .. import validators as v

log = logging.getLogger(__name__)

SLEEPER_MODELS = ("rigid", "flexible")
CASES = ("symmetric", "antisymmetric")


def rectangular_section(width: float, depth: float, E: float, nu: float, rho: float,
                        kappa: float = 5 / 6) -> dict:
    """Beam constants of a rectangular section: EI (N m^2), kGA (N), mass_per_length
    (kg/m), rotary_inertia (rho I, kg m)."""
    area, inertia = width * depth, width * depth ** 3 / 12
    return dict(EI=E * inertia, kGA=kappa * E / (2 * (1 + nu)) * area,
                mass_per_length=rho * area, rotary_inertia=rho * inertia)


#: The default sleeper's section (module docstring: B90/B91-type, equivalent rectangle).
B90_SECTION = rectangular_section(0.25, 300 / (2.6 * 2400 * 0.25), 37e9, 0.2, 2400.0)


@dataclass(frozen=True, kw_only=True)
class Sleeper:
    """A monobloc sleeper carrying both rails (module docstring for the model and sources).

    model: 'flexible' (Timoshenko beam on the ballast bed) or 'rigid' (a rigid body: the
        supports' sleeper mass ms per rail bounces, and rocks under anti-phase rail loads).
    length: sleeper length (m). seat_distance: distance between the rail seats, the rail
        centre distance (m), 1.5 for the 1435 mm gauge.
    EI: bending stiffness (N m^2). kGA: shear stiffness kappa G A (N); inf = no shear
        deformation (Euler-Bernoulli). mass_per_length: rho A (kg/m). rotary_inertia: rho I
        (kg m); 0 = none. eta: the sleeper's loss factor (-). n_elements: beam elements
        over half the sleeper (-).
    The rigid model uses only length and seat_distance (its mass is the supports' ms).
    The flexible model has its own mass, mass_per_length * length / 2 per rail; the
    supports' ms is not used. The ballast under it is the supports' kb (per rail), spread
    uniformly over the sleeper length.
    """

    model: str = "flexible"
    length: float = 2.6
    seat_distance: float = 1.5
    EI: float = B90_SECTION["EI"]
    kGA: float = B90_SECTION["kGA"]
    mass_per_length: float = B90_SECTION["mass_per_length"]
    rotary_inertia: float = B90_SECTION["rotary_inertia"]
    eta: float = 0.02
    n_elements: int = 40

    def __post_init__(self):
        v.one_of("Sleeper.model", self.model, SLEEPER_MODELS)
        v.positive("Sleeper.length", self.length, "m", "e.g. 2.6")
        v.positive("Sleeper.seat_distance", self.seat_distance, "m", "e.g. 1.5")
        if self.seat_distance >= self.length:
            raise ValueError(f"Sleeper.seat_distance = {self.seat_distance!r} m: the rail "
                             f"seats must lie on the sleeper (< length {self.length!r} m)")
        v.positive("Sleeper.EI", self.EI, "N m^2", "e.g. 5.5e6")
        v.positive("Sleeper.mass_per_length", self.mass_per_length, "kg/m", "e.g. 115")
        if not (self.kGA > 0 and not math.isnan(self.kGA)):
            raise ValueError(f"Sleeper.kGA = {self.kGA!r} N: give kappa G A > 0 (inf for no "
                             "shear deformation)")
        v.non_negative("Sleeper.rotary_inertia", self.rotary_inertia, "kg m", "rho I")
        v.non_negative("Sleeper.eta", self.eta, "(-)", "e.g. 0.02")
        n = self.n_elements
        if isinstance(n, bool) or int(n) != n or n < 4:
            raise ValueError(f"Sleeper.n_elements = {n!r}: give an integer >= 4")

    @property
    def mass(self) -> float:
        """Total mass of the flexible sleeper (kg)."""
        return self.mass_per_length * self.length

    @property
    def rocking_ratio(self) -> float:
        """r = L^2 / (3 g^2): the rigid sleeper's anti-phase chain is r times the in-phase
        one (module docstring)."""
        return self.length ** 2 / (3 * self.seat_distance ** 2)

    def scaled(self, weight: float) -> "Sleeper":
        """The sleeper with stiffness and mass times ``weight``: its receptance / weight."""
        return replace(self, EI=self.EI * weight, kGA=self.kGA * weight,
                       mass_per_length=self.mass_per_length * weight,
                       rotary_inertia=self.rotary_inertia * weight)

    def free_frequencies(self, n: int = 6) -> np.ndarray:
        """The first ``n`` free-free bending frequencies of the sleeper (Hz), no bed."""
        lam = np.sort(np.concatenate([_modes(self, c)[0][1:] for c in CASES]))
        return np.sqrt(lam[:n]) / (2 * np.pi)

    def seat_receptance(self, omega, bed, case: str = "symmetric") -> np.ndarray:
        """alpha_s (case 'symmetric') or alpha_a ('antisymmetric') of the rail seat (m/N),
        shape of omega, on the bed of complex stiffness per rail ``bed`` (N/m: kb*, or the
        ballast with its participating mass; scalar or the shape of omega): the flexible
        beam, or the rigid body for model 'rigid' (then without the sleeper's inertia:
        use supports.dynamic_stiffness for the full chain)."""
        v.one_of("case", case, CASES)
        w = np.asarray(omega, dtype=float)
        b = np.broadcast_to(np.asarray(bed, dtype=complex), w.shape)
        if self.model == "rigid":
            r = 1.0 if case == "symmetric" else self.rocking_ratio
            return 1.0 / (r * b)
        s = 2 * b / self.length  # N/m^2 over the whole sleeper
        return _receptance(self, case, np.ascontiguousarray(w).tobytes(),
                           np.ascontiguousarray(s).tobytes(), w.shape).copy()

    def seat_matrix(self, omega, bed) -> np.ndarray:
        """The (..., 2, 2) seat receptance matrix [[alpha11, alpha12], [alpha12, alpha11]]
        (m/N) of the flexible sleeper on ``bed`` (as in seat_receptance)."""
        a_s, a_a = (self.seat_receptance(omega, bed, c) for c in CASES)
        a11, a12 = (a_s + a_a) / 2, (a_s - a_a) / 2
        return np.stack([np.stack([a11, a12], -1), np.stack([a12, a11], -1)], -2)


#: The default flexible sleeper (B90/B91-type, module docstring).
B90 = Sleeper()


#: Assumed values for the participating ballast mass (SupportParameters.mb, kf, eta_f):
#: ballast of density ~1800 kg/m^3 in the load-spreading cone under half a sleeper
#: (0.3 m deep, ~0.22 m^3: the construction of Zhai et al.'s ballast model, J. Sound Vib.
#: 270, 2004) gives ~400 kg per rail seat; subgrade 80 MN/m per rail seat with loss
#: factor 0.5 (assumed, the order of a ballast stiffness). Use with ``kb`` the ballast
#: layer alone: the static stiffness is kb and kf in series.
TWO_LAYER_ASSUMED = {"mb": 400.0, "kf": 80e6, "eta_f": 0.5}


def load_case(sleeper: Sleeper | None, case: str) -> tuple[Sleeper | None, str]:
    """(sleeper, case) a support needs for a load ``case`` of a two-rail track: the rigid
    published sleeper (None) rocks anti-phase with the default geometry of a rigid Sleeper."""
    v.one_of("case", case, CASES)
    if sleeper is None and case == "antisymmetric":
        sleeper = Sleeper(model="rigid")
    return sleeper, case


# --------------------------------------------------------------------- below the pad


def ballast_stiffness(params, omega) -> np.ndarray:
    """Dynamic stiffness (N/m, shape of omega) of the ballast under one rail seat: kb* alone
    (default), or with a participating ballast mass ``mb`` on the subgrade ``kf*`` (the
    classic two-layer support): kb* (kf* - omega^2 mb) / (kb* + kf* - omega^2 mb).
    ``params``: railfem.track.supports.SupportParameters."""
    w = np.asarray(omega, dtype=float)
    kb = params.kb_complex
    if math.isinf(params.kf):  # a ballast mass on a rigid subgrade does not move
        return np.full(w.shape, kb, dtype=complex)
    zf = np.asarray(params.kf * (1 + 1j * params.eta_f) - w ** 2 * params.mb, dtype=complex)
    if math.isinf(params.kb):
        return zf
    with np.errstate(divide="ignore", invalid="ignore"):  # undamped pole: inf
        return np.where(kb + zf == 0, complex(math.inf), kb * zf / (kb + zf))


def seat_stiffness(params, omega) -> np.ndarray:
    """Dynamic stiffness (N/m, complex, shape of omega) that the pad rests on: the rail seat
    of the sleeper on its ballast, for the support ``params`` (SupportParameters) and its
    load case. Default (rigid sleeper mass, no ballast mass, rails in phase): the published
    kb* - omega^2 ms; a rigid sleeper anti-phase: rocking_ratio times the in-phase chain;
    a flexible sleeper: 1 / alpha_s or 1 / alpha_a on the ballast (module docstring)."""
    w = np.asarray(omega, dtype=float)
    sl = params.sleeper
    if sl is None and params.mb == 0 and math.isinf(params.kf):
        return np.asarray(params.kb_complex - w ** 2 * params.ms, dtype=complex)
    kb = ballast_stiffness(params, w)
    if sl is None or sl.model == "rigid":
        z = kb - w ** 2 * params.ms
        return z if params.case == "symmetric" else sl.rocking_ratio * z
    alpha = sl.seat_receptance(w, kb, params.case)
    with np.errstate(divide="ignore"):
        return np.where(np.isinf(alpha), 0.0, 1.0 / alpha)


# --------------------------------------------------------------------- half-sleeper FE


def _element(le: float, sl: Sleeper):
    """Stiffness, mass and unit-bed matrices of one element, DOFs (w1, th1, w2, th2), th =
    dw/dx positive: the interdependent interpolation element (exact static stiffness)."""
    phi = 0.0 if math.isinf(sl.kGA) else 12 * sl.EI / (sl.kGA * le ** 2)
    L, p = le, phi
    k = sl.EI / (L ** 3 * (1 + p)) * np.array([
        [12, 6 * L, -12, 6 * L],
        [6 * L, (4 + p) * L ** 2, -6 * L, (2 - p) * L ** 2],
        [-12, -6 * L, 12, -6 * L],
        [6 * L, (2 - p) * L ** 2, -6 * L, (4 + p) * L ** 2]])
    a, b = 70 * p ** 2 + 147 * p + 78, (35 * p ** 2 + 77 * p + 44) * L / 4
    c, d = 35 * p ** 2 + 63 * p + 27, (35 * p ** 2 + 63 * p + 26) * L / 4
    e, g = (7 * p ** 2 + 14 * p + 8) * L ** 2 / 4, (7 * p ** 2 + 14 * p + 6) * L ** 2 / 4
    unit = L / (210 * (1 + p) ** 2) * np.array([
        [a, b, c, -d], [b, e, d, -g], [c, d, a, -b], [-d, -g, -b, e]])
    h = (3 - 15 * p) * L
    q, t = (4 + 5 * p + 10 * p ** 2) * L ** 2, (-1 - 5 * p + 5 * p ** 2) * L ** 2
    rot = 1 / (30 * (1 + p) ** 2 * L) * np.array([
        [36, h, -36, h], [h, q, -h, t], [-36, -h, 36, -h], [h, t, -h, q]])
    return k, sl.mass_per_length * unit + sl.rotary_inertia * rot, unit


def half_nodes(sl: Sleeper) -> np.ndarray:
    """Nodes on 0 <= x <= length / 2 (m), one at the rail seat, elements of near-equal
    length."""
    half, seat = sl.length / 2, sl.seat_distance / 2
    n_in = max(1, round(sl.n_elements * seat / half))
    n_out = max(1, sl.n_elements - n_in)
    return np.concatenate([np.linspace(0, seat, n_in + 1),
                           np.linspace(seat, half, n_out + 1)[1:]])


def _assemble(sl: Sleeper):
    x = half_nodes(sl)
    n = 2 * len(x)
    K, M, B = (np.zeros((n, n)) for _ in range(3))
    for j in range(len(x) - 1):
        k, m, b = _element(x[j + 1] - x[j], sl)
        sel = np.ix_(range(2 * j, 2 * j + 4), range(2 * j, 2 * j + 4))
        K[sel] += k
        M[sel] += m
        B[sel] += b
    return x, K, M, B


def _geometry(sl: Sleeper) -> tuple:
    """What the free modes of unit EI and unit rho A depend on (the cache key; the modes are
    computed from these values). The ratios are rounded to 12 digits so that stiffness or
    mass scaled by a common factor (a fit of f1) finds the same modes, not a last-digit
    neighbour."""
    shear = 0.0 if math.isinf(sl.kGA) else float(f"{sl.EI / sl.kGA:.12g}")
    return (sl.length, sl.seat_distance, int(sl.n_elements), shear,
            float(f"{sl.rotary_inertia / sl.mass_per_length:.12g}"))


@lru_cache(maxsize=32)
def _unit_modes(geometry: tuple, case: str):
    """(omega_n^2, unit-bed matrix in the modes, seat row of Phi) of the half sleeper of
    ``geometry`` (_geometry) with EI = 1 and rho A = 1 and the symmetry condition of
    ``case``; Phi mass-normalised, the rigid mode first."""
    import scipy.linalg as sla  # here, not at import: `railfem --help` needs no SciPy

    length, seat, n, shear, rotary = geometry
    unit = Sleeper(length=length, seat_distance=seat, n_elements=n, EI=1.0,
                   kGA=math.inf if shear == 0 else 1.0 / shear, mass_per_length=1.0,
                   rotary_inertia=rotary)
    x, K, M, B = _assemble(unit)
    keep = np.arange(len(K)) != (1 if case == "symmetric" else 0)  # theta(0) or w(0) = 0
    K, M, B = (A[np.ix_(keep, keep)] for A in (K, M, B))
    rigid = np.zeros((len(x), 2))
    rigid[:, 0], rigid[:, 1] = (1.0, 0.0) if case == "symmetric" else (x, 1.0)
    r = rigid.ravel()[keep]
    r = r / math.sqrt(r @ M @ r)
    Q = sla.null_space((M @ r)[None, :])  # the mass-orthogonal complement of the rigid mode
    lam, V = sla.eigh(Q.T @ K @ Q, Q.T @ M @ Q)
    phi = np.column_stack([r, Q @ V])
    lam = np.concatenate([[0.0], np.maximum(lam, 0.0)])
    i_seat = int(np.flatnonzero(np.isclose(x, seat / 2))[0])
    row = phi[2 * i_seat - 1]  # the seat's w DOF (2 * i_seat before the removed DOF)
    bed = phi.T @ B @ phi
    for out in (lam, bed, row):
        out.setflags(write=False)
    return lam, bed, row


def _modes(sl: Sleeper, case: str):
    """(omega_n^2 (rad/s)^2, Phi^T B Phi (1/kg), seat row of Phi (1/sqrt(kg))) of the half
    sleeper ``sl``: the unit modes of its geometry scaled by EI and rho A."""
    lam, bed, row = _unit_modes(_geometry(sl), case)
    m = sl.mass_per_length
    return lam * (sl.EI / m), bed / m, row / math.sqrt(m)


#: Modes of the half sleeper below this frequency (Hz) are coupled by the bed in a dense
#: solve; those above enter as single-mode terms coupled to first order (module docstring).
MODAL_CUTOFF_HZ = 12e3


def _seat_inputs(w_bytes, s_bytes, shape):
    w = np.frombuffer(w_bytes, dtype=float).reshape(shape).ravel()
    s = np.frombuffer(s_bytes, dtype=complex).reshape(shape).ravel()
    free = (s == 0) & (w == 0)  # a static sleeper without bed: it floats away
    return w, np.where(free, 1.0, s), free


@lru_cache(maxsize=64)
def _receptance(sl: Sleeper, case: str, w_bytes: bytes, s_bytes: bytes, shape) -> np.ndarray:
    """The modal form of the seat receptance (module docstring), memoised by value: the
    retained modes r coupled by the bed, the truncated ones t through their Schur
    complement with A_tt taken diagonal."""
    w, s, free = _seat_inputs(w_bytes, s_bytes, shape)
    lam, bed, row = _modes(sl, case)
    d = lam * (1 + 1j * sl.eta)
    m = max(1, int(np.count_nonzero(lam <= (2 * np.pi * MODAL_CUTOFF_HZ) ** 2)))
    r, t = slice(0, m), slice(m, None)
    C = bed[r, t]  # the bed's coupling of the retained to the truncated modes, per unit s
    P = (C.T[:, :, None] * C.T[:, None, :]).reshape(-1, m * m)  # C_it C_jt, row t
    bed_t, ii = np.diagonal(bed)[t], np.arange(m)
    out = np.empty(w.shape, dtype=complex)
    for i0 in range(0, len(w), 256):  # bounded memory: (chunk, m, m) complex
        ws, ss = w[i0:i0 + 256, None], s[i0:i0 + 256, None]
        inv_t = 1.0 / (d[t] + ss * bed_t - ws ** 2)  # the truncated modes, uncoupled
        S = (inv_t.real @ P + 1j * (inv_t.imag @ P)).reshape(-1, m, m)  # C inv_t C^T
        S *= -ss[..., None] ** 2
        S += ss[..., None] * bed[r, r]
        S[:, ii, ii] += d[r] - ws ** 2  # the retained modes' Schur complement
        g = row[r] - ss * ((row[t] * inv_t) @ C.T)
        q = np.linalg.solve(S, g[..., None])[..., 0]
        out[i0:i0 + 256] = inv_t @ row[t] ** 2 + np.einsum("fi,fi->f", g, q)
    out[free] = complex(math.inf)
    return out.reshape(shape)


def reference_seat_receptance(sl: Sleeper, omega, bed, case: str = "symmetric"):
    """The seat receptance of the flexible sleeper (m/N) by the full solve, all modes
    coupled by the bed (the reference of the modal form of seat_receptance; slow)."""
    v.one_of("case", case, CASES)
    w = np.asarray(omega, dtype=float)
    b = np.broadcast_to(np.asarray(bed, dtype=complex), w.shape)
    w, s, free = _seat_inputs(np.ascontiguousarray(w).tobytes(),
                              np.ascontiguousarray(2 * b / sl.length).tobytes(), w.shape)
    lam, bed_m, row = _modes(sl, case)
    A = (s[:, None, None] * bed_m[None]
         + np.eye(len(lam))[None] * (lam * (1 + 1j * sl.eta) - w[:, None] ** 2)[:, None, :])
    rhs = np.broadcast_to(row.astype(complex)[None, :, None], (len(w), len(row), 1))
    out = np.linalg.solve(A, rhs)[..., 0] @ row
    out[free] = complex(math.inf)
    return out.reshape(np.shape(omega))


def clear_cache() -> None:
    """Forget the memoised modes and seat receptances (for timings)."""
    _unit_modes.cache_clear()
    _receptance.cache_clear()


__all__ = ["clear_cache", "Sleeper", "reference_seat_receptance", "MODAL_CUTOFF_HZ",
           "B90", "B90_SECTION", "rectangular_section", "load_case",
           "half_nodes", "ballast_stiffness", "TWO_LAYER_ASSUMED", "seat_stiffness",
           "SLEEPER_MODELS", "CASES"]
