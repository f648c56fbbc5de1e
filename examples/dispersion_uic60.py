"""Free UIC60 rail: wavenumbers k(omega) of the propagating waves and the first cut-on.

    python examples/dispersion_uic60.py [OUT_DIR]

Loads the shipped 60E1 mesh (h = 10 mm), assembles the waveguide (steel, undamped), solves
k(omega) at a few frequencies, writes the propagating waves to OUT_DIR/dispersion_uic60.csv
(default OUT_DIR: a new temporary folder) and prints them. The last lines are
``KEY <name> <value>`` in SI units; tests/test_examples.py checks them.
"""
import csv
import sys
import tempfile
from pathlib import Path

import numpy as np

from railfem.rail import meshing
from railfem.rail import waveguide
from railfem.rail import waves
from railfem.materials import Material
from railfem.rail.branches import propagating_mask

FREQUENCIES_HZ = (100.0, 500.0, 1000.0, 2000.0)


def main(out_dir: Path) -> dict:
    mesh = meshing.get_mesh("60E1", 0.010)
    guide = waveguide.assemble(mesh, Material.steel())
    disp = waves.solve(guide, FREQUENCIES_HZ, n_waves=20)
    prop = propagating_mask(disp.k)
    rows = [(f, disp.family[i, j], disp.label[i, j], disp.k[i, j].real, disp.k[i, j].imag)
            for i, f in enumerate(disp.frequency) for j in np.nonzero(prop[i])[0]]
    out_dir.mkdir(parents=True, exist_ok=True)
    with open(out_dir / "dispersion_uic60.csv", "w", newline="") as fh:
        wr = csv.writer(fh)
        wr.writerow(["frequency_hz", "family", "label", "k_re_rad_per_m", "k_im_rad_per_m"])
        wr.writerows(rows)
    print(f"{mesh.name}: {guide.n_dofs} DOFs; propagating waves (rad/m):")
    for f, fam, lab, kr, _ in rows:
        print(f"  {f:7.0f} Hz  {fam:13s}  {lab:18s}  k = {kr:7.3f}")
    print(f"wrote {out_dir / 'dispersion_uic60.csv'}")
    k_vb = [r[3] for r in rows if r[0] == 100.0 and r[2] == "vertical bending"]
    if len(k_vb) != 1:
        raise RuntimeError(f"expected one vertical bending wave at 100 Hz, got {k_vb}")
    return {"k_vertical_bending_100hz": k_vb[0],
            "first_cut_on_hz": float(waves.cut_on_frequencies(guide, n=1)[0])}


if __name__ == "__main__":
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp(prefix="railfem-"))
    for name, value in main(out).items():
        print(f"KEY {name} {value:.10g}")
