"""The job behind ``railfem convergence``: the mesh-convergence study of the free rail's
cut-on frequencies and wavenumbers as CSV, plots and JSON."""
from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np

from ..atomic import json_safe, prepare_output_dir, write_text_atomic
from .common import csv_text, progress_logger, resolve_profile, slug

log = logging.getLogger(__name__)

__all__ = ["run_convergence", "convergence_table"]


def convergence_table(study) -> str:
    """CSV text of a :class:`railfem.studies.convergence.ConvergenceStudy`: one row per mesh size,
    then the reference values and observed rates as rows labelled in the first column."""
    cols = ["h_mm", "n_dofs"] + [f"n_dofs_{fam}" for fam in study.n_dofs_family]
    qnames = [f"cut_on_{j + 1}_{fam}_hz" for j, fam in enumerate(study.cut_on_family)]
    knames = []
    for q, f in enumerate(study.frequencies):
        for j in range(study.wavenumbers.shape[2]):
            if study.wave_family[q, j]:
                knames.append(f"k_{f:g}hz_{study.wave_family[q, j]}_"
                              f"{slug(study.wave_label[q, j])}_rad_per_m")
            else:
                knames.append(f"k_{f:g}hz_{j}_rad_per_m")
    nf, nw = study.wavenumbers.shape[1:]
    header = (
        "# railfem mesh-convergence study\n"
        f"# profile {study.profile}, {'curved' if study.curved else 'straight-sided'} 6-node "
        f"elements; reference: {study.reference}\n"
        "# rows: one per element size h; then 'reference' (Richardson extrapolation of the "
        "three finest meshes, or the finest mesh), 'rate' (observed order: slope of "
        "log|relative error| vs log h) and 'richardson_order' (order of the Richardson fit)\n"
        "# cut_on_*: cut-on frequencies (Hz) of the cross-section modes at k = 0, tracked "
        "by symmetry family and rank; k_*: Re k (rad/m) of the propagating waves\n")
    rows = []
    for i, h in enumerate(study.sizes):
        rows.append([h * 1e3, int(study.n_dofs[i])]
                    + [int(v[i]) for v in study.n_dofs_family.values()]
                    + list(study.cut_on[i]) + list(study.wavenumbers[i].reshape(nf * nw)))
    blank = [""] * (1 + len(study.n_dofs_family))
    rows.append(["reference"] + blank + list(study.cut_on_reference)
                + list(study.wavenumber_reference.reshape(nf * nw)))
    rows.append(["rate"] + blank + list(study.cut_on_rate)
                + list(study.wavenumber_rate.reshape(nf * nw)))
    rows.append(["richardson_order"] + blank + list(study.cut_on_order) + [""] * (nf * nw))
    return csv_text(header, cols + qnames + knames, rows)


def _convergence_plot(sizes, errors, labels, title, path):
    from .. import plotting

    keep = np.any(np.abs(errors) > 1e-12, axis=0)  # round-off-only series say nothing
    ax = plotting.plot_convergence(sizes * 1e3, errors[:, keep],
                                   [lab for lab, k in zip(labels, keep) if k],
                                   xlabel="Element size h (mm)",
                                   ylabel="Relative error vs reference")
    ax.set_title(title)
    return plotting.save_figure(ax, path)


def run_convergence(profile, sizes, out_dir, *, frequencies=(), n_cut_on: int = 6,
                    reference: str = "richardson", progress=None, geometry: str = "curved",
                    use_shipped: bool = False) -> dict:
    """Run :func:`railfem.studies.convergence.convergence_study` and write convergence.csv,
    convergence.png (log-log relative error of the cut-on frequencies against h with fitted
    slopes), convergence_wavenumbers.png (the same for the wavenumbers, when frequencies
    are given) and convergence.json (all arrays).

    geometry: 'curved' (6-node elements with mid-side nodes on the outline, default),
    'straight' (the straight-sided twins) or 'both' (curved in the files above, straight in
    convergence_straight.csv / .png / .json). use_shipped: take the shipped meshes where
    they exist instead of meshing afresh."""
    from ..studies.convergence import convergence_study

    if geometry not in ("curved", "straight", "both"):
        raise ValueError(f"geometry must be 'curved', 'straight' or 'both', got {geometry!r}")
    out = prepare_output_dir(out_dir, "convergence")
    runs = {"curved": [True], "straight": [False], "both": [True, False]}[geometry]
    paths = {}
    for curved in runs:
        study = convergence_study(resolve_profile(profile), sizes, frequencies=frequencies,
                                  n_cut_on=n_cut_on, reference=reference, curved=curved,
                                  use_shipped=use_shipped,
                                  progress=progress or progress_logger("convergence (meshes)"))
        suffix = "_straight" if (geometry == "both" and not curved) else ""
        written = _write_convergence(study, out, suffix)
        if suffix:
            paths.update({f"{k}{suffix}": v for k, v in written.items()})
        else:
            paths.update(written)
    return paths


def _write_convergence(study, out: Path, suffix: str) -> dict:
    kind = "curved" if study.curved else "straight-sided"
    paths = {"csv": write_text_atomic(out / f"convergence{suffix}.csv",
                                      convergence_table(study))}
    labels = [f"cut-on {j + 1} ({fam[:4]}.), {ref:.0f} Hz" for j, (fam, ref) in
              enumerate(zip(study.cut_on_family, study.cut_on_reference))]
    paths["png"] = _convergence_plot(study.sizes, np.abs(study.cut_on_error), labels,
                                     f"{study.profile} ({kind}): cut-on frequencies "
                                     f"({study.reference['cut_on']})",
                                     out / f"convergence{suffix}.png")
    nf, nw = study.wavenumbers.shape[1:]
    err, labels = [], []
    for q, f in enumerate(study.frequencies):
        for j in range(nw):
            if study.wave_family[q, j]:
                err.append(np.abs(study.wavenumber_error[:, q, j]))
                labels.append(f"{study.wave_label[q, j]} @ {f:g} Hz")
    if err:
        paths["png_wavenumbers"] = _convergence_plot(
            study.sizes, np.column_stack(err), labels,
            f"{study.profile} ({kind}): wavenumbers ({study.reference['wavenumbers']})",
            out / f"convergence{suffix}_wavenumbers.png")

    def arr(x):
        return json_safe(np.asarray(x).tolist())

    data = {k: arr(getattr(study, k)) for k in (
        "sizes", "n_dofs", "cut_on", "cut_on_family", "cut_on_rank", "frequencies",
        "wave_family", "wave_label", "cut_on_reference", "cut_on_error", "cut_on_rate",
        "cut_on_order", "wavenumber_reference", "wavenumber_rate")}
    data["wavenumbers"] = arr(study.wavenumbers)
    data["wavenumber_error"] = arr(study.wavenumber_error)
    data["profile"], data["reference"] = study.profile, study.reference
    data["curved"] = study.curved
    data["n_dofs_family"] = {k: arr(v) for k, v in study.n_dofs_family.items()}
    paths["json"] = write_text_atomic(out / f"convergence{suffix}.json",
                                      json.dumps(data, indent=1, allow_nan=False) + "\n")
    paths["study"] = study
    log.info("wrote %s and %s", paths["csv"], paths["png"])
    return paths
