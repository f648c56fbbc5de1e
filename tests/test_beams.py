"""Tests of railfem.track.beams against closed forms, numerical Fourier inversion and limits."""
import dataclasses
import math

import numpy as np
import pytest
from scipy import integrate, optimize

from railfem.track import beams as bm
from railfem.track import supports as sp
from railfem.materials import Material
from railfem.spec import preset as spec_preset

TWO_PI = 2 * np.pi


@pytest.fixture
def rail():
    return bm.BeamSection.catalogue(Material.steel(0.02))


# ---------------------------------------------------------------------------------------------
# independent references


def beam_matrix_receptance(sec, omega, k, s=0.0):
    """W/q from the 2x2 Timoshenko equations of motion (w, psi), exp(-i k x), real k."""
    eta = sec.eta
    EI = sec.E * sec.I * (1 + 1j * eta)
    kGA = sec.kappa * sec.G * sec.area * (1 + 1j * eta)
    m, J = sec.rho * sec.area, sec.rho * sec.I
    a11 = kGA * k**2 + s - omega**2 * m
    a12, a21 = -1j * k * kGA, 1j * k * kGA
    a22 = EI * k**2 + kGA - omega**2 * J
    return a22 / (a11 * a22 - a12 * a21)


def fourier_receptance(sec, omega, x, s=0.0):
    """alpha(x) = (1/pi) int_0^inf W(k) cos(k x) dk by adaptive quadrature (W even in k)."""
    k_ref = max((omega**2 * sec.rho * sec.area / (sec.E * sec.I)) ** 0.25,
                omega * math.sqrt(sec.rho / (sec.kappa * sec.G)),
                (abs(s) / (sec.E * sec.I)) ** 0.25)
    k_max = 60 * k_ref
    breaks = np.linspace(0, k_max, 41)[1:-1]
    total = 0j
    for part, unit in ((np.real, 1.0), (np.imag, 1j)):
        f = lambda k: part(beam_matrix_receptance(sec, omega, k, s))  # noqa: E731
        body, _ = integrate.quad(lambda k: f(k) * np.cos(k * x), 0, k_max, points=breaks,
                                 limit=4000, epsabs=0, epsrel=1e-10)
        if x == 0:
            tail, _ = integrate.quad(f, k_max, np.inf, epsabs=0, epsrel=1e-10, limit=200)
        else:  # QAWF for the oscillatory tail, W ~ 1/(kGA k^2)
            tail, _ = integrate.quad(f, k_max, np.inf, weight="cos", wvar=x, limlst=200)
        total += unit * (body + tail)
    return total / np.pi


def eb_receptance(EI, m, omega, x, s=0.0):
    """Euler-Bernoulli closed form: alpha = -(i e^{-ik1 x} + e^{-k1 x}) / (4 EI k1^3).

    k1 is the root of k^4 = (omega^2 m - s)/EI in the open fourth quadrant (so that both k1
    and -i k1 have Im k < 0); at x = 0 this is -(1 + i) / (4 EI k1^3).
    """
    roots = np.roots([1, 0, 0, 0, -(omega**2 * m - s) / EI])
    k1 = [r for r in roots if r.real > 0 and r.imag < 0]
    assert len(k1) == 1
    k1 = k1[0]
    x = abs(x)
    return -(1j * np.exp(-1j * k1 * x) + np.exp(-k1 * x)) / (4 * EI * k1**3)


# ---------------------------------------------------------------------------------------------
# section


def test_section_construction_and_validation():
    sec = bm.BeamSection.from_material(Material.steel(loss_factor=0.01), area=76.7e-4,
                                       I=3038.3e-8, kappa=0.4)
    assert sec.G == pytest.approx(2.1e11 / 2.6)
    assert sec.eta == 0.01
    assert sec.EI == pytest.approx(2.1e11 * 3038.3e-8 * (1 + 0.01j))
    assert sec.mass_per_length == pytest.approx(60.21, rel=1e-3)  # EN 13674-1: 60.21 kg/m
    assert bm.BeamSection.catalogue().kappa == 0.4
    with pytest.raises(ValueError, match="kappa"):
        dataclasses.replace(sec, kappa=0.0)
    with pytest.raises(ValueError, match="eta"):
        dataclasses.replace(sec, eta=-0.01)
    eb = sec.euler_bernoulli()
    assert not eb.include_shear and eb.rotary_inertia_per_length == 0 and math.isinf(eb.kGA.real)


def test_cowper_shear_coefficients():
    assert bm.shear_coefficient(0.3) == pytest.approx(13 / 15.3)
    assert bm.shear_coefficient(0.0) == pytest.approx(5 / 6)  # classical rectangle value
    assert bm.shear_coefficient(0.3, "circle") == pytest.approx(7.8 / 8.8)
    assert bm.shear_coefficient(0.0, "thin_tube") == pytest.approx(0.5)
    with pytest.raises(ValueError, match="rectangle"):
        bm.shear_coefficient(0.3, "rail")


# ---------------------------------------------------------------------------------------------
# free beam


def test_wavenumbers_solve_dispersion_relation(rail):
    w = TWO_PI * np.array([5.0, 100.0, 1000.0, 4000.0, 8000.0])
    k = bm.timoshenko_wavenumbers(rail, w)
    assert k.shape == (5, 2) and np.all(k.imag < 0)
    for s in (0.0, 2e8 * (1 + 0.3j)):
        k = bm.timoshenko_wavenumbers(rail, w, foundation=s)
        EI = rail.EI
        kGA = rail.kGA
        m, J = rail.mass_per_length, rail.rotary_inertia_per_length
        W = w[:, None]
        a11, a22 = kGA * k**2 + s - W**2 * m, EI * k**2 + kGA - W**2 * J
        det = a11 * a22 - k**2 * kGA**2
        scale = np.abs(a11 * a22) + np.abs(k**2 * kGA**2)
        assert np.all(np.abs(det) < 1e-10 * scale)


def test_undamped_wavenumbers_and_cutoff():
    sec = bm.BeamSection.catalogue(Material.steel(0.0))
    w_c = math.sqrt(sec.kGA.real / sec.rotary_inertia_per_length)  # second-spectrum cut-off
    below, above = bm.timoshenko_wavenumbers(sec, [0.9 * w_c, 1.1 * w_c])
    assert below[0].real > 0 and below[0].imag == 0  # propagating, Re k > 0
    assert below[1].real == 0 and below[1].imag < 0  # near field
    assert above[1].real > 0 and above[1].imag == 0  # second branch now propagates
    # very high frequency: phase speeds tend to sqrt(kappa G / rho) and sqrt(E / rho)
    w = TWO_PI * 2e6
    k = bm.timoshenko_wavenumbers(sec, w)
    assert w / k[0].real == pytest.approx(math.sqrt(sec.kappa * sec.G / sec.rho), rel=1e-3)
    assert w / k[1].real == pytest.approx(math.sqrt(sec.E / sec.rho), rel=1e-3)


def test_euler_bernoulli_section_is_exact_closed_form(rail):
    eb = rail.euler_bernoulli()
    w = TWO_PI * np.array([2.0, 50.0, 700.0, 3000.0])
    x = np.array([0.0, 0.2, 1.3])
    got = bm.free_beam_receptance(eb, w, x)
    assert got.shape == (4, 3)
    ref = np.array([[eb_receptance(eb.EI, eb.mass_per_length, wi, xi) for xi in x] for wi in w])
    np.testing.assert_allclose(got, ref, rtol=1e-10)
    kb = (w**2 * eb.mass_per_length / eb.EI) ** 0.25
    np.testing.assert_allclose(got[:, 0], -(1 + 1j) / (4 * eb.EI * kb**3), rtol=1e-10)


def test_timoshenko_tends_to_euler_bernoulli_at_low_frequency(rail):
    x = np.array([0.0, 0.5, 2.0])
    errors = []
    for f in (1.0, 5.0, 25.0):
        w = TWO_PI * f
        t = bm.free_beam_receptance(rail, w, x)
        e = np.array([eb_receptance(rail.EI, rail.mass_per_length, w, xi) for xi in x])
        errors.append(np.max(np.abs(t / e - 1)))
    assert errors[0] < 1e-3 and errors[1] < 5e-3
    assert errors[0] < errors[1] < errors[2]  # the difference is a frequency effect


@pytest.mark.parametrize("f", [20.0, 300.0, 2000.0, 6000.0])
def test_free_beam_against_fourier_inversion(f):
    sec = bm.BeamSection.catalogue(Material.steel(0.05))
    w = TWO_PI * f
    for x in (0.0, 0.3, 1.5):
        ref = fourier_receptance(sec, w, x)
        got = bm.free_beam_receptance(sec, w, x)
        assert abs(got / ref - 1) < 1e-3, (f, x)


def test_free_beam_symmetry_and_validation(rail):
    w = TWO_PI * np.array([100.0, 1000.0])
    x = np.array([0.1, 0.7])
    np.testing.assert_array_equal(bm.free_beam_receptance(rail, w, x),
                                  bm.free_beam_receptance(rail, w, -x))
    with pytest.raises(ValueError, match="omega"):
        bm.free_beam_receptance(rail, 0.0, 0.0)
    with pytest.raises(ValueError, match="omega"):
        bm.free_beam_receptance(rail, -1.0, 0.0)


# ---------------------------------------------------------------------------------------------
# continuous support


def test_static_winkler_limits():
    sec = bm.BeamSection.catalogue(Material.steel(0.0))
    p = sp.SupportParameters(kp=300e6, kb=90e6)
    s = 300e6 * 90e6 / 390e6 / 0.6
    EI = sec.E * sec.I
    beta = (s / (4 * EI)) ** 0.25
    # Euler-Bernoulli on Winkler foundation: w(0) = P / (8 EI beta^3) (Hetenyi)
    eb = bm.continuous_track_receptance(sec.euler_bernoulli(), p, 0.6, 0.0, 0.0)
    assert eb.real == pytest.approx(1 / (8 * EI * beta**3), rel=1e-12) and eb.imag == 0
    # Timoshenko: w(0) = (1/pi) int (1 + EI c k^2)/(EI k^4 + EI s c k^2 + s) dk, c = 1/kGA,
    # = (1/sqrt(q) + EI c) / (2 EI sqrt(p + 2 sqrt(q))), p = s c, q = s / EI
    c = 1 / sec.kGA.real
    q, pp = s / EI, s * c
    timo_ref = (1 / math.sqrt(q) + EI * c) / (2 * EI * math.sqrt(pp + 2 * math.sqrt(q)))
    timo = bm.continuous_track_receptance(sec, p, 0.6, 0.0, 0.0)
    assert timo.real == pytest.approx(timo_ref, rel=1e-12)
    # the static result is reached smoothly at low frequency
    low = bm.continuous_track_receptance(sec, p, 0.6, TWO_PI * 0.1, 0.0)
    assert low.real == pytest.approx(timo_ref, rel=1e-5)


def test_euler_bernoulli_on_continuous_support_closed_form():
    pr = spec_preset("medium")
    eb = bm.BeamSection.catalogue(Material.steel(pr.rail.eta)).euler_bernoulli()
    w = TWO_PI * np.array([10.0, 150.0, 400.0, 1500.0])
    x = np.array([0.0, 0.6, 2.4])
    got = bm.continuous_track_receptance(eb, pr.support, 0.6, w, x)
    s = sp.continuous_stiffness(pr.support, w, 0.6)
    ref = np.array([[eb_receptance(eb.EI, eb.mass_per_length, wi, xi, si) for xi in x]
                    for wi, si in zip(w, s)])
    np.testing.assert_allclose(got, ref, rtol=1e-10)


@pytest.mark.parametrize("f", [0.0, 20.0, 300.0, 2000.0, 6000.0])
def test_continuous_track_against_fourier_inversion(f):
    pr = spec_preset("medium")
    sec = bm.BeamSection.catalogue(Material.steel(pr.rail.eta))
    w = TWO_PI * f
    s = complex(sp.continuous_stiffness(pr.support, w, 0.6))
    for x in (0.0, 0.3, 1.5):
        ref = fourier_receptance(sec, w, x, s)
        got = bm.continuous_track_receptance(sec, pr.support, 0.6, w, x)
        assert abs(got / ref - 1) < 1e-3, (f, x)


# ---------------------------------------------------------------------------------------------
# discrete supports


def test_single_support_closed_form(rail):
    p = sp.SupportParameters(kp=200e6, eta_p=0.2, ms=120.0, kb=80e6, eta_b=1.0)
    lay = sp.SupportLayout(positions=(0.0,), params=(p,))
    w = TWO_PI * np.array([30.0, 300.0, 3000.0])
    x = np.array([0.0, 0.45, -1.0])
    got = bm.discrete_track_receptance(rail, lay, w, 0.0, x)
    a = bm.free_beam_receptance(rail, w, x)
    K = sp.dynamic_stiffness(p, w)[:, None]
    force = K * a[:, :1] / (1 + K * a[:, :1])  # spring force per unit load
    np.testing.assert_allclose(got, a - a * force, rtol=1e-12)


def test_absent_and_rigid_supports(rail):
    w = TWO_PI * np.array([50.0, 500.0])
    x = np.array([0.0, 0.3, 1.0])
    absent = sp.uniform_layout(sp.SupportParameters(kp=0.0, kb=1e8), n=5)
    np.testing.assert_allclose(bm.discrete_track_receptance(rail, absent, w, 0.1, x),
                               bm.free_beam_receptance(rail, w, x - 0.1), rtol=1e-12)
    rigid = sp.SupportLayout(positions=(0.0,),
                             params=(sp.SupportParameters(kp=math.inf, kb=math.inf),))
    got = bm.discrete_track_receptance(rail, rigid, w, 0.3, x)
    assert np.all(np.abs(got[:, 0]) < 1e-12 * np.abs(got[:, 1]))


def test_shapes(rail):
    lay = sp.uniform_layout(spec_preset("medium").support, n=11)
    w = TWO_PI * np.array([100.0, 200.0, 300.0])
    assert bm.discrete_track_receptance(rail, lay, w, 0.0, 0.0).shape == (3,)
    assert bm.discrete_track_receptance(rail, lay, w, 0.0, [0.0, 0.1]).shape == (3, 2)
    assert bm.discrete_track_receptance(rail, lay, w, [0.0, 0.3, 0.5],
                                        [0.0, 0.1]).shape == (3, 2, 3)
    assert bm.discrete_track_receptance(rail, lay, TWO_PI * 100.0, 0.0, 0.0).shape == (1,)


def inhomogeneous_layout():
    pr = spec_preset("site")
    lay = sp.uniform_layout(pr.support, n=41, pad_length=0.12, n_rows=3)
    lay = sp.with_support(lay, 21, dataclasses.replace(pr.support, kb=0.0))  # voided sleeper
    return sp.with_support(lay, 18, dataclasses.replace(pr.support, kp=900e6, eta_p=0.1))


def test_reciprocity_inhomogeneous_track(rail):
    lay = inhomogeneous_layout()
    pts = np.array([-0.7, 0.0, 0.25, 0.6, 1.3])
    w = TWO_PI * np.array([40.0, 400.0, 1100.0, 3500.0])
    a = bm.discrete_track_receptance(rail, lay, w, pts, pts)
    np.testing.assert_allclose(a, np.swapaxes(a, 1, 2), rtol=1e-9)


def test_point_mobility_is_passive(rail):
    w = TWO_PI * np.geomspace(10, 5000, 60)
    x = np.array([0.0, 0.3, 0.6])  # voided support at x = 0.6 in the inhomogeneous layout
    for lay in (inhomogeneous_layout(), sp.uniform_layout(spec_preset("soft").support, n=61)):
        a = np.stack([bm.discrete_track_receptance(rail, lay, w, xi, xi) for xi in x], -1)
        Y = bm.receptance_to_mobility(w, a)
        assert np.all(Y.real > 0)


def test_voided_sleeper_softens_the_track(rail):
    pr = spec_preset("site")
    lay = sp.uniform_layout(pr.support, n=41)
    void = sp.with_support(lay, 20, dataclasses.replace(pr.support, kb=0.0))
    w = TWO_PI * 20.0
    assert (abs(bm.discrete_track_receptance(rail, void, w, 0.0, 0.0)[0])
            > 1.5 * abs(bm.discrete_track_receptance(rail, lay, w, 0.0, 0.0)[0]))


def test_pad_rows(rail):
    p = spec_preset("medium").support
    w = TWO_PI * np.array([100.0, 1000.0])
    x = np.array([0.0, 0.3])
    point = bm.discrete_track_receptance(rail, sp.uniform_layout(p, n=21), w, 0.0, x)
    one_row = sp.uniform_layout(p, n=21, pad_length=0.15, n_rows=1)
    spread = bm.discrete_track_receptance(rail, one_row, w, 0.0, x)
    assert np.abs(spread / point - 1).max() > 0.01  # the pad length is not ignored
    tiny = sp.uniform_layout(p, n=21, pad_length=1e-4, n_rows=3)
    np.testing.assert_allclose(bm.discrete_track_receptance(rail, tiny, w, 0.0, x), point,
                               rtol=1e-4)


def test_small_spacing_tends_to_continuous_support():
    pr = spec_preset("medium")
    sec = bm.BeamSection.catalogue(Material.steel(pr.rail.eta))
    w = TWO_PI * np.array([30.0, 100.0, 300.0])
    x = np.array([0.0, 0.5, 1.0])
    errors = []
    for d, n in ((0.1, 301), (0.05, 601)):  # 30 m of track either way
        sup = pr.support.scaled(d / 0.6)  # same stiffness per metre as 0.6 m spacing
        disc = bm.discrete_track_receptance(sec, sp.uniform_layout(sup, spacing=d, n=n),
                                            w, 0.0, x)
        cont = bm.continuous_track_receptance(sec, sup, d, w, x)
        errors.append(np.max(np.abs(disc / cont - 1)))
    assert errors[1] < 2e-3
    assert errors[0] / errors[1] > 3  # discreteness error falls like d^2


def pinned_pinned_reference(sec, d):
    """Lowest omega with det A(k = pi/d, omega) = 0 for the undamped beam (brentq)."""
    k = math.pi / d
    EI, kGA = sec.E * sec.I, sec.kappa * sec.G * sec.area
    m, J = sec.rho * sec.area, sec.rho * sec.I
    det = lambda w: (kGA * k**2 - w**2 * m) * (EI * k**2 + kGA - w**2 * J) - (k * kGA) ** 2  # noqa
    w_eb = k**2 * math.sqrt(EI / m)  # Euler-Bernoulli pinned-pinned, above the Timoshenko one
    assert det(0.0) > 0 > det(w_eb)
    return optimize.brentq(det, 0.0, w_eb, xtol=1e-12, rtol=1e-14) / TWO_PI


def test_pinned_pinned_frequency_helper():
    sec = bm.BeamSection.catalogue(Material.steel(0.01))
    for d in (0.3, 0.6, 0.65):
        assert bm.pinned_pinned_frequency(sec, d) == pytest.approx(
            pinned_pinned_reference(sec, d), rel=1e-10)
    eb = sec.euler_bernoulli()
    assert bm.pinned_pinned_frequency(eb, 0.6) == pytest.approx(
        (math.pi / 0.6) ** 2 * math.sqrt(sec.E * sec.I / sec.mass_per_length) / TWO_PI)


def test_pinned_pinned_resonance_on_stiff_supports():
    d = 0.6
    sec = bm.BeamSection.catalogue(Material.steel(0.005))
    stiff = sp.SupportParameters(kp=1e12, kb=math.inf)
    lay = sp.uniform_layout(stiff, spacing=d, n=131)
    f_pp = pinned_pinned_reference(sec, d)
    f = np.arange(800.0, 1400.0, 4.0)
    mid = np.abs(bm.discrete_track_receptance(sec, lay, TWO_PI * f, d / 2, d / 2))
    i = int(np.argmax(mid))
    assert 0 < i < f.size - 1
    res = optimize.minimize_scalar(
        lambda ff: -abs(bm.discrete_track_receptance(sec, lay, TWO_PI * ff, d / 2, d / 2)[0]),
        bounds=(f[i - 1], f[i + 1]), method="bounded", options={"xatol": 1e-3})
    assert res.x == pytest.approx(f_pp, rel=0.01)


@pytest.mark.parametrize("name", ["stiff", "medium", "soft", "site"])
def test_truncation_131_vs_301_supports(name):
    pr = spec_preset(name)
    sec = bm.BeamSection.catalogue(Material.steel(pr.rail.eta))
    w = TWO_PI * np.geomspace(100, 5000, 40)
    x = [0.0, 0.3]  # on a support and at mid-span
    a131 = bm.discrete_track_receptance(sec, sp.uniform_layout(pr.support, n=131), w, x, x)
    a301 = bm.discrete_track_receptance(sec, sp.uniform_layout(pr.support, n=301), w, x, x)
    assert np.max(np.abs(20 * np.log10(np.abs(a131 / a301)))) < 0.1


def test_receptance_to_mobility():
    w = np.array([1.0, 2.0])
    a = np.ones((2, 3), dtype=complex)
    np.testing.assert_allclose(bm.receptance_to_mobility(w, a), 1j * w[:, None] * a)


def test_spread_springs_average_the_point_greens_function(rail):
    """The closed-form box smoothing of the beam kernel equals a midpoint-rule average of the
    point Green's function over both boxes (load box 0.02 m, spring box 0.15 m)."""
    w = TWO_PI * np.array([300.0, 2000.0])
    Ls, Lf, sep = 0.15, 0.02, np.array([0.0, 0.05, 0.6])
    ker = bm.discrete_kernel(rail, [0.0], w, -sep, [0.0], spring_length=Ls, load_length=Lf)
    n = 400
    ts = (np.arange(n) + 0.5) / n * Ls - Ls / 2
    tf = (np.arange(n) + 0.5) / n * Lf - Lf / 2
    for j, s0 in enumerate(sep):
        x = s0 + ts[:, None] - tf[None, :]
        avg = bm.free_beam_receptance(rail, w, x).mean(axis=(1, 2))
        np.testing.assert_allclose(ker.sP[:, ker.sP_index[0, j], 0], avg, rtol=1e-4)
