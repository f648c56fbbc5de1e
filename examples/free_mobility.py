"""Free UIC60 rail: vertical point mobility of the rail head and transfer mobility at 1 m.

    python examples/free_mobility.py [OUT_DIR]

Loads the shipped 60E1 mesh (h = 10 mm), assembles the waveguide (steel, rail loss factor
0.01), loads the head with a unit vertical force spread over a 20 mm x 20 mm patch (20 mm
across the head top, 20 mm along the rail) and computes the mobility (m/s/N) at 100 Hz on
the head at x = 0 (point) and x = 1 m (transfer) by the residue sum over the waves
(railfem.rail.mobility). Writes OUT_DIR/free_mobility_100hz.csv (railfem.io.frf_csv layout; default
OUT_DIR: a new temporary folder) and prints the values. The last line is
``KEY free_mobility_point_100hz <|Y| in m/s/N>``; tests/test_examples.py checks it.
"""
import sys
import tempfile
from pathlib import Path

import numpy as np

from railfem.rail import meshing
from railfem.rail import mobility
from railfem.rail import waveguide
from railfem.io.frf_csv import write_frf_csv
from railfem.materials import Material

FREQUENCY_HZ = 100.0
X_M = (0.0, 1.0)


def main(out_dir: Path) -> dict:
    mesh = meshing.get_mesh("60E1", 0.010)
    guide = waveguide.assemble(mesh, Material.steel(loss_factor=0.01))
    head = mobility.head_patch(guide, width=0.02)
    frf = mobility.free_mobility(guide, [FREQUENCY_HZ], head, [head], X_M, load_length=0.02)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = write_frf_csv(out_dir / "free_mobility_100hz.csv", frf)
    point, transfer = frf.values[0, :, 0]
    print(f"{mesh.name}: {guide.n_dofs} DOFs, free rail, loss factor 0.01, head patch "
          f"20 mm x 20 mm")
    for label, y in (("point (x = 0)", point), ("transfer (x = 1 m)", transfer)):
        print(f"  {FREQUENCY_HZ:g} Hz {label:19s} Y = {y.real:+.4e} {y.imag:+.4e}i m/s/N, "
              f"|Y| = {abs(y):.4e} m/s/N, phase {np.degrees(np.angle(y)):6.1f} deg")
    print(f"wrote {path}")
    return {"free_mobility_point_100hz": float(abs(point))}


if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="railfem-"))
    for name, value in main(out).items():
        print(f"KEY {name} {value:.10g}")
