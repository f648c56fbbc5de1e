"""The site track of METHOD.md Table 1 on the WFE rail: point mobility and decay rates.

    python examples/site_track.py [OUT_DIR]

Runs the job behind ``railfem track`` on a reduced band range (50 Hz - 1 kHz) and prints
the point mobility at 100 Hz and the decay rate in the 100 Hz band. The last lines are
``KEY <name> <value>`` in SI units; tests/test_examples.py checks them.
"""
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from railfem.io.frf_csv import read_frf_csv
from railfem.spec import preset
from railfem.jobs.track import JobSettings, run_track


def main(out_dir: Path) -> dict:
    summary = run_track(preset("site"), out_dir, job=JobSettings(f_low=50.0, f_high=1000.0),
                        cache=False)  # kernels in memory: write only to out_dir
    frf = read_frf_csv(out_dir / "transfer_mobility.csv")
    i = int(np.argmin(np.abs(frf.frequency - 100.0)))
    decay = np.loadtxt(out_dir / "decay_rate.csv", delimiter=",", skiprows=2)  # see header
    j = int(np.argmin(np.abs(decay[:, 0] - 100.0)))
    print(json.dumps(summary["rail_pad_peak_hz"]))
    return {"point_mobility_100hz": float(np.abs(frf.values[i, 0, 0])),
            "decay_rate_100hz_band": float(decay[j, 1])}


if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp())
    for name, value in main(out).items():
        print(f"KEY {name} {value:.8g}")
