"""The discrete coupling of a long uniform layout as a chain of waves
(railfem.track.semiseparable, couple_discrete(method='chain')).

Independent checks: the whole system (diag(a) + diag(b) alpha_ss) F = rhs written out
here from the kernel's arrays and solved densely, for a vertical and a lateral load on
springs in three directions, with one support deviating (supports no longer identical),
and a layout that is not equally spaced (the chain is refused there); the realisation of
a sequence built from known waves."""

import numpy as np
import pytest

import railfem as rf
from railfem import models
from railfem.spec import RailSpec
from railfem.track import coupling
from railfem.track import semiseparable as semi
from railfem.track import wfe as track

F = np.array([60.0, 400.0, 2500.0])


@pytest.fixture(scope="module")
def case():
    spec = rf.preset("site", support_directions="zyx", n_supports=31, rail=RailSpec(h=0.02))
    fx, rx = [0.0, 0.3], [0.0, 0.3, 1.2, 4.5]
    vert, _, _ = models.discrete_kernel(spec, F, fx, rx, cache=False)
    lat, _, _ = models.discrete_kernel(spec, F, fx, rx, outputs=models.LATERAL,
                                       force="head_lateral", cache=False)
    K = track.spring_stiffness(spec.layout(), 2 * np.pi * F, lat)  # every direction code
    return spec, vert, lat, K


def dense_reference(kernel, K):
    """(nf, n_out, n_rx, n_fx) from the whole system in one piece, row-scaled as the
    coupling's (1 / K + alpha) F = alpha_sP for finite springs."""
    n_s, n_p, n_rx, n_fx = kernel.shape
    d = kernel.spring_direction
    out = np.empty((len(kernel.frequency), kernel.rs.shape[2], n_rx, n_fx), dtype=complex)
    for i in range(len(kernel.frequency)):
        k = (K[i][:, d] * kernel.spring_weight[None, :]).ravel()  # set-major springs
        A = kernel.ss[i][kernel.ss_index].transpose(0, 2, 1, 3).reshape(n_s * n_p, -1)
        B = kernel.sP[i][kernel.sP_index].transpose(0, 2, 1).reshape(n_s * n_p, n_fx)
        Fs = np.linalg.solve(np.eye(n_s * n_p) + k[:, None] * A, k[:, None] * B)
        G = kernel.rs[i][kernel.rs_index]  # (rx, s, o, p)
        out[i] = kernel.rP[i][kernel.rP_index].transpose(2, 0, 1) - np.einsum(
            "rsop,spf->orf", G, Fs.reshape(n_s, n_p, n_fx))
    return out


def rel_error(a, b):
    """Largest difference relative to the largest value, per frequency."""
    return (np.abs(a - b).max(axis=(1, 2, 3)) / np.abs(b).max(axis=(1, 2, 3))).max()


def test_layout_is_a_chain(case):
    spec, vert, _, _ = case
    plan = semi.chain_plan(vert.spring_x, vert.ss_index, vert.shape[1])
    assert plan is not None
    assert (plan.n_sup, plan.n_rows, plan.nb) == (spec.n_supports, spec.n_rows,
                                                  spec.n_rows * vert.shape[1])


@pytest.mark.parametrize("load", ["vertical", "lateral"])
def test_chain_equals_dense_solve(case, load):
    _, vert, lat, K = case
    kernel = vert if load == "vertical" else lat
    got = coupling.couple_discrete(kernel, K, method="chain")
    assert rel_error(got, dense_reference(kernel, K)) < 1e-10
    # the dense path of the coupling agrees too (its mirror halves, its family split)
    assert rel_error(got, coupling.couple_discrete(kernel, K, method="dense")) < 1e-10


def test_chain_with_a_deviating_support(case):
    """Supports no longer identical (one support at a third of the stiffness in every
    direction): the chain takes each support's own springs."""
    spec, vert, _, K = case
    K2 = K.copy()
    rows = slice(5 * spec.n_rows, 6 * spec.n_rows)
    K2[:, rows] /= 3
    got = coupling.couple_discrete(vert, K2, method="chain")
    want = dense_reference(vert, K2)
    assert rel_error(got, want) < 1e-10
    assert rel_error(coupling.couple_discrete(vert, K, method="chain"), want) > 1e-4


def test_unequal_spacing_is_solved_densely(case):
    _, vert, _, K = case
    arrays = vert.to_arrays()
    xs = arrays["spring_x"].copy()
    xs[-3:] += 0.01  # the last support moved: not a chain
    arrays["spring_x"] = xs
    moved = coupling.DiscreteKernel.from_arrays(arrays)
    assert semi.chain_plan(moved.spring_x, moved.ss_index, moved.shape[1]) is None
    got = coupling.couple_discrete(moved, K, method="chain")
    assert np.array_equal(got, coupling.couple_discrete(moved, K, method="dense"))


def test_realise_recovers_known_waves():
    """T_n = sum_m u_m v_m^T lam_m^n: rank and every block recovered."""
    rng = np.random.default_rng(3)
    lam = np.exp(-1j * np.array([2.0 - 0.01j, 5.0 - 0.3j, 9.0 - 2j, 1.0 - 8j]) * 0.6)
    u = rng.normal(size=(4, 5)) + 1j * rng.normal(size=(4, 5))
    v = rng.normal(size=(4, 5)) + 1j * rng.normal(size=(4, 5))
    n = np.arange(1, 41)
    T = np.einsum("mi,mj,mn->nij", u, v, lam[:, None] ** n[None, :])
    C, A, B = semi.realise(T)
    assert A.shape == (4, 4)
    assert semi.realisation_error(C, A, B, T) < 1e-12 * np.abs(T).max()
    assert np.allclose(np.sort_complex(np.linalg.eigvals(A)), np.sort_complex(lam))


def test_method_is_checked(case):
    _, vert, _, K = case
    with pytest.raises(ValueError, match="method"):
        coupling.couple_discrete(vert, K, method="sparse")
