"""The energy-iteration equation of the pass-by decay rate, and its root (docs/passby_tdr.md).

Model (METHOD.md §6): wheels ``n = 1..N`` at train positions ``a_n`` are incoherent sources
of equal strength whose band mean-square at the sensor falls as ``A^2 exp(-2 β |u|)`` with
the distance ``u`` from the wheel; ``D = 20 lg(e) β = 8.686 β`` dB/m. With ``s`` the train
position, the band power at the sensor is ``P(s) = A^2 Σ_n exp(-2 β |s - a_n|)``.

Everything follows from one primitive, ``∫_0^u exp(-2β|v|) dv = Φ(u)/β`` with

    Φ(u) = ½ sign(u) (1 - exp(-2 β |u|)):

* energy of wheel ``n`` inside the window ``|s - a_m| ≤ L1/2`` of wheel ``m``
  (``d = a_m - a_n``): ``(A^2/β) [Φ(d + L1/2) - Φ(d - L1/2)]``; for ``d = 0`` this is
  ``(A^2/β)(1 - e^{-β L1})``, for ``|d| ≥ L1/2`` it is ``(A^2/β) sinh(β L1) e^{-2β|d|}``
  (METHOD.md's two terms), and for ``|d| < L1/2`` (overlapping windows, which METHOD.md
  leaves out) ``(A^2/β)(1 - e^{-β L1} cosh 2βd)``;
* energy of wheel ``n`` over the analysed stretch ``S_a ≤ s ≤ S_b``:
  ``(A^2/β) [Φ(S_b - a_n) - Φ(S_a - a_n)]`` (METHOD.md's ``A^2/β`` for an infinite record).

So, with ``A^2/β`` cancelling,

    E_L1 / E_L2 = Σ_m Σ_n [Φ(a_m - a_n + L1/2) - Φ(a_m - a_n - L1/2)]
                  / Σ_n [Φ(S_b - a_n) - Φ(S_a - a_n)]                     (1)

It rises from ``N L1 / (S_b - S_a)`` at β → 0 to 1 at β → ∞ (non-overlapping windows).
The band filter smears the measured power with its power kernel ``k(τ)`` (in train
travel, ``τ = V t``); the model is smeared with the same kernel, ``Φ(u) → Σ_j k_j Φ(u −
τ_j)``, which keeps it exact for modulated noise (:mod:`railfem.estimators.bands`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["phi", "window_terms", "record_terms", "energy_ratio", "EnergyRoot",
           "solve_energy_ratio", "coarse_kernel"]

DB_PER_NEPER_POWER = 20.0 / math.log(10.0)  # D = 8.686 β (β of the amplitude, 1/m)


def phi(u, beta) -> np.ndarray:
    """``Φ(u) = ½ sign(u) (1 − exp(−2β|u|))``; broadcasts ``u`` against ``beta``."""
    u = np.asarray(u, dtype=float)
    return -0.5 * np.sign(u) * np.expm1(-2.0 * np.asarray(beta, dtype=float) * np.abs(u))


def coarse_kernel(tau, weights, n: int = 101) -> tuple[np.ndarray, np.ndarray]:
    """Bin a symmetric smear kernel (positions ``tau``, weights summing to 1) into ``n``
    bins of equal width, so the model costs ``n`` evaluations per term, not thousands."""
    tau = np.asarray(tau, dtype=float)
    weights = np.asarray(weights, dtype=float)
    half = float(np.max(np.abs(tau)))
    if half == 0.0 or tau.size <= n:
        return tau, weights / weights.sum()
    edges = np.linspace(-half, half, n + 1)
    w, _ = np.histogram(tau, bins=edges, weights=weights)
    centres = 0.5 * (edges[1:] + edges[:-1])
    keep = w > 0
    return centres[keep], w[keep] / w[keep].sum()


def _smeared_phi(u: np.ndarray, beta, tau: np.ndarray, k: np.ndarray) -> np.ndarray:
    """``Σ_j k_j Φ(u − τ_j)`` for ``u`` of any shape (beta a scalar)."""
    return np.tensordot(phi(u[..., None] - tau, beta), k, axes=([-1], [0]))


def _kernel(tau, k):
    if tau is None:
        return np.zeros(1), np.ones(1)
    return np.asarray(tau, dtype=float), np.asarray(k, dtype=float)


def window_terms(beta: float, positions, l1: float, tau=None, k=None, *,
                 rows=None) -> np.ndarray:
    """``G_mn``: β/A² times the energy of wheel n in the window of wheel m, shape
    (len(rows), N) (all wheels m when ``rows`` is None)."""
    a = np.asarray(positions, dtype=float)
    m = a if rows is None else a[np.atleast_1d(rows)]
    d = m[:, None] - a[None, :]
    tau, k = _kernel(tau, k)
    return _smeared_phi(d + l1 / 2, beta, tau, k) - _smeared_phi(d - l1 / 2, beta, tau, k)


def record_terms(beta: float, positions, start: float, end: float, tau=None,
                 k=None) -> np.ndarray:
    """(N,) ``H_n``: β/A² times the energy of wheel n over train positions [start, end]."""
    a = np.asarray(positions, dtype=float)
    tau, k = _kernel(tau, k)
    return _smeared_phi(end - a, beta, tau, k) - _smeared_phi(start - a, beta, tau, k)


def energy_ratio(beta: float, positions, l1: float, start: float, end: float, tau=None,
                 k=None, *, wheel: int | None = None) -> float:
    """Model ratio at ``beta``: pooled ``E_L1/E_L2`` (equation (1)), or with ``wheel = m``
    that wheel's window alone, ``N E_L1,m / E_L2`` (scaled to be comparable)."""
    n = np.asarray(positions).size
    h = record_terms(beta, positions, start, end, tau, k).sum()
    if wheel is None:
        return float(window_terms(beta, positions, l1, tau, k).sum() / h)
    return float(n * window_terms(beta, positions, l1, tau, k, rows=wheel).sum() / h)


@dataclass(frozen=True, kw_only=True)
class EnergyRoot:
    """Solution of ``model(β) = measured`` for one ratio."""

    decay_rate: float
    """D = 8.686 β, dB/m, or NaN when there is no root."""
    status: str
    """'ok', 'no_root_high' (ratio above the model's range: decay too high to resolve with
    this L1), 'no_root_low' (below it), 'multiple_roots', 'implausible' (root outside
    the plausible range) or 'ill_conditioned' (a 1 % error of the ratio moves D by more
    than ``kappa_max`` %)."""
    kappa: float
    """Condition number |d ln β / d ln ratio| at the root (NaN without a root)."""
    raw: float
    """The root even when rejected as implausible or ill-conditioned, dB/m (else NaN)."""


def solve_energy_ratio(measured: float, model, *, bracket=(0.01, 300.0),
                       plausible=(0.1, 40.0), kappa_max: float = 10.0,
                       n_scan: int = 48) -> EnergyRoot:
    """Solve ``model(β) = measured`` for β by bracketing (scan + ``scipy.optimize.brentq``).

    ``model(β)`` returns the model ratio; ``bracket`` and ``plausible`` are decay rates in
    dB/m. The scan finds every sign change on a log grid; one sign change is refined by
    brentq, none or several are reported as failures, never guessed.
    """
    from scipy.optimize import brentq

    nan = float("nan")
    if not (math.isfinite(measured) and measured > 0):
        return EnergyRoot(decay_rate=nan, status="no_root_low", kappa=nan, raw=nan)
    betas = np.geomspace(bracket[0], bracket[1], n_scan) / DB_PER_NEPER_POWER
    f = np.array([model(b) - measured for b in betas])
    change = np.flatnonzero(np.sign(f[:-1]) * np.sign(f[1:]) <= 0)
    if change.size == 0:
        status = "no_root_high" if np.all(f < 0) else "no_root_low"
        return EnergyRoot(decay_rate=nan, status=status, kappa=nan, raw=nan)
    if change.size > 1 and np.any(np.diff(change) > 1):
        return EnergyRoot(decay_rate=nan, status="multiple_roots", kappa=nan, raw=nan)
    i = int(change[0])
    if f[i] == 0.0:
        beta = betas[i]
    else:
        beta = brentq(lambda b: model(b) - measured, betas[i], betas[i + 1], xtol=1e-12,
                      rtol=1e-10)
    d = DB_PER_NEPER_POWER * beta
    eps = 1e-3
    slope = (math.log(model(beta * (1 + eps))) - math.log(model(beta * (1 - eps)))) / (
        math.log1p(eps) - math.log1p(-eps))
    kappa = abs(1.0 / slope) if slope != 0 else math.inf
    if not (plausible[0] <= d <= plausible[1]):
        return EnergyRoot(decay_rate=nan, status="implausible", kappa=kappa, raw=d)
    if kappa > kappa_max:
        return EnergyRoot(decay_rate=nan, status="ill_conditioned", kappa=kappa, raw=d)
    return EnergyRoot(decay_rate=d, status="ok", kappa=kappa, raw=d)
