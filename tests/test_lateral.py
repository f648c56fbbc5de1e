"""Supports in three directions, lateral loads, both wave families (issue 15).

Independent checks: the sum/difference spring columns against the same springs taken one by
one (no pairing), the mirror-split coupling against the plain dense solve, reciprocity
between a vertical and a lateral load (both families active), the WFE rail on a continuous
support against the lateral bending-torsion beam (railfem.track.lateral_beam.LateralSection) at low
frequency, discrete vs periodic supports, and vertical results unchanged by the new
horizontal fields when the supports act vertically only."""

from dataclasses import replace

import numpy as np
import pytest

import railfem as rf
from railfem import models
from railfem.track import beams, lateral_beam
from railfem.track import coupling
from railfem.track import directions
from railfem.track import footprints
from railfem.rail import meshing
from railfem.rail import mobility
from railfem.rail import section
from railfem.track import supports
from railfem.track import wfe as track
from railfem.rail import waveguide
from railfem.materials import Material
from railfem.spec import RailSpec


@pytest.fixture(scope="module")
def rail(lateral_rail):
    return lateral_rail  # tests/conftest.py


SITE = supports.PRESETS["site"]
PER_SPRING = replace(SITE, seat="per_spring")


def test_horizontal_fields_are_additive():
    p = supports.SupportParameters(kp=3e8, kb=5e7)
    assert p.kp_lat == 0 and p.kp_long == 0 and np.isinf(p.kb_lat)
    assert not directions.acts_in(p, "y") and directions.acts_in(SITE, "y")
    w = 2 * np.pi * np.array([10.0, 300.0])
    # lateral chain: pad in series with the sleeper on its horizontal ballast support
    kp, kb = SITE.kp_lat * (1 + 1j * SITE.eta_p_lat), SITE.kb_lat * (1 + 1j * SITE.eta_b_lat)
    z = kb - w**2 * SITE.ms_lat
    assert np.allclose(directions.directional_stiffness(SITE, w, "y"), kp * z / (kp + z))
    assert np.allclose(directions.directional_stiffness(p, w, "y"), 0)
    with pytest.raises(ValueError, match="kp_lat"):
        supports.SupportParameters(kp=1e8, kb=1e8, kp_lat=-1.0)
    voided = rf.spec.SupportDeviation(index=0, kb=0.0).apply(SITE)
    assert voided.kb == 0 and voided.kb_lat == 0  # voided in every direction


def test_sum_and_difference_columns_equal_independent_springs(rail):
    """The mirror pairs' sum/difference columns are exact: the same springs entered one by
    one (each its own column, no pairing, no family argument) give the same response to a
    lateral load, with vertical, lateral and longitudinal springs. Springs one by one are
    independent chains: the seat 'per_spring' (the default rigid seat holds the foot's
    roll by the pad alone: tests/test_seat_roll.py)."""
    g, _, lat = rail
    paired = track.foot_springs(g, 4, rule="midpoint", directions="zyx")
    singles, share, dirs = [], [], []
    for d in "zyx":
        reads, _, sh = footprints.spring_reads(g, 4, "midpoint", track.COMPONENT[d])
        for j, r in enumerate(reads):
            singles.append(mobility.Location(label=f"s{j}{d}", weights=r))
            share.append(sh[j])
            dirs.append(d)
    single = track.FootSprings(pairs=tuple(singles[:4]), weight=np.array(share[:4]),
                               y=np.zeros(4), others=tuple(singles[4:]),
                               other_weight=np.array(share[4:]),
                               other_direction=tuple(dirs[4:]))
    lay = supports.uniform_layout(PER_SPRING, 0.6, 9)
    kw = dict(load=lat, outputs=[lat], force_x=[0.1], response_x=[0.1, 0.8])
    f = [150.0, 900.0]
    a = track.discrete_receptance(g, lay, f, n_f=paired, **kw).receptance
    b = track.discrete_receptance(g, lay, f, n_f=single, **kw).receptance
    assert np.abs(a - b).max() < 1e-9 * np.abs(b).max()


def test_mirror_split_with_longitudinal_springs_equals_dense_solve(rail):
    """Longitudinal springs flip sign under x -> -x: the even/odd split of couple_discrete
    (signed) against the plain solve of the same kernel (supports made asymmetric by a
    factor 1 + 1e-15 on one support, which disables the split)."""
    g, _, lat = rail
    springs = track.foot_springs(g, 4, rule="midpoint", directions="zyx")
    lay = supports.uniform_layout(SITE, 0.6, 7)
    f = np.array([200.0, 1200.0])
    kernel = track.discrete_kernel(g, springs, lay.springs().x, f, load=lat, outputs=[lat],
                                   force_x=[0.0, 0.25], response_x=[0.0, -0.4])
    K = track.spring_stiffness(lay, 2 * np.pi * f, kernel)
    split = coupling.couple_discrete(kernel, K)
    K2 = K.copy()
    K2[:, 0] *= 1 + 1e-15
    dense = coupling.couple_discrete(kernel, K2)
    assert np.abs(split - dense).max() < 1e-9 * np.abs(dense).max()



def test_family_split_equals_full_dense_solve(rail):
    """A lateral load loads springs on both symmetry families of the rail: couple_discrete
    solves them as two systems (spring_families: six columns each for four springs in
    three directions). Against the whole system (I + K alpha_ss) F = K alpha_sP solved
    here in one piece from the kernel's arrays."""
    g, _, lat = rail
    springs = track.foot_springs(g, 4, rule="midpoint", directions="zyx")
    lay = supports.uniform_layout(SITE, 0.6, 5)
    f = np.array([120.0, 700.0])
    kernel = track.discrete_kernel(g, springs, lay.springs().x, f, load=lat, outputs=[lat],
                                   force_x=[0.0, 0.3], response_x=[0.1, -0.5])
    groups = coupling.spring_families(kernel.ss)
    assert sorted(len(c) for c in groups) == [6, 6]
    K = track.spring_stiffness(lay, 2 * np.pi * f, kernel)
    got = coupling.couple_discrete(kernel, K)
    n_s, n_p, n_rx, n_fx = kernel.shape
    d = kernel.spring_direction
    for i in range(len(f)):
        k = (K[i][:, d] * kernel.spring_weight[None, :]).ravel()  # set-major springs
        A = kernel.ss[i][kernel.ss_index].transpose(0, 2, 1, 3).reshape(n_s * n_p, -1)
        B = kernel.sP[i][kernel.sP_index].transpose(0, 2, 1).reshape(n_s * n_p, n_fx)
        F = np.linalg.solve(np.eye(n_s * n_p) + k[:, None] * A, k[:, None] * B)
        G = kernel.rs[i][kernel.rs_index]  # (rx, s, o, p)
        want = kernel.rP[i][kernel.rP_index][..., 0] - np.einsum(
            "rsp,spf->rf", G[:, :, 0, :], F.reshape(n_s, n_p, n_fx))
        assert np.abs(got[i, 0] - want).max() < 1e-9 * np.abs(want).max()

@pytest.mark.parametrize("directions", ["zy", "zyx"])
def test_reciprocity_vertical_lateral(rail, directions):
    """Y_AB(x_r, x_f) = Y_BA(x_f, x_r) between an off-centre vertical load A and a lateral
    load B on the head (both families excited by each) on discrete supports acting in
    every direction; load and response are the same patches averaged over the same length.
    Measured: 1e-13 relative."""
    g, A, B = rail
    springs = track.foot_springs(g, 4, rule="midpoint", directions=directions)
    lay = supports.uniform_layout(SITE, 0.6, 11, pad_length=0.15, n_rows=3)
    f = [120.0, 700.0, 2500.0]
    kw = dict(outputs=[A, B], load_length=0.02, response_length=0.02, n_f=springs)
    rA = track.discrete_receptance(g, lay, f, load=A, force_x=[0.1, 0.45],
                                   response_x=[0.1, 0.45], **kw).receptance
    rB = track.discrete_receptance(g, lay, f, load=B, force_x=[0.1, 0.45],
                                   response_x=[0.1, 0.45], **kw).receptance
    # rA[f, out, rx, fx]: out 1 = B's response to load A; rB out 0 = A's response to B
    ab = rB[:, 0]  # response A, load B: (f, rx, fx)
    ba = rA[:, 1].transpose(0, 2, 1)  # response B at fx, load A at rx
    assert np.abs(ab - ba).max() < 1e-8 * np.abs(ab).max()
    assert np.abs(ab).max() > 1e-3 * np.abs(rB[:, 1]).max()  # the cross term is not tiny


def test_lateral_wfe_against_bending_torsion_beam_on_continuous_support(rail):
    """Lateral point and transfer receptances at the side of the head, WFE rail on the
    continuous support (lateral and vertical pads, 'zy') against the Timoshenko/Vlasov
    lateral beam on the same support (lateral stiffness at the foot underside, rotational
    stiffness from the vertical bed's width moment): within 0.5 dB at 50-125 Hz up to 2 m
    from the load (measured, 20 mm and 10 mm meshes alike: 0.19 dB at 50 Hz, 0.06 dB at
    80 Hz, 0.39 dB at 125 Hz; at 200 Hz the web's bending makes it 0.5-1.7 dB). On the
    seat 'per_spring', whose roll restraint is soft (mass-like above the sleeper's
    resonance): with the default rigid seat the pad holds the foot's roll and the 60E1 web
    bends, which the rigid-section beam cannot follow (the rigid seat against the beam on
    a solid bar: tests/test_seat_roll.py)."""
    g, _, lat = rail
    spec_sup = PER_SPRING
    f = np.array([50.0, 80.0, 125.0])
    x = np.array([0.0, 0.5, 1.0, 2.0])
    side = models.head_side(g)
    out = mobility.point(g, waveguide.nearest_boundary_node(g, *side), "y")
    wfe = track.continuous_receptance(g, spec_sup, 0.6, f, load=lat, outputs=[out], x=x,
                                      directions="zy", load_length=0.02).receptance[:, 0, :, 0]
    ls = lateral_beam.LateralSection.from_mesh(g.mesh, g.material)
    bed = track.foot_bed(g).diagonal()
    y = np.zeros(g.n_dofs)
    y[g.node_dofs[:, 2]] = g.nodes[:, 0]
    P = ls.point(*side, "y")
    bm = lateral_beam.lateral_track_receptance(ls, spec_sup, 0.6, 2 * np.pi * f, x, [P], [P],
                                        bed_moment=float(bed @ y**2),
                                        z_foot=float(g.nodes[:, 1].min()),
                                        load_length=0.02)[:, 0, :, 0]
    db = 20 * np.log10(np.abs(wfe / bm))
    print("WFE / beam (dB), rows 50, 80, 125 Hz; columns x = 0, 0.5, 1, 2 m:\n",
          np.round(db, 2))
    assert np.abs(db).max() < 0.5


def test_lateral_beam_decouples_to_timoshenko():
    """With the shear centre at the centroid and the foundation at the shear centre, the
    lateral beam's v is the plain Timoshenko beam in lateral bending (railfem.track.beams)."""
    m = Material.steel(0.02)
    ls = lateral_beam.LateralSection(E=m.E, G=m.G, rho=m.rho, eta=0.02, area=7.67e-3, I_z=5.12e-6,
                              kappa_y=0.55, J=2.2e-6, Gamma=1.6e-8, I_p=3.55e-5, z_s=0.05,
                              e=0.0)
    bs = beams.BeamSection(E=m.E, G=m.G, area=ls.area, I=ls.I_z, kappa=ls.kappa_y,
                           rho=m.rho, eta=0.02)
    w = 2 * np.pi * np.array([50.0, 300.0, 2000.0])
    x = np.array([0.0, 0.7, -1.3])
    a = lateral_beam.lateral_receptance(ls, w, x, [[1, 0, 0]], [[1, 0, 0]], k_y=3e7,
                                 z_spring=ls.z_s)[:, 0, :, 0]
    assert np.allclose(a, beams.supported_beam_receptance(bs, w, x, 3e7), rtol=1e-9)


def test_section_shear_centre_and_warping():
    """60E1: shear centre 46 mm above the foot, 35 mm below the centroid; Gamma 1.6e-8 m^6
    (the independent solution of tests/test_waveguide_physics.py gives the same)."""
    wp = section.warping(meshing.get_mesh("60E1", 0.01))
    assert 0.044 < wp["z_s"] < 0.048 and 0.033 < wp["e"] < 0.037
    assert 1.4e-8 < wp["Gamma"] < 1.8e-8


def test_discrete_and_periodic_lateral_agree():
    """The lateral head receptance of 61 discrete supports (re-centred on the pair) and of
    the periodic model agree where the truncation does not reach (high decay: 200 Hz)."""
    spec = rf.preset("site", rail=RailSpec(h=0.02, eta=0.02), n_supports=61,
                     support_directions="zy")
    f = [200.0, 700.0]
    d = models.receptance(spec, f, [0.3], [0.3, 0.9], outputs=("head_lateral",),
                          force="head_lateral", cache=False)
    p = models.receptance(spec.replace(model="wfe-periodic"), f, [0.3], [0.3, 0.9],
                          outputs=("head_lateral",), force="head_lateral", cache=False)
    assert np.abs(d - p).max() < 1e-3 * np.abs(p).max()


def test_vertical_results_unchanged_by_horizontal_fields():
    """support_directions 'z' (the default) ignores the presets' horizontal fields: equal
    to the same spec with vertical-only support parameters, to the last bit."""
    spec = rf.preset("site", rail=RailSpec(h=0.02), n_supports=21)
    plain = spec.replace(support=supports.SupportParameters(
        kp=SITE.kp, eta_p=SITE.eta_p, ms=SITE.ms, kb=SITE.kb, eta_b=SITE.eta_b))
    f = [150.0, 1000.0]
    a = models.receptance(spec, f, [0.3], [0.3, 1.2], cache=False)
    b = models.receptance(plain, f, [0.3], [0.3, 1.2], cache=False)
    assert np.array_equal(a, b)


def test_door_lateral_channels_and_errors():
    spec = rf.preset("site", rail=RailSpec(h=0.02), n_supports=21)
    with pytest.raises(ValueError, match="support_directions"):
        models.receptance(spec, [100.0], [0.0], [0.0], outputs=("head_lateral",))
    with pytest.raises(ValueError, match="Timoshenko"):
        models.receptance(spec.replace(model="timoshenko-discrete"), [100.0], [0.0], [0.0],
                          force="head_lateral")
    with pytest.raises(ValueError, match="side of the head"):
        models.foot(0.0, "y")
    with pytest.raises(ValueError, match="support_directions"):
        spec.replace(support_directions="y")
    lat = spec.replace(support_directions="yz")
    assert lat.support_directions == "zy"
    Y = models.frf(lat, [300.0], force=[models.head(0.3, "y"), models.head(0.3)],
                   response=[models.head(0.3, "y"), models.head(0.3)], cache=False)
    a = models.receptance(lat, [300.0], [0.3], [0.3], outputs=("head_lateral", "head"),
                          force="head_lateral", cache=False)
    assert np.allclose(Y.to("receptance").values[0, :, 0], a[0, :, 0, 0])
    assert rf.spec.spec_from_dict(rf.spec.spec_to_dict(lat)) == lat
