"""The same data fitted with several track models, and the comparison as a table.

Identified stiffnesses differ between models because each model lacks different physics;
that difference is the model dependence of the identification (docs/identification.md).
"""
from __future__ import annotations

import logging

from railfem.identify.fit import fit

log = logging.getLogger(__name__)

__all__ = ["compare_models", "comparison_table"]


def compare_models(data, models=("wfe-discrete", "wfe-periodic", "timoshenko-discrete",
                                 "timoshenko-continuous"), **fit_options) -> dict:
    """The same data fitted with each model: {model: FitResult}. Identified stiffnesses
    differ between models because each model lacks different physics; that difference is
    the model dependence of the identification (docs/identification.md)."""
    out = {}
    for m in models:
        log.info("model comparison: fitting %s", m)
        out[m] = fit(data, m, **fit_options)
    return out


def comparison_table(results: dict) -> str:
    """A text table: per model, each parameter with its 95 % interval and identifiability,
    and the residual RMS per quantity."""
    names = next(iter(results.values())).names
    lines = ["model".ljust(24) + "".join(n.ljust(30) for n in names) + "residual RMS (dB)"]
    for m, r in results.items():
        cells = []
        for n in names:
            p = r.parameter(n)
            cells.append(f"{p['value']:.3g} [{p['ci95'][0]:.2g},{p['ci95'][1]:.2g}] "
                         f"{p['identifiable'][0]}".ljust(30))
        rms = ", ".join(f"{q} {v:.2f}" for q, v in r.residual_rms.items())
        lines.append(m.ljust(24) + "".join(cells) + rms)
    return "\n".join(lines)
