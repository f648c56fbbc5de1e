"""Wheel-rail contact: elliptic Hertz theory, the linearised contact spring, contact filters.

METHOD.md section 4.

**Hertz.** Two bodies touch at a point; near it the gap is ``h = A x^2 + B y^2`` with the
curvature sums (x along the rail = rolling direction, y across)

    A = (1/R_wheel_rolling + 1/R_rail_longitudinal) / 2
    B = (1/R_wheel_transverse + 1/R_rail_transverse) / 2

(a convex surface has a positive radius, a concave one a negative radius; inf is flat).
Under a load P the contact is an ellipse with semi-axes a (along the smaller curvature sum)
and b, eccentricity e^2 = 1 - b^2/a^2, and with K(e), E(e) the complete elliptic integrals
(scipy's ellipk/ellipe take the parameter m = e^2) Hertz's solution is (Johnson, Contact
Mechanics, 1985, section 4.2, eqs 4.39-4.41 rewritten):

    B'/A' = ((a/b)^2 E(e) - K(e)) / (K(e) - E(e))       fixes e   (A' <= B')
    a^3   = 3 P (K(e) - E(e)) / (2 pi e^2 A' E*)
    delta = 3 P K(e) / (2 pi a E*)                        (mutual approach)
    p0    = 3 P / (2 pi a b)                              (peak pressure)

with 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2. Since P ~ delta^(3/2), the linearised contact
stiffness is ``k_H = dP/d delta = 3 P / (2 delta)`` and the contact receptance 1/k_H.

**Contact filters.** The contact averages the roughness over the patch. With the patch
half-length ``a`` along the rail and ``k = 2 pi / lambda``, the effective roughness is the
roughness times ``H(k)``. Three filters are provided:

* :func:`analytical_filter`: ``|H|^2 = 1 / (1 + (k a)^3 / 4)`` (METHOD.md section 4). Its
  high-ka slope (ka)^-3 is that of roughness uncorrelated across the patch width (a
  single Hertzian line filter [2 J1(ka)/(ka)]^2 averages to 4/(pi (ka)^3)); for roughness
  correlated across the width the filter falls as (ka)^-4. See docs/passby.md for how it
  compares with :func:`numerical_filter` and the limit ka <= 6.5 where it is used.
* :func:`line_filter`: one line along the rail under the Hertz pressure; ``[2 J1(q)/q]^2``.
* :func:`numerical_filter`: the patch cut into n lines across its width; line j has
  half-length a_j = a sqrt(1 - y_j^2/b^2), carries a share w_j of the load and sees its own
  roughness; the roughness of lines i and j is correlated with a coherence
  gamma(k |y_i - y_j|) (a correlation model: Matern of order nu, i.e. the coherence of
  isotropic roughness whose line spectrum falls as k^(-2 nu); 'independent' lines; or
  'full' correlation). ``|H|^2 = sum_ij w_i w_j G_i G_j gamma_ij`` with G_j = 2 J1(k a_j)/(k a_j).
"""
from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from ..materials import Material

__all__ = ["HertzContact", "hertz", "effective_modulus", "contact_receptance",
           "analytical_filter", "line_average", "line_filter", "coherence", "numerical_filter",
           "filter_power", "FILTERS", "ANALYTICAL_FILTER_KA_MAX",
           "DEFAULT_WHEEL_LOAD", "RAIL_HEAD_RADIUS_60E1"]

log = logging.getLogger(__name__)

#: Contact filter kinds of :func:`filter_power`.
FILTERS = ("analytical", "numerical", "none")
#: Upper limit of k a for the analytical filter (METHOD.md section 4).
ANALYTICAL_FILTER_KA_MAX = 6.5
#: Static wheel load (N): a 16 t axle load (typical passenger coach; see docs/wheels.md).
DEFAULT_WHEEL_LOAD = 78.5e3
#: Crown radius of the 60E1 rail head (m), EN 13674-1 (radii 300, 80, 13 mm).
RAIL_HEAD_RADIUS_60E1 = 0.30


def _positive(name: str, value: float) -> None:
    if not (isinstance(value, (int, float, np.floating, np.integer)) and np.isfinite(value)
            and value > 0):
        raise ValueError(f"{name} = {value!r}: give a positive finite number (SI units)")


def _radius(name: str, value: float) -> float:
    """Curvature 1/R; R may be negative (concave) or inf (flat), never 0 or NaN."""
    if not isinstance(value, (int, float, np.floating, np.integer)) or np.isnan(value) \
            or value == 0:
        raise ValueError(f"{name} = {value!r} m: give a radius != 0 (negative = concave, "
                         "inf = flat)")
    return 0.0 if math.isinf(value) else 1.0 / float(value)


def effective_modulus(m1: Material, m2: Material | None = None) -> float:
    """E* of Hertz theory (Pa): 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2."""
    m2 = m2 or m1
    return 1.0 / ((1 - m1.nu**2) / m1.E + (1 - m2.nu**2) / m2.E)


@dataclass(frozen=True, kw_only=True)
class HertzContact:
    """Hertz contact under the static load.

    load: static normal load P (N). a: semi-axis along the rail (m). b: semi-axis across
    (m). approach: mutual approach delta (m). stiffness: linearised k_H = 3P/(2 delta)
    (N/m). peak_pressure: p0 (Pa). e_modulus: E* (Pa).
    """

    load: float
    a: float
    b: float
    approach: float
    stiffness: float
    peak_pressure: float
    e_modulus: float

    @property
    def equivalent_radius(self) -> float:
        """sqrt(a b) (m), the radius of the circle of the same area."""
        return math.sqrt(self.a * self.b)


def _eccentricity(ratio: float) -> float:
    """e^2 (parameter m) of the contact ellipse for curvature ratio B'/A' >= 1."""
    from scipy import optimize, special  # not at import: `railfem --help` needs no SciPy
    if ratio == 1.0:
        return 0.0

    def f(m):
        k, e = special.ellipk(m), special.ellipe(m)
        return (e / (1 - m) - k) - ratio * (k - e)

    # f(0+) -> 0 from above for ratio > 1 at small m; bracket away from both ends
    lo, hi = 1e-12, 1 - 1e-15
    return float(optimize.brentq(f, lo, hi, xtol=1e-15, rtol=1e-14, maxiter=500))


def hertz(load: float = DEFAULT_WHEEL_LOAD, *, wheel_radius: float = 0.46,
          wheel_transverse_radius: float = math.inf,
          rail_transverse_radius: float = RAIL_HEAD_RADIUS_60E1,
          rail_longitudinal_radius: float = math.inf,
          wheel_material: Material | None = None,
          rail_material: Material | None = None) -> HertzContact:
    """Elliptic Hertz contact of a wheel on the rail head (see the module docstring).

    load: static wheel load P (N). wheel_radius: rolling radius (m).
    wheel_transverse_radius: radius of the tread profile across (m; inf for a conical
    tread, negative for a worn hollow tread). rail_transverse_radius: rail-head crown
    radius (m). rail_longitudinal_radius: inf for straight rail.
    """
    from scipy import special
    _positive("load", load)
    _positive("wheel_radius", wheel_radius)
    curv_x = 0.5 * (_radius("wheel_radius", wheel_radius)
                    + _radius("rail_longitudinal_radius", rail_longitudinal_radius))
    curv_y = 0.5 * (_radius("wheel_transverse_radius", wheel_transverse_radius)
                    + _radius("rail_transverse_radius", rail_transverse_radius))
    if curv_x <= 0 or curv_y <= 0:
        raise ValueError(
            f"the curvature sums must be positive (A = {curv_x:.4g}, B = {curv_y:.4g} 1/m): "
            "a concave radius must be larger in magnitude than the convex one it meets")
    e_star = effective_modulus(wheel_material or Material.steel(),
                               rail_material or Material.steel())
    small, large = min(curv_x, curv_y), max(curv_x, curv_y)
    m = _eccentricity(large / small)
    k, e = special.ellipk(m), special.ellipe(m)
    if m == 0.0:  # circle: (K - E)/e^2 -> pi/4
        ratio = math.pi / 4
    else:
        ratio = (k - e) / m
    major = (3 * load * ratio / (2 * math.pi * small * e_star)) ** (1 / 3)
    minor = major * math.sqrt(1 - m)
    approach = 3 * load * k / (2 * math.pi * major * e_star)
    # the major axis lies along the direction of the smaller curvature sum
    a, b = (major, minor) if curv_x <= curv_y else (minor, major)
    return HertzContact(load=float(load), a=a, b=b, approach=approach,
                        stiffness=1.5 * load / approach,
                        peak_pressure=3 * load / (2 * math.pi * a * b), e_modulus=e_star)


def contact_receptance(contact: HertzContact, frequency) -> np.ndarray:
    """Receptance 1/k_H of the linearised contact spring (m/N), shape of ``frequency``;
    mobility is i omega times it (METHOD.md section 4: Y_c = i omega / k_H)."""
    f = np.asarray(frequency, dtype=float)
    return np.full(f.shape, 1.0 / contact.stiffness, dtype=complex)


# ------------------------------------------------------------------- contact filters
def analytical_filter(ka) -> np.ndarray:
    """|H(ka)|^2 = 1 / (1 + (ka)^3 / 4) (METHOD.md section 4), used for ka <= 6.5."""
    q = np.asarray(ka, dtype=float)
    return 1.0 / (1.0 + q**3 / 4.0)


def line_average(q) -> np.ndarray:
    """H of one line under a semi-elliptic (Hertz) pressure: 2 J1(q)/q, q = k a (signed)."""
    from scipy import special
    q = np.asarray(q, dtype=float)
    out = np.ones_like(q)
    nz = np.abs(q) > 1e-8
    out[nz] = 2 * special.j1(q[nz]) / q[nz]
    return out


def line_filter(q) -> np.ndarray:
    """|H|^2 of one line under a semi-elliptic (Hertz) pressure: [2 J1(q)/q]^2, q = k a."""
    return line_average(q) ** 2


def coherence(kd, model: str = "matern", nu: float = 1.0) -> np.ndarray:
    """Coherence gamma of the roughness of two lines a lateral distance d apart at
    wavenumber k (argument k d). 'matern': 2^(1-nu)/Gamma(nu) (kd)^nu K_nu(kd), the
    coherence of isotropic roughness whose line spectrum falls as k^(-2 nu) (nu = 1/2:
    exp(-kd)); 'independent': 1 at d = 0, else 0; 'full': 1."""
    from scipy import special
    x = np.abs(np.asarray(kd, dtype=float))
    if model == "full":
        return np.ones_like(x)
    if model == "independent":
        return (x == 0).astype(float)
    if model != "matern":
        raise ValueError(f"correlation model {model!r}: choose 'matern', 'independent' "
                         "or 'full'")
    _positive("nu", nu)
    out = np.ones_like(x)
    nz = x > 0
    out[nz] = 2 ** (1 - nu) / special.gamma(nu) * x[nz] ** nu * special.kv(nu, x[nz])
    return out


def numerical_filter(k, a: float, b: float, *, n_lines: int = 24,
                     correlation: str = "matern", nu: float = 1.0) -> np.ndarray:
    """|H(k)|^2 of an elliptic Hertz patch (semi-axes a along, b across, m) averaging
    roughness over n_lines lines across its width (see the module docstring).

    k: wavenumbers (rad/m), any shape. Returns |H|^2 with the shape of k."""
    _positive("a", a)
    _positive("b", b)
    if int(n_lines) != n_lines or n_lines < 1:
        raise ValueError(f"n_lines = {n_lines!r}: give an integer >= 1")
    k = np.asarray(k, dtype=float)
    y = (np.arange(n_lines) + 0.5) / n_lines * 2 * b - b       # midpoints across the width
    aj = a * np.sqrt(1 - (y / b) ** 2)
    w = aj**2 / np.sum(aj**2)            # load share of line j: integral of p along it
    kk = k.reshape(-1, 1)
    g = line_average(kk * aj)
    dy = np.abs(y[:, None] - y[None, :])
    gamma = coherence(kk[:, :, None] * dy[None], correlation, nu)  # (nk, n, n)
    gw = g * w
    h2 = np.einsum("ki,kij,kj->k", gw, gamma, gw)
    return h2.reshape(k.shape)


def filter_power(kind: str, frequency, speed: float, contact: HertzContact) -> np.ndarray:
    """|H|^2 of the contact filter ``kind`` ('analytical', 'numerical' or 'none') at the
    narrow-band frequencies (Hz) for train speed V (m/s): k = 2 pi f / V. The analytical
    filter logs a warning beyond its limit k a = ANALYTICAL_FILTER_KA_MAX."""
    _positive("speed", speed)
    f = np.asarray(frequency, dtype=float)
    k = 2 * np.pi * f / speed
    if kind == "analytical":
        ka = k * contact.a
        if ka.max() > ANALYTICAL_FILTER_KA_MAX:
            log.warning(
                "analytical contact filter used up to ka = %.1f, beyond its limit %.1f "
                "(%.0f Hz at %.1f m/s)", ka.max(), ANALYTICAL_FILTER_KA_MAX,
                ANALYTICAL_FILTER_KA_MAX / contact.a * speed / (2 * np.pi), speed)
        return analytical_filter(ka)
    if kind == "numerical":
        return numerical_filter(k, contact.a, contact.b)
    if kind == "none":
        return np.ones_like(f)
    raise ValueError(f"contact filter {kind!r}: choose one of {', '.join(FILTERS)}")
