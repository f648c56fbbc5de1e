"""A force spread over ``numerics.load_length`` (m) is the point-force receptance averaged
over the patch, for the beam models (timoshenko-continuous ignored the load length)."""
from dataclasses import replace

import numpy as np
import pytest

import railfem as rf
from railfem.models import receptance


def _patch_average(spec, f, x, L, n=24):
    """The point-force receptance at each response x averaged over a force patch of length
    L centred on 0: Gauss-Legendre on each side of the force position under the response
    (the integrand has a kink there)."""
    point = spec.replace(numerics=replace(spec.numerics, load_length=0.0))
    t, w = np.polynomial.legendre.leggauss(n)
    out = []
    for xr in x:
        cuts = sorted({-L / 2, L / 2, min(max(xr, -L / 2), L / 2)})
        total = 0.0
        for lo, hi in zip(cuts[:-1], cuts[1:]):
            s = (hi - lo) / 2 * t + (hi + lo) / 2
            a = receptance(point, f, s, [xr], cache=False)[:, 0, 0]  # (nf, ns)
            total = total + a @ (w * (hi - lo) / 2)
        out.append(total / L)
    return np.stack(out, axis=1)


@pytest.mark.parametrize("model", ["timoshenko-continuous", "timoshenko-discrete"])
def test_spread_load_is_the_patch_average_of_the_point_load(model):
    L = 0.08
    spec = rf.preset("medium", model=model)
    spec = spec.replace(numerics=replace(spec.numerics, load_length=L))
    f = np.array([50.0, 400.0, 1500.0, 4000.0])
    x = np.array([0.0, 0.01, 0.3])
    got = receptance(spec, f, [0.0], x, cache=False)[:, 0, :, 0]
    want = _patch_average(spec, f, x, L)
    assert np.allclose(got, want, rtol=1e-6, atol=0), np.max(np.abs(got / want - 1))
    # the spread matters at this length: the test can tell a point load from a patch
    point = receptance(spec.replace(numerics=replace(spec.numerics, load_length=0.0)),
                       f, [0.0], x, cache=False)[:, 0, :, 0]
    assert np.max(np.abs(point / want - 1)) > 1e-3
