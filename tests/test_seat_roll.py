"""The rail seat under the foot springs (SupportParameters.seat): 'rigid' (default) holds the
foot's roll by the pad alone, 'per_spring' (the published chain per spring) lets the seat
roll with the foot against the springs' shares of the sleeper mass.

Independent checks: the roll stiffness of the springs on a held seat against the closed
form sum_j k_j y_j^2 (kp* W^2 / 12 (1 - 1/n^2) for n midpoint springs over the foot width
W); the WFE bar on the continuous support against the bending-torsion beam with the
rotational foundation kp* W^2 / 12 per support (a rigid section: the beam is its exact
low-frequency limit); a rigid, massive sleeper holds the seat in both forms, so they agree
(the clamped-seat limit); vertical loads on the mirror plane give the same response in
both forms; reciprocity between a vertical and a lateral load on the rigid seat."""

from dataclasses import replace

import numpy as np
import pytest

import railfem as rf
from railfem import models
from railfem.rail import mobility, waveguide
from railfem.spec import RailSpec, spec_from_dict, spec_to_dict
from railfem.track import directions, lateral_beam, supports
from railfem.track import wfe as track

SITE = supports.PRESETS["site"]
PER_SPRING = replace(SITE, seat="per_spring")
W = 2 * np.pi * np.array([20.0, 95.0, 160.0, 370.0, 2000.0])


@pytest.fixture(scope="module")
def rail(lateral_rail):
    return lateral_rail  # tests/conftest.py


@pytest.mark.parametrize("n", [4, 8])
def test_held_seat_roll_stiffness_is_the_pads_width_moment(rail, n):
    """A rigid roll theta of the foot loads the vertical springs' difference columns: the
    moment is sum_c K_c (w_c . u)^2 theta, which for the rigid seat must be kp* sum_j
    s_j y_j^2 = kp* W^2 / 12 (1 - 1/n^2) (n equal strips of the foot width W, springs at
    their centres), and for the per-spring chain the same with K_s(omega) in place of kp*."""
    g = rail[0]
    springs = track.foot_springs(g, n, rule="midpoint", directions="zy")
    under = g.nodes[g.node_sets["foot_underside"], 0]
    width, yc = under.max() - under.min(), (under.max() + under.min()) / 2
    u = np.zeros(g.n_dofs)
    u[g.node_dofs[:, 2]] = g.nodes[:, 0] - yc  # unit roll about the foot centre
    cols = [(loc, s) for loc, s, d in zip(springs.others, springs.other_weight,
                                          springs.other_direction) if d == directions.PAD_ROLL]
    assert len(cols) == n // 2
    moment = sum(s * (loc.weights @ u) ** 2 for loc, s in cols)  # per unit column stiffness
    closed = width ** 2 / 12 * (1 - 1 / n ** 2)
    assert moment == pytest.approx(closed, rel=1e-10)
    held = directions.directional_stiffness(SITE, W, directions.PAD_ROLL)
    np.testing.assert_allclose(held * closed, SITE.kp_complex * closed, rtol=1e-14)
    old = directions.directional_stiffness(PER_SPRING, W, directions.PAD_ROLL)
    np.testing.assert_allclose(old, supports.dynamic_stiffness(SITE, W), rtol=1e-14)
    # the kernel gives these columns their own code, so the coupling can tell them apart
    _, share, code = track.spring_columns(g, springs, ["antisymmetric"])
    assert np.count_nonzero(code == track.PAD_ROLL_CODE) == n // 2


@pytest.fixture(scope="module")
def bar(solid_bar):
    return solid_bar  # tests/conftest.py


def test_continuous_rigid_seat_against_bending_torsion_beam(bar):
    """WFE bar on the continuous support ('zy', the default rigid seat) against the lateral
    beam with k_theta = kp* W^2 / 12 / d (the pad on a seat that does not roll; W = 0.1 m)
    and the lateral chain K_y / d at the foot: within 0.2 dB at 50-315 Hz up to 2 m from the
    load (measured 0.11 dB). The per-spring seat's roll restraint, K_s W^2 / 12 / d, is far
    from it (> 3 dB): the check sees the seat."""
    g, lat = bar
    f = np.array([50.0, 80.0, 125.0, 200.0, 315.0])
    x = np.array([0.0, 0.5, 1.0, 2.0])
    side = models.head_side(g)
    out = mobility.point(g, waveguide.nearest_boundary_node(g, *side), "y")
    ls = lateral_beam.LateralSection.from_mesh(g.mesh, g.material)
    P = ls.point(*side, "y")
    w = 2 * np.pi * f
    beam = lateral_beam.lateral_receptance(
        ls, w, x, [P], [P], k_y=directions.directional_stiffness(SITE, w, "y") / 0.6,
        k_theta=SITE.kp_complex * 0.1 ** 2 / 12 / 0.6, z_spring=float(g.nodes[:, 1].min()),
        load_length=0.02)[:, 0, :, 0]
    kw = dict(load=lat, outputs=[out], x=x, directions="zy", load_length=0.02)
    rigid = track.continuous_receptance(g, SITE, 0.6, f, **kw).receptance[:, 0, :, 0]
    old = track.continuous_receptance(g, PER_SPRING, 0.6, f, **kw).receptance[:, 0, :, 0]
    db = 20 * np.log10(np.abs(rigid / beam))
    assert np.abs(db).max() < 0.2, np.round(db, 3).tolist()
    assert np.abs(20 * np.log10(np.abs(old / beam))).max() > 3.0


def test_massive_sleeper_holds_the_seat_in_both_forms(rail):
    """With a rigid, massive sleeper (1e14 kg per rail) the per-spring chain is the pad on a
    clamped seat, K_s -> kp*, which is what the rigid seat gives the roll: the two forms
    agree on a lateral load to 1e-8; at the site's 120 kg they do not."""
    g, _, lat = rail
    kw = dict(load=lat, outputs=[lat], force_x=[0.0], response_x=[0.0, 0.6, 1.8],
              directions="zy", n_f=4, load_length=0.02, response_length=0.02)
    f = [95.0, 160.0, 400.0]

    def run(p):
        lay = supports.uniform_layout(p, 0.6, 9)
        return track.discrete_receptance(g, lay, f, **kw).receptance

    heavy = replace(SITE, ms=1e14)
    a, b = run(heavy), run(replace(heavy, seat="per_spring"))
    assert np.abs(a - b).max() < 1e-8 * np.abs(a).max()
    c, d = run(SITE), run(PER_SPRING)
    assert np.abs(c - d).max() > 0.1 * np.abs(d).max()


@pytest.mark.parametrize("model", ["wfe-periodic", "wfe-discrete", "wfe-continuous"])
def test_vertical_centred_response_is_the_same_for_both_seats(model):
    """A vertical load on the mirror plane does not excite the roll: with springs in every
    direction the vertical head receptances of the two seats are equal (measured: equal to
    the last bit; asserted 1e-12)."""
    spec = rf.preset("site", model=model, support_directions="zyx", n_supports=21,
                     rail=RailSpec(h=0.02))
    old = spec.replace(support=replace(spec.support, seat="per_spring"))
    f = [60.0, 370.0, 1500.0]
    a = models.receptance(spec, f, [0.0], [0.0, 1.2], cache=False)
    b = models.receptance(old, f, [0.0], [0.0, 1.2], cache=False)
    assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max()


def test_reciprocity_vertical_lateral_on_the_rigid_seat(rail):
    """Y_AB(x_r, x_f) = Y_BA(x_f, x_r) between an off-centre vertical load A and a lateral
    load B on discrete supports with the rigid seat (both families excited)."""
    g, A, B = rail
    lay = supports.uniform_layout(SITE, 0.6, 11)
    f = [95.0, 250.0, 1200.0]
    kw = dict(outputs=[A, B], load_length=0.02, response_length=0.02, n_f=4,
              directions="zyx", force_x=[0.1, 0.45], response_x=[0.1, 0.45])
    rA = track.discrete_receptance(g, lay, f, load=A, **kw).receptance
    rB = track.discrete_receptance(g, lay, f, load=B, **kw).receptance
    ab, ba = rB[:, 0], rA[:, 1].transpose(0, 2, 1)
    assert np.abs(ab - ba).max() < 1e-8 * np.abs(ab).max()


def test_seat_option_is_checked_and_kept_by_the_spec():
    with pytest.raises(ValueError, match="seat"):
        replace(SITE, seat="flexible")
    spec = rf.preset("site", support_directions="zy")
    assert spec.support.seat == "rigid"
    old = spec.replace(support=replace(spec.support, seat="per_spring"))
    assert spec_from_dict(spec_to_dict(old)).support.seat == "per_spring"
    # a massless hanging seat holds nothing: the chain's own zero
    loose = replace(SITE, ms=0.0, kb=0.0)
    assert np.all(directions.directional_stiffness(loose, W, directions.PAD_ROLL) == 0)
