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

from railfem.wheelrail import wheelfe
from railfem.wheelrail import wheels
from railfem.response import FRF
from railfem.io.frf_csv import write_frf_csv
from railfem.io.wheel_frf import read_wheel_frf, write_wheel_frf

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
    tab = read_wheel_frf(path)
    fi = np.array([63.0, 1000.0, 4000.0])
    assert np.allclose(tab.receptance(fi), wheels.RigidWheel(mass=700.0).receptance(fi),
                       rtol=1e-9)
    with pytest.raises(ValueError, match="covers"):
        tab.receptance([20.0])
    # write -> read gives the same table
    back = read_wheel_frf(write_wheel_frf(tmp_path / "again.csv", tab))
    assert np.array_equal(back.frequency, tab.frequency)
    assert np.array_equal(back.values, tab.values)


def test_harmonic_without_modes_below_the_cut_off():
    mesh = wheelfe.rectangle_mesh(0.45, 0.46, -0.005, 0.005, 2, 2)
    hm = wheelfe.harmonic_modes(wheelfe.assemble(mesh), 12, 10.0)
    assert hm.frequency.size == 0 and hm.shapes.shape[0] == 0
    assert hm.residual[0, 0] > 0  # all of the harmonic's compliance is residual


def _wheel_3d_frequencies(section, h, k=24):
    """Independent check: the wheel section revolved by Gmsh into a 3-D solid, P2
    tetrahedra, scikit-fem linear elasticity, bore clamped; the k lowest frequencies (Hz)."""
    import gmsh
    import scipy.sparse.linalg as spla
    from skfem import Basis, BilinearForm, ElementTetP2, ElementVector, MeshTet
    from skfem.helpers import dot
    from skfem.models.elasticity import lame_parameters, linear_elasticity

    gmsh.initialize(["-noenv"], readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        pts = [occ.addPoint(r, 0.0, z) for r, z in section.outline()]
        lines = [occ.addLine(pts[i], pts[(i + 1) % len(pts)]) for i in range(len(pts))]
        surf = occ.addPlaneSurface([occ.addCurveLoop(lines)])
        occ.revolve([(2, surf)], 0, 0, 0, 0, 0, 1, 2 * math.pi)
        occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.MeshSizeMin", h / 3)
        gmsh.model.mesh.generate(3)
        tags, coords, _ = gmsh.model.mesh.getNodes()
        types, _, nodes = gmsh.model.mesh.getElements(3)
    finally:
        gmsh.finalize()
    xyz = coords.reshape(-1, 3)
    index = {int(t): i for i, t in enumerate(tags)}
    tet = np.array([index[int(t)] for t in nodes[list(types).index(4)]]).reshape(-1, 4)
    used = np.unique(tet)
    remap = -np.ones(len(xyz), dtype=int)
    remap[used] = np.arange(len(used))
    mesh = MeshTet(xyz[used].T.copy(), remap[tet].T.copy())
    basis = Basis(mesh, ElementVector(ElementTetP2()))
    K = linear_elasticity(*lame_parameters(E, NU)).assemble(basis)

    @BilinearForm
    def mass(u, v, w):
        return RHO * dot(u, v)

    M = mass.assemble(basis)
    bore = mesh.facets_satisfying(lambda x: np.hypot(x[0], x[1]) < section.bore_radius + 3e-3)
    free = basis.complement_dofs(basis.get_dofs(bore).all())
    lam, _ = spla.eigsh(K[free][:, free].tocsc(), k=k, M=M[free][:, free].tocsc(),
                        sigma=-(2 * np.pi * 20) ** 2, which="LM")
    return np.sort(np.sqrt(np.abs(lam)) / (2 * np.pi))


@pytest.mark.slow
def test_default_wheel_modes_match_a_3d_solid_model():
    """The axisymmetric harmonic model of the default 920 mm wheel (bore clamped) against a
    3-D P2-tetrahedral model of the same wheel (h = 35 mm, 46k DOFs, about a minute and
    1.1 GB): the first axial modes n = 2, 3, 4 and the first radial (ovalisation) mode
    n = 2. The coarse 3-D mesh is stiffer: it must lie 0 to 3 % above, and n >= 1 modes
    must come as pairs (cos and sin)."""
    sec = wheelfe.WheelSection()
    axi = wheelfe.assemble(wheelfe.mesh_section(sec, 0.008), axle_mass=math.inf)
    f3 = _wheel_3d_frequencies(sec, 0.035)
    checks = {  # (n, index of the mode in the harmonic): what it is
        (2, 0): "axial, n = 2", (3, 0): "axial, n = 3", (4, 0): "axial, n = 4",
        (2, 2): "radial, n = 2"}
    for (n, k), what in checks.items():
        fa = wheelfe.harmonic_modes(axi, n, 2600.0).frequency[k]
        near = f3[np.argsort(np.abs(f3 - fa))[:2]]
        assert np.all((near / fa > 0.995) & (near / fa < 1.03)), (what, fa, near)
