"""Wheel models: the axisymmetric harmonic FE against ring and plate theory, the flexible
wheel's rigid limit, rigid and tabulated wheels.

Independent references: thin-ring theory (in-plane and out-of-plane flexural modes, the
n = 0 breathing mode; e.g. Blevins, Formulas for natural frequency and mode shape, ring
tables) and Kirchhoff theory of an annular plate clamped at its inner edge (exact Bessel
determinant computed here); both share nothing with the FE except the material."""
import math

import numpy as np
import pytest
from scipy import optimize, special

from railfem import wheelfe, wheels
from railfem.frf import FRF
from railfem.frfio import write_frf_csv

E, NU, RHO = 2.1e11, 0.3, 7850.0
G = E / (2 * (1 + NU))


def _ring_modes(n, f_cut=3000.0):
    R, t, w = 0.5, 0.01, 0.01
    mesh = wheelfe.rectangle_mesh(R - t / 2, R + t / 2, -w / 2, w / 2, 3, 3)
    return wheelfe.harmonic_modes(wheelfe.assemble(mesh), n, f_cut).frequency, (R, t, w)


@pytest.mark.parametrize("n", [2, 3, 4])
def test_thin_ring_flexural_modes(n):
    freq, (R, t, w) = _ring_modes(n)
    A, I = t * w, w * t**3 / 12
    J = 0.1406 * w**4  # square section, St-Venant
    f_in = math.sqrt(E * I / (RHO * A * R**4) * n**2 * (n**2 - 1) ** 2 / (n**2 + 1)) / (2 * math.pi)
    f_out = math.sqrt(E * I / (RHO * A * R**4) * n**2 * (n**2 - 1) ** 2
                      / (n**2 + E * I / (G * J))) / (2 * math.pi)
    lowest = np.sort(freq[freq > 0])[:2]
    assert lowest[0] == pytest.approx(f_out, rel=0.005)
    assert lowest[1] == pytest.approx(f_in, rel=0.005)


def test_thin_ring_breathing_and_rigid_modes():
    f0, (R, _, _) = _ring_modes(0, f_cut=2000.0)
    assert f0[0] == 0.0  # axial translation
    assert f0[-1] == pytest.approx(math.sqrt(E / RHO) / R / (2 * math.pi), rel=0.002)
    f1, _ = _ring_modes(1, f_cut=1000.0)
    assert list(f1) == [0.0, 0.0]  # translation and tilt of a free ring


def _kirchhoff_annular(n, b, a, h, n_roots=1):
    """Natural frequencies (Hz) of an annular Kirchhoff plate clamped at r = b, free at a."""
    D = E * h**3 / (12 * (1 - NU**2))

    def det(k):
        cols = []
        for z, s in (("j", -1), ("y", -1), ("i", 1), ("k", 1)):
            f = {"j": special.jv, "y": special.yv, "i": special.iv, "k": special.kv}[z]
            fp = {"j": special.jvp, "y": special.yvp, "i": special.ivp, "k": special.kvp}[z]
            Zb, Zpb = f(n, k * b), k * fp(n, k * b)
            Za, Zpa, Zppa = f(n, k * a), k * fp(n, k * a), k**2 * fp(n, k * a, 2)
            m_r = Zppa + NU * (Zpa / a - n**2 * Za / a**2)
            v_r = s * k**2 * Zpa - (1 - NU) * n**2 / a**2 * (Zpa - Za / a)
            col = np.array([Zb, Zpb, m_r, v_r])
            cols.append(col / np.linalg.norm(col))
        return np.linalg.det(np.column_stack(cols))

    ks = np.linspace(0.5, 60.0, 4000)
    d = np.array([det(k) for k in ks])
    roots = [optimize.brentq(det, ks[i], ks[i + 1]) for i in np.nonzero(np.diff(np.sign(d)))[0]]
    # drop sign changes through poles: keep roots where |det| is small
    roots = [k for k in roots if abs(det(k)) < 1e-6][:n_roots]
    return np.array(roots) ** 2 * math.sqrt(D / (RHO * h)) / (2 * math.pi)


@pytest.mark.parametrize("n", [0, 1, 2, 3])
def test_annular_plate_axial_modes_match_kirchhoff(n):
    b, a, h = 0.1, 0.5, 0.01
    mesh = wheelfe.rectangle_mesh(b, a, -h / 2, h / 2, 32, 2, bore_radius=b)
    wheel = wheelfe.assemble(mesh, axle_mass=math.inf)  # clamped inner edge
    ref = _kirchhoff_annular(n, b, a, h)[0]
    fe = wheelfe.harmonic_modes(wheel, n, 1.5 * ref).frequency
    # the lowest mode of each harmonic is the plate's first bending mode; thin-plate
    # theory neglects shear and rotary inertia ((k h)^2 ~ 1e-2 here): 1.5 % tolerance
    assert fe[0] == pytest.approx(ref, rel=0.015), (fe, ref)


@pytest.fixture(scope="module")
def coarse_wheel():
    return wheels.flexible_wheel(h=0.02, f_max=3000.0, n_max=4)


def test_flexible_wheel_tends_to_rigid_mass(coarse_wheel):
    f = np.array([5.0, 10.0, 20.0])
    rigid = wheels.RigidWheel(mass=wheels.DEFAULT_UNSPRUNG_MASS).receptance(f)
    ratio = coarse_wheel.receptance(f) / rigid
    assert coarse_wheel.mass == pytest.approx(wheels.DEFAULT_UNSPRUNG_MASS)
    assert np.all(np.abs(20 * np.log10(np.abs(ratio))) < 0.05)
    # and it departs from the rigid mass above its first modes
    hi = np.array([2000.0, 2500.0])
    assert np.any(np.abs(20 * np.log10(np.abs(
        coarse_wheel.receptance(hi) / wheels.RigidWheel().receptance(hi)))) > 3.0)


def test_default_wheel_section_mass_and_mesh_convergence():
    m12 = wheelfe.assemble(wheelfe.mesh_section(h=0.012))
    m8 = wheelfe.assemble(wheelfe.mesh_section(h=0.008), axle_mass=300.0)
    # the section is exact polygons: the mass does not depend on the mesh
    assert m12.mass == pytest.approx(m8.mass, rel=1e-9)
    assert 250 < m12.mass < 400  # a 920 mm wheel weighs about 300-380 kg
    f12 = wheelfe.harmonic_modes(wheelfe.assemble(wheelfe.mesh_section(h=0.012),
                                                  axle_mass=300.0), 2, 2000).frequency
    f8 = wheelfe.harmonic_modes(m8, 2, 2000).frequency
    assert np.allclose(f12[:3], f8[:3], rtol=0.01)


def test_rigid_wheel_receptance_is_a_mass():
    f = np.array([10.0, 100.0])
    a = wheels.RigidWheel(mass=500.0).receptance(f)
    assert np.allclose(a, -1 / ((2 * np.pi * f) ** 2 * 500.0))
    with pytest.raises(ValueError, match="mass"):
        wheels.RigidWheel(mass=-1.0)


def test_tabulated_wheel_round_trip(tmp_path):
    f = np.geomspace(50, 5000, 40)
    rec = wheels.RigidWheel(mass=700.0).receptance(f)
    frf = FRF(frequency=f, values=1j * 2 * np.pi * f * rec, quantity="mobility",
              response=("wheel",), force=("contact",))
    path = write_frf_csv(tmp_path / "wheel.csv", frf)
    tab = wheels.read_wheel_mobility(path)
    fi = np.array([63.0, 1000.0, 4000.0])
    assert np.allclose(tab.receptance(fi), wheels.RigidWheel(mass=700.0).receptance(fi),
                       rtol=1e-9)
    with pytest.raises(ValueError, match="covers"):
        tab.receptance([20.0])


def test_harmonic_without_modes_below_the_cut_off():
    mesh = wheelfe.rectangle_mesh(0.45, 0.46, -0.005, 0.005, 2, 2)
    hm = wheelfe.harmonic_modes(wheelfe.assemble(mesh), 12, 10.0)
    assert hm.frequency.size == 0 and hm.shapes.shape[0] == 0
    assert hm.residual[0, 0] > 0  # all of the harmonic's compliance is residual
