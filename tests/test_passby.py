"""The multi-wheel pass-by: closed forms, superposition and the simplified formula.

References independent of the pass-by solver: the single-wheel closed form
F = i omega r / (Y_rh + Y_c + Y_w) with the rail receptance taken straight from the beam
model (beams.discrete_track_receptance, not through the tables); the sum of one-wheel
simulations; METHOD.md section 8's formula with beta from the EN 15461 decay rate of the
same track (railfem.standards.en15461)."""

import numpy as np
import pytest

from railfem.track import beams
from railfem.wheelrail import contact
from railfem.wheelrail import roughness
from railfem.wheelrail import wheels
from railfem.simulate import passby as P
from railfem.io.train import read_train_layout
from railfem.simulate.train import TrainLayout, default_train, from_cars
from railfem.standards import en15461, iec61260
from railfem.track.supports import uniform_layout
from railfem.models import beam_section
from railfem.spec import preset as rf_preset
from railfem.spec import RailSpec

F = iec61260.ninth_octave_grid(200, 1000)
SPEED = 60.0


@pytest.fixture(scope="module")
def discrete_tables():
    # point supports: the closed form below uses beams.discrete_track_receptance on them
    spec = rf_preset("site", model="timoshenko-discrete", pad_length=0.0)
    return P.rail_tables(spec, F, max_distance=12.0)


def _inputs(f):
    h = contact.hertz()
    spec = roughness.sloped_spectrum(0.0, 10.0)
    r = roughness.amplitude_at(spec, f, SPEED)
    return wheels.RigidWheel().receptance(f), contact.contact_receptance(h, f), r


def test_one_wheel_equals_closed_form(discrete_tables):
    aw, ac, r = _inputs(F)
    train = TrainLayout(axle_offsets=(0.0,))
    xs = 0.3
    X = np.round(np.arange(-2.0, 2.05, 0.1), 10)
    res = P.simulate_passby(discrete_tables, train, aw, ac, r, sensor_x=xs, positions=X,
                            output="head")
    tp = rf_preset("site")
    bs = beam_section(RailSpec(eta=tp.rail.eta))
    w = 2 * np.pi * F
    for k in (0, 7, 20, 33):  # wheel at 4 positions in different spans
        xw = X[k]
        # beam track centred on the support nearest the wheel, as the periodic track allows;
        # the wheel load spread over 0.02 m as the door does (spec.numerics.load_length)
        c = round(xw / tp.spacing) * tp.spacing
        lay = uniform_layout(tp.support, tp.spacing, 131, centre=c)
        a_pt = beams.discrete_track_receptance(bs, lay, w, [xw], [xw], load_length=0.02)[:, 0, 0]
        a_s = beams.discrete_track_receptance(bs, lay, w, [xw], [xs], load_length=0.02)[:, 0, 0]
        Y = 1j * w * np.array([a_pt, ac, aw])
        force = 1j * w * r / Y.sum(axis=0)                    # F = i w R / (Y_rh + Y_c + Y_w)
        v = 1j * w * a_s * force
        assert np.allclose(res.force_sq[:, k, 0], np.abs(force) ** 2, rtol=1e-6)
        assert np.allclose(res.velocity_sq[:, k], np.abs(v) ** 2, rtol=1e-6)


def test_no_interaction_equals_sum_of_single_wheels(discrete_tables):
    aw, ac, r = _inputs(F)
    train = TrainLayout(axle_offsets=(0.0, 2.6, 5.0))
    X = np.round(np.arange(-3.0, 9.0, 0.1), 10)
    full = P.simulate_passby(discrete_tables, train, aw, ac, r, positions=X, interaction=False)
    total = np.zeros_like(full.velocity_sq)
    for o in train.offsets:
        one = P.simulate_passby(discrete_tables, TrainLayout(axle_offsets=(0.0,)), aw, ac, r,
                                positions=np.round(X - o, 10))
        total += one.velocity_sq
    assert np.allclose(full.velocity_sq, total, rtol=1e-10)
    # with interaction the wheels' fields do interfere: the result differs
    inter = P.simulate_passby(discrete_tables, train, aw, ac, r, positions=X)
    assert np.max(np.abs(10 * np.log10(inter.velocity_sq / total))) > 0.1


def test_paper_form_equals_exact_for_one_wheel_and_differs_for_many(discrete_tables):
    aw, ac, r = _inputs(F)
    one = TrainLayout(axle_offsets=(0.0,))
    X = np.round(np.arange(-3.0, 3.0, 0.1), 10)
    a = P.simulate_passby(discrete_tables, one, aw, ac, r, positions=X)
    b = P.simulate_passby(discrete_tables, one, aw, ac, r, positions=X, form="paper")
    assert np.allclose(a.velocity_sq, b.velocity_sq, rtol=1e-10)
    two = TrainLayout(axle_offsets=(0.0, 2.6))
    a = P.simulate_passby(discrete_tables, two, aw, ac, r, positions=X)
    b = P.simulate_passby(discrete_tables, two, aw, ac, r, positions=X, form="paper")
    assert not np.allclose(a.velocity_sq, b.velocity_sq, rtol=1e-3)


def test_forces_repeat_with_the_sleeper_period(discrete_tables):
    aw, ac, r = _inputs(F)
    res = P.simulate_passby(discrete_tables, default_train(), aw, ac, r, before=3, after=3)
    k = int(np.argmin(np.abs(res.position - 0.0)))
    assert np.allclose(res.force_sq[:, k], res.force_sq[:, k + 6], rtol=1e-12)  # 0.6 m
    assert not np.allclose(res.force_sq[:, k], res.force_sq[:, k + 3], rtol=1e-3)


def test_simplified_formula_recovered_under_its_assumptions():
    """Continuous support, no interference, incoherent wheels: the pass-by average of the
    full simulation equals v^2 = w^2 |Y_s r|^2/|Y_rh+Y_w+Y_c|^2 N/(beta L) with beta from
    the EN 15461 decay rate, within 0.5 dB (the formula assumes an exponential decay from
    the wheel; the EN 15461 sum and the 1/9-octave band averages are the rest)."""
    f = iec61260.ninth_octave_grid(100, 2000)
    # step 0.05 m: the EN 15461 hammer positions lie on quarter spans of 0.6 m
    tab = P.rail_tables(rf_preset("site", model="timoshenko-discrete"), f, continuous=True,
                        max_distance=45.0, step=0.05)
    aw, ac, r = _inputs(f)
    train = default_train()
    res = P.simulate_passby(tab, train, aw, ac, r, interaction=False, before=42.0,
                            after=42.0, output="head")
    L = res.position[-1] - res.position[0] + tab.step
    xs = res.settings["sensor_x_m"]
    pos = en15461.hammer_positions(0.6)
    transfer = 1j * 2 * np.pi * f[:, None] * P.table_receptance(tab, 0, xs + pos, xs)
    D = en15461.decay_rate(f, transfer, pos, bands=res.bands).decay_rate
    a0 = P.table_receptance(tab, 0, np.array(xs), np.array(xs))
    v = P.simplified_band_velocity(f, res.bands, rail_receptance=a0, sensor_receptance=a0,
                                   wheel_receptance=aw, contact_receptance=ac, roughness=r,
                                   decay_rate=D, n_wheels=train.n_wheels, length=L)
    diff = res.average_level() - 20 * np.log10(v / 1e-9)
    assert np.all(np.abs(diff) < 0.5), diff


def test_train_layouts(tmp_path):
    t = default_train()
    assert t.n_wheels == 24 and 110 < t.length <= 120
    p = tmp_path / "t.toml"
    p.write_text('name = "x"\n[cars]\ncount = 2\nlength_m = 25.0\nbogie_centres_m = [3.5, 21.5]\n'
                 'axle_spacing_m = 2.5\n')
    assert read_train_layout(p) == from_cars(2, 25.0, (3.5, 21.5), 2.5, name="x")
    p.write_text("axle_offsets_m = [0, 2.5, 2.0]\n")
    with pytest.raises(ValueError, match="increase"):
        read_train_layout(p)


def test_bad_positions_are_named(discrete_tables):
    aw, ac, r = _inputs(F)
    with pytest.raises(ValueError, match="grid"):
        P.simulate_passby(discrete_tables, TrainLayout(axle_offsets=(0.0, 2.55)), aw, ac, r)
    with pytest.raises(ValueError, match="form"):
        P.simulate_passby(discrete_tables, default_train(), aw, ac, r, form="approx")
