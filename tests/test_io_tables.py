"""Plain complex-FRF tables with a column mapping, and wide decay-rate tables."""
import os
from pathlib import Path

import numpy as np
import pytest

from railfem.response import FRF
from railfem.io import (SBB_NIEDERWANGEN_COLUMNS, Channel, ColumnMapping, FrequencyAxisError,
                        MalformedFileError, MissingPositionError, NonFiniteValueError,
                        UnknownUnitError, read_decay_rate_table, read_frf_table,
                        write_decay_rate_table)
from railfem.measurement import DecayRateTable, Metadata

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("RAILFEM_SHARED", REPO.parent / "shared"))
SBB = SHARED / "measured_data" / "sbb_niederwangen" / "tdr_niederwangen_wide.csv"
G = 9.80665


def truth(seed=1):
    rng = np.random.default_rng(seed)
    f = np.geomspace(50, 5000, 21)
    v = (rng.normal(size=(21, 1, 3)) + 1j * rng.normal(size=(21, 1, 3))) * 1e-4  # mobility, SI
    return FRF(frequency=f, values=v, quantity="mobility", response=("head",),
               force=("p0", "p1", "p2"))


def channels(suffixes):
    return tuple(Channel(response="head", force=f"p{i}",
                         columns=(f"H{i} {suffixes[0]}", f"H{i} {suffixes[1]}")) for i in range(3))


def write_table(path, f, cols: dict, freq_name="f [Hz]", comment="# exported by X"):
    names = [freq_name] + list(cols)
    lines = [comment, ";".join(names)] if comment else [";".join(names)]
    data = np.column_stack([f] + list(cols.values()))
    lines += [";".join(repr(float(x)) for x in row) for row in data]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_re_im_in_accelerance_g_per_n_read_as_mobility(tmp_path):
    t = truth()
    acc_g = t.to("accelerance").values[:, 0, :] / G  # the file holds g/N
    cols = {}
    for i in range(3):
        cols[f"H{i} re"], cols[f"H{i} im"] = acc_g[:, i].real, acc_g[:, i].imag
    p = write_table(tmp_path / "x.csv", t.frequency, cols)
    mapping = ColumnMapping(channels=channels(("re", "im")), unit="g/N", frequency="f [Hz]",
                            delimiter=";")
    assert mapping.quantity == "accelerance"
    frf = read_frf_table(p, mapping, quantity="mobility")
    assert frf.quantity == "mobility" and frf.force == ("p0", "p1", "p2")
    np.testing.assert_allclose(frf.values, t.values, rtol=1e-13)


@pytest.mark.parametrize("phase_unit", ["deg", "rad"])
def test_db_phase_receptance_in_mm_per_n(tmp_path, phase_unit):
    t = truth(2)
    rec_mm = t.to("receptance").values[:, 0, :] * 1e3  # mm/N
    ref = 1e-6  # dB re 1e-6 mm/N
    cols = {}
    for i in range(3):
        ph = np.angle(rec_mm[:, i])
        cols[f"H{i} dB"] = 20 * np.log10(np.abs(rec_mm[:, i]) / ref)
        cols[f"H{i} ph"] = np.degrees(ph) if phase_unit == "deg" else ph
    p = write_table(tmp_path / "x.csv", t.frequency / 1e3, cols, freq_name="f_khz")
    mapping = ColumnMapping(channels=channels(("dB", "ph")), unit="mm/N", form="db_phase",
                            phase_unit=phase_unit, db_reference=ref, frequency="f_khz",
                            frequency_unit="kHz", delimiter=";")
    frf = read_frf_table(p, mapping, quantity="mobility")
    np.testing.assert_allclose(frf.frequency, t.frequency, rtol=1e-14)
    np.testing.assert_allclose(frf.values, t.values, rtol=1e-12)


def test_exp_minus_iwt_files_are_conjugated(tmp_path):
    t = truth(3)
    y = np.conj(t.values[:, 0, :])
    cols = {}
    for i in range(3):
        cols[f"H{i} re"], cols[f"H{i} im"] = y[:, i].real, y[:, i].imag
    p = write_table(tmp_path / "x.csv", t.frequency, cols)
    m = ColumnMapping(channels=channels(("re", "im")), unit="m/s/N", frequency="f [Hz]",
                      delimiter=";", time_convention="-")
    np.testing.assert_allclose(read_frf_table(p, m).values, t.values, rtol=1e-15)


def simple(tmp_path, f=(10.0, 20.0, 30.0), re=(1.0, 2.0, 3.0)):
    cols = {"H0 re": np.array(re), "H0 im": np.zeros(3)}
    return write_table(tmp_path / "s.csv", np.array(f), cols, freq_name="f", comment=None)


ONE = (Channel(response="head", force="p0", columns=("H0 re", "H0 im")),)


@pytest.mark.parametrize("kw, error, match", [
    (dict(f=(10.0, 30.0, 20.0)), FrequencyAxisError, "not strictly increasing"),
    (dict(re=(1.0, float("nan"), 3.0)), NonFiniteValueError, "line 3, column 'H0 re'"),
])
def test_table_errors(tmp_path, kw, error, match):
    p = simple(tmp_path, **kw)
    with pytest.raises(error, match=match) as info:
        read_frf_table(p, ColumnMapping(channels=ONE, unit="m/s/N", frequency="f", delimiter=";"))
    assert str(p) in str(info.value)


def test_mapping_errors(tmp_path):
    p = simple(tmp_path)
    with pytest.raises(UnknownUnitError, match="furlong"):
        ColumnMapping(channels=ONE, unit="furlong/N")
    with pytest.raises(MalformedFileError, match="no column 'freq'"):
        read_frf_table(p, ColumnMapping(channels=ONE, unit="m/s/N", frequency="freq",
                                        delimiter=";"))
    two = ONE + (Channel(response="foot", force="p1", columns=("H0 re", "H0 im")),)
    with pytest.raises(MissingPositionError, match="no channel for response 'head' and force 'p1'"):
        read_frf_table(p, ColumnMapping(channels=two, unit="m/s/N", frequency="f", delimiter=";"))
    with pytest.raises(ValueError, match="form = 'polar' is unknown"):
        ColumnMapping(channels=ONE, unit="m/s/N", form="polar")


# ------------------------------------------------------------------ decay-rate tables
def small_table():
    f = np.array([100.0, 125.0, 1250.0, 5000.0])
    d = np.array([[3.0, 13.5], [4.5, np.nan], [12.4, 0.3], [4.8, 2.3]])
    meta = (Metadata(date="2012-09-12", temperature_c=10.6, section="B1", rail_side="li",
                     notes={"Author": "MBBM", "tdr_id": "1.0"}),
            Metadata(date="2013-07-12", temperature_c=29.4, section="B5", rail_side="re",
                     notes={"Author": "MBBM", "tdr_id": "36.0"}))
    return DecayRateTable(frequency=f, decay_rate=d, direction=("z", "y"), metadata=meta,
                          sensor=("head", None))


def assert_same(a, b):
    np.testing.assert_array_equal(a.frequency, b.frequency)
    np.testing.assert_array_equal(a.decay_rate, b.decay_rate)
    assert a.direction == b.direction and a.metadata == b.metadata and a.sensor == b.sensor


def test_decay_rate_table_round_trip(tmp_path):
    t = small_table()
    p = write_decay_rate_table(tmp_path / "tdr.csv", t)
    assert_same(read_decay_rate_table(p), t)
    assert ",," in p.read_text()  # the missing value is an empty cell


def sbb_like(tmp_path, row=None, header=None, unit_comment=None):
    lines = ["loc,sec,messdatum,temp,rail,dir,100,125,160",
             "Ni,B1,2012-09-12,10.6,li,v,3.0,4.5,5.4",
             "Ni,B1,2012-09-12,10.6,re,h,13.5,NA,13.4"]
    if header:
        lines[0] = header
    if row:
        lines[2] = row
    if unit_comment:
        lines.insert(0, unit_comment)
    p = tmp_path / "sbb.csv"
    p.write_text("\n".join(lines) + "\n")
    return p


def test_sbb_like_columns_mapping(tmp_path):
    t = read_decay_rate_table(sbb_like(tmp_path), columns=SBB_NIEDERWANGEN_COLUMNS)
    assert t.direction == ("z", "y") and np.isnan(t.decay_rate[1, 1])
    assert t.metadata[1].rail_side == "re" and t.metadata[0].notes == {"loc": "Ni"}
    assert t.frequency.tolist() == [100.0, 125.0, 160.0]


@pytest.mark.parametrize("kw, error, match", [
    (dict(row="Ni,B1,2012-09-12,10.6,re,q,13.5,1,13.4"), MalformedFileError, "unknown direction"),
    (dict(row="Ni,B1,2012-09-12,10.6,re,h,13.5,-1,13.4"), MalformedFileError, "decay rate <= 0"),
    (dict(row="Ni,B1,2012-09-12,10.6,re,h,13.5,inf,13.4"), NonFiniteValueError, "column '125'"),
    (dict(row="Ni,B1,12.09.2012,10.6,re,h,13.5,1,13.4"), MalformedFileError, "ISO date"),
    (dict(header="loc,sec,messdatum,temp,rail,dir,100,160,125"), FrequencyAxisError,
     "not strictly increasing"),
    (dict(unit_comment="# unit=dB/km"), UnknownUnitError, "dB/m"),
    (dict(header="loc,sec,messdatum,temp,rail,direction,100,125,160"), MalformedFileError,
     "no direction column 'dir'"),
])
def test_decay_rate_table_errors(tmp_path, kw, error, match):
    p = sbb_like(tmp_path, **kw)
    with pytest.raises(error, match=match) as info:
        read_decay_rate_table(p, columns=SBB_NIEDERWANGEN_COLUMNS)
    assert str(p) in str(info.value)


@pytest.mark.skipif(not SBB.exists(), reason=f"SBB table not found at {SBB}")
def test_sbb_niederwangen_table(tmp_path):
    t = read_decay_rate_table(SBB, columns=SBB_NIEDERWANGEN_COLUMNS)
    s = t.summary()
    assert s["rows"] == 31 and s["direction"] == {"y": 15, "z": 16}
    assert s["section"] == {"B1": 3, "B2": 4, "B3": 4, "B4": 4, "B5": 16}
    assert s["date"]["2013-01-29"] == 4 and s["temperature_c"] == [-0.7, 30.5]
    assert t.frequency[0] == 100 and t.frequency[-1] == 5000 and t.frequency.size == 18
    first = t.select(direction="v", section="B1")
    assert len(first) == 2 and first.decay_rate[0, 0] == 3.0  # first data row, 100 Hz
    assert len(t.select(direction="v", section="B5", date="2013")) == 4
    assert_same(read_decay_rate_table(write_decay_rate_table(tmp_path / "t.csv", t)), t)
