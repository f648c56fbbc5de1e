"""Roughness spectra: band mapping, files (round trip, the SBB table format)."""
import numpy as np
import pytest

from railfem.io import roughness_table as RT
from railfem.wheelrail import roughness as R

SBB = ("loc,sec,r_id,Author,kampagne,messdatum,rail,0.5012,0.631,0.7943,1,1.2589\n"
       "Ni,B2,3.0,ACCON,1,2014-07-01,L,,-10.0,-8.0,-6.0,-4.0\n"
       "Ni,B2,4.0,ACCON,1,2014-07-01,R,-12.0,-10.0,-8.0,-6.0,-4.0\n")


def test_amplitude_at_band_centres_is_the_band_level():
    spec = R.sloped_spectrum(-5.0, 10.0)
    V = 50.0
    f = V / spec.wavelength[5:10]
    amp = R.amplitude_at(spec, f, V)
    assert np.allclose(20 * np.log10(amp / 1e-6), spec.level[5:10])
    assert R.frequency_of(0.05, V) == pytest.approx(1000.0)
    with pytest.raises(ValueError, match="fall outside"):
        R.amplitude_at(spec, [1e6], V)


def test_csv_round_trip(tmp_path):
    spec = R.sloped_spectrum(2.0, 8.0, name="test")
    back = RT.read_spectrum_csv(RT.write_spectrum_csv(tmp_path / "r.csv", spec))
    assert np.allclose(back.wavelength, spec.wavelength) and np.allclose(back.level, spec.level,
                                                                         atol=1e-4)


def test_sbb_format(tmp_path):
    p = tmp_path / "sbb.csv"
    p.write_text(SBB)
    rows = RT.read_sbb_roughness(p, average=False)
    assert len(rows) == 2 and len(rows[0].level) == 4  # the empty cell is dropped
    assert rows[1].wavelength[0] == pytest.approx(0.012589)  # cm -> m, long first
    avg = RT.read_sbb_roughness(p)
    # energy average of -10 and -10 dB in the 6.31 mm band, bands shared by both rows
    assert len(avg.level) == 4
    assert avg.level[-1] == pytest.approx(-10.0)
    left = RT.read_sbb_roughness(p, select={"rail": "L"})
    assert left.level[0] == pytest.approx(-4.0)
    with pytest.raises(ValueError, match="no row"):
        RT.read_sbb_roughness(p, select={"rail": "X"})
    # either format by its header
    assert RT.read_roughness(p, {"rail": "L"}).name == left.name
    csv = RT.write_spectrum_csv(tmp_path / "r.csv", R.sloped_spectrum(name="s"))
    assert RT.read_roughness(csv).name == "r"


def test_combine_is_an_energy_sum():
    a = R.sloped_spectrum(0.0, 0.0)
    c = R.combine(a, a)
    assert np.allclose(c.level, 10 * np.log10(2))
