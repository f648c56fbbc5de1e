"""The model decay rate of a fit's residual table (railfem.identify.data.model_decay_rate)
against EN 15461 band by band (iec61260.band_average, en15461.decay_rate_from_band_power):
equal to the last bit, whatever positions the data used."""
from dataclasses import replace

import numpy as np
import pytest

from railfem.identify.data import Target, model_decay_rate
from railfem.standards import en15461, iec61260

F = iec61260.ninth_octave_grid(100.0, 2000.0)
POS = en15461.hammer_positions(0.6)


def reference(target, Y):
    power = iec61260.band_average(target.frequency, Y, target.bands) ** 2
    if target.tdr_used is not None:
        power = np.where(target.tdr_used, power, np.nan)
    return np.column_stack([en15461.decay_rate_from_band_power(
        target.bands.nominal, power[:, o, :], target.nominal_positions,
        point_offset=target.tdr_point_offset).decay_rate for o in range(power.shape[1])])


@pytest.fixture(scope="module")
def target():
    bands = iec61260.third_octave_bands(float(F.min()), float(F.max()))
    rng = np.random.default_rng(3)
    used = rng.uniform(size=(len(bands), 2, len(POS))) > 0.2  # data left some out
    used[:, :, 0] = True
    used[2, 0, 0] = False  # a band whose point the data lost: no decay rate
    used[4, 1, 1:] = False  # the point alone: no decay rate
    return Target(frequency=F, outputs=("head", "foot"), sensor_x=0.3,
                  positions=np.r_[0.02, POS[1:]], use=("tdr",), bands=bands,
                  tdr=np.ones((len(bands), 2)), tdr_used=used, band_weight=np.ones(len(bands)),
                  frf_weight=np.zeros(len(F)))


@pytest.mark.parametrize("variant", ["used", "all", "offset"])
def test_model_decay_rate_equals_en15461_band_by_band(target, variant):
    t = {"used": target, "all": replace(target, tdr_used=None),
         "offset": replace(target, tdr_point_offset=0.02)}[variant]
    rng = np.random.default_rng(5)
    for _ in range(20):
        shape = (len(F), 2, len(POS))
        Y = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) \
            * np.exp(-rng.uniform(0.0, 2.0, len(POS)))
        got, want = model_decay_rate(t, Y), reference(t, Y)
        np.testing.assert_array_equal(got, want)
    assert np.isnan(want).sum() == (2 if variant != "all" else 0)


def test_model_decay_rate_of_a_non_finite_model_follows_en15461(target):
    Y = np.ones((len(F), 2, len(POS)), dtype=complex)
    Y[:, 0, 3] = np.nan  # a model position without a value is left out of the sum
    Y[:4, 1, 0] = 0.0  # no point power in the first band: no decay rate
    np.testing.assert_array_equal(model_decay_rate(target, Y), reference(target, Y))


def test_model_decay_rate_on_a_grid_with_empty_bands(target, caplog):
    """A narrow-band grid coarser than the bands (a cheap diagnosis grid): no decay rate in
    a band without points, the others as EN 15461 gives them, and band_average's warning
    once per target, not once per evaluation (a fit evaluates it thousands of times)."""
    f = F[::4]
    t = replace(target, frequency=f, frf_weight=np.zeros(len(f)))
    empty = np.bincount(iec61260.band_index(f, t.bands) + 1, minlength=len(t.bands) + 1)[1:] == 0
    assert 0 < empty.sum() < len(t.bands)
    rng = np.random.default_rng(7)
    shape = (len(f), 2, len(POS))
    Ys = [(rng.standard_normal(shape) + 1j * rng.standard_normal(shape))
          * np.exp(-rng.uniform(0.0, 2.0, len(POS))) for _ in range(20)]
    wants = [reference(t, Y) for Y in Ys]
    caplog.clear()
    with caplog.at_level("WARNING", logger="railfem.standards.iec61260"):
        gots = [model_decay_rate(t, Y) for Y in Ys]
    for got, want in zip(gots, wants):
        np.testing.assert_array_equal(got, want)
        assert np.isnan(got[empty]).all() and np.isfinite(got[~empty]).any()
    noted = [r for r in caplog.records if "no narrow-band points" in r.getMessage()]
    assert len(noted) == 1
