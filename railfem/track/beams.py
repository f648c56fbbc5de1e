r"""Timoshenko and Euler-Bernoulli reference models of the rail (METHOD.md section 3).

An infinite beam along x with bending stiffness EI*, shear stiffness kappa G* A, mass rho A,
rotary inertia rho I (E* = E (1 + i eta), G* = G (1 + i eta): one rail loss factor), resting on
an optional continuous foundation of stiffness s (N/m per m of rail, complex and frequency
dependent), loaded by a harmonic vertical line load q(x). Time dependence exp(+i omega t).

Derivation (receptance by residues)
-----------------------------------
Displacement w(x), cross-section rotation psi(x), shear force Q = kappa G A (w' - psi),
bending moment M = EI psi'. Equations of motion:

    -omega^2 rho A w   = kappa G A (w'' - psi') - s w + q
    -omega^2 rho I psi = EI psi'' + kappa G A (w' - psi)

With w = W exp(-i k x), psi = Psi exp(-i k x) (d/dx -> -i k):

    [ kGA k^2 + s - omega^2 rho A      -i k kGA                  ] [W  ]   [q]
    [ i k kGA                           EI k^2 + kGA - omega^2 rhoI] [Psi] = [0]

so W = q N(k) / D(k) with N = EI k^2 + kGA - omega^2 rho I and D the determinant. Dividing
both by kGA (so the Euler-Bernoulli limit 1/kGA -> 0, rho I -> 0 is regular), with
c_s = 1/kGA, r = rho I and z = s - omega^2 rho A:

    D(k) = a k^4 + b k^2 + c,   a = EI,  b = EI z c_s - omega^2 r,  c = z (1 - omega^2 r c_s)
    N(k) = EI c_s k^2 + 1 - omega^2 r c_s

(c_s = 0, r = 0 gives Euler-Bernoulli D = EI k^4 + s - omega^2 rho A, N = 1.)

For a point force F at x = 0, q = F delta(x) and with W(k) = int w exp(+i k x) dx,

    w(x) = F/(2 pi) int_{-inf}^{inf} N(k)/D(k) exp(-i k x) dk.

For x > 0 the contour closes in the lower half plane (exp(-i k x) decays for Im k < 0; N/D
= O(k^-2) so Jordan's lemma applies), clockwise, picking the two roots k_n of D with
Im k_n < 0 (the positive-going waves):

    alpha(x) = w/F = -i sum_{n=1,2} N(k_n) / D'(k_n) exp(-i k_n x),
    D'(k) = 2 k (2 a k^2 + b).

N/D is even in k, so alpha(-x) = alpha(x). Check, Euler-Bernoulli free beam: roots k_b and
-i k_b, D' = 4 EI k^3, alpha(0) = -(1 + i) / (4 EI k_b^3) (METHOD.md section 1). The roots
are found from the quadratic in k^2 with the cancellation-free formula. With no damping a
real root is taken with Re k > 0 (positive group velocity, the limiting-absorption choice
for the branches of a free or elastically supported Timoshenko beam); use some damping when
backward waves could occur. The formula is singular only at double roots (D' = 0), e.g. a
free beam at omega = 0 or an undamped beam exactly at the cut-off omega^2 = kGA / (rho I).

Discrete supports
-----------------
Springs at x_l (each support possibly split into rows, see railfem.track.supports.SupportLayout)
with dynamic stiffness K_l. F_l is the force the rail puts on spring l (the spring pushes
the rail with -F_l). Rail displacement at spring j and spring law:

    u_j = alpha(x_j - x_P) P - sum_l alpha(x_j - x_l) F_l,      u_j = F_j / K_j
    =>  (A_ff + diag(1/K)) F = a_fP P    (METHOD.md: (Y_rf + Y_s) F = Y_P P, divided by i omega)
    u_r = alpha(x_r - x_P) P - sum_l alpha(x_r - x_l) F_l

alpha is the free-beam receptance above. Rows with |K_j alpha(0)| <= 1 are multiplied by
K_j, so absent (K = 0) and rigid (K = inf) springs both stay well conditioned.

Quantities: receptance alpha = u/F (m/N); mobility Y = 1j * omega * alpha (m/s/N), see
``receptance_to_mobility``. Frequency is axis 0 of every result.
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace

import numpy as np

from .. import validators
from .coupling import DiscreteKernel, couple_discrete, unique_separations
from ..rail import section as rail_section
from ..rail.greens import residue_sum
from .supports import SupportLayout, SupportParameters, continuous_stiffness

log = logging.getLogger(__name__)

# METHOD.md section 3: shear coefficient for UIC60 vertical bending.
UIC60_KAPPA_VERTICAL = 0.4
# EN 13674-1 60E1 nominal section constants (also reproduced by railfem/data, SOURCES.md).
UIC60_AREA = 76.70e-4  # m^2
UIC60_I_VERTICAL = 3038.3e-8  # m^4, bending in the vertical plane (about the horizontal axis)
UIC60_I_LATERAL = 512.3e-8  # m^4, bending in the lateral plane


def shear_coefficient(nu: float, shape: str = "rectangle") -> float:
    """Timoshenko shear coefficient kappa from Cowper (1966).

    G. R. Cowper, "The shear coefficient in Timoshenko's beam theory", J. Appl. Mech. 33
    (1966) 335-340, Table 1:
      rectangle:          kappa = 10 (1 + nu) / (12 + 11 nu)
      circle (solid):     kappa = 6 (1 + nu) / (7 + 6 nu)
      thin-walled tube:   kappa = 2 (1 + nu) / (4 + 3 nu)
    A rail is none of these; METHOD.md uses kappa ~ 0.4 for UIC60 vertical bending
    (UIC60_KAPPA_VERTICAL).
    """
    if not -1.0 < nu < 0.5:
        raise ValueError(f"Poisson ratio nu = {nu!r} must lie in (-1, 0.5)")
    forms = {
        "rectangle": lambda v: 10 * (1 + v) / (12 + 11 * v),
        "circle": lambda v: 6 * (1 + v) / (7 + 6 * v),
        "thin_tube": lambda v: 2 * (1 + v) / (4 + 3 * v),
    }
    try:
        return float(forms[shape](nu))
    except KeyError:
        raise ValueError(f"unknown shape {shape!r}; valid shapes: {', '.join(forms)}") from None


@dataclass(frozen=True, kw_only=True)
class BeamSection:
    """Beam section and material for the reference models.

    E: Young's modulus (Pa). G: shear modulus (Pa). area: cross-section area A (m^2).
    I: second moment of area about the bending axis through the centroid (m^4).
    kappa: shear coefficient (-), shear stiffness kappa G A. rho: density (kg/m^3).
    eta: loss factor (-), E* = E (1 + i eta) and G* = G (1 + i eta).
    include_shear: shear deformation (False: shear-rigid, Euler-Bernoulli / Rayleigh).
    include_rotary_inertia: rotary inertia rho I (False: Euler-Bernoulli / shear beam).
    """

    E: float
    G: float
    area: float
    I: float
    kappa: float
    rho: float
    eta: float = 0.0
    include_shear: bool = True
    include_rotary_inertia: bool = True

    def __post_init__(self):
        for name, unit in (("E", "Pa"), ("G", "Pa"), ("area", "m^2"), ("I", "m^4"),
                           ("kappa", "-"), ("rho", "kg/m^3")):
            validators.positive(f"BeamSection.{name}", getattr(self, name), unit)
        validators.non_negative("BeamSection.eta", self.eta, "-",
                                "a negative loss factor creates energy")

    @classmethod
    def from_material(cls, material, *, area: float, I: float, kappa: float,
                      eta: float | None = None) -> "BeamSection":
        """From a Material-like object (attributes E, nu, rho and loss_factor or eta).

        G = E / (2 (1 + nu)). ``eta`` overrides the material's loss factor.
        """
        if eta is None:
            eta = getattr(material, "loss_factor", getattr(material, "eta", 0.0))
        nu = material.nu
        return cls(E=material.E, G=material.E / (2 * (1 + nu)), area=area, I=I, kappa=kappa,
                   rho=material.rho, eta=eta)

    @classmethod
    def catalogue(cls, material=None, *, direction: str = "vertical",
                  kappa: float | None = None) -> "BeamSection":
        """60E1 with the EN 13674-1 catalogue constants: area 76.70 cm^2, I = 3038.3 cm^4
        in vertical bending or 512.3 cm^4 in lateral bending (UIC60_AREA, UIC60_I_VERTICAL,
        UIC60_I_LATERAL).

        material: E, nu, rho and loss factor (default ``Material.steel()``: E = 210 GPa,
        nu = 0.3, rho = 7850 kg/m^3, no loss). kappa: the catalogue gives no shear
        coefficient; vertical bending defaults to METHOD.md's 0.4 for UIC60 (the curved
        60E1 mesh gives 0.393, ``BeamSection.from_mesh``); for lateral bending give it.
        """
        from ..materials import Material

        if direction not in ("vertical", "lateral"):
            raise ValueError(f"direction must be 'vertical' or 'lateral', got {direction!r}")
        if kappa is None:
            if direction != "vertical":
                raise ValueError("give kappa for lateral bending (no default is documented)")
            kappa = UIC60_KAPPA_VERTICAL
        I = UIC60_I_VERTICAL if direction == "vertical" else UIC60_I_LATERAL
        return cls.from_material(material or Material.steel(), area=UIC60_AREA, I=I,
                                 kappa=kappa)

    @classmethod
    def from_mesh(cls, mesh, material=None, *, direction: str = "vertical") -> "BeamSection":
        """The constants of a section mesh (railfem.rail.section): area and I by quadrature
        on the (curved) mesh, kappa from the flexural shear problem, for vertical (I_y,
        kappa_z) or lateral (I_z, kappa_y) bending. material: E, nu, rho and loss factor
        (default ``Material.steel()``)."""
        from ..materials import Material

        if direction not in ("vertical", "lateral"):
            raise ValueError(f"direction must be 'vertical' or 'lateral', got {direction!r}")
        vertical = direction == "vertical"
        A, _, Iy, Iz = rail_section.moments(mesh)
        return cls.from_material(material or Material.steel(), area=A, I=Iy if vertical else Iz,
                                 kappa=rail_section.shear_coefficient(mesh, "z" if vertical
                                                                      else "y"))

    def euler_bernoulli(self) -> "BeamSection":
        """The same section without shear deformation and rotary inertia."""
        return replace(self, include_shear=False, include_rotary_inertia=False)

    @property
    def EI(self) -> complex:
        """Complex bending stiffness E* I (N m^2)."""
        return self.E * self.I * (1 + 1j * self.eta)

    @property
    def kGA(self) -> complex:
        """Complex shear stiffness kappa G* A (N); inf if shear is ignored."""
        if not self.include_shear:
            return complex(math.inf)
        return self.kappa * self.G * self.area * (1 + 1j * self.eta)

    @property
    def mass_per_length(self) -> float:
        """rho A (kg/m)."""
        return self.rho * self.area

    @property
    def rotary_inertia_per_length(self) -> float:
        """rho I (kg m); 0 if rotary inertia is ignored."""
        return self.rho * self.I if self.include_rotary_inertia else 0.0

    def _shear_compliance(self) -> complex:
        return 0.0 if not self.include_shear else 1.0 / self.kGA


# ---------------------------------------------------------------------------------------------
# dispersion and residues


def _as_omega(omega, *, allow_zero: bool) -> np.ndarray:
    w = np.asarray(omega, dtype=float)
    bad = ~np.isfinite(w) | (w < 0) | ((w == 0) if not allow_zero else False)
    if np.any(bad):
        raise ValueError(
            "omega must be finite and "
            + (">= 0" if allow_zero else "> 0 (a free beam has no static receptance)")
            + " rad/s (angular frequency, not Hz)")
    return w


def _coefficients(section: BeamSection, w: np.ndarray, s):
    """a, b, c of D(k) = a k^4 + b k^2 + c and the N(k) pieces, all normalised by kGA."""
    cs = section._shear_compliance()
    r = section.rotary_inertia_per_length
    EI = section.EI
    z = np.asarray(s, dtype=complex) - w**2 * section.mass_per_length
    a = EI
    b = EI * z * cs - w**2 * r
    c = z * (1 - w**2 * r * cs)
    return a, b, c, cs, r


def _pick_positive_going(k2: np.ndarray) -> np.ndarray:
    """The root k of k^2 = k2 with Im k < 0; if (numerically) real, the one with Re k > 0."""
    k = np.sqrt(k2.astype(complex))
    real = np.abs(k.imag) <= 1e-10 * np.abs(k)
    flip = np.where(real, k.real < 0, k.imag > 0)
    return np.where(flip, -k, k)


def _waves(section: BeamSection, w: np.ndarray, s):
    """Positive-going wavenumbers (..., 2) and residue weights N(k_n)/D'(k_n) (..., 2)."""
    a, b, c, cs, r = _coefficients(section, w, s)
    b = np.broadcast_to(b, np.broadcast(b, c).shape).astype(complex)
    c = np.broadcast_to(c, b.shape).astype(complex)
    sq = np.sqrt(b * b - 4 * a * c)
    # choose the sign that avoids cancellation in -(b +- sq)/2
    sq = np.where((np.conj(b) * sq).real >= 0, sq, -sq)
    q = -(b + sq) / 2
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = np.stack([q / a, c / q], axis=-1)
    order = np.argsort(-lam.real, axis=-1)  # column 0: larger Re k^2 (propagating bending)
    lam = np.take_along_axis(lam, order, axis=-1)
    k = _pick_positive_going(lam)
    n_k = section.EI * cs * lam + (1 - w[..., None] ** 2 * r * cs)
    d_prime = 2 * k * (2 * a * lam + b[..., None])
    if np.any(~np.isfinite(lam)) or np.any(d_prime == 0):
        raise ValueError(
            "degenerate dispersion relation (double root): a free beam at omega = 0 or an "
            "undamped beam exactly at its cut-off; add damping or move the frequency")
    return k, n_k / d_prime


def _green(k: np.ndarray, res: np.ndarray, x: np.ndarray) -> np.ndarray:
    """alpha(x) = -i sum_n res_n exp(-i k_n |x|); k, res shape (..., 2), x any shape."""
    xa = np.abs(x)
    lead = k.shape[:-1]
    kk = k.reshape(lead + (1,) * xa.ndim + (2,))
    rr = res.reshape(kk.shape)
    return -1j * np.sum(rr * np.exp(-1j * kk * xa[..., None]), axis=-1)


def timoshenko_wavenumbers(section: BeamSection, omega, foundation=0.0) -> np.ndarray:
    """The two positive-going wavenumbers (rad/m), shape omega.shape + (2,).

    Im k < 0 (decaying towards +x); undamped real roots have Re k > 0. Column 0 is the root
    with the larger Re k^2 (the propagating bending wave of the free beam), column 1 the other
    (near field below the cut-off sqrt(kappa G A / (rho I)), second spectrum above it).
    ``foundation``: continuous support stiffness per unit length (N/m^2), scalar or omega-shaped.
    """
    w = _as_omega(omega, allow_zero=True)
    k, _ = _waves(section, w, foundation)
    return k


def supported_beam_receptance(section: BeamSection, omega, x, foundation, *,
                              load_length: float = 0.0) -> np.ndarray:
    """Receptance (m/N) of an infinite beam on a continuous foundation, force at x = 0.

    ``foundation``: stiffness per unit length (N/m^2, complex), scalar or omega-shaped.
    ``load_length`` (m): the force is spread uniformly over that length centred on x = 0
    (the closed-form average of the point-force receptance over the patch, as in the
    discrete models); 0 is a point force. Result shape omega.shape + x.shape; symmetric in x.
    """
    w = _as_omega(omega, allow_zero=True)
    k, res = _waves(section, w, foundation)
    x = np.asarray(x, dtype=float)
    if load_length == 0:
        return _green(k, res, x)
    if not (np.isfinite(load_length) and load_length > 0):
        raise ValueError(f"load_length must be a finite length >= 0 (m), got {load_length:g}")
    return _spread_green(k, res, x, load_length)


def _spread_green(k: np.ndarray, res: np.ndarray, x: np.ndarray, load_length: float) -> np.ndarray:
    """``_green`` averaged over a force spread uniformly over ``load_length`` = L centred on
    0, shape k.shape[:-1] + x.shape. Closed form of (1/L) int exp(-i k |x - s|) ds: outside
    the patch (|x| >= L/2) exp(-i k |x|) 2 sin(k L/2) / (k L); inside it
    -(expm1(-i k (L/2 + x)) + expm1(-i k (L/2 - x))) / (i k L)."""
    xa = np.abs(x)
    lead = k.shape[:-1]
    kk = k.reshape(lead + (1,) * xa.ndim + (2,))
    rr = res.reshape(kk.shape)
    half = load_length / 2
    xx = xa[..., None]
    with np.errstate(over="ignore", invalid="ignore"):
        outside = np.exp(-1j * kk * xx) * np.sin(kk * half) / (kk * half)
        inside = -(np.expm1(-1j * kk * (half + xx)) + np.expm1(-1j * kk * (half - xx))) / (
            1j * kk * load_length)
    kernel = np.where(xx >= half, outside, inside)
    return -1j * np.sum(rr * kernel, axis=-1)


def free_beam_receptance(section: BeamSection, omega, x) -> np.ndarray:
    """Point (x = 0) / transfer receptance u(x)/F (m/N) of an infinite free beam.

    Residue sum of the module docstring; shape omega.shape + x.shape; symmetric in x.
    Mobility = 1j * omega * receptance.
    """
    w = _as_omega(omega, allow_zero=False)
    k, res = _waves(section, w, 0.0)
    return _green(k, res, np.asarray(x, dtype=float))


def continuous_track_receptance(section: BeamSection, support_params: SupportParameters,
                                spacing: float, omega, x, *,
                                load_length: float = 0.0) -> np.ndarray:
    """Receptance (m/N) of an infinite beam on the continuous two-layer support.

    The support of METHOD.md section 2 smeared along the rail: s = K_s(omega) / spacing.
    The force is spread over ``load_length`` (m, 0 a point; supported_beam_receptance).
    Shape omega.shape + x.shape. omega = 0 is allowed (static beam on elastic foundation).
    """
    w = _as_omega(omega, allow_zero=True)
    s = continuous_stiffness(support_params, w, spacing)
    if np.any(~np.isfinite(s)):
        raise ValueError("continuous support stiffness is infinite (rigid pad and ballast?): "
                         "a rigidly supported continuous beam does not move")
    return supported_beam_receptance(section, w, x, s, load_length=load_length)


def discrete_kernel(section: BeamSection, spring_x, omega, force_x, response_x, *,
                    spring_length: float = 0.0, load_length: float = 0.0,
                    response_length: float = 0.0) -> DiscreteKernel:
    """The parameter-free part of the beam on discrete supports (railfem.track.coupling): free-beam
    receptances between the springs at ``spring_x``, the loads at ``force_x`` and the
    responses at ``response_x`` (m), at each omega (rad/s, 1-D).

    Springs spread their force over ``spring_length``, loads over ``load_length`` and
    responses are averaged over ``response_length`` (m), with the same closed-form box
    smoothing as the WFE rail (railfem.rail.greens.residue_sum); 0 is a point."""
    w = np.atleast_1d(_as_omega(omega, allow_zero=False))
    if w.ndim != 1:
        raise ValueError("omega must be a scalar or 1-D array (rad/s)")
    xs, fx, rx = (np.atleast_1d(np.asarray(v, dtype=float)).reshape(-1)
                  for v in (spring_x, force_x, response_x))
    k, res = _waves(section, w, 0.0)
    u_ss, i_ss = unique_separations(xs[:, None] - xs[None, :])
    u_sP, i_sP = unique_separations(xs[:, None] - fx[None, :])
    u_rs, i_rs = unique_separations(rx[:, None] - xs[None, :])
    u_rP, i_rP = unique_separations(rx[:, None] - fx[None, :])
    log.debug("beam discrete kernel: %d frequencies, %d springs, %d forces, %d responses",
              w.size, xs.size, fx.size, rx.size)
    one = np.ones((1, 2))
    parts = {"ss": (u_ss, spring_length, spring_length), "sP": (u_sP, load_length, spring_length),
             "rs": (u_rs, spring_length, response_length),
             "rP": (u_rP, load_length, response_length)}
    g = {name: np.empty((w.size, len(u), 1, 1), dtype=complex) for name, (u, _, _) in parts.items()}
    for i in range(w.size):
        # the beam is its own mirror image: forward and backward terms carry the residues
        terms = (one, res[i][:, None], one, res[i][:, None])
        for name, (u, Lf, Lr) in parts.items():
            g[name][i] = residue_sum(terms, k[i], u, Lf, Lr).transpose(1, 0, 2)
    return DiscreteKernel(frequency=w / (2 * np.pi), spring_weight=np.ones(1), spring_x=xs,
                          ss=g["ss"],
                          ss_sep=u_ss, ss_index=i_ss, sP=g["sP"][..., 0], sP_index=i_sP,
                          rs=g["rs"],
                          rs_index=i_rs, rP=g["rP"][..., 0], rP_index=i_rP)


def discrete_track_receptance(section: BeamSection, layout: SupportLayout, omega, force_x,
                              response_x, *, load_length: float = 0.0) -> np.ndarray:
    """Receptance (m/N) of an infinite beam on the discrete supports of ``layout``.

    Unit vertical force at each of ``force_x`` (m), spread over ``load_length`` (m, default
    a point), response at each of ``response_x`` (m). Result shape (n_freq,) +
    shape(response_x) + shape(force_x) for 1-D or scalar omega. Compatibility equation of
    the module docstring with the free-beam Green's function (``discrete_kernel`` then
    ``coupling.couple_discrete``); every support (and every row of a spread support) has
    its own K_s, and a pad spreads each row's force over its slice of the pad length.
    """
    fx = np.asarray(force_x, dtype=float)
    rx = np.asarray(response_x, dtype=float)
    kernel = discrete_kernel(section, layout.springs().x, omega, fx, rx,
                             spring_length=layout.row_length, load_length=load_length)
    w = 2 * np.pi * kernel.frequency
    out = couple_discrete(kernel, layout.spring_stiffness(w))[:, 0]
    return out.reshape((w.size,) + rx.shape + fx.shape)


def receptance_to_mobility(omega, receptance) -> np.ndarray:
    """Mobility Y = 1j * omega * receptance (m/s/N), frequency on axis 0."""
    w = np.asarray(omega, dtype=float)
    a = np.asarray(receptance)
    return 1j * w.reshape(w.shape + (1,) * (a.ndim - w.ndim)) * a


def pinned_pinned_frequency(section: BeamSection, spacing: float, mode: int = 1) -> float:
    """Pinned-pinned frequency (Hz) of a span ``spacing`` (m): the lower Timoshenko root.

    A simply supported span of length d has modes sin(n pi x / d); for the Timoshenko beam
    the frequency equation with k = n pi / d is (Timoshenko 1921; Han, Benaroya & Wei,
    J. Sound Vib. 225 (1999) 935-988, simply supported case)

        rho A rho I / kGA omega^4 - [rho A + k^2 (EI rho A / kGA + rho I)] omega^2 + EI k^4 = 0,

    the free-beam dispersion relation at k = n pi / d. The lower root (bending branch) is
    returned, computed as 2 C / (B + sqrt(B^2 - 4 A C)) so that the Euler-Bernoulli limit
    omega^2 = EI k^4 / (rho A) is regular. Undamped values (eta ignored).
    """
    if not np.isfinite(spacing) or spacing <= 0:
        raise ValueError(f"spacing = {spacing!r} m: use a span length > 0 m")
    undamped = replace(section, eta=0.0)
    cs = undamped._shear_compliance().real
    r = undamped.rotary_inertia_per_length
    m = undamped.mass_per_length
    EI = undamped.EI.real
    kn = mode * math.pi / spacing
    A = m * r * cs
    B = m + kn**2 * (EI * m * cs + r)
    C = EI * kn**4
    omega2 = 2 * C / (B + math.sqrt(B * B - 4 * A * C))
    return math.sqrt(omega2) / (2 * math.pi)


__all__ = [
    "BeamSection", "shear_coefficient", "timoshenko_wavenumbers", "free_beam_receptance",
    "supported_beam_receptance", "continuous_track_receptance", "discrete_kernel",
    "discrete_track_receptance",
    "receptance_to_mobility", "pinned_pinned_frequency", "UIC60_KAPPA_VERTICAL", "UIC60_AREA",
    "UIC60_I_VERTICAL", "UIC60_I_LATERAL",
]
