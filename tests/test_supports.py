"""Tests of railfem.track.supports against hand formulas and physical limits."""
import dataclasses
import math

import numpy as np
import pytest

from railfem.track import supports as sp

OMEGA = 2 * np.pi * np.array([0.0, 10.0, 63.0, 250.0, 1000.0, 4000.0])


def reference_stiffness(kp, eta_p, ms, kb, eta_b, omega):
    """Pad in series with the sleeper-on-ballast, written as compliances (independent form)."""
    kps = kp * (1 + 1j * eta_p)
    zb = kb * (1 + 1j * eta_b) - omega**2 * ms
    return 1.0 / (1.0 / kps + 1.0 / zb)


@pytest.fixture
def medium():
    return sp.SupportParameters(kp=300e6, eta_p=0.1, ms=120.0, kb=90e6, eta_b=1.5)


def test_dynamic_stiffness_matches_series_formula(medium):
    got = sp.dynamic_stiffness(medium, OMEGA)
    ref = reference_stiffness(300e6, 0.1, 120.0, 90e6, 1.5, OMEGA)
    assert got.shape == OMEGA.shape
    np.testing.assert_allclose(got, ref, rtol=1e-12)


def test_static_and_high_frequency_limits(medium):
    k0 = sp.dynamic_stiffness(medium, 0.0)
    kps, kbs = 300e6 * (1 + 0.1j), 90e6 * (1 + 1.5j)
    assert k0 == pytest.approx(kps * kbs / (kps + kbs), rel=1e-12)
    # far above the sleeper resonance the sleeper mass blocks: only the pad is felt
    assert sp.dynamic_stiffness(medium, 2 * np.pi * 1e6) == pytest.approx(kps, rel=1e-4)


def test_zero_sleeper_mass_is_two_springs_in_series():
    p = sp.SupportParameters(kp=200e6, eta_p=0.2, ms=0.0, kb=50e6, eta_b=0.5)
    kps, kbs = 200e6 * (1 + 0.2j), 50e6 * (1 + 0.5j)
    np.testing.assert_allclose(sp.dynamic_stiffness(p, OMEGA), kps * kbs / (kps + kbs),
                               rtol=1e-12)


def test_rigid_elements():
    rigid_ballast = sp.SupportParameters(kp=300e6, eta_p=0.1, kb=math.inf)
    np.testing.assert_allclose(sp.dynamic_stiffness(rigid_ballast, OMEGA), 300e6 * (1 + 0.1j))
    # continuity: a very stiff ballast approaches the rigid case
    near = sp.SupportParameters(kp=300e6, eta_p=0.1, kb=1e16)
    np.testing.assert_allclose(sp.dynamic_stiffness(near, OMEGA), 300e6 * (1 + 0.1j), rtol=1e-6)
    rigid_pad = sp.SupportParameters(kp=math.inf, ms=120.0, kb=90e6, eta_b=1.0)
    np.testing.assert_allclose(sp.dynamic_stiffness(rigid_pad, OMEGA),
                               90e6 * (1 + 1j) - OMEGA**2 * 120.0)
    both = sp.SupportParameters(kp=math.inf, kb=math.inf)
    assert np.all(np.isinf(sp.dynamic_stiffness(both, OMEGA)))
    assert np.all(sp.support_receptance(both, OMEGA) == 0)


def test_missing_pad_and_undamped_resonances():
    no_pad = sp.SupportParameters(kp=0.0, kb=90e6)
    assert np.all(sp.dynamic_stiffness(no_pad, OMEGA) == 0)
    assert np.all(np.isinf(sp.support_receptance(no_pad, OMEGA)))
    # undamped: sleeper-on-ballast resonance kb = w^2 ms -> K_s = 0;
    # sleeper between the two springs, kp + kb = w^2 ms -> K_s infinite
    p = sp.SupportParameters(kp=300e6, ms=100.0, kb=100e6)
    w_b, w_pb = math.sqrt(100e6 / 100.0), math.sqrt(400e6 / 100.0)
    assert abs(sp.dynamic_stiffness(p, w_b)) < 1e-6 * 300e6
    assert np.isinf(sp.dynamic_stiffness(p, w_pb))


def test_support_is_passive_for_all_presets():
    w = 2 * np.pi * np.geomspace(1, 1e4, 200)
    for name, support in sp.PRESETS.items():
        k = sp.dynamic_stiffness(support, w)
        # with exp(+i w t) the power taken by the spring is w Im(K) |u|^2 / 2 >= 0
        assert np.all(k.imag > 0), name


def test_support_receptance_is_inverse(medium):
    np.testing.assert_allclose(sp.support_receptance(medium, OMEGA) *
                               sp.dynamic_stiffness(medium, OMEGA), 1.0, rtol=1e-12)


@pytest.mark.parametrize("kwargs, words", [
    (dict(kp=-1.0, kb=1e6), ["kp", "-1.0", ">= 0"]),
    (dict(kp=1e6, kb=float("nan")), ["kb", "nan"]),
    (dict(kp=1e6, kb=1e6, eta_p=-0.1), ["eta_p", "-0.1"]),
    (dict(kp=1e6, kb=1e6, eta_b=float("inf")), ["eta_b"]),
    (dict(kp=1e6, kb=1e6, ms=-5.0), ["ms", "-5.0", "kg"]),
    (dict(kp=1e6, kb=1e6, ms=float("inf")), ["ms"]),
])
def test_invalid_parameters_are_named(kwargs, words):
    with pytest.raises(ValueError) as err:
        sp.SupportParameters(**kwargs)
    for w in words:
        assert w in str(err.value)


def test_complex_stiffness_rejected_and_frozen():
    with pytest.raises(TypeError, match="loss factor"):
        sp.SupportParameters(kp=1e6 + 1e5j, kb=1e6)
    p = sp.SupportParameters(kp=1e6, kb=1e6)
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.kp = 2e6
    with pytest.raises(TypeError):
        sp.SupportParameters(1e6, 0.1)  # keyword-only


def test_scaled_chain_scales_stiffness(medium):
    np.testing.assert_allclose(sp.dynamic_stiffness(medium.scaled(0.25), OMEGA),
                               0.25 * sp.dynamic_stiffness(medium, OMEGA), rtol=1e-12)


def test_continuous_stiffness(medium):
    np.testing.assert_allclose(sp.continuous_stiffness(medium, OMEGA, 0.6),
                               sp.dynamic_stiffness(medium, OMEGA) / 0.6)
    with pytest.raises(ValueError, match="spacing"):
        sp.continuous_stiffness(medium, OMEGA, 0.0)
    with pytest.raises(ValueError, match="omega"):
        sp.dynamic_stiffness(medium, -1.0)


TABLE1 = {  # METHOD.md Table 1: kp (MN/m), eta_p, kb (MN/m), eta_b, eta_r
    "stiff": (600, 0.05, 48, 2.0, 0.05),
    "medium": (300, 0.10, 90, 1.5, 0.04),
    "soft": (120, 0.15, 120, 1.0, 0.03),
    "very_soft": (60, 0.20, 360, 0.5, 0.02),
    "site": (600, 0.25, 42, 1.0, 0.01),
}


def test_presets_reproduce_table1():
    """The Table 1 tracks as specs (railfem.spec.preset): supports, spacing, rail loss."""
    from railfem.spec import preset

    assert set(sp.PRESETS) == set(TABLE1)
    for name, (kp, eta_p, kb, eta_b, eta_r) in TABLE1.items():
        spec = preset(name)
        assert spec.name == name
        s = spec.support
        assert (s.kp, s.eta_p, s.kb, s.eta_b) == (kp * 1e6, eta_p, kb * 1e6, eta_b)
        assert s.ms == 120.0 and spec.spacing == 0.6 and spec.rail.eta == eta_r
        assert s == sp.PRESETS[name]
    assert sp.preset_key("very soft") == "very_soft" == preset("very-soft").name
    with pytest.raises(KeyError) as err:
        preset("concrete")
    assert "concrete" in str(err.value) and "very_soft" in str(err.value)


def test_uniform_layout_positions(medium):
    lay = sp.uniform_layout(medium, spacing=0.6, n=131, centre=1.0)
    x = lay.x
    assert len(lay) == 131 and x[65] == pytest.approx(1.0)
    np.testing.assert_allclose(np.diff(x), 0.6)
    np.testing.assert_allclose(x + x[::-1], 2.0, atol=1e-12)  # symmetric about the centre
    even = sp.uniform_layout(medium, spacing=0.6, n=4)
    np.testing.assert_allclose(even.x, [-0.9, -0.3, 0.3, 0.9])
    assert lay.nearest_support(1.25) == 65


def test_spring_rows_split_each_support(medium):
    lay = sp.uniform_layout(medium, spacing=0.6, n=3, pad_length=0.16, n_rows=4)
    s = lay.springs()
    assert s.x.size == 12
    np.testing.assert_allclose(s.x[4:8], [-0.06, -0.02, 0.02, 0.06])  # slice midpoints
    np.testing.assert_allclose(np.bincount(s.support_index, s.weight), 1.0)
    k = lay.spring_stiffness(OMEGA)
    assert k.shape == (OMEGA.size, 12)
    per_support = np.stack([k[:, s.support_index == j].sum(axis=1) for j in range(3)], -1)
    expected = np.repeat(sp.dynamic_stiffness(medium, OMEGA)[:, None], 3, axis=1)
    np.testing.assert_allclose(per_support, expected, rtol=1e-12)


def test_with_support_copies(medium):
    lay = sp.uniform_layout(medium, n=5)
    void = dataclasses.replace(medium, kb=0.0)
    new = sp.with_support(lay, 2, void)
    assert new.params[2] == void and lay.params[2] == medium
    assert all(new.params[j] == medium for j in (0, 1, 3, 4))
    assert sp.with_support(lay, -1, void).params[4] == void
    with pytest.raises(IndexError):
        sp.with_support(lay, 5, void)
    # a voided sleeper (no ballast) has no static stiffness but still the pad-mass dynamics
    assert sp.dynamic_stiffness(void, 0.0) == 0


def test_layout_validation(medium):
    with pytest.raises(ValueError, match="params"):
        sp.SupportLayout(positions=(0.0, 0.6), params=(medium,))
    with pytest.raises(ValueError, match="pad_length"):
        sp.SupportLayout(positions=(0.0,), params=(medium,), n_rows=3)
    with pytest.raises(ValueError, match="n_rows"):
        sp.SupportLayout(positions=(0.0,), params=(medium,), n_rows=0)
    with pytest.raises(ValueError, match="spacing"):
        sp.uniform_layout(medium, spacing=-0.6)


def test_foot_spring_weights():
    w_foot = 0.15
    y = np.linspace(-w_foot / 2, w_foot / 2, 8)
    w = sp.foot_spring_weights(y, w_foot)
    h = w_foot / 7
    np.testing.assert_allclose(w, [0.5 * h / w_foot] + [h / w_foot] * 6 + [0.5 * h / w_foot])
    assert w.sum() == pytest.approx(1.0)
    # irregular, unsorted nodes: weights follow the input order and still sum to 1
    y2 = np.array([0.03, -0.07, 0.0, 0.07])
    w2 = sp.foot_spring_weights(y2, w_foot)
    # sorted: -0.07, 0, 0.03, 0.07; edges -0.075, -0.035, 0.015, 0.05, 0.075
    np.testing.assert_allclose(w2, np.array([0.035, 0.04, 0.05, 0.025]) / w_foot)
    assert sp.foot_spring_weights([0.0], w_foot) == pytest.approx([1.0])
    with pytest.raises(ValueError, match="within the foot"):
        sp.foot_spring_weights([0.0, 0.1], w_foot)
    with pytest.raises(ValueError, match="repeated"):
        sp.foot_spring_weights([0.0, 0.0], w_foot)
