import math

import numpy as np
import pytest

from railfem.standards.en15461 import (
    STANDARD_POSITIONS_IN_SPANS,
    decay_rate,
    decay_rate_from_band_power,
    hammer_positions,
    lowest_measurable_decay_rate,
    weighted_intervals,
)
from railfem.standards.iec61260 import ninth_octave_grid, third_octave_bands

DB_PER_NEPER = 20 * math.log10(math.e)  # 8.686: D = 8.686 beta for |Y|^2 ~ exp(-2 beta x)


def beta_of(d):
    return d / DB_PER_NEPER


def test_standard_hammer_positions():
    x = hammer_positions(0.6)
    assert len(STANDARD_POSITIONS_IN_SPANS) == 29 and x.size == 29
    np.testing.assert_allclose(x[:11], 0.6 * np.arange(0, 2.51, 0.25))
    np.testing.assert_allclose(
        x[11:] / 0.6, [3, 3.5, 4, 5, 6, 7, 8, 10, 12, 16, 20, 24, 30, 36, 42, 48, 54, 66]
    )
    assert x[-1] == pytest.approx(39.6)
    with pytest.raises(ValueError, match="sleeper_spacing"):
        hammer_positions(-0.6)


def test_weighted_intervals_half_interval_rule():
    np.testing.assert_allclose(weighted_intervals([0.0, 1.0, 3.0, 4.0]), [0.5, 1.5, 1.5, 0.5])
    x = hammer_positions(0.65)
    dx = weighted_intervals(x)
    assert dx.sum() == pytest.approx(x[-1])  # covers exactly the measured length
    assert dx[0] == pytest.approx(0.65 / 8) and dx[-1] == pytest.approx(0.65 * 12 / 2)


@pytest.mark.parametrize(
    "positions, match",
    [([0.1, 0.2, 0.3], "positions\\[0\\] must be 0"), ([0.0, 0.5, 0.5], "strictly increasing"), ([0.0], "at least 2")],
)
def test_position_errors(positions, match):
    with pytest.raises(ValueError, match=match):
        weighted_intervals(positions)


def exp_field(beta, x):
    return np.exp(-2 * beta * np.asarray(x))


@pytest.mark.parametrize("d_true", [0.5, 2.0, 8.0])
@pytest.mark.parametrize("h", [0.05, 0.3])
def test_uniform_grid_matches_closed_form_geometric_sum(d_true, h):
    # Uniform grid x_i = i h, i = 0..M: the half-interval sum of q^i (q = e^{-2 beta h}) is the
    # geometric series minus half the end terms, S = h[(1 - q^{M+1})/(1 - q) - (1 + q^M)/2].
    m = 400
    beta = beta_of(d_true)
    x = h * np.arange(m + 1)
    q = math.exp(-2 * beta * h)
    s = h * ((1 - q ** (m + 1)) / (1 - q) - (1 + q**m) / 2)
    expected = 10 * math.log10(math.e) / s
    res = decay_rate_from_band_power([500.0], exp_field(beta, x)[None, :], x)
    assert res.decay_rate[0] == pytest.approx(expected, rel=1e-12)
    # for a long grid this is 8.686 tanh(beta h)/h (the M -> infinity limit)
    if d_true * x[-1] > 60:
        assert res.decay_rate[0] == pytest.approx(DB_PER_NEPER * math.tanh(beta * h) / h, rel=1e-6)


def test_converges_to_8686_beta_as_grid_is_refined():
    d_true = 6.0
    beta = beta_of(d_true)
    errors = []
    for h in (0.2, 0.1, 0.05, 0.025):
        x = np.arange(0, 20 + h / 2, h)  # 120 dB of decay: no truncation
        res = decay_rate_from_band_power([500.0], exp_field(beta, x)[None, :], x)
        errors.append(abs(res.decay_rate[0] - d_true))
    ratios = np.array(errors[:-1]) / np.array(errors[1:])
    np.testing.assert_allclose(ratios, 4.0, rtol=0.02)  # trapezoid rule: second order
    assert errors[-1] / d_true < 2e-4


@pytest.mark.parametrize(
    "d_true, rel", [(1.0, 0.01), (2.0, 0.01), (5.0, 0.01), (10.0, 0.015), (15.0, 0.025), (30.0, 0.09)]
)
def test_standard_grid_exponential_decay_tolerance(d_true, rel):
    # On the EN 15461 grid (d = 0.6 m) a pure exponential decay is recovered within 1 % for
    # 1 ... 5 dB/m; at high decay the 0.15 m first step dominates (trapezoid rule
    # overestimates the integral, so D comes out low: -1.1 % at 10, -2.2 % at 15, -8 % at
    # 30 dB/m).
    x = hammer_positions(0.6)
    res = decay_rate_from_band_power([500.0], exp_field(beta_of(d_true), x)[None, :], x)
    assert res.decay_rate[0] == pytest.approx(d_true, rel=rel)
    assert res.decay_rate[0] < d_true or d_true < 3  # sign of the discretisation error
    assert res.measurable[0] and res.suitable[0]
    assert res.n_used[0] == 29


def test_no_decay_gives_floor_and_fails_far_field_check():
    x = hammer_positions(0.6)
    res = decay_rate_from_band_power([100.0], np.ones((1, x.size)), x)
    assert res.decay_rate[0] == pytest.approx(10 * math.log10(math.e) / 39.6)
    assert not res.measurable[0] and not res.suitable[0]
    assert res.far_field_drop[0] == pytest.approx(0.0)


def test_low_decay_truncation_and_d_min():
    x = hammer_positions(0.6)
    assert lowest_measurable_decay_rate(x) == pytest.approx(10 / 39.6)
    # 0.2 dB/m falls only 7.9 dB over 39.6 m: flagged
    low = decay_rate_from_band_power([100.0], exp_field(beta_of(0.2), x)[None, :], x)
    assert not low.measurable[0] and not low.suitable[0]
    assert low.far_field_drop[0] == pytest.approx(0.2 * 39.6)
    # estimate follows the truncated-integral bias D / (1 - 10^(-D L / 10)) within 1 %
    assert low.decay_rate[0] == pytest.approx(0.2 / (1 - 10 ** (-0.2 * 39.6 / 10)), rel=0.01)
    ok = decay_rate_from_band_power([100.0], exp_field(beta_of(0.4), x)[None, :], x)
    assert ok.measurable[0] and ok.suitable[0]


def polluted_transfer(d_true, floor_db, positions, f, seed=0):
    """exp(-(beta + i k) x) plus random complex noise of power floor_db re the point."""
    rng = np.random.default_rng(seed)
    beta = beta_of(d_true)
    k = 2 * np.pi * f / 300.0  # any wavenumber: |Y|^2 does not depend on it
    y = np.exp(-(beta + 1j * k[:, None]) * positions[None, :])
    noise = (rng.normal(size=y.shape) + 1j * rng.normal(size=y.shape)) / math.sqrt(2)
    return y + 10 ** (floor_db / 20) * noise


def floor_power(d_true, floor_db, positions, n_bands=1):
    """Band power of an exponential field plus an incoherent noise floor (deterministic)."""
    p = exp_field(beta_of(d_true), positions) + 10 ** (floor_db / 10)
    return np.tile(p, (n_bands, 1))


def test_threshold_exclusion_drops_noise_polluted_far_positions():
    x = hammer_positions(0.6)
    d_true = 3.0
    power = floor_power(d_true, -20.0, x)
    raw = decay_rate_from_band_power([100.0], power, x)
    cut = decay_rate_from_band_power([100.0], power, x, threshold_db=-15.0)
    # the floor adds 0.01 * 39.6 m to the true sum 4.343/3 = 1.45 m: D about 21 % low
    assert raw.decay_rate[0] == pytest.approx(10 * math.log10(math.e) / (1.4476 + 0.396), rel=0.01)
    assert raw.decay_rate[0] < 0.8 * d_true
    # level of exp + floor crosses -15 dB near 5.5 m: 4.8 m is the last kept position
    assert x[cut.used[0]][-1] == pytest.approx(4.8)
    assert cut.n_used[0] == 18  # 0 ... 2.5 d in quarters (11), then 3 ... 8 d (7)
    assert cut.decay_rate[0] == pytest.approx(d_true, rel=0.02)
    assert cut.measurable[0] and cut.suitable[0]


def test_threshold_exclusion_narrow_band_noisy_transfers():
    # complex noise at -20 dB re the point on a 1/90-octave grid (30 points per band)
    x = hammer_positions(0.6)
    bands = third_octave_bands(100, 2000)
    f = 1000 * 10 ** (np.arange(-314, 105) / 300)  # covers 89.8 ... 2222 Hz
    d_true = 3.0
    y = polluted_transfer(d_true, -20.0, x, f, seed=0)
    raw = decay_rate(f, y, x, bands=bands)
    cut = decay_rate(f, y, x, bands=bands, threshold_db=-15.0)
    assert np.all(raw.decay_rate < 0.88 * d_true)
    np.testing.assert_allclose(cut.decay_rate, d_true, rtol=0.10)
    assert np.all(cut.used[:, x <= 3.0]) and not np.any(cut.used[:, x >= 8.0])


def test_attenuation_range_rejects_implausible_positions_below_400hz():
    x = hammer_positions(0.6)
    centres = np.array([200.0, 315.0, 400.0, 500.0])
    d_true = 5.0
    power = floor_power(d_true, -25.0, x, n_bands=4)
    res = decay_rate_from_band_power(centres, power, x, attenuation_range=(3.0, 30.0))
    low = centres < 400
    # far positions on the -25 dB floor imply < 3 dB/m (25 dB / 39.6 m = 0.6 dB/m): dropped
    assert not np.any(res.used[low][:, x >= 8.0])
    assert np.all(res.used[~low])  # the rule is not applied at and above 400 Hz
    assert np.all(res.decay_rate[~low] < 0.9 * d_true)  # 4.36: floor over 39.6 m
    np.testing.assert_allclose(res.decay_rate[low], d_true, rtol=0.04)


def test_attenuation_range_fails_loudly_when_true_decay_below_range(caplog):
    # a real 2 dB/m decay violates a 3 dB/m lower bound everywhere: far field rejected,
    # D overestimated, and a warning says so
    x = hammer_positions(0.6)
    with caplog.at_level("WARNING", logger="railfem.standards.en15461"):
        res = decay_rate_from_band_power(
            [200.0], exp_field(beta_of(2.0), x)[None, :], x, attenuation_range=(3.0, 30.0)
        )
    assert res.decay_rate[0] > 4.0
    assert "widen attenuation_range" in caplog.text


def test_band_power_input_equals_narrow_band_path():
    x = hammer_positions(0.6)
    f = ninth_octave_grid(200, 800)
    bands = third_octave_bands(200, 800)
    y = polluted_transfer(4.0, -40.0, x, f, seed=5)
    a = decay_rate(f, y, x, bands=bands, threshold_db=-20)
    power = np.stack([np.mean(np.abs(y[3 * b:3 * b + 3]) ** 2, axis=0) for b in range(len(bands))])
    b = decay_rate_from_band_power(bands.nominal, power, x, threshold_db=-20)
    np.testing.assert_allclose(a.decay_rate, b.decay_rate, rtol=1e-12)
    np.testing.assert_array_equal(a.frequency, [200, 250, 315, 400, 500, 630, 800])


def test_decay_rate_input_errors():
    x = hammer_positions(0.6)
    f = ninth_octave_grid(200, 800)
    with pytest.raises(ValueError, match="n_positions"):
        decay_rate(f, np.ones((f.size, 5)), x)
    with pytest.raises(ValueError, match="bands on axis 0"):
        decay_rate_from_band_power([100.0, 200.0], np.ones((29, 2)), x)
    with pytest.raises(ValueError, match="attenuation_range"):
        decay_rate_from_band_power([100.0], np.ones((1, 29)), x, attenuation_range=(30, 3))


def test_point_offset_weights():
    # the point struck 0.5 m from the sensor: its weight is half the gap to the next position
    np.testing.assert_allclose(weighted_intervals([0.0, 1.0, 3.0, 4.0], point_offset=0.5),
                               [0.25, 1.25, 1.5, 0.5])
    with pytest.raises(ValueError, match="point_offset"):
        weighted_intervals([0.0, 1.0, 3.0], point_offset=1.0)
    x = hammer_positions(0.6)
    a = decay_rate_from_band_power([500.0], exp_field(beta_of(5.0), x)[None, :], x,
                                   point_offset=0.02)
    ratio = exp_field(beta_of(5.0), x)
    xr = x.copy()
    xr[0] = 0.02
    s = np.sum((ratio[1:] + ratio[:-1]) / 2 * np.diff(xr))  # trapezoid written out
    assert a.decay_rate[0] == pytest.approx(10 * math.log10(math.e) / s, rel=1e-12)


def test_floor_tail_start():
    from railfem.standards.en15461 import floor_tail_start

    x = hammer_positions(0.6)
    for d in (0.5, 3.0, 30.0):  # a pure exponential never looks like a floor
        assert floor_tail_start(x, -d * x, -15.0, 3.0) is None
    level = np.maximum(-3.0 * x, -30.0)  # 3 dB/m onto a flat floor at -30 dB from 10 m
    k = floor_tail_start(x, level, -15.0, 3.0)
    # from 9.6 m (-28.8 dB) on the levels fall < 3 dB; from 7.2 m (-21.6 dB) they still fall
    assert x[k] == pytest.approx(9.6)
