"""Tables, figures and report.md of ``railfem study passby`` (railfem.jobs.study)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..atomic import write_text

__all__ = ["write_study_outputs", "SBB_ROUGHNESS"]

#: The SBB Niederwangen rail roughness table, relative to a checkout's folder (../shared).
SBB_ROUGHNESS = Path("../shared/measured_data/sbb_niederwangen/"
                     "rail_roughness_niederwangen_wide.csv")

LABELS = {"full": "full method",
          "simplified_model_hammer": "simplified, A model, TDR hammer",
          "simplified_default_hammer": "simplified, A default, TDR hammer",
          "simplified_model_energy": "simplified, A model, TDR energy",
          "simplified_default_energy": "simplified, A default, TDR energy",
          "simplified_model_slope": "simplified, A model, TDR slope",
          "simplified_default_slope": "simplified, A default, TDR slope"}


def _f(v, fmt="{:.2f}") -> str:
    return "" if v is None or not np.isfinite(v) else fmt.format(v)


def _slug(name: str) -> str:
    return name.replace(" ", "_")


def _tdr_rows(results) -> tuple[str, list[str]]:
    head = ("track,band_hz,hammer_en15461_db_per_m,far_field_db_per_m,energy_db_per_m,"
            "energy_error_db_per_m,energy_error_pct,energy_status,slope_db_per_m,"
            "slope_error_db_per_m,slope_error_pct,slope_status,energy_raw,slope_raw")
    rows = []
    for r in results:
        for i, b in enumerate(r["bands_hz"]):
            h = r["hammer"][i]
            cells = [r["track"], f"{b:g}", _f(h), _f(r["far"][i])]
            for key in ("energy", "slope"):
                v = r[key][i]
                cells += [_f(v), _f(v - h), _f(100 * (v - h) / h, "{:.0f}"),
                          r[f"{key}_status"][i]]
            cells += [_f(r["energy_raw"][i]), _f(r["slope_raw"][i])]
            rows.append(",".join(cells))
    return head, rows


def _md_tdr(r) -> list[str]:
    lines = [f"#### {r['track']} track (wheels detected: {r['wheels']})", "",
             "| band (Hz) | hammer EN 15461 (truth) | far field | energy iteration | "
             "error | slope fitting | error |", "|---|---|---|---|---|---|---|"]
    for i, b in enumerate(r["bands_hz"]):
        h = r["hammer"][i]
        cells = [f"{b:g}", _f(h), _f(r["far"][i])]
        for key in ("energy", "slope"):
            v = r[key][i]
            st = r[f"{key}_status"][i]
            cells += [_f(v) if np.isfinite(v) else f"– ({st}; raw {_f(r[key + '_raw'][i])})",
                      f"{_f(v - h, '{:+.2f}')} ({_f(100 * (v - h) / h, '{:+.0f}')} %)"
                      if np.isfinite(v) else ""]
        lines.append("| " + " | ".join(cells) + " |")
    return lines + [""]


def _md_table(title, x_cm, columns: dict) -> list[str]:
    keys = list(columns)
    lines = [title, "", "| wavelength (cm) | " + " | ".join(keys) + " |",
             "|---|" + "---|" * len(keys)]
    for j, x in enumerate(x_cm):
        lines.append(f"| {x:.3g} | " + " | ".join(_f(columns[k][j], "{:+.1f}") for k in keys)
                     + " |")
    return lines + [""]


def _plots(out: Path, results, files: dict, sbb) -> None:
    from ..plotting import plot_band_errors, plot_decay_rate_estimates, plot_roughness, save_figure

    for r in results:
        b = np.asarray(r["bands_hz"], dtype=float)
        ax = plot_decay_rate_estimates(b, {
            "hammer EN 15461 (model, truth)": (r["hammer"], None),
            "far-field attenuation (model)": (r["far"], None),
            "energy iteration": (r["energy"], r["energy_std"]),
            "slope fitting": (r["slope"], r["slope_std"])})
        ax.set_title(f"{r['track']} track: decay rate from 4 simulated pass-bys "
                     "(10 % noise, 0.1 m wheel error)", fontsize="small")
        files[f"tdr_{_slug(r['track'])}_png"] = save_figure(
            ax, out / "figures" / f"tdr_{_slug(r['track'])}.png")
        wl = np.asarray(r["wavelength_m"])
        curves = {"known roughness (truth)": r["true_level"]}
        curves.update({LABELS[k]: r["roughness"][k] for k in (
            "full", "simplified_model_hammer", "simplified_default_hammer",
            "simplified_model_energy", "simplified_model_slope")})
        ax = plot_roughness(wl, curves, styles={"known roughness (truth)": {
            "color": "k", "lw": 2.5, "marker": None}})
        _add_sbb(ax, sbb)
        ax.set_title(f"{r['track']} track: combined roughness from 4 pass-bys",
                     fontsize="small")
        files[f"roughness_{_slug(r['track'])}_png"] = save_figure(
            ax, out / "figures" / f"roughness_{_slug(r['track'])}.png")
        ax = plot_band_errors(wl, {LABELS[k]: v - r["true_level"]
                                   for k, v in r["roughness"].items()})
        ax.set_title(f"{r['track']} track: roughness estimate - truth", fontsize="small")
        files[f"roughness_errors_{_slug(r['track'])}_png"] = save_figure(
            ax, out / "figures" / f"roughness_errors_{_slug(r['track'])}.png")
        if "sensitivity" in r:
            err = {}
            for key, v in r["sensitivity"].items():
                err[f"full, {key}"] = v["full"] - r["true_level"]
                err[f"simplified, {key}"] = v["simplified_model_hammer"] - r["true_level"]
            ax = plot_band_errors(wl, err)
            ax.set_title(f"{r['track']} track: roughness error with the track model's pad "
                         "(kp) or ballast (kb) stiffness off by 25 %", fontsize="small")
            files["sensitivity_png"] = save_figure(ax, out / "figures" / "sensitivity.png")
            ax = plot_band_errors(wl, r["causes"])
            ax.set_title(f"{r['track']} track: simplified method on noise-free band values",
                         fontsize="small")
            files["causes_png"] = save_figure(ax, out / "figures" / "simplified_causes.png")
    ax = plot_roughness({}, {})
    if _add_sbb(ax, sbb, every_row=True):
        ax.set_title("SBB Niederwangen, directly measured rail roughness", fontsize="small")
        files["sbb_png"] = save_figure(ax, out / "figures" / "sbb_rail_roughness.png")


def _add_sbb(ax, sbb, every_row: bool = False) -> bool:
    """Plot the SBB rail roughness table ``sbb`` (the energy average of all rows; each
    section's average with every_row); False if there is none."""
    from ..io.roughness_table import read_sbb_roughness

    if sbb is None:
        return False
    avg = read_sbb_roughness(sbb)
    ax.plot(avg.wavelength * 100, avg.level, color="tab:brown", lw=2,
            label="SBB Niederwangen rail (measured, mean)")
    if every_row:
        for sec in ("B1", "B2", "B3", "B4", "B5"):
            try:
                s = read_sbb_roughness(sbb, select={"sec": sec})
            except ValueError:
                continue
            ax.plot(s.wavelength * 100, s.level, lw=1, alpha=0.7, label=f"section {sec}")
    ax.legend(fontsize="x-small")
    return True


def write_study_outputs(out: Path, results, cfg) -> dict:
    """All tables, figures and report.md; returns their paths."""
    files = {}
    head, rows = _tdr_rows(results)
    files["tdr_csv"] = write_text(out / "tables" / "tdr_errors.csv",
                                  "# decay rate from simulated pass-bys vs the model's EN "
                                  "15461 decay rate at the sensor (truth), dB/m\n" + head +
                                  "\n" + "\n".join(rows) + "\n")
    keys = list(results[0]["roughness"])
    lines = ["# roughness estimate - known roughness per wavelength band (dB); combined "
             "over the pass-bys", "track,wavelength_m,true_db," + ",".join(keys)]
    for r in results:
        for j, lam in enumerate(r["wavelength_m"]):
            lines.append(f"{r['track']},{lam:.5g},{r['true_level'][j]:.2f}," + ",".join(
                _f(r["roughness"][k][j] - r["true_level"][j]) for k in keys))
    files["roughness_csv"] = write_text(out / "tables" / "roughness_errors.csv",
                                        "\n".join(lines) + "\n")
    lines = ["# simplified - full estimate per wavelength band (dB)",
             "track,wavelength_m," + ",".join(k for k in keys if k != "full")]
    for r in results:
        for j, lam in enumerate(r["wavelength_m"]):
            lines.append(f"{r['track']},{lam:.5g}," + ",".join(
                _f(r["roughness"][k][j] - r["roughness"]["full"][j]) for k in keys
                if k != "full"))
    files["simplified_vs_full_csv"] = write_text(out / "tables" / "simplified_vs_full.csv",
                                                 "\n".join(lines) + "\n")
    md = ["# Pass-by study: decay-rate estimators and roughness methods", "",
          f"Model {cfg['model']}; {len(cfg['speeds_kmh'])} pass-bys per track at "
          f"{', '.join(f'{v:g}' for v in cfg['speeds_kmh'])} km/h; noise "
          f"{cfg['noise_fraction']:g} of the largest band RMS, wheel-position error "
          f"sigma {cfg['position_error']:g} m, seed {cfg['seed']}. Truth of the decay rate: "
          "the model's EN 15461 decay rate with the foot sensor at mid-span.", "",
          "## Decay rates (dB/m)", ""]
    for r in results:
        md += _md_tdr(r)
    md += ["## Roughness: estimate - truth (dB), combined over the pass-bys", ""]
    for r in results:
        md += _md_table(f"#### {r['track']} track", np.asarray(r["wavelength_m"]) * 100,
                        {LABELS[k]: np.asarray(v) - r["true_level"]
                         for k, v in r["roughness"].items()})
    md += ["## Simplified - full (dB)", ""]
    for r in results:
        md += _md_table(f"#### {r['track']} track", np.asarray(r["wavelength_m"]) * 100,
                        {LABELS[k]: np.asarray(v) - r["roughness"]["full"]
                         for k, v in r["roughness"].items() if k != "full"})
    for r in results:
        if "sensitivity" not in r:
            continue
        cols = {}
        for key, v in r["sensitivity"].items():
            cols[f"full, {key}"] = v["full"] - r["true_level"]
            cols[f"simpl., {key}"] = v["simplified_model_hammer"] - r["true_level"]
        md += _md_table(f"## Sensitivity ({r['track']} track): estimate - truth (dB), "
                        "track model off by 25 %", np.asarray(r["wavelength_m"]) * 100, cols)
        if "tdr_causes" in r:
            md += [f"## Causes of the TDR estimators' errors ({r['track']} track): estimate "
                   "(dB/m), EN 15461 truth and far field beside", "",
                   "| band (Hz) | hammer | far field | " + " | ".join(
                       f"{m}, {k}" for k in r["tdr_causes"] for m in ("energy", "slope"))
                   + " |", "|---|---|---|" + "---|" * (2 * len(r["tdr_causes"]))]
            for i, b in enumerate(r["bands_hz"]):
                md.append(f"| {b:g} | {_f(r['hammer'][i])} | {_f(r['far'][i])} | " + " | ".join(
                    _f(v[m][i]) or v[m + '_status'][i] for v in r["tdr_causes"].values()
                    for m in ("energy", "slope")) + " |")
            md.append("")
        md += _md_table(f"## Causes of the simplified method's error ({r['track']} track, "
                        "noise-free band values): estimate - truth (dB)",
                        np.asarray(r["wavelength_m"]) * 100, r["causes"])
        lines = ["wavelength_m," + ",".join(f'"{k}"' for k in r["causes"])]
        for j, lam in enumerate(r["wavelength_m"]):
            lines.append(f"{lam:.5g}," + ",".join(_f(v[j]) for v in r["causes"].values()))
        files["causes_csv"] = write_text(out / "tables" / "simplified_causes.csv",
                                         "\n".join(lines) + "\n")
        lines = ["wavelength_m," + ",".join(
            f'"{m}, {k}"' for k in r["sensitivity"] for m in ("full", "simplified"))]
        for j, lam in enumerate(r["wavelength_m"]):
            lines.append(f"{lam:.5g}," + ",".join(
                _f(v[m][j] - r["true_level"][j]) for v in r["sensitivity"].values()
                for m in ("full", "simplified_model_hammer")))
        files["sensitivity_csv"] = write_text(out / "tables" / "sensitivity.csv",
                                              "\n".join(lines) + "\n")
    md += ["## Timing (s, per track in its worker process)", "",
           "| track | model | simulate + write | TDR estimators | roughness | sensitivity + causes "
           "| total |", "|---|---|---|---|---|---|---|"]
    for r in results:
        t = r["timing"]
        md.append(f"| {r['track']} | {t['model_s']:.0f} | {t['simulate_s']:.0f} | "
                  f"{t['tdr_estimators_s']:.0f} | {t['roughness_s']:.0f} | "
                  f"{t.get('sensitivity_and_causes_s', 0):.0f} | {t['total_s']:.0f} |")
    _plots(out, results, files, cfg.get("sbb"))
    md += ["", "Figures: " + ", ".join(sorted(Path(v).name for k, v in files.items()
                                              if k.endswith("_png"))), ""]
    files["report"] = write_text(out / "report.md", "\n".join(md) + "\n")
    return files
