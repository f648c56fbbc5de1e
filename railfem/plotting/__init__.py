"""Matplotlib figures for railfem results.

Every plotting function draws into ``ax`` (or ``axes``) when given, otherwise on a
new figure, and returns the Axes; save with :func:`save_figure`. Matplotlib is
imported inside the functions (``import railfem`` stays fast), and without a
display the non-interactive Agg backend is selected.

Conventions follow :mod:`railfem.conventions`: frequency (or position, or
element size) is axis 0 of every array; a wave ``exp(-i k x)`` is positive-going
when ``Im k < 0``.

The figures live by subject in :mod:`.dispersion`, :mod:`.frequency` (responses, band
values, decay rates), :mod:`.rail` (along the rail, pass-by levels, mesh convergence),
:mod:`.measure` (estimates against measurements or the truth), :mod:`.fitting` (a fit's
measured and fitted mobilities, profile likelihoods) and :mod:`.diagnosis`;
what they share (matplotlib setup, :func:`save_figure`, argument checks, band axis) is in
:mod:`.base`. Import the names from ``railfem.plotting``.
"""

from __future__ import annotations

from ..rail.branches import MAX_ATTENUATION, propagating_mask
from .base import nominal_band_label, save_figure
from .diagnosis import (plot_candidate_scores, plot_error_before_after,
                        plot_error_before_after_parts, plot_residual_distance,
                        plot_residual_map, plot_residual_spectrum)
from .dispersion import (FAMILY_LINESTYLES, TYPE_COLOURS, branch_colours, plot_branches,
                         plot_dispersion, plot_dispersion_k)
from .fitting import plot_profiles, plot_transfer_fit
from .frequency import (DECAY_RATE_YLIM, mark_cut_ons, mark_frequencies, plot_band_values,
                        plot_decay_rate, plot_decay_rate_results, plot_magnitude_phase,
                        plot_point_mobility)
from .measure import (plot_band_errors, plot_band_overlay, plot_band_residual,
                      plot_decay_rate_estimates, plot_roughness)
from .rail import (along_rail_frequencies, convergence_slope, plot_along_rail, plot_convergence,
                   plot_passby_levels)

__all__ = [
    "MAX_ATTENUATION", "propagating_mask", "save_figure", "plot_dispersion",
    "plot_dispersion_k", "plot_branches", "branch_colours", "plot_magnitude_phase",
    "mark_frequencies", "plot_point_mobility", "nominal_band_label", "plot_band_values",
    "plot_decay_rate", "plot_decay_rate_results", "mark_cut_ons", "along_rail_frequencies",
    "plot_along_rail", "convergence_slope", "plot_convergence", "plot_band_overlay",
    "plot_band_residual", "plot_passby_levels", "plot_decay_rate_estimates",
    "plot_roughness", "plot_band_errors", "plot_residual_map", "plot_residual_spectrum",
    "plot_residual_distance", "plot_error_before_after", "plot_candidate_scores",
    "plot_transfer_fit", "plot_profiles", "plot_error_before_after_parts",
    # constants of the figures (public before the split too, not listed then)
    "TYPE_COLOURS", "FAMILY_LINESTYLES", "DECAY_RATE_YLIM",
]
