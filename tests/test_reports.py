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
