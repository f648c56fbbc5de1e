"""Deviating supports on the discrete tracks by a low-rank (Woodbury) update of the
uniform coupling (railfem.track.woodbury.SupportUpdate): against the direct coupling
solve of the same kernel with the deviating stiffness (each pair on its re-centred
supports, as railfem.models solves a uniform track), its derivatives against central
differences, and the diagnosis's evaluator on wfe-discrete against the door."""
import math

import numpy as np
import pytest

import railfem as rf
from railfem import models
from railfem.spec import RailSpec
from railfem.track.coupling import couple_discrete
from railfem.track.woodbury import SupportUpdate
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
    "one changed, two at the mean": {2: (1.0, 0.05), 6: (1.0, 1.0), -3: (1.0, 1.0)},
}
# every listed support at the mean: no support enters the update (its tangents only)
AT_MEAN = {**CASES, "all at the mean": {2: (1.0, 1.0), 6: (1.0, 1.0), -3: (1.0, 1.0)}}


@pytest.mark.parametrize("name", CASES)
def test_woodbury_equals_the_direct_coupling_solve(case, name):
    spec, kernel, jr, jf, shift, pattern, su = case
    K, k_dev, idx = stiffness(spec, CASES[name])
    ref = direct(spec, kernel, jr, jf, shift, pattern, K, k_dev, idx)
    got = su.receptance(K, k_dev, idx)
    uni = su.receptance(K, np.repeat(K[:, None], len(idx), axis=1), idx)
    assert np.abs(ref - uni).max() > 1e-3 * np.abs(ref).max()  # the deviation matters
    assert np.abs(got - ref).max() < 1e-8 * np.abs(ref).max(), name


def test_woodbury_selected_pairs(case):
    spec, kernel, jr, jf, shift, pattern, su = case
    K, k_dev, idx = stiffness(spec, CASES["three supports scaled"])
    full = su.receptance(K, k_dev, idx, gradient=True)
    some = su.receptance(K, k_dev, idx, gradient=True, pairs=[3, 1])
    for x, y in zip(full, some):
        assert np.allclose(x[:, :, [3, 1]], y, rtol=1e-12, atol=0)


def test_woodbury_uniform_is_the_uniform_track(case):
    spec, kernel, jr, jf, shift, pattern, su = case
    K = dynamic_stiffness(spec.support, 2 * np.pi * F)
    ref = couple_discrete(kernel, K[:, None] * pattern[None, :])[:, :, jr, jf]
    got = su.receptance(K, np.empty((len(F), 0)), [])
    assert np.abs(got - ref).max() < 1e-8 * np.abs(ref).max()


@pytest.mark.parametrize("name", ["three supports scaled", "random factors on 33 supports",
                                  "one changed, two at the mean", "all at the mean"])
def test_woodbury_derivatives_against_central_differences(case, name):
    spec, kernel, jr, jf, shift, pattern, su = case
    K, k_dev, idx = stiffness(spec, AT_MEAN[name])
    _, du = su.receptance(K, k_dev, idx, gradient=True)
    for j in (0, len(idx) // 2, len(idx) - 1):
        h = 1e-6
        a, b = k_dev.copy(), k_dev.copy()
        a[:, j] *= math.exp(-h)
        b[:, j] *= math.exp(h)
        ref = (su.receptance(K, b, idx) - su.receptance(K, a, idx)) / (2 * h)
        got = du[:, :, :, j] * k_dev[:, j, None, None]  # d / d ln k
        assert np.abs(got - ref).max() < 1e-6 * np.abs(ref).max(), j


@pytest.mark.parametrize("name", ["three supports scaled", "one changed, two at the mean"])
def test_woodbury_uniform_derivative_against_central_differences(case, name):
    """d receptance / d K of the supports not listed (k_dev held), as the base parameters'
    tangents use it; the other outputs equal those without it."""
    spec, kernel, jr, jf, shift, pattern, su = case
    K, k_dev, idx = stiffness(spec, CASES[name])
    u, du, duK = su.receptance(K, k_dev, idx, gradient=True, uniform=True)
    u2, du2 = su.receptance(K, k_dev, idx, gradient=True)
    assert np.array_equal(u, u2) and np.array_equal(du, du2)
    h = 1e-4
    ref = (su.receptance(K * math.exp(h), k_dev, idx)
           - su.receptance(K * math.exp(-h), k_dev, idx)) / (2 * h)
    assert np.abs(duK * K[:, None, None] - ref).max() < 1e-5 * np.abs(ref).max()


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


# ------------------------------------------------------------------ the diagnosis's evaluator


@pytest.fixture(scope="module")
def data():
    from benchmarks.blind import generators as g
    from railfem.diagnosis import prepare
    from railfem.standards import en15461

    pos = en15461.hammer_positions(0.6).astype(float)[::4]
    pos[0] = models.POINT_OFFSET
    f = F[:3]
    return prepare(g.measurement(np.ones((len(f), 1, len(pos)), complex), pos, f))


@pytest.fixture(scope="module")
def record(data):
    return data.records[0]


def test_evaluator_takes_deviations_on_wfe_discrete_by_the_woodbury_path(record):
    """wfe-discrete with a voided sleeper: the evaluator's Woodbury path agrees with the
    door (the full coupling solve on supports at absolute positions, 20 m beyond every
    position: the two differ by the truncation of the supported stretch only), and its
    closed-form tangents with central differences of the receptance."""
    from railfem.diagnosis.evaluate import MARGIN, Evaluator
    from railfem.identify.forward import door_receptance

    t = record.fit
    spec = wfe_spec(n_supports=131).replace(deviations=(rf.SupportDeviation(index=2, kb=0.05),))
    ev = Evaluator()
    a, tan = ev.tangents(spec, record)
    assert np.array_equal(a, ev.receptance(spec, record))
    far = spec.replace(n_supports=2 * math.ceil((t.force_x.max() + MARGIN) / 0.6) + 1)
    ref = door_receptance(far, t.frequency, t.sensor_x, t.force_x, t.outputs)
    uni = door_receptance(far.replace(deviations=()), t.frequency, t.sensor_x, t.force_x,
                          t.outputs)
    point = np.abs(ref[:, :, :1])
    assert (np.abs(ref - uni) / point).max() > 0.05  # the void matters
    assert (np.abs(a - ref) / point).max() < 3e-3
    h = 1e-5
    for which in ("kb", "kp"):
        d = spec.deviations[0]
        up, dn = (spec.replace(deviations=(rf.SupportDeviation(
            index=2, **{**{"kb": d.kb, "kp": d.kp}, which: getattr(d, which) * math.exp(s)}),))
            for s in (h, -h))
        ref_t = (ev.receptance(up, record) - ev.receptance(dn, record)) / (2 * h)
        assert np.abs(tan[(2, which)] - ref_t).max() < 1e-5 * np.abs(ref_t).max(), which
    for name in ("kp", "eta_b"):  # a base parameter moves every support, the voided one too
        up, dn = (spec.replace(**{name: getattr(spec.support, name) * math.exp(s)})
                  for s in (h, -h))
        ref_t = (ev.receptance(up, record) - ev.receptance(dn, record)) / (2 * h)
        got = tan[("base", name)]
        assert np.abs(got - ref_t).max() < 1e-5 * np.abs(ref_t).max(), name


def test_evaluator_deviations_at_a_shifted_geometry(record):
    """A geometry effect with a deviating support (a pair of candidates): the Woodbury
    form of the kernel of every registered shift, against the door at the shifted
    positions."""
    from railfem.diagnosis.evaluate import MARGIN, Evaluator, shifted
    from railfem.identify.forward import door_receptance

    t = record.fit
    spec = wfe_spec(n_supports=131).replace(deviations=(rf.SupportDeviation(index=1, kb=0.05),))
    shifts = [(0.1, 0.0), (0.0, 0.06)]
    ev = Evaluator(shifts={record.name: shifts})
    for s in shifts:
        sx, fx = shifted(record, s)
        far = spec.replace(n_supports=2 * math.ceil((fx.max() + MARGIN) / 0.6) + 1)
        ref = door_receptance(far, t.frequency, sx, fx, t.outputs)
        a = ev.receptance(spec, record, s)
        assert (np.abs(a - ref) / np.abs(ref[:, :, :1])).max() < 3e-3, s
        assert ev.tangents(spec, record, s)[0].shape == a.shape
    assert ev.n_kernels == 1  # one Woodbury form serves both shifts


def test_voided_and_random_support_are_tried_on_wfe_discrete_and_said_why_not_elsewhere(data):
    from railfem.diagnosis import effects
    from railfem.diagnosis.loop import applicable
    from railfem.spec import model_kind

    for name in ("voided_sleeper", "random_support"):
        e = effects.get(name)
        assert "deviations" in e.needs
        assert effects.deviation_refusal(model_kind("wfe-discrete")) == ""
        assert effects.deviation_refusal(model_kind("timoshenko-discrete")) == ""
        assert "periodic" in effects.deviation_refusal(model_kind("wfe-periodic"))
    said = effects.not_tried({"random_support": "not screened by default"})
    assert "random_support (not screened by default)" in said
    assert effects.not_tried({}) == ""
    for name in ("voided_sleeper", "random_support"):
        assert applicable(effects.get(name), data, "wfe-discrete") == (True, "")
        ok, why = applicable(effects.get(name), data, "wfe-periodic")
        assert not ok and "periodic" in why


@pytest.mark.slow
def test_diagnose_names_a_voided_sleeper_on_wfe_discrete():
    """The closed loop on wfe-discrete: data with a voided sleeper (support 2, ballast
    factor 0.05; the door, supports at absolute positions), a coarse grid up to 2 kHz:
    voided_sleeper is tried (a Woodbury update per evaluation), named, at its support."""
    from benchmarks.blind import generators as g
    from railfem.diagnosis import diagnose

    f = g.frequencies(low=50.0, high=2000.0)[::3]
    data = g.dataset("voided_sleeper", 0, f=f, model="wfe-discrete")
    d = diagnose(data, model="wfe-discrete", effects=("voided_sleeper",), n_starts=2)
    assert "voided_sleeper" not in d.skipped
    assert d.chosen is not None and d.chosen.name == "voided_sleeper", d.statement
    assert d.chosen.grid[("voided_sleeper", "index")] == g.CASES["voided_sleeper"]["index"]
