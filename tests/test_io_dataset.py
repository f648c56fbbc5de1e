"""Dataset folders (frf.csv + meta.json): round trips, the shared datasets, named errors."""
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from railfem.response import FRF
from railfem.io import (FrequencyAxisError, MalformedFileError, MissingPositionError,
                        NonFiniteValueError, UnknownQuantityError, UnknownUnitError, read_dataset,
                        read_measurement, write_dataset)
from railfem.measurement import HammerMeasurement, Metadata, Sensor

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("RAILFEM_SHARED", REPO.parent / "shared"))
DATASETS = SHARED / "datasets"
needs_shared = pytest.mark.skipif(not DATASETS.exists(), reason=f"no shared datasets at {DATASETS}")


def measurement(quantity="accelerance", seed=0):
    rng = np.random.default_rng(seed)
    x = np.array([0.02, 0.15, 0.3, 0.6, 1.2, 2.4])
    f = np.geomspace(50, 5000, 13)
    v = rng.normal(size=(13, 2, 6)) + 1j * rng.normal(size=(13, 2, 6))
    frf = FRF(frequency=f, values=v * 1e-3, quantity=quantity, response=("head", "foot"),
              force=tuple(f"h{i}" for i in range(6)), response_x=[0.325, 0.325],
              force_x=0.325 + x)
    return HammerMeasurement(
        frf=frf, positions=x, sleeper_spacing=0.65, sensor_x=0.325, rail="60E1",
        sensors=(Sensor(name="head", y=0.0, z=0.172, note="top"), Sensor(name="foot", y=0.05)),
        metadata=Metadata(date="2024-05-01", temperature_c=12.5, section="S1", rail_side="left",
                          notes={"team": "A", "sleeper_mass_kg_per_rail": 120.0}))


@pytest.mark.parametrize("quantity", ["receptance", "mobility", "accelerance"])
def test_write_then_read_is_exact(tmp_path, quantity):
    m = measurement(quantity)
    write_dataset(tmp_path / "ds", m)
    assert sorted(p.name for p in (tmp_path / "ds").iterdir()) == ["frf.csv", "meta.json"]
    r = read_dataset(tmp_path / "ds")
    np.testing.assert_array_equal(r.frf.values, m.frf.values)
    np.testing.assert_array_equal(r.frf.frequency, m.frf.frequency)
    np.testing.assert_array_equal(r.positions, m.positions)
    assert r.frf.quantity == quantity and r.sensors == m.sensors
    assert (r.sleeper_spacing, r.sensor_x, r.rail) == (0.65, 0.325, "60E1")
    assert r.metadata == m.metadata
    np.testing.assert_allclose(r.frf.force_x, m.frf.force_x, rtol=0, atol=1e-15)


def test_read_converts_quantity_on_request(tmp_path):
    m = measurement("accelerance")
    write_dataset(tmp_path / "ds", m)
    r = read_dataset(tmp_path / "ds", quantity="mobility")
    np.testing.assert_allclose(r.frf.values * (2j * np.pi * m.frequency)[:, None, None],
                               m.frf.values, rtol=1e-14)


@needs_shared
@pytest.mark.parametrize("site", ["refsim_site", "practice_site_b"])
def test_shared_dataset_reads_and_round_trips(tmp_path, site):
    m = read_measurement(DATASETS / site)
    assert m.frf.shape == (69, 2, 29) and m.frf.quantity == "mobility"
    assert m.point_offset == pytest.approx(0.02) and m.positions[-1] == pytest.approx(39.6)
    assert m.sensor_x == pytest.approx(0.3) and m.sleeper_spacing == pytest.approx(0.6)
    assert [s.name for s in m.sensors] == ["head", "foot"]
    assert m.sensor("head").z == pytest.approx(0.172) and m.sensor("head").direction == "z"
    # independent spot check of one cell against the raw CSV text
    raw = np.loadtxt(DATASETS / site / "frf.csv", delimiter=",", skiprows=1)
    assert m.frf.values[1, 1, 0] == complex(raw[1, 3], raw[1, 4])  # foot, position 0.02
    assert m.frf.values[5, 0, 28] == complex(raw[5, 113], raw[5, 114])  # head, 39.6 m
    assert "truth" not in json.dumps(m.metadata.as_dict())
    write_dataset(tmp_path / site, m)
    r = read_dataset(tmp_path / site)
    np.testing.assert_array_equal(r.frf.values, m.frf.values)
    assert r.metadata == m.metadata
    assert json.loads((tmp_path / site / "meta.json").read_text())["hammer_positions_m"] == \
        json.loads((DATASETS / site / "meta.json").read_text())["hammer_positions_m"]


@needs_shared
def test_truth_json_is_never_read(tmp_path):
    shutil.copytree(DATASETS / "refsim_site", tmp_path / "ds")
    (tmp_path / "ds" / "truth.json").write_text("this is not json {")
    m = read_dataset(tmp_path / "ds")  # a reader that opened truth.json would fail here
    assert m.frf.shape[2] == 29


def write_folder(tmp_path, meta_changes=None, rows=None, header=None):
    m = measurement("mobility")
    d = write_dataset(tmp_path / "bad", m)
    meta = json.loads((d / "meta.json").read_text())
    meta.update(meta_changes or {})
    for k, v in list(meta.items()):
        if v is KeyError:
            del meta[k]
    (d / "meta.json").write_text(json.dumps(meta))
    lines = (d / "frf.csv").read_text().splitlines()
    if header is not None:
        lines[0] = header(lines[0])
    for i, fn in (rows or {}).items():
        lines[i] = fn(lines[i])
    (d / "frf.csv").write_text("\n".join(lines) + "\n")
    return d


def set_cell(k, text):
    def fn(line):
        cells = line.split(",")
        cells[k] = text
        return ",".join(cells)
    return fn


@pytest.mark.parametrize("kw, error, match", [
    (dict(rows={3: set_cell(5, "nan")}), NonFiniteValueError, "line 4, column 'head_x0.150_re'"),
    (dict(rows={3: set_cell(5, "abc")}), MalformedFileError, "not a number"),
    (dict(rows={3: set_cell(0, "1e6")}), FrequencyAxisError, "not strictly increasing"),
    (dict(rows={1: set_cell(0, "0")}), FrequencyAxisError, "not positive"),
    (dict(meta_changes={"hammer_positions_m": [0.02, 0.15, 0.3, 0.6, 1.2]}),
     MissingPositionError, "position 2.4 m is not one of meta.json"),
    (dict(meta_changes={"hammer_positions_m": KeyError}), MissingPositionError, "missing"),
    (dict(header=lambda h: h.replace("foot_x0.300_im", "foot_x0.310_im")),
     MissingPositionError, "position 0.31 m"),
    (dict(meta_changes={"quantity": "vertical impedance = force / velocity [N s/m]"}),
     UnknownQuantityError, "names none"),
    (dict(meta_changes={"quantity": "vertical mobility [furlong/N]"}), UnknownUnitError,
     "unknown unit"),
    (dict(meta_changes={"quantity": "vertical mobility [m/N]"}), UnknownQuantityError,
     "is a receptance"),
    (dict(meta_changes={"sleeper_spacing_m": "0.6"}), MalformedFileError, "not a number"),
])
def test_malformed_datasets_name_file_place_and_fix(tmp_path, kw, error, match):
    d = write_folder(tmp_path, **kw)
    with pytest.raises(error, match=match) as info:
        read_dataset(d)
    msg = str(info.value)
    assert str(d) in msg and ";" in msg  # the file, then the fix after the semicolon


def test_missing_column_for_a_sensor(tmp_path):
    d = write_folder(tmp_path)
    lines = (d / "frf.csv").read_text().splitlines()
    keep = [j for j, c in enumerate(lines[0].split(",")) if not c.startswith("foot_x0.600")]
    (d / "frf.csv").write_text("\n".join(",".join(np.array(l.split(","))[keep]) for l in lines))
    with pytest.raises(MissingPositionError, match="no column foot_x0.600_re"):
        read_dataset(d)


def test_not_a_dataset(tmp_path):
    with pytest.raises(MalformedFileError, match="not a folder"):
        read_dataset(tmp_path / "nothing")
    (tmp_path / "x.uff").write_text("")
    with pytest.raises(MalformedFileError, match="no hammer geometry"):
        read_measurement(tmp_path / "x.uff")
