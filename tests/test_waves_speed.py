"""The fast wave solver (railfem.rail.waves): same matrices and waves as the straightforward
build, the in-memory wave cache, BLAS thread pinning and the real-arithmetic frozen tail.

Speed itself is measured in benchmarks/bench_waveguide.py, not asserted here.
"""
import numpy as np
import pytest
import scipy.sparse as sp
from scipy.optimize import linear_sum_assignment

from railfem.rail import meshing
from railfem.rail import mobility
from railfem.rail import waveguide
from railfem.rail import waves
from railfem.materials import Material

_GUIDES = {}


def rail(h, eta):
    if (h, eta) not in _GUIDES:
        _GUIDES[h, eta] = waveguide.assemble(meshing.get_mesh("60E1", h), Material.steel(eta))
    return _GUIDES[h, eta]


@pytest.fixture(autouse=True)
def fresh_cache(monkeypatch):
    monkeypatch.delenv(waves.CACHE_VARIABLE, raising=False)
    monkeypatch.delenv(waves.THREADS_VARIABLE, raising=False)
    waves.clear_cache()
    yield
    waves.clear_cache()


def lil_reference(guide, family, omega):
    """A(omega) and B of the k^2 problem built the textbook way (lil block assignment)."""
    T = guide.families[family].T
    comp = guide.families[family].component
    order = np.concatenate([np.nonzero(comp == 0)[0], np.nonzero(comp != 0)[0]])
    na = int(np.sum(comp == 0))
    K0, K1, K2, M = ((T.T @ X @ T).tocsr()[order][:, order]
                     for X in (guide.K0, guide.K1, guide.K2, guide.M))
    c = 1 + 1j * guide.loss_factor
    Z = (c * K0 - omega**2 * M).tolil()
    Z[:na, na:] = c * K1[:na, na:]
    B = sp.lil_matrix(K2.shape, dtype=complex)
    B[:na, :na] = K2.tolil()[:na, :na]
    B[na:, na:] = K2.tolil()[na:, na:]
    B[na:, :na] = -K1[na:, :na]
    return Z.tocsc(), (c * B.tocsr()).tocsc()


@pytest.mark.parametrize("eta", [0.0, 0.03])
@pytest.mark.parametrize("family", waveguide.FAMILIES)
def test_matrices_equal_the_lil_build_bit_for_bit(eta, family):
    g = rail(0.02, eta)
    ops = waves.FamilyOperators(g, family)
    for f in (0.0, 137.0, 4321.0):
        Z_ref, B_ref = lil_reference(g, family, 2 * np.pi * f)
        Z = ops.constant_matrix(2 * np.pi * f)
        assert np.array_equal(Z.toarray(), Z_ref.toarray())
        assert Z.dtype == (np.float64 if eta == 0 else np.complex128)  # real when undamped
    assert np.array_equal(ops.B.toarray(), B_ref.toarray())


def matched(k1, k2):
    """Largest relative distance between two wavenumber sets paired one-to-one."""
    d = np.abs(k1[:, None] - k2[None, :]) / np.abs(k1)[:, None]
    r, c = linear_sum_assignment(d)
    return d[r, c].max()


@pytest.mark.parametrize("eta", [0.0, 0.02])
def test_shift_invert_waves_are_the_smallest_dense_waves(eta):
    """Real (eta = 0) and complex arithmetic: the shift-invert waves are the 20 smallest-|k|
    waves of the dense solve, with the same residue denominators."""
    g = rail(0.02, eta)
    ops = waves.FamilyOperators(g, "symmetric")
    for f in (80.0, 2500.0):
        d = waves.waves_at(ops, 2 * np.pi * f, method="dense")
        s = waves.waves_at(ops, 2 * np.pi * f, method="shift-invert", n_waves=20)
        assert matched(s.k, d.k[:20]) < 1e-8
        # phi is normalised up to a phase, phi psi^T / d is not
        res_s = (s.phi[:, :3] * s.phi[:, :3]).sum(0) / s.denom[:3]
        res_d = (d.phi[:, :3] * d.phi[:, :3]).sum(0) / d.denom[:3]
        assert np.abs(res_s - res_d).max() < 1e-7 * np.abs(res_d).max()


def test_cache_returns_the_same_waves_without_solving(monkeypatch):
    g = rail(0.02, 0.01)
    ops = waves.FamilyOperators(g, "symmetric")
    w1 = waves.waves_at(ops, 2 * np.pi * 500, method="shift-invert", n_waves=20)
    calls = []
    solve = waves._solve_waves
    monkeypatch.setattr(waves, "_solve_waves", lambda *a, **k: calls.append(a) or solve(*a, **k))
    again = waves.FamilyOperators(g, "symmetric")  # new object, same content
    assert waves.waves_at(again, 2 * np.pi * 500, method="shift-invert", n_waves=20) is w1
    assert not calls
    assert not w1.phi.flags.writeable and not w1.k.flags.writeable
    with pytest.raises(ValueError):
        w1.k[0] = 0.0
    # a different loss factor, frequency or wave count is a different entry
    other = waves.FamilyOperators(rail(0.02, 0.02), "symmetric")
    assert other.key != ops.key
    waves.waves_at(other, 2 * np.pi * 500, method="shift-invert", n_waves=20)
    waves.waves_at(ops, 2 * np.pi * 501, method="shift-invert", n_waves=20)
    waves.waves_at(ops, 2 * np.pi * 500, method="shift-invert", n_waves=21)
    assert len(calls) == 3


def test_cache_is_bounded_and_can_be_disabled(monkeypatch):
    g = rail(0.02, 0.01)
    ops = waves.FamilyOperators(g, "symmetric")
    w = waves.waves_at(ops, 2 * np.pi * 100, method="shift-invert", n_waves=20)
    size = w.k.nbytes + w.phi.nbytes + w.denom.nbytes
    monkeypatch.setenv(waves.CACHE_VARIABLE, str(2.5 * size / 1e6))
    for f in (200, 300, 400, 500):
        waves.waves_at(ops, 2 * np.pi * f, method="shift-invert", n_waves=20)
    info = waves.cache_info()
    assert info["entries"] == 2 and info["bytes"] <= info["limit_bytes"]
    # least recently used went first: 400 and 500 Hz remain
    assert waves.waves_at(ops, 2 * np.pi * 500, method="shift-invert", n_waves=20) is \
        waves.waves_at(ops, 2 * np.pi * 500, method="shift-invert", n_waves=20)
    monkeypatch.setenv(waves.CACHE_VARIABLE, "0")
    a = waves.waves_at(ops, 2 * np.pi * 500, method="shift-invert", n_waves=20)
    b = waves.waves_at(ops, 2 * np.pi * 500, method="shift-invert", n_waves=20)
    assert a is not b and np.array_equal(a.k, b.k)  # fixed ARPACK start: reproducible
    monkeypatch.setenv(waves.CACHE_VARIABLE, "lots")
    with pytest.raises(ValueError, match="RAILFEM_WAVE_CACHE_MB"):
        waves.waves_at(ops, 2 * np.pi * 600, method="shift-invert", n_waves=20)


def test_operators_with_a_foundation_are_not_cached():
    g = rail(0.02, 0.01)
    ops = waves.FamilyOperators(g, "symmetric")
    ops.extra = lambda omega: 1e6 * sp.identity(ops.B0.shape[0], format="csc")
    a = waves.waves_at(ops, 2 * np.pi * 300, method="shift-invert", n_waves=10)
    assert waves.cache_info()["entries"] == 0
    assert a is not waves.waves_at(ops, 2 * np.pi * 300, method="shift-invert", n_waves=10)


def test_blas_threads_are_pinned_inside_solver_calls(monkeypatch):
    from threadpoolctl import threadpool_info, threadpool_limits

    seen = []
    real = waves._lambdas_dense

    def spy(*a, **k):
        seen.append({i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"})
        return real(*a, **k)

    monkeypatch.setattr(waves, "_lambdas_dense", spy)
    ops = waves.FamilyOperators(rail(0.02, 0.0), "antisymmetric")
    with threadpool_limits(2, user_api="blas"):
        waves.waves_at(ops, 2 * np.pi * 100, method="dense")
        monkeypatch.setenv(waves.THREADS_VARIABLE, "2")
        waves.waves_at(ops, 2 * np.pi * 200, method="dense")
        monkeypatch.setenv(waves.THREADS_VARIABLE, "none")
        waves.waves_at(ops, 2 * np.pi * 300, method="dense")
        after = {i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"}
    assert seen == [{1}, {2}, {2}] and after == {2}
    monkeypatch.setenv(waves.THREADS_VARIABLE, "0")
    with pytest.raises(ValueError, match="RAILFEM_BLAS_THREADS"):
        waves.waves_at(ops, 2 * np.pi * 400, method="dense")


def test_frozen_tail_completes_the_retained_waves_without_double_counting():
    """eta = 0.05 makes the damped ranking differ from a naive undamped one: the undamped
    pairs (k, -conj k) have equal |k|, and pairs straddle the split at ranks 20 and 40 on this
    mesh (before the first-order loss shift was added the tail held the member the retained
    set already had). Retained + tail must be the dense set at the tail's frequency."""
    g = rail(0.02, 0.05)
    ops = waves.FamilyOperators(g, "symmetric")
    om = 2 * np.pi * 30
    dense = waves.waves_at(ops, om, method="dense")
    for n in (20, 40):
        kept = waves.waves_at(ops, om, method="shift-invert", n_waves=n).k
        tail = waves.frozen_tail(ops, om, n).k
        assert len(kept) + len(tail) == len(dense.k)
        # measured 4.4e-4 (the inverted dense form's round-off on its largest |k|); a wave
        # counted twice and its partner missed gives 0.44 at n = 20
        assert matched(np.concatenate([kept, tail]), dense.k) < 1e-3


def test_real_arithmetic_tail_is_as_accurate_as_the_damped_one():
    """Point and near-point receptances (head patch, 20 mm load length or a point along the
    rail; head and foot-sensor outputs) with 40 retained waves + a tail frozen at 30 Hz,
    against all waves at each frequency (dense). The tail solved undamped in the direct form
    -B^-1 A with a first-order loss shift, against the tail solved with the loss factor in
    the same form. Measured (h = 20 mm, eta = 0.05, 100 / 1000 / 3000 Hz): both 7.3e-5 at
    most, the two tails differ by 6.7e-10; the former inverted-form tail was off by up to
    1.5e-3 (its large-|k| eigenvalues carry the inverted form's round-off)."""
    g = rail(0.02, 0.05)
    ops = waves.FamilyOperators(g, "symmetric")
    locs = [mobility.head_patch(g, 0.02), mobility.point(g, "foot_sensor", "z")]
    fr = mobility.FamilyResponse(g, "symmetric", locs[0].weights[:, None],
                                 np.column_stack([lo.weights for lo in locs]))
    fast = waves.frozen_tail(ops, 2 * np.pi * 30, 40)
    damped = waves.frozen_tail(ops, 2 * np.pi * 30, 40, damped=True)
    x = np.array([0.0, 0.01])
    worst = {"fast": 0.0, "damped": 0.0, "between": 0.0}
    for f in (100.0, 1000.0, 3000.0):
        ref = waves.waves_at(ops, 2 * np.pi * f, method="dense")
        kept = waves.waves_at(ops, 2 * np.pi * f, method="shift-invert", n_waves=40)
        for L in (0.0, 0.02):
            r = mobility.wave_sum(fr, ref, x, L, 0.0)
            a = mobility.wave_sum(fr, waves.join(kept, fast), x, L, 0.0)
            b = mobility.wave_sum(fr, waves.join(kept, damped), x, L, 0.0)
            worst["fast"] = max(worst["fast"], (np.abs(a - r) / np.abs(r)).max())
            worst["damped"] = max(worst["damped"], (np.abs(b - r) / np.abs(r)).max())
            worst["between"] = max(worst["between"], (np.abs(a - b) / np.abs(b)).max())
    assert worst["fast"] < 5e-4 and worst["damped"] < 5e-4, worst
    assert worst["between"] < 1e-6, worst


@pytest.mark.parametrize("lengths", [(0.0, 0.0), (0.02, 0.0), (0.15, 0.15), (0.02, 0.01)])
def test_residue_sum_equals_the_sum_over_every_wave_at_every_position(lengths):
    """The staircase residue sum (each wave summed up to its reach) against the full
    double sum of every wave's kernel (greens.wave_kernels) at every position."""
    from railfem.rail import greens

    rng = np.random.default_rng(1)
    nw = 300
    k = np.concatenate([rng.uniform(0.5, 20, 30) * (1 - 0.005j),
                        rng.uniform(50, 600, nw - 30) * (0.3 - 1j)])
    terms = [rng.standard_normal((3, nw)) + 1j * rng.standard_normal((3, nw)),
             rng.standard_normal((nw, 2)), rng.standard_normal((3, nw)),
             rng.standard_normal((nw, 2))]
    x = np.concatenate([np.linspace(-80, 80, 161), [0.0, 0.005, -0.005, 0.01, 0.0101]])
    fwd, bwd = greens.wave_kernels(k, x, *lengths)
    full = -1j * np.einsum("on,ni,nx->oxi", terms[0], terms[1], fwd) \
        - 1j * np.einsum("on,ni,nx->oxi", terms[2], terms[3], bwd)
    got = greens.residue_sum(terms, k, x, *lengths)
    assert np.abs(got - full).max() < 1e-13 * np.abs(full).max()


def test_labels_of_all_waves_at_once_equal_the_per_wave_projection():
    """label_shapes (all columns at once) against the mass-metric projection of each
    shape on the rigid motions done one wave at a time, and solve(labels=False) gives the
    same wavenumbers without labels."""
    from railfem.rail import labels

    g = rail(0.02, 0.01)
    d = waves.solve(g, [300.0, 2000.0], n_waves=30)
    bare = waves.solve(g, [300.0, 2000.0], n_waves=30, labels=False)
    assert np.array_equal(d.k, bare.k, equal_nan=True)
    assert set(bare.label.ravel()) == {""}
    ops = waves.FamilyOperators(g, "symmetric")
    w = waves.waves_at(ops, 2 * np.pi * 300.0, method="shift-invert", n_waves=30)
    full = ops.T @ w.phi
    M = g.M
    expected = []
    for j in range(full.shape[1]):
        u = full[:, j]
        total = np.real(np.vdot(u, M @ u))
        shares = {}
        for name, comp in (("longitudinal", 0), ("vertical bending", 2)):
            r = np.zeros(g.n_dofs)
            r[g.node_dofs[:, comp]] = 1.0
            shares[name] = abs(r @ (M @ u)) ** 2 / (r @ (M @ r)) / total
        best = max(shares, key=shares.get)
        expected.append(best if shares[best] >= labels.RIGID_SHARE else None)
    got = labels.label_shapes(g, ops, w.phi)
    for e, l in zip(expected, got):
        if e is not None:  # a symmetric wave carried by a rigid motion: that motion
            assert l == e
    assert "vertical bending" in got and "longitudinal" in got


@pytest.mark.parametrize("eta", [0.001, 0.03, 0.1])
def test_loss_factor_is_a_complex_frequency_of_the_rail_without_loss(eta):
    """(1 + i eta) K(k) - omega^2 M = (1 + i eta) [K(k) - omega'^2 M], omega' = omega /
    sqrt(1 + i eta): the waves of the damped rail are those of the undamped rail at the
    complex frequency omega' (same k), and its receptance is the undamped one at omega'
    divided by 1 + i eta. Solved independently: the damped rail at real omega, the rail
    without loss at complex omega'."""
    g, g0 = rail(0.02, eta), rail(0.02, 0.0)
    loc = mobility.head_patch(g, 0.02)
    fr = mobility.FamilyResponse(g, "symmetric", loc.weights[:, None], loc.weights[:, None])
    fr0 = mobility.FamilyResponse(g0, "symmetric", loc.weights[:, None], loc.weights[:, None])
    x = np.array([0.0, 0.6, 6.0])
    for f in (200.0, 2500.0):
        om = 2 * np.pi * f
        w = waves.waves_at(fr.ops, om, method="shift-invert", n_waves=20)
        w0 = waves.waves_at(fr0.ops, waves.loss_frequency(om, eta), method="shift-invert",
                            n_waves=20)
        assert np.abs(w.k - w0.k).max() < 1e-8 * np.abs(w.k).max()
        r = mobility.wave_sum(fr, w, x, 0.02)
        r0 = mobility.wave_sum(fr0, w0, x, 0.02) / (1 + 1j * eta)
        assert np.abs(r - r0).max() < 1e-8 * np.abs(r).max()


def test_kernel_at_another_rail_loss_factor_equals_a_fresh_one(monkeypatch):
    """wfe.discrete_kernel(..., eta_r=) on a guide of another loss factor: the same kernel
    as one built on a guide assembled with eta_r, and the undamped near-field tail is not
    solved again (its eigen-solve is cached without the loss factor)."""
    from railfem.track import wfe

    g = rail(0.02, 0.01)
    springs = wfe.foot_springs(g, 2)
    load = mobility.head_patch(g, 0.02)
    out = [mobility.point(g, "foot_sensor", "z")]
    kw = dict(load=load, outputs=out, force_x=[0.0, 0.3], response_x=[0.0, 1.2],
              spring_length=0.15, n_waves=20)
    xs, f = np.arange(-5, 6) * 0.6, [100.0, 900.0, 3000.0]
    wfe.discrete_kernel(g, springs, xs, f, **kw)
    dense = []
    solve = waves._lambdas_dense
    monkeypatch.setattr(waves, "_lambdas_dense", lambda *a, **k: dense.append(1) or solve(*a, **k))
    for eta in (0.001, 0.1):
        got = wfe.discrete_kernel(g, springs, xs, f, eta_r=eta, **kw)
        ref = wfe.discrete_kernel(rail(0.02, eta), springs, xs, f, **kw)
        for name in ("ss", "sP", "rs", "rP"):
            a, b = getattr(got, name), getattr(ref, name)
            assert np.abs(a - b).max() < 1e-12 * np.abs(b).max(), name
    assert not dense
