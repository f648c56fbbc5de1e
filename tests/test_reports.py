"""What the fit and diagnose commands tell a user: one far-field note per fit (not one per
model evaluation), progress that stays silent off a terminal and gives no ETA before it
has timed a few steps, the fit's printed summary (MN/m, every file written, a hint to
diagnose) and the diagnosis report's wording (values of the gates, labelled tables, open
grid intervals, dominant bands and what to try next)."""
import logging
import sys

import numpy as np
import pytest

import railfem as rf
from railfem.identify import fit

sys.path.insert(0, str(__import__("pathlib").Path(__file__).parent))
from test_fit import measurement, noisy, simulate  # noqa: E402

FAR_FIELD = "far-field 10 dB check fails"


def test_a_fit_notes_the_far_field_check_once(caplog):
    """A noise floor at -30 dB cuts the far transfers: the decay rate's far-field check
    fails for the data and for every model evaluation; one INFO line, not dozens."""
    Y0, pos = simulate("timoshenko-continuous")
    meas = measurement(noisy(Y0, 0.05, 0, floor_db=-30.0), pos)
    with caplog.at_level(logging.DEBUG, logger="railfem.standards.en15461"):
        fit(meas, "timoshenko-continuous", parameters=("kp", "eta_p", "kb", "eta_b"),
            base=rf.preset("site"), use=("point", "tdr"), n_starts=1, workers=1,
            profiles=())
    lines = [r for r in caplog.records if FAR_FIELD in r.getMessage()]
    assert len(lines) > 5  # the check does fail for model evaluations (at DEBUG)
    assert sum(r.levelno == logging.INFO for r in lines) == 1


class _Terminal(__import__("io").StringIO):
    def isatty(self):
        return True


def test_progress_is_silent_off_a_terminal(caplog):
    import io

    from railfem.jobs.common import Progress, progress_bar_enabled, watch_progress

    stream = io.StringIO()
    assert not progress_bar_enabled(stream)
    with caplog.at_level(logging.INFO, logger="railfem"):
        with watch_progress(("railfem.identify.fit", r"(?P<done>\d+)/(?P<total>\d+)", {}),
                            stream=stream):
            logging.getLogger("railfem.identify.fit").info("fit: start 1/2 done")
        p = Progress("sweep", stream=stream)
        for i in range(1, 4):
            p(i, 3)
    assert stream.getvalue() == ""  # no bar: log lines only
    assert "fit: start 1/2 done" in caplog.text and "sweep: 3/3" in caplog.text
    quiet = logging.getLogger("railfem").level
    try:  # railfem -q: the loggers pass warnings only, no bar even on a terminal
        logging.getLogger("railfem").setLevel(logging.WARNING)
        assert not progress_bar_enabled(_Terminal())
    finally:
        logging.getLogger("railfem").setLevel(quiet)


def test_progress_gives_no_time_left_before_a_few_steps(caplog):
    from railfem.jobs.common import ETA_AFTER, Progress

    p = Progress("track", min_interval=0.0, bar=False)
    with caplog.at_level(logging.INFO, logger="railfem.jobs.common"):
        for i in range(1, 11):
            p(i, 10)
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 10
    assert not any("left" in m for m in lines[:ETA_AFTER])  # first steps: set-up
    assert all("left" in m for m in lines[ETA_AFTER:])
    term = _Terminal()
    level = logging.getLogger("railfem").level
    try:
        logging.getLogger("railfem").setLevel(logging.INFO)
        bar = Progress("track", stream=term)
        bar(1, 10)
        assert "1/10" in term.getvalue() and "left" not in term.getvalue()
        bar.close()
    finally:
        logging.getLogger("railfem").setLevel(level)


def test_fit_prints_every_file_values_in_mn_per_m_and_what_next(tmp_path, capsys):
    """railfem fit prints its summary in the command line's units (kp, kb in MN/m; fit.json
    keeps SI), a 'wrote' line for every file it wrote, and points to diagnose when a band's
    residual is large (30 % scatter on the FRFs)."""
    import json

    from railfem.cli import main
    from railfem.io import write_dataset

    Y0, pos = simulate("timoshenko-continuous")
    data = tmp_path / "data"
    write_dataset(data, measurement(noisy(Y0, 0.3, 2), pos))
    out = tmp_path / "out"
    code = main(["-q", "fit", str(data), "--model", "timoshenko-continuous", "--use",
                 "point,tdr", "--parameters", "kp,eta_p,kb,eta_b", "--starts", "1",
                 "--workers", "1", "--no-profiles", "--out", str(out)])
    printed = capsys.readouterr().out
    assert code == 0
    run = json.loads((out / "run.json").read_text())
    written = [ln.split(" ", 1)[1] for ln in printed.splitlines() if ln.startswith("wrote ")]
    assert sorted(written) == sorted(run["files"].values())
    assert {"fit.json", "point.png", "tdr.png", "residual.png", "run.json"} <= {
        p.rsplit("/", 1)[1] for p in written}
    kp = [ln for ln in printed.splitlines() if ln.strip().startswith("kp = ")][0]
    value = float(kp.split("=")[1].split()[0])
    assert kp.split()[3] == "MN/m" and 200 < value < 800  # truth 400 MN/m
    fitted = json.loads((out / "fit.json").read_text())
    p = [p for p in fitted["parameters"] if p["name"] == "kp"][0]
    assert p["unit"] == "N/m" and 2e8 < p["value"] < 8e8  # SI in the file
    assert f"railfem diagnose {data}" in printed
    assert (out / "summary.txt").read_text().strip() in printed


# ------------------------------------------------------------------ the diagnosis report

def _diagnose(tmp_path, case, effects):
    """railfem diagnose (in-process, warnings as errors) on a small blind data set."""
    import json
    import warnings

    from benchmarks.blind import generators as g
    from railfem.io import write_dataset
    from railfem.jobs.diagnose import run_diagnose

    src = tmp_path / "data"
    write_dataset(src, g.dataset(case, 0, f=g.frequencies(low=50.0, high=4000.0)[::2])[0])
    out = tmp_path / "out"
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # e.g. 'Mean of empty slice'
        run = run_diagnose(src, out, model="timoshenko-discrete", effects=effects,
                           n_starts=2)
    return src, run, (out / "report.md").read_text(), json.loads(
        (out / "diagnosis.json").read_text())


def test_report_names_gate_values_tables_and_held_out_db(tmp_path):
    """A found effect: the gates printed with their values (not the rule names), the
    candidate table labelled as screening values and the chosen one as final values, one
    sign convention for the held-out change, the held-out error in dB as well."""
    src, run, md, s = _diagnose(tmp_path, "pad_frequency", ["pad_frequency", "noise_floor"])
    assert s["chosen"]["name"] == "pad_frequency"
    for name in ("MIN_GAIN", "ALPHA", "DELTA_BIC"):
        assert name not in md and name not in s["rules"]["text"]
    assert "by >= 10 %" in md and "at 0.01" in md and "by more than 10" in md
    assert "## Candidates (screening values)" in md
    assert "## Chosen: pad_frequency (final refit values)" in md
    red = s["candidates"][0]["held_out"]["reduction"]
    row = [ln for ln in md.splitlines() if ln.startswith("| 1 | pad_frequency")][0]
    assert f"| {100 * red:.0f} % |" in row and red > 0  # a reduction, as the log says
    held = [ln for ln in md.splitlines() if ln.startswith("Held-out error")][0]
    assert "held-out RMS residual (dB)" in held and " -> " in held.split("(dB)")[1]
    assert run["groups"][0]["summary"][0] == s["statement"]


def test_report_of_an_unexplained_residual_says_where_and_what_next(tmp_path, capsys):
    """An effect outside the library (a softer rail): the report and the printed summary
    name the dominant bands with their RMS and what to try next (another model for what a
    beam skips, random_support, a band limit)."""
    from railfem.io.diagnosis_report import dominant_bands

    src, run, md, s = _diagnose(tmp_path, "rail_stiffness", ["pad_frequency"])
    assert s["verdict"] != "explained"
    top = dominant_bands(s)
    worst = max((r for r in s["error_after"] or s["error_before"]), key=lambda r: r["rms_db"])
    assert top[0]["band_hz"] == worst["band_hz"]
    assert f"the {worst['band_hz']:g} Hz band of {worst['quantity']} at " \
           f"{worst['rms_db']:.1f} dB RMS" in md
    assert "What to try next:" in md
    steps = s["next_steps"]
    assert any(f"railfem diagnose {src}" in n for n in steps)
    summary = run["groups"][0]["summary"]
    assert summary[0] == s["statement"] and summary[1].startswith("dominant: ")
    assert [ln[len("next: "):] for ln in summary[2:]] == steps


def test_open_grid_interval_is_shown_open():
    from railfem.io.diagnosis_report import interval

    p = {"ci95": [0.16, 0.24], "reason": "profile over the grid, open on the high side"}
    assert interval(p) == "[0.16, ≥ 0.24 (grid edge)]"
    p["reason"] = "profile over the grid, open on the low and high side"
    assert interval(p) == "[≤ 0.16 (grid edge), ≥ 0.24 (grid edge)]"
    assert interval({"ci95": [1.0, 2.0], "reason": "profile over the grid"}) == "[1, 2]"


def test_next_steps_name_a_band_limit_another_model_and_random_support():
    """The worst band at 5 kHz on a beam model: leave out the bands from its lower edge
    (4454 Hz, rounded down to 4400), a WFE model, and the candidate left out by default."""
    from railfem.jobs.diagnose import findings, next_steps

    rows = [{"part": "held", "quantity": "transfer", "band_hz": 5000.0, "rms_db": 15.4},
            {"part": "fit", "quantity": "transfer", "band_hz": 630.0, "rms_db": 9.0},
            {"part": "fit", "quantity": "tdr", "band_hz": 630.0, "rms_db": 15.2},
            {"part": "fit", "quantity": "point", "band_hz": 8000.0, "rms_db": 12.4}]
    s = {"verdict": "unexplained", "statement": "no candidate explains the residual",
         "model": "timoshenko-discrete", "error_before": rows, "error_after": None,
         "candidates": [{"name": "pad_frequency", "effects": ["pad_frequency"]}],
         "skipped": {"random_support": "not screened by default (tens of parameters)"},
         "failures": [], "library": [{"name": "pad_frequency"}, {"name": "random_support"}]}
    steps = next_steps(s, "site_b")
    assert steps[0].endswith("`railfem diagnose site_b --f-high 4400`")
    assert "`railfem diagnose site_b --model wfe-discrete`" in steps[1]
    assert "`railfem diagnose site_b --effects random_support`" in steps[2]
    assert len(steps) == 3  # every effect of the library was tried or named
    s["next_steps"] = steps
    lines = findings(s)
    assert lines[1] == ("dominant: the 5000 Hz band of transfer at 15.4 dB RMS (held-out "
                        "part); the 630 Hz band of tdr at 15.2 dB RMS (fitted part); the "
                        "8000 Hz band of point at 12.4 dB RMS (fitted part)")
    assert next_steps(dict(s, model="wfe-discrete"), "site_b", "table") == steps[2:]



# ------------------------------------------------------------------ fit intervals

def test_coarse_profile_interval_follows_the_parabola():
    """A kernel-parameter profile has few points: delta chi^2 = 400 x^2 sampled at
    -0.5, -0.05, 0, 0.5 crosses 3.841 at +-0.098; a straight line from 0 to 0.5 would cross
    at 0.019 (too narrow); widened, the interval follows the parabola (exact here)."""
    from railfem.identify.profiling import CHI2_95, profile_interval

    x = np.array([-0.5, -0.05, 0.0, 0.5])
    lo, hi, open_ = profile_interval(x, 400 * x ** 2)
    assert hi == pytest.approx(0.5 * CHI2_95 / 100)  # the chord
    lo, hi, open_ = profile_interval(x, 400 * x ** 2, widen=True)
    half = np.sqrt(CHI2_95 / 400)
    assert (lo, hi) == (pytest.approx(-half), pytest.approx(half)) and open_ is None
    # never beyond the point already above the threshold
    lo, hi, _ = profile_interval(np.array([-0.06, 0.0, 0.06]), 1e4 * np.array([.1, 0, 1]),
                                 widen=True)
    assert -0.06 <= lo and hi <= 0.06
