"""Deviating supports on the discrete tracks by a low-rank (Woodbury) update of the
uniform coupling (railfem.track.coupling.SupportUpdate): against the direct coupling
solve of the same kernel with the deviating stiffness (each pair on its re-centred
supports, as railfem.models solves a uniform track), its derivatives against central
differences, and the diagnosis's evaluator on wfe-discrete against the door."""
import math

import numpy as np
import pytest

import railfem as rf
from railfem import models
from railfem.spec import RailSpec
from railfem.track.coupling import SupportUpdate, couple_discrete
from railfem.track.supports import dynamic_stiffness

F = np.array([80.0, 250.0, 700.0, 1500.0])
SX = 0.3
POS = np.array([0.02, 0.3, 0.9, 2.4, 6.0])


def wfe_spec(**changes):
    base = dict(model="wfe-discrete", pad_length=0.0, n_supports=41,
                rail=RailSpec(h=0.02))
    return rf.preset("site", **{**base, **changes}).replace(kp=400e6, kb=60e6)


@pytest.fixture(scope="module")
def case():
    spec = wfe_spec()
    kernel, jr, jf = models.discrete_kernel(spec, F, SX + POS, [SX], outputs=("head", "foot"))
    shift = np.round((SX + SX + POS) / (2 * spec.spacing)).astype(int)
    pattern = spec.layout().springs().weight
    su = SupportUpdate(kernel, pattern, jr[0], jf[0], shift, n_rows=spec.n_rows)
    return spec, kernel, jr[0], jf[0], shift, pattern, su


def direct(spec, kernel, jr, jf, shift, pattern, K, k_dev, indices):
    """The full coupling solve, pair by pair on its re-centred supports."""
    centre = (spec.n_supports - 1) // 2
    out = np.empty((len(F), kernel.rs.shape[2], len(jr)), dtype=complex)
    for p in range(len(jr)):
        Ks = np.repeat(K[:, None], spec.n_supports, axis=1)
        for j, J in enumerate(indices):
            s = centre + J - shift[p]
            if 0 <= s < spec.n_supports:
                Ks[:, s] = k_dev[:, j]
        sets = np.repeat(Ks, spec.n_rows, axis=1) * pattern[None, :]
        out[:, :, p] = couple_discrete(kernel, sets)[:, :, jr[p], jf[p]]
    return out


def stiffness(spec, factors):
    w = 2 * np.pi * F
    K = dynamic_stiffness(spec.support, w)
    devs = [rf.SupportDeviation(index=i, kp=kp, kb=kb) for i, (kp, kb) in factors.items()]
    k_dev = np.column_stack([dynamic_stiffness(d.apply(spec.support), w) for d in devs])
    return K, k_dev, list(factors)


CASES = {
    "voided support": {3: (1.0, 1e-3)},
    "three supports scaled": {-1: (0.5, 1.0), 0: (2.0, 0.3), 4: (1.0, 3.0)},
    "random factors on 33 supports": {
        i: tuple(np.exp(np.random.default_rng(i + 8).normal(0, [0.3, 0.5])))
        for i in range(-8, 25)},
}


@pytest.mark.parametrize("name", CASES)
def test_woodbury_equals_the_direct_coupling_solve(case, name):
    spec, kernel, jr, jf, shift, pattern, su = case
    K, k_dev, idx = stiffness(spec, CASES[name])
    ref = direct(spec, kernel, jr, jf, shift, pattern, K, k_dev, idx)
    got = su.receptance(K, k_dev, idx)
    uni = su.receptance(K, np.repeat(K[:, None], len(idx), axis=1), idx)
    assert np.abs(ref - uni).max() > 1e-3 * np.abs(ref).max()  # the deviation matters
    assert np.abs(got - ref).max() < 1e-8 * np.abs(ref).max(), name


def test_woodbury_uniform_is_the_uniform_track(case):
    spec, kernel, jr, jf, shift, pattern, su = case
    K = dynamic_stiffness(spec.support, 2 * np.pi * F)
    ref = couple_discrete(kernel, K[:, None] * pattern[None, :])[:, :, jr, jf]
    got = su.receptance(K, np.empty((len(F), 0)), [])
    assert np.abs(got - ref).max() < 1e-8 * np.abs(ref).max()


@pytest.mark.parametrize("name", ["three supports scaled", "random factors on 33 supports"])
def test_woodbury_derivatives_against_central_differences(case, name):
    spec, kernel, jr, jf, shift, pattern, su = case
    K, k_dev, idx = stiffness(spec, CASES[name])
    _, du = su.receptance(K, k_dev, idx, gradient=True)
    for j in (0, len(idx) // 2, len(idx) - 1):
        h = 1e-6
        a, b = k_dev.copy(), k_dev.copy()
        a[:, j] *= math.exp(-h)
        b[:, j] *= math.exp(h)
        ref = (su.receptance(K, b, idx) - su.receptance(K, a, idx)) / (2 * h)
        got = du[:, :, :, j] * k_dev[:, j, None, None]  # d / d ln k
        assert np.abs(got - ref).max() < 1e-6 * np.abs(ref).max(), j


def test_woodbury_with_pads_in_rows():
    """A support spread over rows (pad of finite length): its every row changes."""
    spec = wfe_spec(pad_length=0.15, n_rows=3, n_supports=21)
    f = F[:2]
    kernel, jr, jf = models.discrete_kernel(spec, f, SX + POS[:3], [SX], outputs=("head",))
    shift = np.round((2 * SX + POS[:3]) / (2 * spec.spacing)).astype(int)
    pattern = spec.layout().springs().weight
    su = SupportUpdate(kernel, pattern, jr[0], jf[0], shift, n_rows=3)
    w = 2 * np.pi * f
    K = dynamic_stiffness(spec.support, w)
    k_dev = np.column_stack([0.2 * K, 3 * K])
    centre = (spec.n_supports - 1) // 2
    for p in range(len(jr[0])):
        Ks = np.repeat(K[:, None], spec.n_supports, axis=1)
        for j, J in enumerate((0, 2)):
            Ks[:, centre + J - shift[p]] = k_dev[:, j]
        ref = couple_discrete(kernel, np.repeat(Ks, 3, axis=1) * pattern)[:, :, jr[0][p],
                                                                            jf[0][p]]
        got = su.receptance(K, k_dev, (0, 2))[:, :, p]
        assert np.abs(got - ref).max() < 1e-8 * np.abs(ref).max()
