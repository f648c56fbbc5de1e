"""Elliptic Hertz contact and contact filters against published and closed-form values.

* Timoshenko & Goodier, Theory of Elasticity (1951), section 140 (also Roark's Formulas):
  contact ellipse coefficients m, n with a = m (3 P / (4 E* (A + B)))^(1/3), b = n (...),
  tabulated against cos(theta) = (B - A)/(A + B).
* Circular contact (A = B = 1/(2R)): a = (3 P R / (4 E*))^(1/3), delta = a^2 / R.
* The linearised stiffness against a finite difference of the load-approach law.
* Contact filters: full lateral correlation gives the filter of the load carried per unit
  length, (1 - x^2/a^2), whose transform is 3 (sin q - q cos q)/q^3 (closed form)."""
import math

import numpy as np
import pytest

from railfem.wheelrail import contact

# theta (deg): (m, n), Timoshenko & Goodier Table (section 140)
TG_TABLE = {30: (2.731, 0.493), 35: (2.397, 0.530), 40: (2.136, 0.567), 45: (1.926, 0.604),
            50: (1.754, 0.641), 55: (1.611, 0.678), 60: (1.486, 0.717), 65: (1.378, 0.759),
            70: (1.284, 0.802), 75: (1.202, 0.846), 80: (1.128, 0.893), 85: (1.061, 0.944)}
E_STAR = 2.1e11 / (2 * (1 - 0.3**2))


@pytest.mark.parametrize("theta", sorted(TG_TABLE))
def test_ellipse_semi_axes_match_timoshenko_goodier(theta):
    m_ref, n_ref = TG_TABLE[theta]
    A = 1.0
    ct = math.cos(math.radians(theta))
    B = A * (1 + ct) / (1 - ct)
    P = 50e3
    h = contact.hertz(P, wheel_radius=1 / (2 * A), wheel_transverse_radius=1 / (2 * B),
                      rail_transverse_radius=math.inf)
    base = (3 * P / (4 * E_STAR * (A + B))) ** (1 / 3)
    # the table is given to 3 decimals; its 70 deg entry n = 0.802 is the farthest (0.0021)
    assert h.a / base == pytest.approx(m_ref, abs=0.0025)
    assert h.b / base == pytest.approx(n_ref, abs=0.0025)


def test_circular_contact_closed_form():
    R, P = 0.25, 20e3
    h = contact.hertz(P, wheel_radius=2 * R, wheel_transverse_radius=2 * R,
                      rail_transverse_radius=math.inf, rail_longitudinal_radius=math.inf)
    # A = B = 1/(4R) ... equivalent sphere radius R_e = 1/(2A) = 2R? use R_e directly
    Re = 1 / (2 * (1 / (2 * (2 * R))))
    a = (3 * P * Re / (4 * E_STAR)) ** (1 / 3)
    assert h.a == pytest.approx(a, rel=1e-9) and h.b == pytest.approx(a, rel=1e-9)
    assert h.approach == pytest.approx(a**2 / Re, rel=1e-9)
    assert h.stiffness == pytest.approx(1.5 * P / h.approach, rel=1e-12)


def test_linearised_stiffness_is_the_slope_of_the_load_approach_law():
    P = contact.DEFAULT_WHEEL_LOAD
    h0 = contact.hertz(P)
    eps = 1e-4
    d1, d2 = contact.hertz(P * (1 - eps)).approach, contact.hertz(P * (1 + eps)).approach
    assert h0.stiffness == pytest.approx(2 * eps * P / (d2 - d1), rel=1e-6)


def test_default_wheel_rail_contact_is_plausible():
    # 920 mm wheel, 300 mm crown, 78.5 kN: an ellipse longer along the rail, k_H ~ 1.3e9
    h = contact.hertz()
    assert h.a > h.b
    assert 1.0e9 < h.stiffness < 1.6e9
    assert 5e-3 < h.a < 8e-3
    assert contact.contact_receptance(h, [100.0])[0] == pytest.approx(1 / h.stiffness)


def test_bad_contact_input_is_named():
    with pytest.raises(ValueError, match="load"):
        contact.hertz(-1.0)
    with pytest.raises(ValueError, match="curvature"):
        contact.hertz(1e4, wheel_transverse_radius=-0.2, rail_transverse_radius=0.3)


def test_numerical_filter_limits():
    a, b = 6e-3, 5e-3
    k = np.array([1.0, 100.0, 500.0, 1000.0])
    q = k * a
    # fully correlated across the width: transform of the load per unit length (1 - x^2/a^2)
    full = contact.numerical_filter(k, a, b, n_lines=400, correlation="full")
    closed = (3 * (np.sin(q) - q * np.cos(q)) / q**3) ** 2
    assert np.allclose(full, closed, rtol=2e-3, atol=1e-6)
    # one line is the Hertz line filter
    one = contact.numerical_filter(k, a, b, n_lines=1, correlation="independent")
    assert np.allclose(one, contact.line_filter(q))
    # long wavelengths pass unchanged; the Matern filter lies between the two limits
    mat = contact.numerical_filter(k, a, b)
    assert mat[0] == pytest.approx(1.0, abs=1e-3)
    assert np.all(mat <= 1.0 + 1e-12)


def test_analytical_filter_form():
    ka = np.array([0.0, 1.0, 6.5, 100.0])
    h2 = contact.analytical_filter(ka)
    assert h2[0] == 1.0 and h2[1] == pytest.approx(0.8)
    assert h2[3] * ka[3] ** 3 == pytest.approx(4.0, rel=1e-5)  # (ka)^-3 asymptote
