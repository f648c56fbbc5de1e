"""Measurement objects: validation and behaviour (railfem.measurement)."""
import numpy as np
import pytest

from railfem.response import FRF
from railfem.measurement import (DecayRateMeasurement, DecayRateTable, HammerMeasurement,
                                 Metadata, Sensor, direction_name)
from railfem.standards.en15461 import hammer_positions


def frf(n_pos=4, sensors=("head", "foot"), sensor_x=None, positions=None):
    f = np.array([100.0, 200.0, 400.0])
    x = np.array([0.02, 0.15, 0.3, 0.45][:n_pos]) if positions is None else positions
    v = np.ones((3, len(sensors), len(x))) * (1 + 1j)
    return FRF(frequency=f, values=v, quantity="mobility", response=sensors,
               force=tuple(f"p{i}" for i in range(len(x))),
               force_x=None if sensor_x is None else sensor_x + x)


def sensors(names=("head", "foot")):
    return tuple(Sensor(name=n) for n in names)


def test_hammer_measurement_holds_geometry():
    m = HammerMeasurement(frf=frf(sensor_x=0.3), positions=[0.02, 0.15, 0.3, 0.45],
                          sensors=sensors(), sleeper_spacing=0.6, sensor_x=0.3,
                          metadata=Metadata(date="2024-05-01", temperature_c=12.5))
    assert m.point_offset == pytest.approx(0.02)
    assert m.sensor_names == ("head", "foot")
    assert m.transfer("foot").shape == (3, 4)
    assert m.with_sensors("foot").frf.shape == (3, 1, 4)
    sub = m.with_positions([3, 1])  # the point stays first, the order is the positions'
    assert sub.positions.tolist() == [0.02, 0.15, 0.45]
    assert sub.frf.force == ("p0", "p1", "p3") and sub.frf.force_x.tolist() == pytest.approx(
        [0.32, 0.45, 0.75])
    assert m.positions.tolist() == [0.02, 0.15, 0.3, 0.45]  # the original is untouched
    with pytest.raises(ValueError, match="outside 0...3"):
        m.with_positions([4])
    assert not m.positions.flags.writeable
    with pytest.raises(KeyError, match="no sensor 'rail'"):
        m.sensor("rail")


@pytest.mark.parametrize("kw, match", [
    (dict(positions=[0.0, 0.15, 0.3]), "3 hammer positions but the FRF has 4"),
    (dict(positions=[0.0, 0.3, 0.15, 0.45]), "strictly increasing"),
    (dict(positions=[0.1, 0.15, 0.3, 0.45]), "must be the point FRF"),
    (dict(positions=[0.0, 0.15, np.nan, 0.45]), "NaN/inf"),
    (dict(sleeper_spacing=-0.6), "sleeper_spacing = -0.6 m"),
    (dict(sensors=sensors(("foot", "head"))), "must match the FRF response labels"),
    (dict(excitation="up"), "excitation = 'up' is unknown"),
])
def test_hammer_measurement_rejects_bad_input(kw, match):
    args = dict(frf=frf(), positions=[0.0, 0.15, 0.3, 0.45], sensors=sensors(),
                sleeper_spacing=0.6)
    args.update(kw)
    with pytest.raises(ValueError, match=match):
        HammerMeasurement(**args)


def test_force_x_must_agree_with_positions():
    with pytest.raises(ValueError, match="force_x"):
        HammerMeasurement(frf=frf(sensor_x=0.3), positions=[0.0, 0.15, 0.3, 0.45],
                          sensors=sensors(), sleeper_spacing=0.6, sensor_x=0.25)


def test_metadata_validation_and_round_trip():
    m = Metadata(date="2013-01-29", temperature_c=-0.7, section="B5", rail_side="li",
                 notes={"tdr_id": "36.0", "nested": {"a": [1, 2]}})
    assert Metadata.from_dict(m.as_dict()) == m
    assert m.notes["nested"]["a"] == (1, 2)  # frozen copy
    with pytest.raises(ValueError, match="YYYY-MM-DD"):
        Metadata(date="29.01.2013")
    with pytest.raises(ValueError, match="below absolute zero"):
        Metadata(temperature_c=-300)
    with pytest.raises(ValueError, match="cannot be kept as metadata"):
        Metadata(notes={"x": object()})
    with pytest.raises(ValueError, match="unknown metadata key"):
        Metadata.from_dict({"temp": 3})


def test_direction_aliases():
    assert [direction_name(d) for d in ("v", "h", "vertical", "lateral", "z", "Y")] == \
        ["z", "y", "z", "y", "z", "y"]
    with pytest.raises(ValueError, match="aliases"):
        direction_name("q")


def table():
    f = np.array([100.0, 125.0, 160.0])
    d = np.array([[3.0, 13.5, 2.7], [4.5, 13.9, np.nan], [5.4, 13.4, 4.8]])
    meta = (Metadata(date="2012-09-12", section="B1", temperature_c=10.6),
            Metadata(date="2012-09-12", section="B1", temperature_c=10.6),
            Metadata(date="2013-01-29", section="B5", temperature_c=0.0))
    return DecayRateTable(frequency=f, decay_rate=d, direction=("v", "h", "z"), metadata=meta)


def test_decay_rate_table_rows_and_selection():
    t = table()
    assert len(t) == 3 and t.direction == ("z", "y", "z")
    assert len(t.select(direction="v")) == 2
    assert len(t.select(direction="z", section="B5")) == 1
    assert len(t.select(date="2012")) == 2
    assert len(t.select(date=["2012-09-12", "2013-01-29"], direction="h")) == 1
    r = t.row(2)
    assert isinstance(r, DecayRateMeasurement) and r.valid.tolist() == [True, False, True]
    back = DecayRateTable.from_rows(t.rows())
    np.testing.assert_array_equal(back.decay_rate, t.decay_rate)
    s = t.summary()
    assert s["rows"] == 3 and s["section"] == {"B1": 2, "B5": 1}
    assert s["temperature_c"] == [0.0, 10.6]
    with pytest.raises(KeyError, match="the table has"):
        t.select(section="B9")


def test_decay_rate_validation():
    with pytest.raises(ValueError, match="bands on axis 0"):
        DecayRateTable(frequency=[100.0, 125.0], decay_rate=np.ones((3, 2)),
                       direction=("z", "z"), metadata=(Metadata(), Metadata()))
    with pytest.raises(ValueError, match="> 0"):
        DecayRateMeasurement(frequency=[100.0, 125.0], decay_rate=[1.0, -2.0])
    with pytest.raises(ValueError, match="strictly increasing"):
        DecayRateMeasurement(frequency=[125.0, 100.0], decay_rate=[1.0, 2.0])
    with pytest.raises(ValueError, match="inf"):
        DecayRateMeasurement(frequency=[100.0, 125.0], decay_rate=[1.0, np.inf])


def test_standard_positions_build_a_measurement():
    x = hammer_positions(0.6)
    m = HammerMeasurement(frf=frf(sensors=("head",), positions=x), positions=x,
                          sensors=sensors(("head",)), sleeper_spacing=0.6)
    assert m.point_offset == 0.0 and m.positions.size == 29
