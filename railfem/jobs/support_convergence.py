"""The job behind ``railfem support-convergence``: the rail-on-pad peak (and decay rates)
against the section mesh, the springs across the foot and the rows along the pad."""
from __future__ import annotations

from ..atomic import prepare_output_dir, write_text_atomic
from .common import progress_logger

__all__ = ["run_support_convergence"]


def run_support_convergence(out_dir, cases: dict, *, preset: str = "site",
                            decay: bool = False, n_supports: int = 41, profile: str = "60E1",
                            progress=None) -> dict:
    """Run :func:`railfem.studies.support_convergence.support_study` and write peaks.csv,
    peaks.txt (the table) and, with ``decay``, decay_rates.csv."""
    from ..studies import support_convergence as sc

    out = prepare_output_dir(out_dir, "support-convergence")
    res = sc.support_study(cases, preset, decay=decay, n_supports=n_supports, profile=profile,
                           progress=progress or progress_logger("support convergence"))
    paths = {"csv": write_text_atomic(out / "peaks.csv", sc.peak_csv(res["peaks"])),
             "txt": write_text_atomic(out / "peaks.txt", sc.peak_table(res["peaks"]) + "\n")}
    if decay:
        paths["decay_csv"] = write_text_atomic(out / "decay_rates.csv", sc.decay_csv(res["decay"]))
    return {"paths": paths, **res}
