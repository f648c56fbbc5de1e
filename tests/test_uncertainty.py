"""railfem.identify.uncertainty against Monte Carlo on linear least squares (no model of
railfem involved): the model-based covariance where the entries are independent, the
cluster-robust one where they share noise within clusters."""
from types import SimpleNamespace

import numpy as np
import pytest

from railfem.identify import uncertainty as u
from railfem.params import Parameter


def _design(rng, n_clusters=40, per=12):
    x = np.linspace(0, 1, n_clusters * per)
    J = np.column_stack([np.ones_like(x), x, np.sin(6 * x)])
    return J, np.repeat(np.arange(n_clusters), per)


def _monte_carlo(J, clusters, rng, shared, trials=2000):
    """SD of the LS estimates over trials; noise per entry 1 (white) plus ``shared`` (one
    draw per cluster, the same for its entries)."""
    est, rob, mod = [], [], []
    G = clusters.max() + 1
    for _ in range(trials):
        e = rng.standard_normal(len(J)) + shared * rng.standard_normal(G)[clusters]
        x, *_ = np.linalg.lstsq(J, e, rcond=None)
        r = J @ x - e
        est.append(x)
        _, C_diag, *_ = u.covariance(J, r)
        mod.append(C_diag)
        rob.append(np.diag(u.robust_covariance(J, r, clusters)[0]))
    sd = np.std(est, axis=0)
    return sd, np.sqrt(np.mean(mod, axis=0)), np.sqrt(np.mean(rob, axis=0))


def test_robust_covariance_equals_model_based_on_independent_noise():
    rng = np.random.default_rng(0)
    J, cl = _design(rng)
    sd, mod, rob = _monte_carlo(J, cl, rng, shared=0.0)
    assert np.allclose(mod / sd, 1, atol=0.06)
    assert np.allclose(rob / sd, 1, atol=0.1)


def test_robust_covariance_sees_noise_shared_within_clusters():
    """Noise shared by the 12 entries of a cluster (SD 1 each, as the white part): the
    model-based SD is about half the true one, the cluster-robust one within 10 %; the
    analysis takes the larger (its interval widens to the true size)."""
    rng = np.random.default_rng(1)
    J, cl = _design(rng)
    sd, mod, rob = _monte_carlo(J, cl, rng, shared=1.0)
    assert np.all(mod / sd < 0.5)
    assert np.allclose(rob / sd, 1, atol=0.1)

    Space = SimpleNamespace(
        parameters=tuple(Parameter(name=n, unit="-", log=False, lower=-10, upper=10)
                         for n in "abc"),
        names=tuple("abc"), lower=np.full(3, -10.0), upper=np.full(3, 10.0))

    e = rng.standard_normal(len(J)) + rng.standard_normal(cl.max() + 1)[cl]
    x, *_ = np.linalg.lstsq(J, e, rcond=None)
    r = J @ x - e
    plain = u.analyse(Space, x, J, r)["parameters"]
    robust = u.analyse(Space, x, J, r, clusters=cl)["parameters"]
    for p, q in zip(plain, robust):
        assert q["std_vector"] >= p["std_vector"]
    assert robust[0]["std_vector"] > 1.5 * plain[0]["std_vector"]


def _bumps(t, centres, width=0.06):
    return np.exp(-0.5 * ((t[:, None] - np.asarray(centres)[None, :]) / width) ** 2)


def test_nuisance_covariance_covers_unfitted_random_terms():
    """Six fitted bumps (0.1..0.6) and six unfitted random ones beyond them (0.7..1.0, SD
    2, the noise SD 1): the estimates take on the unfitted scatter, most at the edge. With
    N (their columns times SD) the analysis' SD matches the Monte Carlo SD and the 95 %
    intervals cover the truth at least 95 % of the time; without it the edge parameter's
    SD is less than half the true one and its interval covers far less. (The residual
    variance s^2 also holds the part of the unfitted terms the fit cannot absorb, so the
    interior parameters, which they hardly move, are reported conservatively.)"""
    rng = np.random.default_rng(3)
    t = np.linspace(0, 1, 400)
    J = _bumps(t, np.linspace(0.1, 0.6, 6))
    N = 2.0 * _bumps(t, np.linspace(0.7, 1.0, 6))
    Space = SimpleNamespace(
        parameters=tuple(Parameter(name=f"p{i}", unit="-", log=False, lower=-50, upper=50)
                         for i in range(6)),
        names=tuple(f"p{i}" for i in range(6)), lower=np.full(6, -50.0),
        upper=np.full(6, 50.0))
    est, sd_with, sd_without, cover_with, cover_without = [], [], [], [], []
    for _ in range(1000):
        e = N @ rng.standard_normal(6) + rng.standard_normal(len(t))
        x, *_ = np.linalg.lstsq(J, e, rcond=None)  # the truth is 0
        r = J @ x - e
        w = u.analyse(Space, x, J, r, nuisance=N)
        wo = u.analyse(Space, x, J, r)
        est.append(x)
        sd_with.append([p["std_vector"] for p in w["parameters"]])
        sd_without.append([p["std_vector"] for p in wo["parameters"]])
        cover_with.append([p["ci95"][0] <= 0 <= p["ci95"][1] for p in w["parameters"]])
        cover_without.append([p["ci95"][0] <= 0 <= p["ci95"][1] for p in wo["parameters"]])
    sd = np.std(est, axis=0)
    ratio = np.mean(sd_with, axis=0) / sd
    assert np.all(ratio > 0.95) and ratio[-1] < 1.1
    assert np.mean(sd_without, axis=0)[-1] < 0.5 * sd[-1]
    assert np.all(np.mean(cover_with, axis=0) > 0.94)
    assert np.mean(cover_without, axis=0)[-1] < 0.7


def test_combination_std_of_a_sum_of_anticorrelated_parameters():
    """Two columns that nearly coincide (a mean and a factor on it): each estimate scatters
    widely, their sum hardly; combination_std gives the sum's Monte Carlo SD (model-based
    and, with clusters, the larger of it and the robust one)."""
    rng = np.random.default_rng(5)
    t = np.linspace(0, 1, 300)
    J = np.column_stack([np.ones_like(t), np.ones_like(t) + 0.05 * t])
    Space = SimpleNamespace(
        parameters=tuple(Parameter(name=n, unit="-", log=False, lower=-1e3, upper=1e3)
                         for n in "ab"),
        names=("a", "b"), lower=np.full(2, -1e3), upper=np.full(2, 1e3))
    cl = np.repeat(np.arange(30), 10)
    sums, sds, sds_cl, sd_a = [], [], [], []
    for _ in range(1000):
        e = rng.standard_normal(len(t))
        x, *_ = np.linalg.lstsq(J, e, rcond=None)
        an = u.analyse(Space, x, J, J @ x - e)
        sums.append(x.sum())
        sds.append(u.combination_std(an, [1.0, 1.0]))
        sds_cl.append(u.combination_std(u.analyse(Space, x, J, J @ x - e, clusters=cl),
                                        [1.0, 1.0]))
        sd_a.append(an["parameters"][0]["std_vector"])
    assert np.mean(sds) == pytest.approx(np.std(sums), rel=0.05)
    # the larger of two estimates of the same SD (the robust one from 30 clusters)
    assert np.all(np.array(sds_cl) >= np.array(sds))
    assert np.mean(sds_cl) == pytest.approx(np.std(sums), rel=0.15)
    assert np.mean(sd_a) > 10 * np.std(sums)
