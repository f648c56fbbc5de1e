"""Fit campaigns: every row of a decay-rate table fitted on a Dask cluster.

Rows on the same bands share one forward model: its kernels (and, for a kernel parameter,
the profile nodes) are computed once and scattered to the workers, each fitting rows with
one BLAS thread.
"""
from __future__ import annotations

import logging
import time

import numpy as np

from railfem.identify.data import decay_rate_target
from railfem.identify.fit import DEFAULT_PARAMETERS, FIT_BOUNDS, base_spec, fit
from railfem.identify.forward import ForwardModel, Geometry
from railfem.identify.problem import Problem
from railfem.identify.profiling import default_workers, prebuild_nodes
from railfem.params import ParameterSpace

log = logging.getLogger(__name__)

__all__ = ["fit_campaign", "shared_forward"]


def _campaign_fit(forward, meas, opts):
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1):
        res = fit(meas, forward=forward, workers=1, **opts)
    return res


def shared_forward(first, *, model="wfe-discrete", base=None, parameters=DEFAULT_PARAMETERS,
                   cache=None):
    """(space, target, forward): the forward model every row on the bands of the
    measurement ``first`` shares."""
    spec0 = base_spec(first, model, base)
    b = {n: FIT_BOUNDS[n] for n in parameters if n in FIT_BOUNDS}
    space = ParameterSpace(spec0, parameters, bounds=b)
    target = decay_rate_target(first, spec0.spacing)
    geometry = Geometry(frequency=target.frequency, outputs=target.outputs,
                        sensor_x=target.sensor_x, force_x=target.force_x)
    return space, target, ForwardModel(space, geometry, cache=cache)


def _prebuild_profile_nodes(space, target, forward, slow_nodes: int, workers: int) -> None:
    """The profile nodes of the first kernel parameter every row uses, built once (in
    processes); nothing for a fit without kernel parameters."""
    slow = [n for n in space.names if n in forward.slow]
    if not slow:
        return
    i = space.names.index(slow[0])
    nodes = np.linspace(space.lower[i], space.upper[i], slow_nodes + 2)[1:-1]
    x = np.clip(space.from_spec(space.base), space.lower, space.upper)
    prebuild_nodes(Problem(target=target, forward=forward), nodes, i, x, workers)


def _fit_on_cluster(items, forward, opts, scheduler, workers) -> list:
    """The FitResult of each row, in the order of ``items``."""
    from dask.distributed import Client, LocalCluster, as_completed

    if scheduler:
        client = Client(scheduler)
        cluster = None
    else:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=None)
        client = Client(cluster)
    try:
        fwd = client.scatter(forward, broadcast=True)
        futs = {client.submit(_campaign_fit, fwd, m, opts, pure=False): k
                for k, (_, m) in enumerate(items)}
        results = [None] * len(items)
        t0 = time.perf_counter()
        for n, fut in enumerate(as_completed(futs), 1):
            k = futs[fut]
            results[k] = fut.result()
            md = items[k][1].metadata
            log.info("campaign: row %d (%s %s %s) done, %d/%d, %.0f s", items[k][0],
                     md.section, md.date, md.rail_side, n, len(items),
                     time.perf_counter() - t0)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return results


def fit_campaign(items, *, scheduler=None, base=None, workers=None, model="wfe-discrete",
                 parameters=DEFAULT_PARAMETERS, slow_nodes=None, slow_refine=None,
                 cache=None, **opts):
    """Fit every (index, DecayRateMeasurement) of ``items`` on a Dask cluster (the address
    ``scheduler`` or a LocalCluster of ``workers`` processes, one thread each). Rows on the
    same bands share one forward model: its kernels (and, for a kernel parameter, the
    profile nodes) are computed once here and scattered to the workers. Returns
    [(index, measurement, FitResult)] in the order given."""
    first = items[0][1]
    space, target, forward = shared_forward(first, model=model, base=base,
                                            parameters=parameters, cache=cache)
    beam = space.base.is_beam
    slow_nodes = slow_nodes or (5 if beam else 6)
    slow_refine = (3 if beam else 0) if slow_refine is None else slow_refine
    nw = workers or default_workers()
    _prebuild_profile_nodes(space, target, forward, slow_nodes, nw)
    opts.update(slow_nodes=slow_nodes, slow_refine=slow_refine)
    for _, m in items:
        if not np.array_equal(m.frequency, first.frequency):
            raise ValueError("campaign rows must share the bands of the first row")
    results = _fit_on_cluster(items, forward, opts, scheduler, nw)
    return [(i, m, r) for (i, m), r in zip(items, results)]
