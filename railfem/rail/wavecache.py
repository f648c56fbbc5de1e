"""The wave solvers' run-time settings: BLAS threads inside solver calls and the bounded
in-memory cache of wave sets (railfem.rail.waves keys it by the operators' content).

* ``blas_threads``: BLAS limited to RAILFEM_BLAS_THREADS threads (default 1) in a solver call.
* ``cached(key, solve)``: solve() memoised in an LRU bounded by RAILFEM_WAVE_CACHE_MB (default
  512 MB; 0 switches it off); ``clear_cache``, ``cache_info``.
"""
from __future__ import annotations

import os
from collections import OrderedDict
from contextlib import contextmanager

THREADS_VARIABLE = "RAILFEM_BLAS_THREADS"  # BLAS threads in solver calls; "none": leave as set
CACHE_VARIABLE = "RAILFEM_WAVE_CACHE_MB"  # bound of the in-memory wave cache; 0 disables it
# 512: a diagnosis on WFE holds the undamped pairs of its frozen tails (N x N each, 12-50 MB
# for a 10 mm section) for the base and its discretisation variants; at 256 they were
# evicted by the per-frequency waves and solved again (benchmarks/results/results_tests.txt)
DEFAULT_CACHE_MB = 512.0
_controller = None
_cache: OrderedDict = OrderedDict()


@contextmanager
def blas_threads():
    """Limit BLAS threads inside a solver call to RAILFEM_BLAS_THREADS (default 1).

    One thread is fastest for these problem sizes on a shared machine (threaded OpenBLAS
    oversubscribed a loaded 2-core machine and ran the dense solves 10-50x slower); set
    RAILFEM_BLAS_THREADS to a number to use more, or to "none" to leave BLAS alone."""
    global _controller
    value = os.environ.get(THREADS_VARIABLE, "1").strip().lower()
    if value in ("none", ""):
        yield
        return
    try:
        n = int(value)
        if n < 1:
            raise ValueError
    except ValueError:
        raise ValueError(f"{THREADS_VARIABLE}={value!r}: use a number of threads >= 1 or "
                         "'none'") from None
    if _controller is None:
        from threadpoolctl import ThreadpoolController

        _controller = ThreadpoolController()
    with _controller.limit(limits=n, user_api="blas"):
        yield


def cache_limit() -> float:
    """The wave cache's bound in bytes (RAILFEM_WAVE_CACHE_MB); 0: no cache."""
    value = os.environ.get(CACHE_VARIABLE, str(DEFAULT_CACHE_MB))
    try:
        mb = float(value)
        if not mb >= 0:
            raise ValueError
    except ValueError:
        raise ValueError(f"{CACHE_VARIABLE}={value!r}: use a size in MB >= 0 (0 disables the "
                         "wave cache)") from None
    return mb * 1e6


def _nbytes(w) -> int:
    return w.k.nbytes + w.phi.nbytes + w.denom.nbytes


def clear_cache() -> None:
    """Forget every cached wave solution (waves_at and frozen_tail results)."""
    _cache.clear()


def cache_info() -> dict:
    """Number of cached wave sets and their size in bytes."""
    return {"entries": len(_cache), "bytes": sum(_nbytes(w) for w in _cache.values()),
            "limit_bytes": cache_limit()}


def cached(key, solve):
    """solve() (a wave set: arrays k, phi, denom) memoised under ``key`` in the bounded LRU
    cache, its arrays made read-only (shared between callers); solve() itself when the
    cache is off."""
    limit = cache_limit()
    if limit <= 0:
        return solve()
    hit = _cache.get(key)
    if hit is not None:
        _cache.move_to_end(key)
        return hit
    w = solve()
    for arr in (w.k, w.phi, w.denom):
        arr.flags.writeable = False
    size = _nbytes(w)
    if size <= limit:
        _cache[key] = w
        total = sum(_nbytes(v) for v in _cache.values())
        while total > limit:
            total -= _nbytes(_cache.popitem(last=False)[1])
    return w
