"""The shift-invert route of railfem.rail.waves: the frequency matrix divided by the complex
modulus factor c = 1 + i eta, factorised block by block (axial, in-plane), against a dense
solve of the damped k^2 pencil built independently (lil blocks, complex modulus applied to
the stiffness, no division by c, one dense generalised eigen-solve).
"""
import numpy as np
import pytest
import scipy.linalg as sl
import scipy.sparse as sp
import scipy.sparse.linalg as spl

from railfem.materials import Material
from railfem.rail import meshing, waveguide, waves

_GUIDES = {}


def rail(eta):
    if eta not in _GUIDES:
        _GUIDES[eta] = waveguide.assemble(meshing.get_mesh("60E1", 0.02), Material.steel(eta))
    return _GUIDES[eta]


@pytest.fixture(autouse=True)
def no_cache(monkeypatch):
    monkeypatch.setenv(waves.CACHE_VARIABLE, "0")


def damped_pencil(guide, family, omega):
    """Z and B of Z x + k^2 B x = 0 with the loss factor on the stiffness, built from the
    guide's matrices by block assignment: Z = c K0 - omega^2 M with its axial/in-plane block
    c K1, B = c [[K2aa, 0], [-K1pa, K2pp]] (u_a = i k w)."""
    T = guide.families[family].T
    comp = guide.families[family].component
    a, p = np.nonzero(comp == 0)[0], np.nonzero(comp != 0)[0]
    order = np.concatenate([a, p])
    na = len(a)
    K0, K1, K2, M = ((T.T @ X @ T).tocsr()[order][:, order]
                     for X in (guide.K0, guide.K1, guide.K2, guide.M))
    c = 1 + 1j * guide.loss_factor
    Z = (c * K0 - omega**2 * M).tolil()
    Z[:na, na:] = c * K1[:na, na:]
    B = sp.lil_matrix(K2.shape, dtype=complex)
    B[:na, :na] = c * K2.tolil()[:na, :na]
    B[na:, na:] = c * K2.tolil()[na:, na:]
    B[na:, :na] = -c * K1[na:, :na]
    return Z.toarray(), B.toarray()


@pytest.mark.parametrize("eta, family", [(0.01, "symmetric"), (0.1, "antisymmetric")])
def test_damped_shift_invert_wavenumbers_equal_a_dense_solve(eta, family):
    g = rail(eta)
    ops = waves.FamilyOperators(g, family)
    for f in (150.0, 2500.0):
        om = 2 * np.pi * f
        w = waves.waves_at(ops, om, method="shift-invert", n_waves=20)
        Z, B = damped_pencil(g, family, om)
        lam = 1.0 / sl.eigvals(np.linalg.solve(Z, -B))  # the largest 1 / k^2 most accurate
        lam = lam[np.argsort(np.abs(lam))][:20]
        got = w.k**2
        # every wave found, each once, to 1e-8 relative
        err = np.abs(got[:, None] - lam[None, :]) / np.abs(lam)[None, :]
        assert np.all(err.min(axis=1) < 1e-8), err.min(axis=1).max()
        assert len(set(err.argmin(axis=1))) == 20
        assert np.all(w.k.imag < 0)  # positive-going: decaying towards +x


def test_blockwise_solve_equals_a_solve_of_the_whole_matrix():
    """factorised(omega) solves (c K0' - omega^2 M + extra) / c, blockwise when the
    frequency matrix is block upper triangular and with one LU when a foundation couples
    the in-plane rows to the axial columns."""
    g = rail(0.05)
    ops = waves.FamilyOperators(g, "symmetric")
    om = 2 * np.pi * 700.0
    rng = np.random.default_rng(3)
    r = rng.standard_normal((ops.B0.shape[0], 3)) + 1j * rng.standard_normal((ops.B0.shape[0], 3))
    na, n = ops.na, ops.B0.shape[0]
    coupling = sp.csc_matrix(([1e7, 2e7], ([na + 1, 0], [0, na + 2])), shape=(n, n))
    for extra in (None, lambda omega: 3e8 * sp.identity(n, format="csc"),
                  lambda omega: coupling):
        ops.extra = extra
        Z = (ops.constant_matrix(om) / ops.c).tocsc()
        ref = spl.spsolve(Z, r)
        got = ops.factorised(om)(r)
        assert np.abs(got - ref).max() < 1e-10 * np.abs(ref).max()


def test_undamped_rail_on_a_lossy_foundation_is_solved_in_complex_arithmetic():
    """A rail without loss (c = 1) on a foundation of complex stiffness: the frequency
    matrix is complex although c is real; shift-invert gives the dense solve's waves."""
    g = rail(0.0)
    ops = waves.FamilyOperators(g, "symmetric")
    n = ops.B0.shape[0]
    bed = sp.diags(np.r_[np.zeros(n - 12), np.ones(12)]).tocsc()  # last in-plane DOFs
    ops.extra = lambda omega: (2e8 + 4e7j) * bed
    om = 2 * np.pi * 900.0
    got = waves.waves_at(ops, om, method="shift-invert", n_waves=15).k
    ref = waves.waves_at(ops, om, method="dense").k[:15]
    assert np.iscomplexobj(got) and np.abs(got.imag).min() > 0
    err = np.abs(got[:, None] ** 2 - ref[None, :] ** 2).min(axis=1) / np.abs(got) ** 2
    assert err.max() < 1e-8, err.max()


@pytest.mark.parametrize("eta", [0.0, 0.02])
def test_orderings_found_once_solve_at_every_frequency_and_next_to_a_cut_on(eta):
    """The blocks' fill-reducing orderings come from the first factorisation and are reused
    at later frequencies (block-ordered patterns); the solves stay backward stable next to a
    cut-on, where the in-plane block is nearly singular (threshold pivoting)."""
    g = rail(eta)
    ops = waves.FamilyOperators(g, "antisymmetric")
    f_cut = waves.cut_on_frequencies(g, n=1, family="antisymmetric")[0]
    n = ops.B0.shape[0]
    rng = np.random.default_rng(5)
    r = rng.standard_normal((n, 2)) + (1j * rng.standard_normal((n, 2)) if eta else 0)
    first = ops.factorised(2 * np.pi * 400.0)  # real arithmetic without loss
    for f in (400.0, 2600.0, f_cut * (1 + 1e-9)):
        om = 2 * np.pi * f
        solve = ops.factorised(om)
        assert all(np.array_equal(a, b) for a, b in zip(solve.orders, first.orders))
        Z = (ops.constant_matrix(om) / ops.c).tocsc()
        for rhs in (r, r[:, 0]):
            x = solve(rhs)
            assert x.shape == rhs.shape
            backward = np.abs(Z @ x - rhs).max() / (spl.norm(Z, np.inf) * np.abs(x).max())
            assert backward < 1e-14, backward
            if f < 1000:  # well conditioned: the same solution as a direct solve
                ref = spl.spsolve(Z, rhs)
                assert np.abs(x - ref).max() < 1e-10 * np.abs(ref).max()


@pytest.mark.parametrize("eta", [0.0, 0.03])
def test_shift_invert_operator_is_the_pencil_in_block_coordinates(eta):
    """op y = -Z^-1 B0 y with y = x[perm]: against a direct solve of the frequency matrix
    divided by c in the operators' own order, for a real and a complex operator."""
    g = rail(eta)
    ops = waves.FamilyOperators(g, "symmetric")
    om = 2 * np.pi * 1300.0
    op, perm = ops.shift_invert_operator(om)
    n = ops.B0.shape[0]
    assert np.array_equal(np.sort(perm), np.arange(n))
    assert np.all(perm[: ops.na] < ops.na)  # axial DOFs stay first
    rng = np.random.default_rng(7)
    x = rng.standard_normal(n) + (1j * rng.standard_normal(n) if eta else 0)
    Z = (ops.constant_matrix(om) / ops.c).tocsc()
    ref = -spl.spsolve(Z, ops.B0 @ x)
    got = op.matvec(x[perm])
    assert got.dtype == (complex if eta else float)
    assert np.abs(got - ref[perm]).max() < 1e-11 * np.abs(ref).max()
    assert np.abs(op.matvec(x[perm]) - got).max() == 0  # the input is not modified


def test_waves_do_not_depend_on_what_was_solved_before():
    """Every solve uses the same block orderings, the first one included: the waves at a
    frequency are identical on fresh operators and after solves at other frequencies."""
    g = rail(0.02)
    om = 2 * np.pi * 800.0
    fresh = waves.waves_at(waves.FamilyOperators(g, "symmetric"), om, method="shift-invert",
                           n_waves=20)
    ops = waves.FamilyOperators(g, "symmetric")
    waves.waves_at(ops, 2 * np.pi * 300.0, method="shift-invert", n_waves=20)
    later = waves.waves_at(ops, om, method="shift-invert", n_waves=20)
    assert np.array_equal(fresh.k, later.k)
    assert np.array_equal(fresh.phi, later.phi)


def test_denominators_equal_the_derivative_of_the_quadratic_pencil():
    """ops.dA (one product with B0) against psi^T c (2 k K2 + i K1) phi with psi = T_a phi
    built column by column from the guide's matrices, for any shapes and wavenumbers
    (k = 0 included)."""
    g = rail(0.04)
    ops = waves.FamilyOperators(g, "antisymmetric")
    T = g.families["antisymmetric"].T
    K1, K2 = ((T.T @ X @ T).tocsr()[ops.order][:, ops.order] for X in (g.K1, g.K2))
    rng = np.random.default_rng(11)
    n = ops.B0.shape[0]
    phi = rng.standard_normal((n, 5)) + 1j * rng.standard_normal((n, 5))
    k = np.array([0.0, 2.5 - 0.01j, -30.0j, 140.0 - 80.0j, 1e-4])
    psi = phi.copy()
    psi[: ops.na] *= -1.0
    ref = np.array([(1 + 0.04j) * psi[:, j] @ ((2 * k[j] * K2 + 1j * K1) @ phi[:, j])
                    for j in range(5)])
    got = ops.dA(k, phi)
    assert np.max(np.abs(got - ref) / np.abs(ref)) < 1e-12
