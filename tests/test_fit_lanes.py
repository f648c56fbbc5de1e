"""A fit's WFE kernels split over worker processes by frequency (railfem.identify.profiling
.Lanes): the kernel of part of a frequency grid, its near-field tail solved at the grid's
lowest frequency, is the whole grid's kernel there, so the engines and the model-form
variants built in the lanes equal those built in one process."""
import importlib
from types import SimpleNamespace

import numpy as np
import pytest

import railfem as rf
from railfem import models
from railfem.identify import discrepancy
from railfem.identify.forward import ForwardModel, Geometry, door_receptance
from railfem.identify.profiling import Lanes
from railfem.params import ParameterSpace
from railfem.spec import RailSpec
from railfem.track.kernelcache import KernelStore

from benchmarks.blind import generators as g

F = importlib.import_module("railfem.identify.fit")  # the module (identify.fit is the function)
FREQ = np.array([60.0, 250.0, 900.0, 1800.0, 3100.0])


def small_spec():
    """A short, coarse wfe-discrete track (cheap kernels)."""
    return rf.preset("site", model="wfe-discrete", n_supports=31, pad_length=0.0,
                     n_rows=1, rail=RailSpec(h=0.02))


def rel(a, b) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


def test_part_of_a_grid_with_the_grids_tail_frequency_is_the_grid():
    spec = small_spec()
    fx, rx = [0.0, 0.6], [0.1]
    whole = models.receptance(spec, FREQ, fx, rx, cache=False)
    parts = [models.receptance(spec, FREQ[rows], fx, rx, cache=False,
                               tail_frequency=FREQ[0]) for rows in (slice(0, 2), slice(2, 5))]
    assert rel(np.concatenate(parts), whole) < 1e-12
    # the tail solved at the part's own lowest frequency is another (close) result
    alone = models.receptance(spec, FREQ[2:], fx, rx, cache=False)
    assert rel(alone, whole[2:]) > 1e-12


def test_lanes_build_the_engines_and_variants_of_one_process():
    spec = small_spec()
    names = ("kp", "eta_p", "kb", "eta_b", "eta_r")
    space = ParameterSpace(spec, names, bounds={n: F.FIT_BOUNDS[n] for n in names})
    geometry = Geometry(frequency=FREQ, outputs=("head", "foot"), sensor_x=0.0,
                        force_x=np.array([0.0, 0.6, 1.2]))
    x = np.clip(space.from_spec(spec), space.lower, space.upper)
    variants = [s for _, s in discrepancy.variants(spec)]
    laned = ForwardModel(space, geometry, cache=KernelStore(directory=False))
    with Lanes(SimpleNamespace(forward=laned), 2) as lanes:  # before the serial waves
        laned.builder = lanes.builder
        got = laned.receptance(x)
        got_variants = lanes.receptances(variants, False, rail=spec.rail)  # split and whole
    serial = ForwardModel(space, geometry, cache=KernelStore(directory=False))
    assert rel(got, serial.receptance(x)) < 1e-12
    for s, a in zip(variants, got_variants):
        ref = door_receptance(s, FREQ, 0.0, geometry.force_x, geometry.outputs,
                              cache=False)
        assert rel(a, ref) < 1e-12


@pytest.mark.slow  # two whole fits, ~10 s CPU; the two tests above cover the parts
def test_a_fit_on_two_lanes_is_the_fit_in_one_process():
    """The whole cold fit (rail-loss profile, its refinement, the discrepancy's variants
    with their prefetched tails, the refit under the final scales) with workers=2 gives the
    serial fit's estimates and costs."""
    spec = small_spec().replace(kp=400e6, eta_p=0.2, kb=60e6, eta_b=1.0, eta_r=0.02)
    f = np.geomspace(100.0, 3000.0, 4)
    xs, pos, hx = models.hammer_x(spec, positions=np.array([0.0, 0.3, 0.6, 1.2, 2.4]))
    a = models.receptance(spec, f, hx, [xs], outputs=("head",), cache=False)[:, :, 0, :]
    pos = pos.copy()
    pos[0] = models.POINT_OFFSET
    meas = g.measurement(2j * np.pi * f[:, None, None] * a, pos, f, stated_sensor_x=xs)
    base = small_spec()
    runs = [F.fit(meas, base=base, use=("point", "transfer"), n_starts=1, workers=w,
                  profiles=(), cache=KernelStore(directory=False)) for w in (2, 1)]
    laned, serial = runs
    assert laned.discrepancy["variants"] == serial.discrepancy["variants"]
    assert len(laned.discrepancy["variants"]) == 3
    np.testing.assert_allclose(laned.x, serial.x, rtol=1e-9, atol=1e-12)
    assert laned.cost == pytest.approx(serial.cost, rel=1e-9)
    assert laned.slow_profile["cost"] == pytest.approx(serial.slow_profile["cost"], rel=1e-9)
