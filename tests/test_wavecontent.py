"""Per-wave contributions and cross-section content (railfem.track.wavecontent).

Independent checks: the per-wave contributions of the continuously supported rail sum to
the transfer of railfem.track.wfe.continuous_receptance (its own residue sum) and, for a
point load, each is the residue term -i R phi (psi^T F / d) exp(-i k x) written out; the
lateral bending waves of a slender rectangular bar on a lateral Winkler bed have the
Euler-Bernoulli wavenumbers k^4 = (omega^2 m - s*) / (E* I) with I = h w^3 / 12 (the bed
acts on the lateral motion in proportion to the mass, so it is a Winkler bed through the
centroid); the content of a rigid roll about the foot is read back exactly."""

import dataclasses

import numpy as np
import pytest
import scipy.sparse as sp

from railfem import models
from railfem.materials import Material
from railfem.rail import meshing, mobility, profiles, waveguide
from railfem.rail.mobility import wave_sum, wave_terms
from railfem.rail.waves import FamilyOperators, waves_at
from railfem.track import supports
from railfem.track import wfe as track
from railfem.track.wavecontent import (
    continuous_wave_sets, section_content, wave_contributions)

SITE = supports.PRESETS["site"]


@pytest.fixture(scope="module")
def rail():
    g = waveguide.assemble(meshing.get_mesh("60E1", 0.02), Material.steel(0.01))
    side = models.head_side(g)
    load = mobility.surface_patch(g, side, 0.02, "y", label="lateral", along="z")
    out = mobility.point(g, waveguide.nearest_boundary_node(g, *side), "y")
    return g, load, out


@pytest.mark.parametrize("params, directions", [
    (SITE, "zyx"), (dataclasses.replace(SITE, k_roll=1e6, eta_roll=0.25), "zyxr")])
def test_contributions_sum_to_the_continuous_transfer(rail, params, directions):
    g, load, out = rail
    f = np.array([100.0, 160.0])
    x = np.array([-19.8, -3.0, -0.6, 0.0, 0.005, 0.02, 1.2, 6.0])
    sets = continuous_wave_sets(g, params, 0.6, f, load=load, outputs=[out],
                                directions=directions)
    direct = track.continuous_receptance(g, params, 0.6, f, load=load, outputs=[out], x=x,
                                         load_length=0.02, directions=directions)
    for i, fam_sets in enumerate(sets):
        assert {fr.ops.family for fr, _ in fam_sets} == {"symmetric", "antisymmetric"}
        c = sum(wave_contributions(fr, w, x, 0.02, 0.0).sum(axis=0) for fr, w in fam_sets)
        ref = direct.receptance[i, :, :, :]
        assert np.max(np.abs(c - ref)) < 1e-9 * np.max(np.abs(ref))
        for fr, w in fam_sets:
            each = wave_contributions(fr, w, x, 0.02, 0.0)
            assert each.shape == (len(w.k), 1, len(x), 1)
            assert np.allclose(each.sum(axis=0), wave_sum(fr, w, x, 0.02, 0.0),
                               rtol=0, atol=1e-12 * np.abs(ref).max())


def test_a_contribution_is_the_residue_term(rail):
    g, load, out = rail
    ops = track.supported_operators(g, SITE, 0.6, "antisymmetric", "zyx")
    fr = mobility.FamilyResponse(g, "antisymmetric", load.weights[:, None],
                                 out.weights[:, None])
    w = waves_at(ops, 2 * np.pi * 160.0, method="shift-invert", n_waves=12)
    x = np.array([0.3, 2.0, -2.0])
    c = wave_contributions(fr, w, x)[:, 0, :, 0]
    T = g.families["antisymmetric"].T
    flip = np.where(g.families["antisymmetric"].component == 0, -1.0, 1.0)
    for n in range(len(w.k)):
        phi = T @ w.phi[:, n]
        psi = T @ (flip * w.phi[:, n])  # left eigenvector: axial DOFs flipped
        amp = -1j * (out.weights @ phi) * (psi @ load.weights) / w.denom[n]
        assert c[n, 0] == pytest.approx(amp * np.exp(-1j * w.k[n] * 0.3), rel=1e-10)
        assert c[n, 1] == pytest.approx(amp * np.exp(-2j * w.k[n]), rel=1e-10)
    # backward: the mirrored load and response (same channel on the same side) agree
    assert np.allclose(c[:, 2], c[:, 1], rtol=1e-8, atol=1e-8 * np.abs(c).max())
    assert wave_terms(fr, w)[0].shape == (1, len(w.k))


def test_lateral_bending_on_a_winkler_bed_is_euler_bernoulli():
    """Bar 20 mm wide, 60 mm high: (k r)^2 < 1e-3 at these k, so Euler-Bernoulli holds to
    ~5e-4 in k; a wrong bed (e.g. s/2) or the vertical I would miss by > 10 %."""
    width, height = 0.02, 0.06
    mat = Material.steel(0.01)
    g = waveguide.assemble(meshing.get_mesh(profiles.get_profile("rect:20x60"), 0.005), mat)
    fam = "antisymmetric"
    ops = FamilyOperators(g, fam)
    T = g.families[fam].T
    on_y = np.zeros(g.n_dofs)
    on_y[g.node_dofs[:, 1]] = 1.0
    My = sp.diags(on_y) @ g.M @ sp.diags(on_y)
    area = width * height
    bed = (T.T @ My @ T).tocsr()[ops.order][:, ops.order] / (mat.rho * area)
    EI = mat.E * height * width ** 3 / 12 * (1 + 0.01j)
    m = mat.rho * area
    for s, f in ((3e6 * (1 + 0.3j), 20.0), (3e6 * (1 + 0.3j), 60.0), (2e5 * (1 + 0.1j), 80.0)):
        ops.extra = lambda omega, s=s: s * bed
        omega = 2 * np.pi * f
        w = waves_at(ops, omega, method="dense")
        content = section_content(g, T, w.phi[:, :6])
        bending = w.k[:6][content.lateral > 0.99]
        r = ((omega ** 2 * m - s) / EI) ** 0.25 * 1j ** np.arange(4)
        exact = np.sort_complex(r[r.imag < 0])
        assert len(bending) == 2
        got = np.sort_complex(bending)
        assert np.allclose(got, exact, rtol=1.5e-3)
        assert np.allclose(-8.686 * got.imag, -8.686 * exact.imag, rtol=3e-3)


def test_content_of_a_rigid_roll_about_the_foot(rail):
    g, _, _ = rail
    u = np.zeros(g.n_dofs, dtype=complex)
    y, z = g.nodes[:, 0], g.nodes[:, 1] - g.nodes[:, 1].min()
    u[g.node_dofs[:, 1]] = -z  # turning about the foot underside's middle
    u[g.node_dofs[:, 2]] = y
    sc = section_content(g, sp.identity(g.n_dofs, format="csr"), u[:, None])
    assert sc.pivot_z[0] == pytest.approx(0.0, abs=1e-12)
    assert sc.lateral[0] + sc.roll[0] == pytest.approx(1.0, abs=1e-12)
    assert sc.deformation[0] < 1e-12 and sc.axial[0] == 0.0 and sc.vertical[0] < 1e-24
    # the centroid's lateral motion -z_C: its energy m z_C^2 against the roll's J_C
    m = (u.conj() @ (g.M @ u)).real
    assert sc.roll[0] > 0.3 and sc.lateral[0] > 0.5 and m > 0
    assert abs(sc.head_y[0]) > 5 * abs(sc.foot_y[0])
    pure = np.zeros(g.n_dofs)
    pure[g.node_dofs[:, 1]] = 1.0  # a lateral translation: no roll, pivot at infinity
    sc = section_content(g, sp.identity(g.n_dofs, format="csr"), pure[:, None])
    assert sc.lateral[0] == pytest.approx(1.0, abs=1e-12) and np.isinf(sc.pivot_z[0])
    assert sc.head_y[0] == pytest.approx(1.0) and sc.foot_y[0] == pytest.approx(1.0)
