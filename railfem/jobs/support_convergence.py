"""The job behind ``railfem support-convergence``: the rail-on-pad peak (and decay rates)
against the section mesh, the springs across the foot and the rows along the pad."""
from __future__ import annotations

from ..atomic import prepare_output_dir, write_text_atomic
from .common import progress_logger

__all__ = ["run_support_convergence"]


def run_support_convergence(out_dir, cases: dict | None = None, *,
                            sizes=(0.01, 0.0075, 0.005), widths=(16, 32, 64),
                            rows=(1, 2, 3, 6), pad_lengths=(0.0, 0.15), rule: str = "midpoint",
                            rows_ref: int = 3, preset: str = "site", decay: bool = False,
                            n_supports: int = 41, profile: str = "60E1",
                            progress=None) -> dict:
    """Run :func:`railfem.studies.support_convergence.support_study` on ``cases`` (default:
    the one-at-a-time sweeps of :func:`~railfem.studies.support_convergence.sweeps` over
    ``sizes`` (m), ``widths``, ``rows`` and ``pad_lengths`` (m) around the reference with
    ``rows_ref`` rows) and write peaks.csv, peaks.txt (the table, also returned as
    'text') and, with ``decay``, decay_rates.csv."""
    from ..studies import support_convergence as sc

    if cases is None:
        cases = sc.sweeps(sizes, widths, rows, pad_lengths, rule=rule, rows_ref=rows_ref)
    out = prepare_output_dir(out_dir, "support-convergence")
    res = sc.support_study(cases, preset, decay=decay, n_supports=n_supports, profile=profile,
                           progress=progress or progress_logger("support convergence"))
    text = sc.peak_table(res["peaks"]) + "\n"
    paths = {"csv": write_text_atomic(out / "peaks.csv", sc.peak_csv(res["peaks"])),
             "txt": write_text_atomic(out / "peaks.txt", text)}
    if decay:
        paths["decay_csv"] = write_text_atomic(out / "decay_rates.csv",
                                               sc.decay_csv(res["decay"]))
    return {"paths": paths, "text": text, **res}
