"""The eigen form in the stiffness of one direction (railfem.track.directional) against the
coupling solve (railfem.track.coupling.couple_discrete) of the same kernel, for a lateral
load (both families) with the lateral springs varied and the vertical and longitudinal
ones held, and its derivative against a central difference."""

import numpy as np
import pytest

import railfem as rf
from railfem import models
from railfem.spec import RailSpec
from railfem.track import coupling
from railfem.track import directional
from railfem.track import wfe as track

F = np.array([80.0, 450.0, 2200.0])


@pytest.fixture(scope="module")
def case():
    spec = rf.preset("site", support_directions="zyx", n_supports=15, pad_length=0.0,
                     n_rows=1, rail=RailSpec(h=0.02))
    positions = np.array([0.3, 0.45, 1.2, 3.3])
    kernel, jr, jf = models.discrete_kernel(spec, F, positions, [0.3],
                                            outputs=models.LATERAL, force="head_lateral",
                                            cache=False)
    K = track.spring_stiffness(spec.layout(), 2 * np.pi * F, kernel)
    pattern = spec.layout().springs().weight
    return spec, kernel, jr[0], jf[0], K, pattern


def coupled(kernel, K, jr, jf, k_y, pattern):
    K2 = K.copy()
    K2[:, :, 1] = k_y[:, None] * pattern[None, :]
    return coupling.couple_discrete(kernel, K2)[:, :, jr, jf]


def test_lateral_stiffness_in_eigen_form(case):
    _, kernel, jr, jf, K, pattern = case
    ds = directional.directional_spectral(kernel, K, pattern, "y", jr, jf)
    for factor in (1.0, 0.2, 7.0):
        k_y = K[:, 0, 1] / pattern[0] * factor * (1 + 0.3j * (factor != 1.0))
        want = coupled(kernel, K, jr, jf, k_y, pattern)
        got = ds.receptance(k_y)
        scale = np.abs(want).max(axis=(1, 2), keepdims=True)
        assert (np.abs(got - want) / scale).max() < 1e-9
    # the held springs matter: without them the answer is another one
    K0 = K.copy()
    K0[:, :, [0, 2]] = 0
    free = directional.directional_spectral(kernel, K0, pattern, "y", jr, jf)
    k_y = K[:, 0, 1] / pattern[0]
    assert np.abs(free.receptance(k_y) - ds.receptance(k_y)).max() > 1e-3 * np.abs(
        ds.receptance(k_y)).max()


def test_derivative(case):
    _, kernel, jr, jf, K, pattern = case
    ds = directional.directional_spectral(kernel, K, pattern, "y", jr, jf)
    k = K[:, 0, 1] / pattern[0]
    h = 1e-4 * np.abs(k)
    fd = (ds.receptance(k + h) - ds.receptance(k - h)) / (2 * h[:, None, None])
    got = ds.derivative(k)
    assert np.abs(got - fd).max() < 1e-5 * np.abs(fd).max()


def test_checks(case):
    _, kernel, jr, jf, K, pattern = case
    with pytest.raises(ValueError, match="shape"):
        directional.directional_spectral(kernel, K[:, :, 0], pattern, "y", jr, jf)
