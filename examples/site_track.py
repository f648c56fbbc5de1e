"""The site track of METHOD.md Table 1 on the WFE rail: point mobility and decay rates.

    python examples/site_track.py [OUT_DIR]

Computes, through the model door (railfem.models.frf), the vertical mobilities of an EN 15461
hammer test on the site track (sensor on the head at mid-span, the standard's 29 hammer
positions) on a reduced band range (50 Hz - 1 kHz), the EN 15461 decay rates from them,
writes the mobilities to OUT_DIR/transfer_mobility.csv (railfem.io.frf_csv layout;
default OUT_DIR: a new temporary folder) and prints the point mobility at 100 Hz and the
decay rate in the 100 Hz band. The last lines are ``KEY <name> <value>`` in SI units;
tests/test_examples.py checks them.
"""
import sys
import tempfile
from pathlib import Path

import numpy as np

from railfem.io.frf_csv import write_frf_csv
from railfem.models import frf, hammer_x, head
from railfem.spec import preset
from railfem.standards import en15461, iec61260


def main(out_dir: Path) -> dict:
    spec = preset("site")
    f = iec61260.ninth_octave_grid(50.0, 1000.0)
    sensor_x, positions, hammer = hammer_x(spec)  # position 0 is struck 20 mm off the sensor
    Y = frf(spec, f, force=[head(x) for x in hammer], response=[head(sensor_x)],
            cache=False)  # kernels in memory: write only to out_dir
    tdr = en15461.decay_rate(f, Y.values[:, 0, :], positions)
    path = write_frf_csv(Path(out_dir) / "transfer_mobility.csv", Y)
    i = int(np.argmin(np.abs(f - 100.0)))
    j = int(np.argmin(np.abs(tdr.frequency - 100.0)))
    print(f"{spec.name} track, {spec.model}: |Y| at {f[i]:.1f} Hz = "
          f"{abs(Y.values[i, 0, 0]):.4e} m/s/N, decay rate {tdr.decay_rate[j]:.2f} dB/m "
          f"in the {tdr.frequency[j]:g} Hz band")
    print(f"wrote {path}")
    return {"point_mobility_100hz": float(np.abs(Y.values[i, 0, 0])),
            "decay_rate_100hz_band": float(tdr.decay_rate[j])}


if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp())
    for name, value in main(out).items():
        print(f"KEY {name} {value:.8g}")
