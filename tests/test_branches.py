"""Dispersion branches followed by mode-shape continuity (railfem.rail.branches)."""
import numpy as np
import pytest

from railfem.rail import branches
from railfem.rail import meshing
from railfem.rail import section
from railfem.rail import waveguide
from railfem.rail import waves
from railfem.materials import Material


# ------------------------------------------------------------------ the tracking core
def test_mac_is_one_for_parallel_and_zero_for_orthogonal_shapes():
    a = np.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])
    b = np.array([[2j, 0.0], [0.0, 0.0], [0.0, 3.0]])
    m = branches.mac(a, b)
    assert m == pytest.approx(np.array([[1.0, 0.0], [0.0, 0.0]]))
    W = np.diag([1.0, 4.0, 1.0])  # in a weighted metric (1, 1, 0) and (1, -1/4, 0)...
    u = np.array([[1.0], [1.0], [0.0]])
    v = np.array([[1.0], [-0.25], [0.0]])
    assert branches.mac(u, v, W)[0, 0] == pytest.approx(0.0, abs=1e-15)  # ...are orthogonal
    assert branches.mac(u, v)[0, 0] > 0.1
    with pytest.raises(ValueError, match="same n"):
        branches.mac(a, b[:2])


def crossing_sweep(n=21):
    """Two fixed orthogonal shapes whose 'wavenumbers' cross at the middle of the sweep;
    at each point the columns are sorted by wavenumber, as a solver returns them. A third
    shape appears at point 15 (a cut-on)."""
    e = np.eye(4)
    x = np.linspace(0, 1, n)
    k_a, k_b = 1 + 2 * x, 2 - 0 * x  # cross at x = 0.5
    shapes, ks = [], []
    for i in range(n):
        cols = [(k_a[i], e[:, 0] * (1 + 0.1j)), (k_b[i], e[:, 1] + 0.05 * e[:, 3])]
        if i >= 15:
            cols.append((0.1 * i, e[:, 2]))
        cols.sort(key=lambda c: c[0])
        ks.append(np.array([c[0] for c in cols]))
        shapes.append(np.column_stack([c[1] for c in cols]))
    return shapes, ks, k_a, k_b


def test_track_keeps_each_branch_through_a_crossing():
    shapes, ks, k_a, k_b = crossing_sweep()
    index = branches.track(shapes)
    assert index.shape == (21, 3)
    got_a = np.array([ks[p][index[p, 0]] for p in range(21)])
    got_b = np.array([ks[p][index[p, 1]] for p in range(21)])
    assert got_a == pytest.approx(k_a) and got_b == pytest.approx(k_b)
    # the solver's column order swaps at the crossing: following columns would not
    assert ks[0][0] == pytest.approx(k_a[0]) and ks[-1][0] != pytest.approx(k_a[-1])
    # the cut-on starts a third branch at point 15
    assert np.all(index[:15, 2] == -1) and np.all(index[15:, 2] >= 0)


def test_track_follows_a_slowly_turning_shape_and_splits_at_a_jump():
    angles = np.linspace(0, np.pi / 2, 31)  # 3 degrees per step: a veering
    shapes = [np.array([[np.cos(a)], [np.sin(a)], [0.0]]) for a in angles]
    assert np.all(branches.track(shapes)[:, 0] == 0)  # one branch although the end is
    assert branches.track(shapes).shape[1] == 1        # orthogonal to the start
    jump = shapes[:10] + [np.array([[0.0], [0.0], [1.0]])] + shapes[10:]
    index = branches.track(jump, max_gap=0)
    assert index.shape[1] == 3  # the unrelated shape and what follows it start branches
    with pytest.raises(ValueError, match="min_mac"):
        branches.track(shapes, min_mac=0.0)


def test_branch_labels_vote_over_the_start_in_sweep_measure():
    lab = np.array([["a"], ["a"], ["b"], ["b"], ["b"], ["b"], ["b"]], dtype=object)
    pos = np.array([0.0, 1.0, 2.0, 2.1, 2.2, 2.3, 10.0])
    # first window 2.5: 'a' covers 0-1.5, 'b' 1.5-2.5 (one unit): 'a' wins on measure,
    # though 'b' has more points
    assert branches.branch_labels(lab, pos, 2.5)[0] == "a"
    assert branches.branch_labels(lab, pos, 100.0)[0] == "b"  # the whole branch
    assert branches.branch_labels(np.array([["", ""]], dtype=object), [0.0], 1.0).tolist() \
        == ["", ""]


def test_branch_names_are_unique_words():
    names = branches.branch_names(["torsion", "cross-section (sym.)", "cross-section (sym.)"],
                                  [50.0, 4200.0, 9800.0])
    assert names.tolist() == ["torsion", "symmetric cross-section wave, from 4.2 kHz",
                              "symmetric cross-section wave, from 9.8 kHz"]


# ------------------------------------------------------------- 60E1, h = 20 mm, k(omega)
@pytest.fixture(scope="module")
def guide():
    return waveguide.assemble(meshing.get_mesh("60E1", 0.02), Material.steel(0.0))


@pytest.fixture(scope="module")
def kw(guide):
    f = np.geomspace(50.0, 5000.0, 46)
    return branches.k_of_omega(guide, f, n_waves=30)


def branch(br, name):
    (j,) = np.nonzero(br.name == name)[0]
    return br.frequency[:, j], br.k[:, j], j


def test_k_of_omega_has_one_named_branch_per_wave(kw, guide):
    assert sorted(kw.name) == sorted([
        "longitudinal", "vertical bending", "lateral bending", "torsion", "web bending",
        "antisymmetric cross-section wave"])
    for name in ("longitudinal", "vertical bending", "lateral bending", "torsion"):
        f, k, j = branch(kw, name)
        assert np.all(np.isfinite(k)), f"{name} is broken into pieces"
        assert np.all(np.diff(k.real) > 0)  # positive group velocity all along
        # neighbours on a branch have alike shapes; on the curved mesh the symmetric
        # foot-flapping cut-on is at 5040 Hz (5128 Hz straight-sided), so the longitudinal
        # wave veers over the last step below 5 kHz (MAC 0.80): checked up to 4.5 kHz
        below = f[1:] < 4500
        assert np.nanmin(kw.mac[1:, j][below]) > 0.9
    # the labeller alone switches along the torsion branch (the bug); the branch keeps one
    f, k, j = branch(kw, "torsion")
    assert len(set(kw.point_label[:, j])) > 1 and kw.label[j] == "torsion"


def test_cut_on_branches_start_at_the_k0_cut_on_frequencies(kw, guide):
    """Independent: the cut-on frequencies are eigenvalues of the k = 0 section problem."""
    f_cut = waves.cut_on_frequencies(guide, 4, family="antisymmetric")
    for name, fc in (("web bending", f_cut[0]), ("antisymmetric cross-section wave", f_cut[1])):
        f, k, j = branch(kw, name)
        first = np.flatnonzero(np.isfinite(f))[0]
        assert kw.frequency[first - 1, 0] < fc <= f[first] * 1.001


def test_longitudinal_and_bending_branches_meet_beam_theory(kw, guide):
    """Independent: bar and Euler-Bernoulli beam wavenumbers from the section constants."""
    m = Material.steel()
    f, k, _ = branch(kw, "longitudinal")
    low = f <= 200
    assert k[low].real == pytest.approx(2 * np.pi * f[low] / np.sqrt(m.E / m.rho), rel=2e-3)
    sc = section.section_constants(guide.mesh)
    for name, inertia in (("vertical bending", sc.I_y), ("lateral bending", sc.I_z)):
        f, k, _ = branch(kw, name)
        kb = ((2 * np.pi * f[:3]) ** 2 * m.rho * sc.area / (m.E * inertia)) ** 0.25
        assert k[:3].real == pytest.approx(kb, rel=0.03), name


def test_branches_cross_without_swapping(kw):
    """Vertical bending and torsion cross near 400 Hz; each keeps its own slope
    d ln k / d ln f through the crossing, and the two slopes differ: a swap of branches at
    the crossing would show as a jump of slope."""
    f, k_v, _ = branch(kw, "vertical bending")
    _, k_t, _ = branch(kw, "torsion")
    d = k_v.real - k_t.real
    # the first crossing; on the curved mesh they cross again at 4.5 kHz, where vertical
    # bending bends towards the 5040 Hz foot-flapping cut-on
    i = np.nonzero(np.diff(np.sign(d)))[0][0]
    assert 250 < f[i] < 600
    lnf = np.log(f)

    def slope(k, a, b):
        return (np.log(k[b].real) - np.log(k[a].real)) / (lnf[b] - lnf[a])

    for k in (k_v, k_t):
        before, after = slope(k, i - 2, i), slope(k, i + 1, i + 3)
        assert after == pytest.approx(before, rel=0.08)
    assert abs(slope(k_v, i - 2, i) - slope(k_t, i - 2, i)) > 0.15


def test_frequencies_must_increase(guide):
    with pytest.raises(ValueError, match="increasing"):
        branches.k_of_omega(guide, [100.0, 50.0])
    with pytest.raises(ValueError, match="increasing"):
        branches.omega_of_k(guide, [1.0, 1.0])


# ------------------------------------------------------------- 60E1, h = 20 mm, omega(k)
@pytest.fixture(scope="module")
def wk(guide):
    return branches.omega_of_k(guide, np.linspace(0.1, 12.0, 25), n_modes=6)


def test_omega_of_k_names_the_longitudinal_branch(wk):
    """The old omega(k) plot named columns of ascending frequency by their majority label,
    which dropped the longitudinal branch from the legend."""
    assert {"longitudinal", "vertical bending", "lateral bending", "torsion"} <= set(wk.name)
    f, k, _ = branch(wk, "longitudinal")
    c = np.sqrt(Material.steel().E / Material.steel().rho)
    low = k.real <= 2.0
    assert f[low] == pytest.approx(c * k[low].real / (2 * np.pi), rel=2e-3)
    assert len(set(wk.name)) == wk.n_branches


def test_cut_ons_are_the_k0_frequencies_with_names(guide):
    cuts = branches.cut_ons(guide, 1000.0, 6000.0)
    f_ref = waves.cut_on_frequencies(guide, 8)
    assert [c.frequency for c in cuts] == pytest.approx(f_ref[(f_ref >= 1000) & (f_ref <= 6000)])
    sym = [c for c in cuts if c.family == "symmetric"]
    assert [c.label for c in sym] == ["foot flapping", "foot flapping"]
    assert [c.axial for c in sym] == [True, False]
    assert sym[0].name == "foot flapping (axial)"
    assert branches.cut_ons(guide, 100.0, 1000.0) == []
